#include "gltfexport.h"

#include <tiny_gltf.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <sstream>

#include "jsontext.h"

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

int addMaterial(tinygltf::Model& model, const char* name, double r, double g, double b) {
    tinygltf::Material m;
    m.name = name;
    m.pbrMetallicRoughness.baseColorFactor = {r, g, b, 1.0};
    m.pbrMetallicRoughness.metallicFactor = 0.0;
    m.pbrMetallicRoughness.roughnessFactor = 1.0;
    m.doubleSided = true;
    model.materials.push_back(m);
    return int(model.materials.size() - 1);
}

// One block's mesh + node.
void addBlock(tinygltf::Model& model, const format::Header& header, const format::Block& block,
              const ExportedBlock& sel, int terrainMaterial, int riverMaterial) {
    const format::Level& level = block.levels[sel.wanted.level];
    const std::size_t n = level.vertexCount;
    const double dx0 = block.originX - header.originX, dy0 = block.originY - header.originY;

    std::vector<float> positions(3 * n);
    std::vector<double> lo(3, std::numeric_limits<double>::infinity());
    std::vector<double> hi(3, -std::numeric_limits<double>::infinity());
    for (std::size_t i = 0; i < n; ++i) {
        const format::Vertex& v = block.vertices[i];
        toGltf(double(v.x), double(v.y), double(v.z), &positions[3 * i]);
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
        const format::Vertex& a = block.vertices[tri.a];
        const format::Vertex& b = block.vertices[tri.b];
        const format::Vertex& c = block.vertices[tri.c];
        const double ux = double(b.x) - a.x, uy = double(b.y) - a.y, uz = double(b.z) - a.z;
        const double vx = double(c.x) - a.x, vy = double(c.y) - a.y, vz = double(c.z) - a.z;
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

    const int posView = appendView(model, positions.data(), positions.size() * sizeof(float),
                                   TINYGLTF_TARGET_ARRAY_BUFFER);
    const int posAcc = addAccessor(model, posView, TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC3,
                                   n, lo, hi);
    const int normView = appendView(model, normals.data(), normals.size() * sizeof(float),
                                    TINYGLTF_TARGET_ARRAY_BUFFER);
    const int normAcc =
        addAccessor(model, normView, TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC3, n);

    tinygltf::Mesh mesh;
    mesh.name = "block_" + std::to_string(block.col) + "_" + std::to_string(block.row);
    // One indexed primitive over the block's POSITION accessor (NORMAL only for the terrain).
    auto addPrimitive = [&](const std::vector<std::uint32_t>& indices, int mode, int material,
                            int normalAccessor) {
        if (indices.empty()) return;
        const int view = appendView(model, indices.data(), indices.size() * sizeof(std::uint32_t),
                                    TINYGLTF_TARGET_ELEMENT_ARRAY_BUFFER);
        tinygltf::Primitive p;
        p.attributes["POSITION"] = posAcc;
        if (normalAccessor >= 0) p.attributes["NORMAL"] = normalAccessor;
        p.indices = addAccessor(model, view, TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT,
                                TINYGLTF_TYPE_SCALAR, indices.size());
        p.mode = mode;
        p.material = material;
        mesh.primitives.push_back(p);
    };
    addPrimitive(triIndices, TINYGLTF_MODE_TRIANGLES, terrainMaterial, normAcc);
    addPrimitive(lineIndices, TINYGLTF_MODE_LINE, riverMaterial, -1);
    tinygltf::Node node;
    node.name = mesh.name;
    node.translation = {dx0, 0.0, -dy0};
    if (!mesh.primitives.empty()) {
        model.meshes.push_back(mesh);
        node.mesh = int(model.meshes.size() - 1);
    }
    Value::Object extras;
    extras["index"] = Value(int(sel.block));
    extras["col"] = Value(int(block.col));
    extras["row"] = Value(int(block.row));
    extras["tree_level"] = Value(int(block.level));
    extras["level"] = Value(int(sel.wanted.level));
    extras["step"] = Value(int(sel.wanted.step));
    extras["h_lim"] = Value(sel.hLim);
    extras["error"] = Value(sel.wanted.error);
    extras["distance"] = Value(sel.distance);
    extras["min_depth"] = Value(sel.box.minDepth);
    extras["axis_cos"] = Value(sel.box.axisCos);
    extras["vertical_sin"] = Value(sel.box.verticalSin);
    extras["rivers"] = Value(sel.box.horizontal);
    node.extras = Value(extras);
    model.nodes.push_back(node);
    model.scenes[0].nodes.push_back(int(model.nodes.size() - 1));
}

}  // namespace

bool exportGltf(const ExportOptions& options, ExportSummary& summary, std::string& error) {
    summary = {};
    // The output first: a bad -o (the input itself, a missing folder) fails before the work.
    format::AtomicFile out;
    if (!out.open(options.outPath, {.replace = true, .inputs = {options.path}}, error)) {
        return false;
    }
    format::Reader reader;
    if (!reader.open(options.path, error)) return false;
    std::uint32_t metric = 0;
    if (!resolveMetric(reader, options.selection, metric, error)) return false;
    const format::Header& header = reader.header();

    tinygltf::Model model;
    model.asset.version = "2.0";
    model.asset.generator = "unilod export";
    Value::Object assetExtras;
    // glTF is JSON: text from the outside (a CRS, a path) must be valid UTF-8 (jsontext.h).
    assetExtras["crs_wkt"] = Value(validUtf8(header.crsWkt));
    assetExtras["origin"] =
        Value(Value::Array{Value(header.originX), Value(header.originY), Value(0.0)});
    assetExtras["axes"] = Value(std::string(
        "gltf (x, y, z) = (X - origin[0], Z, -(Y - origin[1])) for a world point (X east, Y "
        "north, Z up) of crs_wkt, metres"));
    assetExtras["source"] = Value(validUtf8(options.path));
    assetExtras["metric"] =
        Value(std::string(metric == format::kMetricPaper ? "paper" : "max"));
    Value::Object sel;
    const SelectionOptions& so = options.selection;
    if (so.useCamera) {
        sel["camera"] = Value(Value::Array{Value(so.eye[0]), Value(so.eye[1]), Value(so.eye[2])});
        sel["fov_degrees"] = Value(so.fovDegrees);
        sel["width_pixels"] = Value(so.widthPixels);
        sel["height_pixels"] = Value(so.heightPixels);
        sel["pixels"] = Value(so.pixels);
        sel["distance"] = Value(std::string(so.distance == engine::DistanceMode::Centre
                                                ? "centre of the block's bounding box"
                                                : "nearest point of the block's bounding box"));
        sel["culled"] = Value(so.hasDirection && so.cull);
        if (so.hasDirection) {
            sel["yaw_degrees"] = Value(so.yawDegrees);
            sel["pitch_degrees"] = Value(so.pitchDegrees);
        }
    } else {
        sel["h_lim"] = Value(so.hLim);
    }
    assetExtras["selection"] = Value(sel);
    model.asset.extras = Value(assetExtras);
    model.buffers.resize(1);
    model.scenes.resize(1);
    model.scenes[0].name = "unilod";
    model.defaultScene = 0;
    const int terrainMaterial = addMaterial(model, "terrain", 0.6, 0.6, 0.55);
    const int riverMaterial = addMaterial(model, "river", 0.1, 0.3, 0.9);

    // The cut through the block hierarchy (engine/lod/cut.h, as the engine selects it): every
    // block's box and levels first (a visible one read and validated once), then the drawn
    // nodes, read again, in file order.
    const std::size_t count = reader.blocks().size();
    std::vector<std::vector<format::Level>> levels(count);
    std::vector<engine::LodNode> nodes(count);
    format::Block block;
    for (std::size_t i = 0; i < count; ++i) {
        const format::BlockInfo& info = reader.blocks()[i];
        if (blockVisible(info, so)) {
            if (!reader.readBlock(i, block, error)) return false;
            nodes[i] = engine::lodNode(block);
            levels[i] = std::move(block.levels);
        } else {
            // Outside the view: only its box and links matter (the cut skips its subtree).
            nodes[i] = engine::lodNode(info);
            levels[i].push_back(format::Level{});
        }
        nodes[i].levels = &levels[i];
        if (options.progress) options.progress(i + 1, 2 * count);
    }
    std::vector<engine::NodeChoice> cut;
    engine::selectCut(viewSpec(so), nodes, metric, cut);
    std::vector<std::uint32_t> drawn;
    for (const engine::NodeChoice& c : cut)
        drawn.push_back(c.block);
    std::sort(drawn.begin(), drawn.end());
    for (std::size_t k = 0; k < drawn.size(); ++k) {
        const std::uint32_t i = drawn[k];
        if (!reader.readBlock(i, block, error)) return false;
        const ExportedBlock s = selectLevel(block, i, so, metric);
        addBlock(model, header, block, s, terrainMaterial, riverMaterial);
        summary.blocks.push_back(s);
        summary.vertices += s.vertexCount;
        summary.triangles += s.triangles;
        summary.riverEdges += s.riverEdges;
        if (options.progress) options.progress(count + (k + 1) * count / drawn.size(), 2 * count);
    }

    std::ostringstream glb;
    tinygltf::TinyGLTF writer;
    if (!writer.WriteGltfSceneToStream(&model, glb, false, true) || !glb) {
        error = options.outPath + ": cannot serialize the glTF model";
        return false;
    }
    if (!out.write(glb.view(), error) || !out.commit(error)) return false;
    summary.bytes = out.bytes();  // what landed on disk
    return true;
}

}  // namespace unilod::exporter
