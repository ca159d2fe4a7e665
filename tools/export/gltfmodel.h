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
// - Compressed (`export --compress`, GltfEncoding::compress), the layout gltfpack and CesiumJS
//   use for web delivery: POSITION as 16-bit integers (KHR_mesh_quantization; the node's
//   translation moves to the centre of the level's box and its uniform scale is the step, so a
//   coordinate is off by at most half a step: the box's largest half-side / 32 767), NORMAL as
//   normalised 8-bit integers; vertices reordered by first use of the triangles in vertex-cache
//   order (meshoptimizer), the same vertices and triangles; every buffer view compressed with
//   meshoptimizer's codecs (EXT_meshopt_compression; the uncompressed layout is described by a
//   fallback buffer without data, as the extension allows when it is required).
//   Meshes drawn side by side share their border vertices, so the exports quantize on one grid
//   per tree level (QuantizationGrid below) rather than per mesh: a shared vertex decodes to the
//   same point in both meshes and no crack opens between them.
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
    // > 0: the positions given to addLevelMesh already lie on this step's grid relative to the
    // translation, which is used as it is (QuantizationGrid); 0: the level's own box grid.
    double step = 0;
    // With `step`: the positions before the border vertices were snapped (same frame), which
    // the normals are computed from; null: from the positions given.
    const std::vector<double>* unsnapped = nullptr;
};

// The grids of --compress (see above). Tree level L quantizes with step S_L = S_0 * 2^m_L,
// non-decreasing in L, the smallest that holds every entry of levels <= L on 16 bits (S_0 from
// the leaves'). A vertex on the border between two nodes of tree level B (and so of every level
// below: node borders nest) is snapped to S_B's grid before any mesh quantizes it, and a mesh of
// an entry at level L <= B puts its origin on S_L's grid: S_B is a multiple of S_L, so the vertex
// is exactly on that mesh's grid and decodes to the same point in every mesh whose border it is
// on. A vertex inside an entry is rounded by that entry's own grid (an ancestor or descendant is
// never drawn beside it). Cost: a vertex on a high-level border is off by up to S_B / 2 in the
// leaves too (the exports report the largest move).
class QuantizationGrid {
public:
    // `halfExtent[i]`: a bound of |p - c| per axis, in the export's frame, for every vertex p of
    // entry i and the centre c of its box; 0 for an entry not exported.
    void init(const format::Header& header, const std::vector<format::BlockInfo>& entries,
              const std::vector<double>& halfExtent);
    double step(std::uint32_t treeLevel) const;
    // The highest tree level whose node borders pass through (x, y) (file CRS), -1 where no two
    // entries meet (inside a leaf, on the model's outer edge).
    int borderLevel(double x, double y) const;
    // `p` (3 coordinates in the export's frame) of a vertex of an entry at `treeLevel`, rounded
    // to the grid of B = borderLevel(x, y) where B >= treeLevel (a border of the entry); left
    // alone inside the entry (B < treeLevel: the entry's own rounding is all it needs).
    void snap(double x, double y, std::uint32_t treeLevel, double p[3]) const;
    // The point of tree level L's grid nearest `c` (3 coordinates).
    void origin(std::uint32_t treeLevel, double c[3]) const;

private:
    std::vector<double> steps_;
    double originX_ = 0, originY_ = 0, blockWidth_ = 0, blockHeight_ = 0;
    std::uint32_t blocksX_ = 0, blocksY_ = 0;
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
    double quantizationStep = 0;  // compressed: the node's scale (a coordinate is within half)
    bool offGrid = false;  // GltfEncoding::step given but too fine for the level (own grid used)
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
