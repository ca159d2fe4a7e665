#include "gltfmodel.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <sstream>

namespace unilod::exporter {

namespace {

using tinygltf::Value;

// Appends raw bytes to the single buffer (4-byte aligned) and returns a new buffer view.
int appendView(tinygltf::Model& model, const void* data, std::size_t bytes, int target) {
    std::vector<unsigned char>& buf = model.buffers[0].data;
    while (buf.size() % 4 != 0)
        buf.push_back(0);
    tinygltf::BufferView view;
    view.buffer = 0;
    view.byteOffset = buf.size();
    view.byteLength = bytes;
    view.target = target;
    const auto* p = static_cast<const unsigned char*>(data);
    buf.insert(buf.end(), p, p + bytes);
    model.bufferViews.push_back(view);
    return int(model.bufferViews.size() - 1);
}

int addAccessor(tinygltf::Model& model, int view, int componentType, int type, std::size_t count,
                std::vector<double> minValues = {}, std::vector<double> maxValues = {}) {
    tinygltf::Accessor a;
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

tinygltf::Model newGltfModel(const std::string& generator, GltfMaterials& materials) {
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
    return model;
}

int addLevelMesh(tinygltf::Model& model, const format::Block& block, std::size_t levelIndex,
                 const std::vector<double>& xyz, const std::array<double, 3>& translation,
                 const std::string& name, const GltfMaterials& materials, LevelCounts& counts) {
    const format::Level& level = block.levels[levelIndex];
    const std::size_t n = level.vertexCount;

    std::vector<float> positions(3 * n);
    std::vector<double> lo(3, std::numeric_limits<double>::infinity());
    std::vector<double> hi(3, -std::numeric_limits<double>::infinity());
    for (std::size_t i = 0; i < n; ++i) {
        toGltf(xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2], &positions[3 * i]);
        for (int k = 0; k < 3; ++k) {
            lo[k] = std::min(lo[k], double(positions[3 * i + k]));
            hi[k] = std::max(hi[k], double(positions[3 * i + k]));
        }
    }
    // Area-weighted normals: the sum of the (unnormalised) face normals of the level's triangles,
    // computed in the file's axes, then rotated like the positions.
    std::vector<double> acc(3 * n, 0.0);
    std::vector<std::uint32_t> triIndices;
    triIndices.reserve(3 * std::size_t(level.triangleCount));
    for (std::uint32_t t = 0; t < level.triangleCount; ++t) {
        const format::Triangle& tri = block.terrainIndices[level.triangleFirst + t];
        const double* a = &xyz[3 * std::size_t(tri.a)];
        const double* b = &xyz[3 * std::size_t(tri.b)];
        const double* c = &xyz[3 * std::size_t(tri.c)];
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

    tinygltf::Mesh mesh;
    mesh.name = name;
    if (n > 0) {
        const int posView = appendView(model, positions.data(), positions.size() * sizeof(float),
                                       TINYGLTF_TARGET_ARRAY_BUFFER);
        const int posAcc = addAccessor(model, posView, TINYGLTF_COMPONENT_TYPE_FLOAT,
                                       TINYGLTF_TYPE_VEC3, n, lo, hi);
        const int normView = appendView(model, normals.data(), normals.size() * sizeof(float),
                                        TINYGLTF_TARGET_ARRAY_BUFFER);
        const int normAcc =
            addAccessor(model, normView, TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC3, n);
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
    node.translation = {translation[0], translation[2], -translation[1]};
    if (!mesh.primitives.empty()) {
        model.meshes.push_back(mesh);
        node.mesh = int(model.meshes.size() - 1);
    }
    model.nodes.push_back(node);
    model.scenes[0].nodes.push_back(int(model.nodes.size() - 1));
    return int(model.nodes.size() - 1);
}

bool writeGlb(tinygltf::Model& model, std::string& glb) {
    std::ostringstream out;
    tinygltf::TinyGLTF writer;
    if (!writer.WriteGltfSceneToStream(&model, out, false, true) || !out) return false;
    glb = std::move(out).str();
    return true;
}

}  // namespace unilod::exporter
