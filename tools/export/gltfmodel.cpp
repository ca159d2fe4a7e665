#include "gltfmodel.h"

#include <meshoptimizer.h>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <mutex>
#include <nlohmann/json.hpp>
#include <sstream>

namespace unilod::exporter {

namespace {

using tinygltf::Value;

// The largest 16-bit grid coordinate of a compressed position (gltfmodel.h).
constexpr double kQuantizationMax = 32767.0;

// The bufferView extras key that hands a view's meshopt filter (EXT_meshopt_compression
// "OCTAHEDRAL": its bytes are already the filter's encoding) from addLevelMesh
// to meshoptCompress, which moves it into the extension.
constexpr const char* kFilterKey = "unilod_meshopt_filter";

// Appends raw bytes to the single buffer (4-byte aligned) and returns a new buffer view
// (`stride`: the vertex stride it declares, 0 for none; `filter`: see kFilterKey).
int appendView(tinygltf::Model& model, const void* data, std::size_t bytes, int target,
               std::size_t stride = 0, const char* filter = nullptr) {
    std::vector<unsigned char>& buf = model.buffers[0].data;
    while (buf.size() % 4 != 0)
        buf.push_back(0);
    tinygltf::BufferView view;
    view.buffer = 0;
    view.byteOffset = buf.size();
    view.byteLength = bytes;
    view.target = target;
    view.byteStride = stride;
    if (filter) view.extras = Value(Value::Object{{kFilterKey, Value(std::string(filter))}});
    const auto* p = static_cast<const unsigned char*>(data);
    buf.insert(buf.end(), p, p + bytes);
    model.bufferViews.push_back(view);
    return int(model.bufferViews.size() - 1);
}

int addAccessor(tinygltf::Model& model, int view, int componentType, int type, std::size_t count,
                std::vector<double> minValues = {}, std::vector<double> maxValues = {},
                bool normalized = false) {
    tinygltf::Accessor a;
    a.normalized = normalized;
    a.bufferView = view;
    a.byteOffset = 0;
    a.componentType = componentType;
    a.type = type;
    a.count = count;
    a.minValues = std::move(minValues);
    a.maxValues = std::move(maxValues);
    model.accessors.push_back(a);
    return int(model.accessors.size() - 1);
}

int addMaterial(tinygltf::Model& model, const char* name, double r, double g, double b,
                bool unlit) {
    tinygltf::Material m;
    m.name = name;
    m.pbrMetallicRoughness.baseColorFactor = {r, g, b, 1.0};
    m.pbrMetallicRoughness.metallicFactor = 0.0;
    m.pbrMetallicRoughness.roughnessFactor = 1.0;
    m.doubleSided = true;
    if (unlit) m.extensions["KHR_materials_unlit"] = Value(Value::Object{});
    model.materials.push_back(m);
    return int(model.materials.size() - 1);
}

}  // namespace

tinygltf::Model newGltfModel(const std::string& generator, const GltfEncoding& encoding,
                             GltfMaterials& materials) {
    tinygltf::Model model;
    model.asset.version = "2.0";
    model.asset.generator = generator;
    model.buffers.resize(1);
    model.scenes.resize(1);
    model.scenes[0].name = "unilod";
    model.defaultScene = 0;
    materials.terrain = addMaterial(model, "terrain", 0.6, 0.6, 0.55, false);
    materials.river = addMaterial(model, "river", 0.1, 0.3, 0.9, true);
    model.extensionsUsed.push_back("KHR_materials_unlit");
    if (encoding.compress) {
        model.extensionsUsed.push_back("KHR_mesh_quantization");
        model.extensionsRequired.push_back("KHR_mesh_quantization");
    }
    return model;
}

int addLevelMesh(tinygltf::Model& model, const format::Block& block, std::size_t levelIndex,
                 const std::vector<double>& xyz, const std::array<double, 3>& translation,
                 const std::string& name, const GltfEncoding& encoding,
                 const GltfMaterials& materials, LevelCounts& counts) {
    const format::Level& level = block.levels[levelIndex];
    const std::size_t n = level.vertexCount;

    // Area-weighted normals: the sum of the (unnormalised) face normals of the level's triangles,
    // computed in the file's axes, then rotated like the positions.
    std::vector<double> acc(3 * n, 0.0);
    std::vector<std::uint32_t> triIndices;
    triIndices.reserve(3 * std::size_t(level.triangleCount));
    const std::vector<double>& surface = encoding.unsnapped ? *encoding.unsnapped : xyz;
    for (std::uint32_t t = 0; t < level.triangleCount; ++t) {
        const format::Triangle& tri = block.terrainIndices[level.triangleFirst + t];
        const double* a = &surface[3 * std::size_t(tri.a)];
        const double* b = &surface[3 * std::size_t(tri.b)];
        const double* c = &surface[3 * std::size_t(tri.c)];
        const double ux = b[0] - a[0], uy = b[1] - a[1], uz = b[2] - a[2];
        const double vx = c[0] - a[0], vy = c[1] - a[1], vz = c[2] - a[2];
        const double nx = uy * vz - uz * vy, ny = uz * vx - ux * vz, nz = ux * vy - uy * vx;
        for (std::uint32_t id : {tri.a, tri.b, tri.c}) {
            acc[3 * id] += nx;
            acc[3 * id + 1] += ny;
            acc[3 * id + 2] += nz;
        }
        triIndices.insert(triIndices.end(), {tri.a, tri.b, tri.c});
    }
    std::vector<float> normals(3 * n);
    for (std::size_t i = 0; i < n; ++i) {
        const double len = std::sqrt(acc[3 * i] * acc[3 * i] + acc[3 * i + 1] * acc[3 * i + 1] +
                                     acc[3 * i + 2] * acc[3 * i + 2]);
        if (len > 0) {
            toGltf(acc[3 * i] / len, acc[3 * i + 1] / len, acc[3 * i + 2] / len, &normals[3 * i]);
        } else {
            toGltf(0, 0, 1, &normals[3 * i]);  // a vertex of no triangle: up
        }
    }
    std::vector<std::uint32_t> lineIndices;
    lineIndices.reserve(2 * std::size_t(level.riverCount));
    for (std::uint32_t e = 0; e < level.riverCount; ++e) {
        const format::Edge& edge = block.riverIndices[level.riverFirst + e];
        lineIndices.insert(lineIndices.end(), {edge.a, edge.b});
    }
    counts.vertices = std::uint32_t(n);
    counts.triangles = level.triangleCount;
    counts.riverEdges = level.riverCount;

    // glTF axes, in double: the node's translation, then the positions relative to it.
    const std::array<double, 3> origin = {translation[0], translation[2], -translation[1]};
    std::vector<double> g(3 * n);
    for (std::size_t i = 0; i < n; ++i) {
        g[3 * i] = xyz[3 * i];
        g[3 * i + 1] = xyz[3 * i + 2];
        g[3 * i + 2] = -xyz[3 * i + 1];
    }
    double scale = 1.0;
    // Compressed: triangles in vertex-cache order and vertices by their first use (what the
    // codecs compress best), 16-bit positions where they fit (see gltfmodel.h).
    std::vector<std::uint32_t> order(n);  // new index -> old index
    for (std::size_t i = 0; i < n; ++i)
        order[i] = std::uint32_t(i);
    if (encoding.compress && n > 0) {
        if (!triIndices.empty()) {
            std::vector<std::uint32_t> cached(triIndices.size());
            meshopt_optimizeVertexCache(cached.data(), triIndices.data(), triIndices.size(), n);
            triIndices.swap(cached);
        }
        std::vector<std::uint32_t> remap(n, ~0u);  // old -> new
        std::uint32_t next = 0;
        for (std::uint32_t v : triIndices)
            if (remap[v] == ~0u) remap[v] = next++;
        for (std::size_t i = 0; i < n; ++i)  // vertices of no triangle: last, in file order
            if (remap[i] == ~0u) remap[i] = next++;
        for (std::size_t i = 0; i < n; ++i)
            order[remap[i]] = std::uint32_t(i);
        for (std::uint32_t& v : triIndices)
            v = remap[v];
        for (std::uint32_t& v : lineIndices)
            v = remap[v];
        // 16-bit where every position fits (the grid's points), else floats.
        bool fits = encoding.step > 0;
        for (std::size_t i = 0; fits && i < 3 * n; ++i)
            fits = std::fabs(std::round(g[i] / encoding.step)) <= kQuantizationMax;
        counts.shortPositions = fits;
        if (fits) scale = encoding.step;
    }

    tinygltf::Mesh mesh;
    mesh.name = name;
    if (n > 0) {
        int posView = 0, posAcc = 0, normView = 0, normAcc = 0;
        // Compressed views declare their stride (the meshopt codec's element size).
        const std::size_t floatStride = encoding.compress ? 3 * sizeof(float) : 0;
        if (counts.shortPositions) {
            // 16-bit positions (x, y, z, padding: glTF aligns vertex elements to 4 bytes).
            std::vector<std::int16_t> q(4 * n, 0);
            std::vector<double> lo(3, std::numeric_limits<double>::infinity());
            std::vector<double> hi(3, -std::numeric_limits<double>::infinity());
            for (std::size_t i = 0; i < n; ++i)
                for (std::size_t k = 0; k < 3; ++k) {
                    const double v = std::round(g[3 * std::size_t(order[i]) + k] / scale);
                    q[4 * i + k] = static_cast<std::int16_t>(v);
                    lo[k] = std::min(lo[k], v);
                    hi[k] = std::max(hi[k], v);
                }
            posView = appendView(model, q.data(), q.size() * sizeof(std::int16_t),
                                 TINYGLTF_TARGET_ARRAY_BUFFER, 4 * sizeof(std::int16_t));
            posAcc = addAccessor(model, posView, TINYGLTF_COMPONENT_TYPE_SHORT, TINYGLTF_TYPE_VEC3,
                                 n, lo, hi);
        } else {
            // Floats: exact on the grid when compressed (see gltfmodel.h).
            std::vector<float> positions(3 * n);
            std::vector<double> lo(3, std::numeric_limits<double>::infinity());
            std::vector<double> hi(3, -std::numeric_limits<double>::infinity());
            for (std::size_t i = 0; i < 3 * n; ++i) {
                positions[i] = static_cast<float>(g[3 * std::size_t(order[i / 3]) + i % 3]);
                lo[i % 3] = std::min(lo[i % 3], double(positions[i]));
                hi[i % 3] = std::max(hi[i % 3], double(positions[i]));
            }
            // (meshopt's exponential filter, exact on these grid points, compressed them worse:
            // 553 kB -> 588 kB for the demo tileset's 78 k float positions.)
            posView = appendView(model, positions.data(), positions.size() * sizeof(float),
                                 TINYGLTF_TARGET_ARRAY_BUFFER, floatStride);
            posAcc = addAccessor(model, posView, TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC3,
                                 n, lo, hi);
        }
        if (encoding.compress) {
            // 8-bit normals in meshopt's octahedral filter (two 8-bit coordinates on the
            // octahedron, a scale, padding): a client decodes them to normalised 8-bit vectors.
            std::vector<float> unit(4 * n, 0.0f);
            for (std::size_t i = 0; i < n; ++i)
                for (std::size_t k = 0; k < 3; ++k)
                    unit[4 * i + k] = normals[3 * std::size_t(order[i]) + k];
            std::vector<std::int8_t> qn(4 * n, 0);
            meshopt_encodeFilterOct(qn.data(), n, 4, 8, unit.data());
            normView = appendView(model, qn.data(), qn.size(), TINYGLTF_TARGET_ARRAY_BUFFER, 4,
                                  "OCTAHEDRAL");
            normAcc = addAccessor(model, normView, TINYGLTF_COMPONENT_TYPE_BYTE, TINYGLTF_TYPE_VEC3,
                                  n, {}, {}, true);
        } else {
            normView = appendView(model, normals.data(), normals.size() * sizeof(float),
                                  TINYGLTF_TARGET_ARRAY_BUFFER);
            normAcc =
                addAccessor(model, normView, TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC3, n);
        }
        // One indexed primitive over the POSITION accessor (NORMAL only for the terrain). Indices
        // are 16-bit where the level's vertices fit (glTF reserves the type's largest value, so
        // at most 65 535 vertices), half the bytes of 32-bit ones.
        const bool shortIndices = n <= 65535;
        std::vector<std::uint16_t> narrow;
        auto addPrimitive = [&](const std::vector<std::uint32_t>& indices, int mode, int material,
                                int normalAccessor) {
            if (indices.empty()) return;
            int view = 0;
            if (shortIndices) {
                narrow.resize(indices.size());
                std::transform(indices.begin(), indices.end(), narrow.begin(),
                               [](std::uint32_t i) { return static_cast<std::uint16_t>(i); });
                view = appendView(model, narrow.data(), narrow.size() * sizeof(std::uint16_t),
                                  TINYGLTF_TARGET_ELEMENT_ARRAY_BUFFER);
            } else {
                view = appendView(model, indices.data(), indices.size() * sizeof(std::uint32_t),
                                  TINYGLTF_TARGET_ELEMENT_ARRAY_BUFFER);
            }
            tinygltf::Primitive p;
            p.attributes["POSITION"] = posAcc;
            if (normalAccessor >= 0) p.attributes["NORMAL"] = normalAccessor;
            p.indices = addAccessor(model, view,
                                    shortIndices ? TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT
                                                 : TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT,
                                    TINYGLTF_TYPE_SCALAR, indices.size());
            p.mode = mode;
            p.material = material;
            mesh.primitives.push_back(p);
        };
        addPrimitive(triIndices, TINYGLTF_MODE_TRIANGLES, materials.terrain, normAcc);
        addPrimitive(lineIndices, TINYGLTF_MODE_LINE, materials.river, -1);
    }
    tinygltf::Node node;
    node.name = name;
    // In double (toGltf's float would lose the translation's precision).
    node.translation = {origin[0], origin[1], origin[2]};
    if (counts.shortPositions) node.scale = {scale, scale, scale};
    if (!mesh.primitives.empty()) {
        model.meshes.push_back(mesh);
        node.mesh = int(model.meshes.size() - 1);
    }
    model.nodes.push_back(node);
    model.scenes[0].nodes.push_back(int(model.nodes.size() - 1));
    return int(model.nodes.size() - 1);
}

namespace {

constexpr std::uint32_t kGlbMagic = 0x46546C67;  // "glTF"
constexpr std::uint32_t kChunkJson = 0x4E4F534A, kChunkBin = 0x004E4942;

std::uint32_t readU32(const std::string& s, std::size_t at) {
    std::uint32_t v;
    std::memcpy(&v, s.data() + at, 4);  // GLB is little-endian, as every target of this code
    return v;
}

void appendU32(std::string& s, std::uint32_t v) {
    char b[4];
    std::memcpy(b, &v, 4);
    s.append(b, 4);
}

// Every buffer view of a .glb written by tinygltf from addLevelMesh's meshes replaced by its
// meshoptimizer encoding (EXT_meshopt_compression, gltfmodel.h): vertex views as ATTRIBUTES with
// their declared stride, the indices of TRIANGLES primitives as TRIANGLES, of LINES as INDICES.
// False on a view no primitive uses in one of those roles (not a model of ours).
bool meshoptCompress(std::string& glb) {
    static std::once_flag versions;  // the bitstream versions the extension specifies
    std::call_once(versions, [] {
        meshopt_encodeVertexVersion(0);
        meshopt_encodeIndexVersion(1);
    });
    std::string text, bin;
    if (!splitGlb(glb, text, bin)) return false;
    nlohmann::json j = nlohmann::json::parse(text, nullptr, false);
    if (j.is_discarded()) return false;
    if (!j.contains("bufferViews")) return true;  // no mesh (an empty view): nothing to compress
    nlohmann::json& views = j["bufferViews"];
    const nlohmann::json& accessors = j["accessors"];
    enum class Mode { None, Attributes, Triangles, Indices };
    struct Use {
        Mode mode = Mode::None;
        std::size_t count = 0, stride = 0;
    };
    std::vector<Use> uses(views.size());
    auto use = [&](std::size_t accessor, Mode mode) {
        const nlohmann::json& a = accessors.at(accessor);
        Use& u = uses.at(std::size_t(a.at("bufferView")));
        u.mode = mode;
        u.count = a.at("count");
        if (mode == Mode::Attributes)
            u.stride = views.at(std::size_t(a.at("bufferView"))).value("byteStride", 0u);
        else
            u.stride = int(a.at("componentType")) == TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT ? 2 : 4;
    };
    for (const nlohmann::json& mesh : j.value("meshes", nlohmann::json::array()))
        for (const nlohmann::json& p : mesh.at("primitives")) {
            for (const auto& [name, accessor] : p.at("attributes").items())
                use(std::size_t(accessor), Mode::Attributes);
            if (p.contains("indices"))
                use(std::size_t(p["indices"]),
                    p.value("mode", TINYGLTF_MODE_TRIANGLES) == TINYGLTF_MODE_TRIANGLES
                        ? Mode::Triangles
                        : Mode::Indices);
        }
    std::string packed;
    std::vector<unsigned char> out;
    std::vector<std::uint32_t> indices;
    for (std::size_t i = 0; i < views.size(); ++i) {
        nlohmann::json& v = views[i];
        const Use& u = uses[i];
        const std::size_t offset = v.value("byteOffset", 0u), length = v.at("byteLength");
        if (u.mode == Mode::None || u.stride == 0 || u.count * u.stride != length ||
            offset + length > bin.size())
            return false;
        const char* data = bin.data() + offset;
        std::size_t bytes = 0;
        const char* modeName = "ATTRIBUTES";
        if (u.mode == Mode::Attributes) {
            if (u.stride % 4 != 0 || u.stride > 256) return false;
            out.resize(meshopt_encodeVertexBufferBound(u.count, u.stride));
            bytes = meshopt_encodeVertexBuffer(out.data(), out.size(), data, u.count, u.stride);
        } else {
            indices.resize(u.count);
            std::uint32_t vertices = 0;
            for (std::size_t k = 0; k < u.count; ++k) {
                if (u.stride == 2) {
                    std::uint16_t x;
                    std::memcpy(&x, data + 2 * k, 2);
                    indices[k] = x;
                } else {
                    std::memcpy(&indices[k], data + 4 * k, 4);
                }
                vertices = std::max(vertices, indices[k] + 1);
            }
            if (u.mode == Mode::Triangles) {
                if (u.count % 3 != 0) return false;
                modeName = "TRIANGLES";
                out.resize(meshopt_encodeIndexBufferBound(u.count, vertices));
                bytes = meshopt_encodeIndexBuffer(out.data(), out.size(), indices.data(), u.count);
            } else {
                modeName = "INDICES";
                out.resize(meshopt_encodeIndexSequenceBound(u.count, vertices));
                bytes =
                    meshopt_encodeIndexSequence(out.data(), out.size(), indices.data(), u.count);
            }
        }
        if (bytes == 0) return false;
        while (packed.size() % 4 != 0)
            packed.push_back('\0');
        v["buffer"] = 1;
        nlohmann::json& e = v["extensions"]["EXT_meshopt_compression"];
        e = {{"buffer", 0},         {"byteOffset", packed.size()},
             {"byteLength", bytes}, {"byteStride", u.stride},
             {"count", u.count},    {"mode", modeName}};
        if (v.contains("extras")) {  // the filter addLevelMesh applied (kFilterKey)
            if (u.mode != Mode::Attributes) return false;
            e["filter"] = v["extras"].at(kFilterKey);
            v.erase("extras");
        }
        packed.append(reinterpret_cast<const char*>(out.data()), bytes);
    }
    if (packed.size() > 0xFFFF0000u) return false;  // beyond a GLB chunk
    j["buffers"] = nlohmann::json::array(
        {{{"byteLength", packed.size()}},
         {{"byteLength", bin.size()},
          {"extensions", {{"EXT_meshopt_compression", {{"fallback", true}}}}}}});
    for (const char* list : {"extensionsUsed", "extensionsRequired"})
        j[list].push_back("EXT_meshopt_compression");
    glb = joinGlb(j.dump(), packed);
    return true;
}

}  // namespace

bool splitGlb(const std::string& glb, std::string& json, std::string& bin) {
    if (glb.size() < 20 || readU32(glb, 0) != kGlbMagic || readU32(glb, 4) != 2 ||
        readU32(glb, 8) != glb.size())
        return false;
    const std::size_t jsonLength = readU32(glb, 12);
    if (readU32(glb, 16) != kChunkJson || jsonLength > glb.size() - 20) return false;
    json.assign(glb, 20, jsonLength);
    bin.clear();
    const std::size_t at = 20 + jsonLength;
    if (at == glb.size()) return true;
    if (glb.size() - at < 8 || readU32(glb, at + 4) != kChunkBin) return false;
    const std::size_t binLength = readU32(glb, at);
    if (binLength > glb.size() - at - 8) return false;
    bin.assign(glb, at + 8, binLength);
    return true;
}

std::string joinGlb(const std::string& json, const std::string& bin) {
    std::string j = json, b = bin;
    while (j.size() % 4 != 0)
        j.push_back(' ');
    while (b.size() % 4 != 0)
        b.push_back('\0');
    std::string glb;
    appendU32(glb, kGlbMagic);
    appendU32(glb, 2);
    appendU32(glb, std::uint32_t(12 + 8 + j.size() + (b.empty() ? 0 : 8 + b.size())));
    appendU32(glb, std::uint32_t(j.size()));
    appendU32(glb, kChunkJson);
    glb += j;
    if (!b.empty()) {
        appendU32(glb, std::uint32_t(b.size()));
        appendU32(glb, kChunkBin);
        glb += b;
    }
    return glb;
}

bool writeGlb(tinygltf::Model& model, const GltfEncoding& encoding, std::string& glb) {
    std::ostringstream out;
    tinygltf::TinyGLTF writer;
    if (!writer.WriteGltfSceneToStream(&model, out, false, true) || !out) return false;
    glb = std::move(out).str();
    return !encoding.compress || meshoptCompress(glb);
}

QuantizationGrid::QuantizationGrid(double leafHalfExtent) {
    step_ = std::exp2(std::ceil(std::log2(std::max(leafHalfExtent, 1e-3) / 32000.0)));
}

double QuantizationGrid::snap(double p[3]) const {
    double moved = 0;
    for (int k = 0; k < 3; ++k) {
        const double q = std::round(p[k] / step_) * step_;
        moved = std::max(moved, std::fabs(q - p[k]));
        p[k] = q;
    }
    return moved;
}

void exactXY(const format::Block& block, std::size_t v, double& x, double& y) {
    if (block.grid.size() == block.vertices.size()) {
        const double ox = std::round(block.originX / format::kGridUnit);
        const double oy = std::round(block.originY / format::kGridUnit);
        x = (ox + double(block.grid[v].x)) * format::kGridUnit;
        y = (oy + double(block.grid[v].y)) * format::kGridUnit;
    } else {
        x = block.originX + double(block.vertices[v].x);
        y = block.originY + double(block.vertices[v].y);
    }
}

}  // namespace unilod::exporter
