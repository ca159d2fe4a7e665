// `unilod export`: the LOD selected for one view (selection.h) as a glTF 2.0 binary (.glb) that
// Blender and three.js open (issue 6, item 2). Written with tinygltf.
//
// Layout of the .glb:
// - Axes: glTF is y-up, right-handed, metres. A world point (X, Y, Z) of the file's working CRS
//   (x east, y north, z up) becomes glTF (X - originX, Z, -(Y - originY)): x -> x, z (up) -> y,
//   y (north) -> -z. This is a rotation (determinant +1), so the counter-clockwise triangles of
//   the file (seen from above) stay front-facing seen from above. The origin is the .ulod
//   header's origin (the DEM's cell (0, 0) centre). Positions are the file's own block-relative
//   floats (x, y relative to the block origin, z absolute), mapped as above; each block's node
//   has translation (blockOriginX - originX, 0, -(blockOriginY - originY)) in double, so a viewer
//   gets the same precision as the engine.
// - asset.extras: {"crs_wkt": header WKT, "origin": [originX, originY, 0], "axes": the mapping
//   above in words, "source": the .ulod path, "metric": "max"|"paper", "selection": the options}.
// - One node and one mesh per block (node name "block_COL_ROW", extras: col, row, level, step,
//   h_lim, error, distance), translated as above. The mesh's first primitive: mode TRIANGLES,
//   POSITION (with min / max) and NORMAL (per-vertex, area-weighted over the level's triangles)
//   of the level's vertex prefix [0, vertexCount), UNSIGNED_INT indices = the level's triangles.
//   Second primitive (only when the level has river edges): mode LINES on the same POSITION
//   accessor, indices = the level's river edges. Two materials: "terrain" (grey), "river" (blue).
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "selection.h"

namespace unilod::exporter {

struct ExportOptions {
    std::string path;     // the .ulod file
    std::string outPath;  // the .glb to write (format::AtomicFile; replaced, never the input)
    SelectionOptions selection;
    std::function<void(std::size_t, std::size_t)> progress;  // blocks done, total
};

struct ExportSummary {
    std::vector<ExportedBlock> blocks;  // file order
    std::uint64_t vertices = 0, triangles = 0, riverEdges = 0;
    std::uint64_t bytes = 0;
};

// glTF axes of a file vector (x east, y north, z up): see the layout above.
inline void toGltf(double dx, double dy, double z, float out[3]) {
    out[0] = static_cast<float>(dx);
    out[1] = static_cast<float>(z);
    out[2] = static_cast<float>(-dy);
}

// Returns false with a message naming the file on a data error; no output file is left then.
bool exportGltf(const ExportOptions& options, ExportSummary& summary, std::string& error);

}  // namespace unilod::exporter
