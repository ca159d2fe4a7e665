// The glTF building blocks both exports share (one implementation): `unilod export` writes one
// .glb of a view's cut (gltfexport.h), `unilod export --3dtiles` one .glb per tile (tiles3d.h).
//
// A stored level of a block becomes one mesh + one node:
// - Axes: glTF is y-up, right-handed, metres. A vector (x east, y north, z up) becomes glTF
//   (x, z, -y): a rotation (determinant +1), so the counter-clockwise triangles of the file (seen
//   from above) stay front-facing seen from above. 3D Tiles rotates glTF content back to z-up.
// - The caller gives every vertex of the level's prefix as a double (x, y, z) in those axes,
//   relative to the node's translation (also in those axes): positions are stored as floats near
//   zero, the translation in double, so a viewer keeps the engine's precision.
// - First primitive: mode TRIANGLES, POSITION (with min / max) and NORMAL (per vertex,
//   area-weighted over the level's triangles) of the vertex prefix [0, vertexCount), UNSIGNED_INT
//   indices = the level's triangles, material "terrain". Second primitive (only when the level
//   has river edges): mode LINES on the same POSITION accessor, indices = the level's river
//   edges, material "river" (unlit blue: KHR_materials_unlit).
// - Compressed (`export --compress`, GltfEncoding), the layout gltfpack and CesiumJS use for web
//   delivery: every position snapped to one grid of power-of-two step S for the whole export
//   (QuantizationGrid), each node's translation a grid point; POSITION as 16-bit integers with
//   the node's uniform scale S (KHR_mesh_quantization) where the level's box fits 32 767 steps
//   around it (the leaves: S is sized from them), else as floats, which hold grid points exactly
//   (multiples of a power of two below 2^24 steps); NORMAL as normalised 8-bit integers (from the
//   positions before snapping); vertices reordered by first use of the triangles in vertex-cache
//   order (meshoptimizer), the same vertices and triangles; every buffer view compressed with
//   meshoptimizer's codecs (EXT_meshopt_compression; the uncompressed layout is described by a
//   fallback buffer without data, as the extension allows when it is required). A vertex moves
//   by at most S / 2 per coordinate, and one point shared by two meshes (a border of a leaf and
//   of a node drawn beside it) decodes to the same point in both: no crack opens between them,
//   which separate per-mesh grids would leave.
#pragma once

#include <tiny_gltf.h>

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "ulod.h"

namespace unilod::exporter {

// glTF axes of a file vector (x east, y north, z up): see above.
inline void toGltf(double dx, double dy, double z, float out[3]) {
    out[0] = static_cast<float>(dx);
    out[1] = static_cast<float>(z);
    out[2] = static_cast<float>(-dy);
}

struct GltfEncoding {
    bool compress = false;  // see above
    // Compressed: the grid step S; the positions given to addLevelMesh lie on its grid
    // relative to the translation, which is a grid point too (QuantizationGrid).
    double step = 0;
    // Compressed: the positions before snapping (same frame), which the normals are computed
    // from; null: from the positions given.
    const std::vector<double>* unsnapped = nullptr;
};

// The grid of --compress (see above).
class QuantizationGrid {
public:
    // `leafHalfExtent`: a bound of |p - c| per axis, in the export's frame, for every vertex p of
    // a leaf entry and the centre c of its box. S = the smallest power of two with which that
    // fits 32 000 steps (the rest of the 32 767 leaves room for the rounding).
    explicit QuantizationGrid(double leafHalfExtent = 0);
    double step() const { return step_; }
    // `p` (3 coordinates) moved to the nearest grid point; returns the largest move.
    double snap(double p[3]) const;

private:
    double step_ = 1;
};

// Vertex v's x, y in the file CRS from its exact grid position (the same double for a point in
// every block and node that holds it); from its float where the block has no grid positions.
void exactXY(const format::Block& block, std::size_t v, double& x, double& y);

struct GltfMaterials {
    int terrain = -1, river = -1;
};

// An empty model (asset 2.0, one buffer, one scene) with the two materials (and, compressed,
// KHR_mesh_quantization required).
tinygltf::Model newGltfModel(const std::string& generator, const GltfEncoding& encoding,
                             GltfMaterials& materials);

// Counts of what addLevelMesh wrote.
struct LevelCounts {
    std::uint32_t vertices = 0, triangles = 0, riverEdges = 0;
    bool shortPositions = false;  // compressed: 16-bit positions (else floats)
};

// Appends stored level `level` of `block` as a mesh + node named `name` and adds the node to
// scene 0. `xyz`: 3 doubles per vertex of the level's prefix (file axes, relative to
// `translation`). Indices are 16-bit where the level has at most 65 535 vertices, else 32-bit.
// Returns the node's index (its extras are the caller's).
int addLevelMesh(tinygltf::Model& model, const format::Block& block, std::size_t level,
                 const std::vector<double>& xyz, const std::array<double, 3>& translation,
                 const std::string& name, const GltfEncoding& encoding,
                 const GltfMaterials& materials, LevelCounts& counts);

// The model as a binary glTF (.glb), its buffer views meshopt-compressed when `encoding` says so.
// False when tinygltf cannot serialise it.
bool writeGlb(tinygltf::Model& model, const GltfEncoding& encoding, std::string& glb);

// The bytes of a .glb's two chunks (GLB container 2: JSON, then an optional BIN); false when
// `glb` is not such a container. Used by writeGlb and by the tests that decode its output.
bool splitGlb(const std::string& glb, std::string& json, std::string& bin);
// A .glb container of a JSON text and a BIN chunk (each padded to 4 bytes).
std::string joinGlb(const std::string& json, const std::string& bin);

}  // namespace unilod::exporter
