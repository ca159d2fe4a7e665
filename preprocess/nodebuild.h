// Issue 18's block hierarchy: the inner nodes of a quadtree over the block grid.
//
// Leaves are the blocks (blockbuild.h). A node at tree level L covers the 2^L x 2^L blocks from
// (col * 2^L, row * 2^L) on; its children are the (up to four) nodes of level L - 1 inside it
// that hold any of the domain. A node starts from the union of its children's coarsest states
// (CoarseState): the same points (merged where two children share one), the outline of the union
// of their triangles as the domain's rings, their coarsest river edges chained into polylines.
// The borders the children shared are now interior and simplify; the node's own outer border
// stays locked (it is shared with the neighbour node of the same level, so adjacent drawn nodes
// meet without cracks), except where it is the DEM's outer edge and leaves leave that unlocked
// (ingest option lockOuterEdge), so the root's outline simplifies as the domain's does. A river
// vertex where a river crossed a child border is an ordinary river vertex now; river ends,
// junctions and pinch points of the outline stay locked.
//
// The node then runs the same greedy deletion as a block (deletion.h), with its `max` error
// measured against every ORIGINAL point of its area (ModelError extra samples), the running
// maximum starting at its children's largest final error (errors stay monotone up the tree) and
// that error as slack on every chain deviation (deletion.h DeletionOptions::chainSlack). Its
// records, errors, levels and index data are stored like a block's.
//
// Hand-over: a block or node that has a parent stops deleting once it has
// nodeHandoffTriangles(side, level) triangles or fewer (its coarsest state; the root runs to the
// end), a node above the blocks also once its next deletion would cost more than twice its
// starting error. Errors then about double per tree level, as the view distance at which a node
// is drawn does (the chunked-LOD rule), and a node's outer border, locked at full resolution, is
// not what its error is spent on (measured, 16M points: with the triangle rule alone the root's
// children reached 327 m and a uniform 100 m cut had to draw 5 nodes of 16-32k triangles). Without
// it the children would delete to their very end (only locked points, errors of the whole relief or
// of a collapsed outline) and no node could start below that error.
//
// Stop rule: the tree is built up to one root covering the whole model (a block grid of
// bx x by blocks has ceil(log2(max(bx, by))) levels above the leaves); the leaves are the blocks,
// whose size (`--block-size`, automatic by default) is where splitting stops.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "blockbuild.h"
#include "points.h"

namespace unilod {

// The hand-over triangle count of a node of tree `level` (0: a block) for blocks of `side`
// sampled cells: twice the node's locked border (4 side 2^level points), which no deletion
// removes: below that the node would be its border alone, with an error of the whole relief;
// for a block at least side^2 / 8 (1/16 of its 2 side^2 triangles; 8192 for 256-cell blocks, 512
// for 64-cell ones). A node above the blocks also hands over before its error passes twice its
// starting error (buildNode: DeletionOptions::stopKey), so errors about double per tree level
// as the view distance that draws a node does.
std::uint32_t nodeHandoffTriangles(int side, std::uint32_t level);

// The lines of a node's outer border (cell-centre coordinates of its first and last column and
// row) and whether points on each are locked.
struct NodeBorder {
    double x0 = 0, x1 = 0, y0 = 0, y1 = 0;
    bool lockX0 = true, lockX1 = true, lockY0 = true, lockY1 = true;
};

// The node's starting point set (above): points merged by exact (x, y), rings from the outline
// of the union of the children's triangles (the domain on the left of every ring edge), rivers
// from their coarsest river edges. Deterministic for a given child order.
PointSet nodePointSet(const std::vector<const CoarseState*>& children, const NodeBorder& border);

// Builds a node from its children's coarsest states: `block` (col, row: the node's position in
// its level's grid) and the node's own coarsest state for its parent. `originals` calls its
// argument once for every original point of the node's area. Greedy order only (the paper's
// 3D_DP order builds no tree). Returns false with `error` on failure.
bool buildNode(const std::vector<const CoarseState*>& children, const NodeBorder& border,
               std::uint32_t col, std::uint32_t row, const BlockBuildOptions& options,
               const std::function<void(const std::function<void(const Point&)>&)>& originals,
               std::size_t originalCount, format::Block& block, BlockBuildStats& stats,
               CoarseState& coarse, std::string& error);

}  // namespace unilod
