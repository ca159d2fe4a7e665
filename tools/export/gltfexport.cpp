#include "gltfexport.h"

#include "gltfmodel.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <limits>
#include <sstream>

#include "jsontext.h"
#include "refine.h"

namespace unilod::exporter {

namespace {

using tinygltf::Value;

// One block's mesh + node.
// `drawn`: the level written (the cut's, or a refined mesh appended to `block`).
// Returns the largest move of a vertex onto the grid (0 uncompressed).
double addBlock(tinygltf::Model& model, const format::Header& header, const format::Block& block,
                const ExportedBlock& sel, std::size_t drawn, GltfEncoding encoding,
                const QuantizationGrid& grid, const GltfMaterials& materials) {
    const format::Level& level = block.levels[drawn];
    const std::size_t n = level.vertexCount;
    std::vector<double> xyz(3 * n), unsnapped;
    double moved = 0;
    std::array<double, 3> translation = {block.originX - header.originX,
                                         block.originY - header.originY, 0.0};
    if (encoding.compress && n > 0) {
        // Exact positions relative to the file origin moved onto the grid, the node's origin a
        // grid point near the block's centre (gltfmodel.h).
        double lo[3] = {HUGE_VAL, HUGE_VAL, HUGE_VAL}, hi[3] = {-HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
        unsnapped.resize(3 * n);
        for (std::size_t i = 0; i < n; ++i) {
            double x = 0, y = 0;
            exactXY(block, i, x, y);
            double* p = &xyz[3 * i];
            p[0] = x - header.originX;
            p[1] = y - header.originY;
            p[2] = block.vertices[i].z;
            std::copy(p, p + 3, &unsnapped[3 * i]);
            moved = std::max(moved, grid.snap(p));
            for (int k = 0; k < 3; ++k) {
                lo[k] = std::min(lo[k], p[k]);
                hi[k] = std::max(hi[k], p[k]);
            }
        }
        for (std::size_t k = 0; k < 3; ++k)
            translation[k] = 0.5 * (lo[k] + hi[k]);
        grid.snap(translation.data());
        for (std::size_t i = 0; i < 3 * n; ++i) {
            xyz[i] -= translation[i % 3];
            unsnapped[i] -= translation[i % 3];
        }
        encoding.step = grid.step();
        encoding.unsnapped = &unsnapped;
    } else {
        // The file's own block-relative floats, translated by the block origin (in double).
        for (std::size_t i = 0; i < n; ++i) {
            const format::Vertex& v = block.vertices[i];
            xyz[3 * i] = v.x;
            xyz[3 * i + 1] = v.y;
            xyz[3 * i + 2] = v.z;
        }
    }
    LevelCounts counts;
    tinygltf::Node& node = model.nodes[std::size_t(
        addLevelMesh(model, block, drawn, xyz, translation,
                     "block_" + std::to_string(block.col) + "_" + std::to_string(block.row),
                     encoding, materials, counts))];
    Value::Object extras;
    extras["index"] = Value(int(sel.block));
    extras["col"] = Value(int(block.col));
    extras["row"] = Value(int(block.row));
    extras["tree_level"] = Value(int(block.level));
    extras["level"] = Value(int(sel.wanted.level));
    extras["step"] = Value(int(sel.wanted.step));
    extras["refined"] = Value(sel.refined);
    extras["steps_done"] = Value(int(sel.stepsDone));
    extras["h_lim"] = Value(sel.hLim);
    if (std::isfinite(sel.hLimRiver)) extras["h_lim_river"] = Value(sel.hLimRiver);
    extras["error"] = Value(sel.wanted.error);
    extras["river_error"] = Value(sel.wanted.riverError);
    extras["distance"] = Value(sel.distance);
    extras["min_depth"] = Value(sel.box.minDepth);
    extras["axis_cos"] = Value(sel.box.axisCos);
    extras["vertical_sin"] = Value(sel.box.verticalSin);
    extras["rivers"] = Value(sel.box.horizontal);
    node.extras = Value(extras);
    return moved;
}

}  // namespace

bool exportGltf(const ExportOptions& options, ExportSummary& summary, std::string& error) {
    summary = {};
    // The output first: a bad -o (the input itself, a missing folder) fails before the work.
    format::AtomicFile out;
    if (!out.open(options.outPath,
                  {.replace = options.overwrite, .inputs = {options.path}, .inputParts = {}},
                  error)) {
        return false;
    }
    format::Reader reader;
    if (!reader.open(options.path, error)) return false;
    std::uint32_t metric = 0;
    if (!resolveMetric(reader, options.selection, metric, error)) return false;
    const format::Header& header = reader.header();

    GltfMaterials materials;
    tinygltf::Model model = newGltfModel("unilod export", options.encoding, materials);
    Value::Object assetExtras;
    // glTF is JSON: text from the outside (a CRS, a path) must be valid UTF-8 (jsontext.h).
    assetExtras["crs_wkt"] = Value(validUtf8(header.crsWkt));
    assetExtras["origin"] =
        Value(Value::Array{Value(header.originX), Value(header.originY), Value(0.0)});
    assetExtras["axes"] = Value(std::string(
        "gltf (x, y, z) = (X - origin[0], Z, -(Y - origin[1])) for a world point (X east, Y "
        "north, Z up) of crs_wkt, metres"));
    assetExtras["source"] = Value(validUtf8(options.path));
    assetExtras["metric"] = Value(std::string(format::metricName(metric)));
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

    // The cut through the block hierarchy (engine/lod/cut.h, as the engine selects it) from the
    // directory's boxes and levels, then the drawn nodes, read and validated, in file order.
    const std::size_t count = reader.blocks().size();
    std::vector<engine::LodNode> nodes(count);
    format::Block block;
    for (std::size_t i = 0; i < count; ++i)
        nodes[i] = engine::lodNode(reader.blocks()[i]);
    std::vector<engine::NodeChoice> cut;
    engine::selectCut(viewSpec(so), nodes, metric, cut);
    // --compress: the grid sized from the leaves' boxes in the directory (+ 1 m).
    double leafHalfExtent = 0;
    for (const format::BlockInfo& b : reader.blocks())
        if (b.level == 0)
            leafHalfExtent = std::max({leafHalfExtent, 0.5 * (b.maxX - b.minX) + 1,
                                       0.5 * (b.maxY - b.minY) + 1, 0.5 * (b.maxZ - b.minZ) + 1});
    const QuantizationGrid grid(leafHalfExtent);
    std::vector<std::uint32_t> drawn;
    for (const engine::NodeChoice& c : cut)
        drawn.push_back(c.block);
    std::sort(drawn.begin(), drawn.end());
    for (std::size_t k = 0; k < drawn.size(); ++k) {
        const std::uint32_t i = drawn[k];
        if (!reader.readBlock(i, block, error)) return false;
        ExportedBlock s = selectLevel(block, i, so, metric);
        std::size_t level = s.wanted.level;
        // An entry refined for the view from its records, as the engine draws it (scene.h
        // SceneOptions::refine, lod/refine.h).
        if (so.useCamera && so.refine && s.wanted.step < block.steps.size()) {
            engine::Refinement refinement;
            std::string why;
            if (refinement.init(block, why)) {
                engine::RefinedMesh mesh;
                refinement.refine(viewSpec(so), mesh, s.wanted.step);
                level = refinement.appendAsLevel(mesh, block);
                s.refined = true;
                s.stepsDone = mesh.stepsDone;
                s.vertexCount = block.levels[level].vertexCount;
                s.triangles = block.levels[level].triangleCount;
                s.riverEdges = block.levels[level].riverCount;
            }
        }
        summary.maxQuantizationError =
            std::max(summary.maxQuantizationError,
                     addBlock(model, header, block, s, level, options.encoding, grid, materials));
        summary.blocks.push_back(s);
        summary.vertices += s.vertexCount;
        summary.triangles += s.triangles;
        summary.riverEdges += s.riverEdges;
        if (options.progress) options.progress(k + 1, drawn.size());
    }

    if (options.encoding.compress) {
        Value::Object& ax = model.asset.extras.Get<Value::Object>();
        ax["compression"] = Value(std::string(
            "positions on one grid (16-bit with KHR_mesh_quantization where a node fits, else "
            "float), 8-bit octahedral normals (meshopt filter), EXT_meshopt_compression"));
        ax["quantization_step_m"] = Value(grid.step());
        ax["max_quantization_error_m"] = Value(summary.maxQuantizationError);
    }
    std::string glb;
    if (!writeGlb(model, options.encoding, glb)) {
        error = options.outPath + ": cannot serialize the glTF model";
        return false;
    }
    if (!out.write(glb, error) || !out.commit(error)) return false;
    summary.bytes = out.bytes();  // what landed on disk
    return true;
}

}  // namespace unilod::exporter
