// `unilod export`: the LOD selected for one view (selection.h) as a glTF 2.0 binary (.glb) that
// Blender and three.js open (issue 6, item 2). Written with tinygltf.
//
// Layout of the .glb (the mesh of a level: gltfmodel.h, axes and primitives):
// - The world origin is the .ulod header's origin (the DEM's cell (0, 0) centre): a world point
//   (X, Y, Z) becomes glTF (X - originX, Z, -(Y - originY)). Positions are the file's own
//   block-relative floats; each block's node has translation (blockOriginX - originX, 0,
//   -(blockOriginY - originY)) in double.
// - asset.extras: {"crs_wkt": header WKT, "origin": [originX, originY, 0], "axes": the mapping
//   above in words, "source": the .ulod path, "metric": "max"|"paper", "selection": the options}.
// - One node and one mesh per block (node name "block_COL_ROW", extras: col, row, level, step,
//   h_lim, error, distance), translated as above.
// - --compress: quantized and meshopt-compressed (gltfmodel.h); each node then translates to its
//   level's box centre and scales by its step, asset.extras "compression" names the encoding
//   and "max_quantization_error_m" the largest half step.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "gltfmodel.h"
#include "selection.h"

namespace unilod::exporter {

struct ExportOptions {
    std::string path;     // the .ulod file
    std::string outPath;  // the .glb to write (format::AtomicFile; never the input)
    bool overwrite = false;  // replace an existing outPath (--overwrite)
    GltfEncoding encoding;   // --compress (gltfmodel.h)
    SelectionOptions selection;
    std::function<void(std::size_t, std::size_t)> progress;  // blocks done, total
};

struct ExportSummary {
    std::vector<ExportedBlock> blocks;  // file order
    std::uint64_t vertices = 0, triangles = 0, riverEdges = 0;
    std::uint64_t bytes = 0;
    double maxQuantizationError = 0;  // compressed: the largest half step of a node (metres)
};

// Returns false with a message naming the file on a data error; no output file is left then.
bool exportGltf(const ExportOptions& options, ExportSummary& summary, std::string& error);

}  // namespace unilod::exporter
