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

struct GltfMaterials {
    int terrain = -1, river = -1;
};

// An empty model (asset 2.0, one buffer, one scene) with the two materials.
tinygltf::Model newGltfModel(const std::string& generator, GltfMaterials& materials);

// Counts of what addLevelMesh wrote.
struct LevelCounts {
    std::uint32_t vertices = 0, triangles = 0, riverEdges = 0;
};

// Appends stored level `level` of `block` as a mesh + node named `name` and adds the node to
// scene 0. `xyz`: 3 doubles per vertex of the level's prefix (file axes, relative to
// `translation`). Indices are 16-bit where the level has at most 65 535 vertices, else 32-bit.
// Returns the node's index (its extras are the caller's).
int addLevelMesh(tinygltf::Model& model, const format::Block& block, std::size_t level,
                 const std::vector<double>& xyz, const std::array<double, 3>& translation,
                 const std::string& name, const GltfMaterials& materials, LevelCounts& counts);

// The model as a binary glTF (.glb). False when tinygltf cannot serialise it.
bool writeGlb(tinygltf::Model& model, std::string& glb);

}  // namespace unilod::exporter
