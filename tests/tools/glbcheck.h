// Reading `unilod export --compress` output back (test_cli_export, test_cli_tiles): the .glb's
// meshopt-compressed buffer views decoded with meshoptimizer's decoders into the plain layout
// tinygltf loads (meshopt's octahedral filter undone), and a compressed level compared with the
// same level exported without
// --compress: the same vertices (each within the reported bound), the same triangles with the
// same winding, the same river edges, normals within the 8-bit rounding.
#pragma once

#include <gtest/gtest.h>
#include <meshoptimizer.h>
#include <tiny_gltf.h>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <map>
#include <string>
#include <tuple>
#include <vector>

#include "gltfmodel.h"

namespace unilod::test {

// The plain .glb of a compressed one ("" after a failure was recorded).
inline std::string decodeMeshoptGlb(const std::string& glb) {
    std::string text, bin;
    if (!exporter::splitGlb(glb, text, bin)) {
        ADD_FAILURE() << "not a GLB container";
        return "";
    }
    nlohmann::json j = nlohmann::json::parse(text);
    const auto has = [&](const char* list, const char* name) {
        const auto& l = j.value(list, nlohmann::json::array());
        return std::find(l.begin(), l.end(), name) != l.end();
    };
    EXPECT_TRUE(has("extensionsRequired", "EXT_meshopt_compression"));
    EXPECT_TRUE(has("extensionsRequired", "KHR_mesh_quantization"));
    EXPECT_EQ(j["buffers"].size(), 2u);
    const std::size_t fallback = j["buffers"][1]["byteLength"];
    EXPECT_TRUE(j["buffers"][1]["extensions"]["EXT_meshopt_compression"]["fallback"]);
    const std::size_t packedLength = j["buffers"][0]["byteLength"];  // the BIN chunk, unpadded
    EXPECT_TRUE(packedLength <= bin.size() && bin.size() - packedLength < 4);
    std::string plain(fallback, '\0');
    for (nlohmann::json& v : j["bufferViews"]) {
        const nlohmann::json& e = v["extensions"]["EXT_meshopt_compression"];
        const std::size_t count = e["count"], stride = e["byteStride"];
        const std::size_t at = e["byteOffset"], length = e["byteLength"];
        const std::string mode = e["mode"];
        EXPECT_EQ(int(e["buffer"]), 0);
        EXPECT_EQ(int(v["buffer"]), 1);
        EXPECT_LE(at + length, bin.size());
        EXPECT_EQ(count * stride, std::size_t(v["byteLength"]));
        EXPECT_LE(std::size_t(v.value("byteOffset", 0u)) + count * stride, fallback);
        if (at + length > bin.size() || count * stride != std::size_t(v["byteLength"]) ||
            std::size_t(v.value("byteOffset", 0u)) + count * stride > fallback)
            return "";
        char* out = plain.data() + std::size_t(v.value("byteOffset", 0u));
        const auto* in = reinterpret_cast<const unsigned char*>(bin.data() + at);
        int rc = -1;
        if (mode == "ATTRIBUTES")
            rc = meshopt_decodeVertexBuffer(out, count, stride, in, length);
        else if (mode == "TRIANGLES")
            rc = meshopt_decodeIndexBuffer(out, count, stride, in, length);
        else if (mode == "INDICES")
            rc = meshopt_decodeIndexSequence(out, count, stride, in, length);
        EXPECT_EQ(rc, 0) << "mode " << mode;
        if (rc != 0) return "";
        const std::string filter = e.value("filter", "NONE");
        if (filter == "OCTAHEDRAL") {
            EXPECT_TRUE(mode == "ATTRIBUTES" && (stride == 4 || stride == 8));
            meshopt_decodeFilterOct(out, count, stride);
        } else {
            EXPECT_EQ(filter, "NONE");
        }
        v.erase("extensions");
        v["buffer"] = 0;
    }
    j["buffers"] = nlohmann::json::array({{{"byteLength", plain.size()}}});
    for (const char* list : {"extensionsUsed", "extensionsRequired"}) {
        auto& l = j[list];
        l.erase(std::remove(l.begin(), l.end(), "EXT_meshopt_compression"), l.end());
    }
    return exporter::joinGlb(j.dump(), plain);
}

inline tinygltf::Model loadGlbBytes(const std::string& glb) {
    tinygltf::Model m;
    tinygltf::TinyGLTF loader;
    std::string err, warn;
    EXPECT_TRUE(loader.LoadBinaryFromMemory(
        &m, &err, &warn, reinterpret_cast<const unsigned char*>(glb.data()), unsigned(glb.size())))
        << err;
    return m;
}

// What a node's mesh says, in the model's frame (node translation + scale applied, in double).
struct GlbMesh {
    std::vector<std::array<double, 3>> positions, normals;
    std::vector<std::array<std::uint32_t, 3>> triangles;
    std::vector<std::array<std::uint32_t, 2>> lines;
};

inline GlbMesh readGlbMesh(const tinygltf::Model& m, int nodeIndex) {
    GlbMesh out;
    const tinygltf::Node& node = m.nodes.at(std::size_t(nodeIndex));
    if (node.mesh < 0) return out;
    const double scale = node.scale.empty() ? 1.0 : node.scale[0];
    if (!node.scale.empty()) {
        EXPECT_EQ(node.scale[1], scale);
        EXPECT_EQ(node.scale[2], scale);
    }
    const auto bytesOf = [&](int accessor, const tinygltf::Accessor*& a) {
        a = &m.accessors.at(std::size_t(accessor));
        const tinygltf::BufferView& v = m.bufferViews.at(std::size_t(a->bufferView));
        return std::make_pair(
            m.buffers.at(std::size_t(v.buffer)).data.data() + v.byteOffset + a->byteOffset,
            std::size_t(v.byteStride));
    };
    for (const tinygltf::Primitive& p : m.meshes.at(std::size_t(node.mesh)).primitives) {
        if (out.positions.empty()) {
            const tinygltf::Accessor* a = nullptr;
            auto [data, stride] = bytesOf(p.attributes.at("POSITION"), a);
            for (std::size_t i = 0; i < a->count; ++i) {
                std::array<double, 3> x{};
                for (std::size_t k = 0; k < 3; ++k) {
                    double c = 0;
                    if (a->componentType == TINYGLTF_COMPONENT_TYPE_FLOAT) {
                        float f;
                        std::memcpy(&f, data + i * (stride ? stride : 12) + 4 * k, 4);
                        c = f;
                    } else {
                        EXPECT_EQ(a->componentType, TINYGLTF_COMPONENT_TYPE_SHORT);
                        EXPECT_FALSE(a->normalized);
                        std::int16_t s;
                        std::memcpy(&s, data + i * (stride ? stride : 6) + 2 * k, 2);
                        c = s;
                        EXPECT_GE(s, a->minValues[k]);
                        EXPECT_LE(s, a->maxValues[k]);
                    }
                    x[k] = node.translation[k] + scale * c;
                }
                out.positions.push_back(x);
            }
        }
        if (p.attributes.count("NORMAL")) {
            const tinygltf::Accessor* a = nullptr;
            auto [data, stride] = bytesOf(p.attributes.at("NORMAL"), a);
            for (std::size_t i = 0; i < a->count; ++i) {
                std::array<double, 3> x{};
                for (std::size_t k = 0; k < 3; ++k) {
                    if (a->componentType == TINYGLTF_COMPONENT_TYPE_FLOAT) {
                        float f;
                        std::memcpy(&f, data + i * (stride ? stride : 12) + 4 * k, 4);
                        x[k] = f;
                    } else {
                        EXPECT_EQ(a->componentType, TINYGLTF_COMPONENT_TYPE_BYTE);
                        EXPECT_TRUE(a->normalized);
                        std::int8_t s;
                        std::memcpy(&s, data + i * (stride ? stride : 3) + k, 1);
                        x[k] = std::max(-1.0, s / 127.0);
                    }
                }
                out.normals.push_back(x);
            }
        }
        const tinygltf::Accessor* a = nullptr;
        auto [data, stride] = bytesOf(p.indices, a);
        std::vector<std::uint32_t> idx(a->count);
        for (std::size_t i = 0; i < a->count; ++i) {
            if (a->componentType == TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT) {
                std::uint16_t s;
                std::memcpy(&s, data + 2 * i, 2);
                idx[i] = s;
            } else {
                std::memcpy(&idx[i], data + 4 * i, 4);
            }
        }
        if (p.mode == TINYGLTF_MODE_TRIANGLES)
            for (std::size_t i = 0; i + 2 < idx.size(); i += 3)
                out.triangles.push_back({idx[i], idx[i + 1], idx[i + 2]});
        else
            for (std::size_t i = 0; i + 1 < idx.size(); i += 2)
                out.lines.push_back({idx[i], idx[i + 1]});
    }
    return out;
}

// Compares a compressed mesh with the plain one: every compressed vertex is the plain vertex
// nearest to it, within `bound` per coordinate (plus 1 mm for the plain floats), one to one;
// then the triangles (each rotated to start at its smallest plain index, so the winding counts)
// and the river edges are the same sets, and normals agree within 0.02. Returns the mapping
// compressed index -> plain index (empty after a failure).
inline std::vector<std::uint32_t> expectSameMesh(const GlbMesh& plain, const GlbMesh& packed,
                                                 double bound, const std::string& what) {
    EXPECT_EQ(plain.positions.size(), packed.positions.size()) << what;
    EXPECT_EQ(plain.triangles.size(), packed.triangles.size()) << what;
    EXPECT_EQ(plain.lines.size(), packed.lines.size()) << what;
    if (plain.positions.size() != packed.positions.size()) return {};
    const double tol = bound + 1e-3, cell = std::max(1.0, 2 * tol);
    std::map<std::array<long long, 3>, std::vector<std::uint32_t>> hash;
    const auto key = [&](const std::array<double, 3>& p, int dx, int dy, int dz) {
        return std::array<long long, 3>{std::llround(std::floor(p[0] / cell)) + dx,
                                        std::llround(std::floor(p[1] / cell)) + dy,
                                        std::llround(std::floor(p[2] / cell)) + dz};
    };
    for (std::uint32_t i = 0; i < plain.positions.size(); ++i)
        hash[key(plain.positions[i], 0, 0, 0)].push_back(i);
    std::vector<std::uint32_t> map(packed.positions.size(), ~0u);
    std::vector<bool> used(plain.positions.size(), false);
    int bad = 0;
    for (std::uint32_t i = 0; i < packed.positions.size(); ++i) {
        const auto& p = packed.positions[i];
        double best = HUGE_VAL;
        for (int dx = -1; dx <= 1; ++dx)
            for (int dy = -1; dy <= 1; ++dy)
                for (int dz = -1; dz <= 1; ++dz) {
                    const auto it = hash.find(key(p, dx, dy, dz));
                    if (it == hash.end()) continue;
                    for (std::uint32_t j : it->second) {
                        double d = 0;
                        for (int k = 0; k < 3; ++k)
                            d = std::max(d, std::fabs(plain.positions[j][k] - p[k]));
                        if (d < best) best = d, map[i] = j;
                    }
                }
        if (best > tol || map[i] == ~0u || used[map[i]]) {
            if (++bad < 5)
                ADD_FAILURE() << what << ": compressed vertex " << i << " (" << p[0] << ", " << p[1]
                              << ", " << p[2] << ") is " << best
                              << " m from the nearest plain vertex (bound " << bound << ")";
            continue;
        }
        used[map[i]] = true;
        if (!plain.normals.empty() && !packed.normals.empty())
            for (int k = 0; k < 3; ++k)
                if (std::fabs(plain.normals[map[i]][k] - packed.normals[i][k]) > 0.02 && ++bad < 5)
                    ADD_FAILURE() << what << ": normal of vertex " << i << " "
                                  << plain.normals[map[i]][k] << " vs " << packed.normals[i][k];
    }
    if (bad) return {};
    auto canon = [](std::array<std::uint32_t, 3> t) {
        while (t[0] > t[1] || t[0] > t[2])
            t = {t[1], t[2], t[0]};
        return t;
    };
    std::vector<std::array<std::uint32_t, 3>> a, b;
    for (const auto& t : plain.triangles)
        a.push_back(canon(t));
    for (const auto& t : packed.triangles)
        b.push_back(canon({map[t[0]], map[t[1]], map[t[2]]}));
    std::sort(a.begin(), a.end());
    std::sort(b.begin(), b.end());
    EXPECT_TRUE(a == b) << what << ": the triangles differ";
    std::vector<std::array<std::uint32_t, 2>> la, lb;
    for (const auto& l : plain.lines)
        la.push_back({std::min(l[0], l[1]), std::max(l[0], l[1])});
    for (const auto& l : packed.lines)
        lb.push_back({std::min(map[l[0]], map[l[1]]), std::max(map[l[0]], map[l[1]])});
    std::sort(la.begin(), la.end());
    std::sort(lb.begin(), lb.end());
    EXPECT_TRUE(la == lb) << what << ": the river edges differ";
    return map;
}

// Cracks: vertices of different meshes that are one point in the plain export (within 1 mm) must
// decode to one point in the compressed one (within 1 µm). `meshes`: (plain, packed, mapping from
// expectSameMesh, group); meshes of the same group are not compared (an entry's chain, or an
// ancestor: never drawn side by side). `related(a, b)` says whether two groups may be drawn side
// by side. Returns the number of shared points compared.
template <typename Related>
std::size_t expectNoCracks(
    const std::vector<std::tuple<const GlbMesh*, const GlbMesh*, std::vector<std::uint32_t>, int>>&
        meshes,
    Related sideBySide) {
    // Plain position rounded to 1 cm -> (mesh, packed vertex).
    std::map<std::array<long long, 3>, std::vector<std::pair<std::size_t, std::uint32_t>>> points;
    for (std::size_t m = 0; m < meshes.size(); ++m) {
        const auto& [plain, packed, map, group] = meshes[m];
        for (std::uint32_t i = 0; i < map.size(); ++i) {
            const auto& p = plain->positions[map[i]];
            points[{std::llround(p[0] * 100), std::llround(p[1] * 100), std::llround(p[2] * 100)}]
                .push_back({m, i});
        }
    }
    std::size_t compared = 0;
    int bad = 0;
    for (const auto& [k, list] : points)
        for (std::size_t a = 0; a < list.size(); ++a)
            for (std::size_t b = a + 1; b < list.size(); ++b) {
                const auto& [ma, ia] = list[a];
                const auto& [mb, ib] = list[b];
                if (!sideBySide(std::get<3>(meshes[ma]), std::get<3>(meshes[mb]))) continue;
                ++compared;
                const auto& pa = std::get<1>(meshes[ma])->positions[ia];
                const auto& pb = std::get<1>(meshes[mb])->positions[ib];
                for (int c = 0; c < 3; ++c)
                    if (std::fabs(pa[c] - pb[c]) > 1e-6 && ++bad < 5)
                        ADD_FAILURE() << "a shared vertex decodes to two points (" << pa[c]
                                      << " vs " << pb[c] << "): a crack";
            }
    return compared;
}

}  // namespace unilod::test
