// Issue 18's block hierarchy: the inner nodes of a quadtree over the block grid.
//
// Leaves are the blocks (blockbuild.h). A node at tree level L covers the 2^L x 2^L blocks from
// (col * 2^L, row * 2^L) on; its children are the (up to four) nodes of level L - 1 inside it
// that hold any of the domain. A node starts from the union of its children's hand-over states
// (CoarseState, below): the same points (merged where two children share one), the outline of
// the union of their triangles as the domain's rings, their river edges there chained into
// polylines.
// The borders the children shared are now interior and simplify; the node's own outer border
// stays locked (it is shared with the neighbour node of the same level, so adjacent drawn nodes
// meet without cracks), except where it is the DEM's outer edge and leaves leave that unlocked
// (ingest option lockOuterEdge), so the root's outline simplifies as the domain's does. A river
// vertex where a river crossed a child border is an ordinary river vertex now; river ends,
// junctions and pinch points of the outline stay locked.
//
// The node then runs the same greedy deletion as a block (deletion.h), with its `max` error
// measured against every ORIGINAL point of its area (ModelError extra samples), the running
// maximum starting at its children's largest hand-over error (errors stay monotone up the tree).
// Its river chains start as the children's at the hand-over, so each river edge carries the
// original river points it replaced (CoarseState::riverCover, deletion.h
// DeletionOptions::riverCover): a node's river deviation is measured against the original river as
// a block's is; outline chains take the starting error as slack. Its records, errors, levels and
// index data are stored like a block's.
//
// The node's starting triangulation is exactly the union of its children's: Delaunay ties
// (cocircular grid points) are broken by one symbolic perturbation everywhere (predicates.h
// incirclePerturbed), and the children's full-resolution shared border keeps each side's
// triangles Delaunay in the union, so the node starts at its children's error (measured, 4M
// points: without the perturbation level-1 nodes started at 11-28 m above children that ended
// at 7.5 m, and the 100 m cut was 4.9x the river-holding TIN; with it 1.6x).
//
// Hand-over: a block or node that has a parent hands its state over before a deletion costing
// more than nodeHandoffError (the same for every node of a tree level: siblings hand over alike;
// not above kHandoffShare of its original points' triangles) or once it has
// nodeHandoffTriangles triangles or fewer: that state is what the parent starts from. Errors then
// double per tree level, as the view distance at which a node is drawn does (the chunked-LOD rule),
// up to the cap at which one root draws the whole model. The block or node itself simplifies on to
// the end of its order (its own coarser levels): where its parent does not fit h_lim (the parent's
// box comes nearer the eye) the child may still, at an error above the hand-over. Measured on the
// bundled 64-cell model (median triangles of the `bench` paths at P = 1): fly-over
// 12 904 -> 11 747, jacksboro_path 25 752 -> 21 730, orbit 24 506 -> 11 625 (there the cap had
// stopped every level at 17 m).
//
// Stop rule: the tree is built up to one root covering the whole model (a block grid of
// bx x by blocks has ceil(log2(max(bx, by))) levels above the leaves); the leaves are the blocks,
// whose size (`--block-size`, automatic by default) is where splitting stops.
#pragma once

#include <cstdint>
#include <string>
#include <unordered_map>
#include <vector>

#include "blockbuild.h"
#include "points.h"

namespace unilod {

// The hand-over triangle count of a block or node of tree `level` (0: a block) whose rectangle
// is `width` x `height` sampled cells, `lockedCells` of them along its locked border lines (the
// sides it shares with a neighbour; the DEM's outer edge is not locked, NodeBorder): twice that,
// the points no deletion removes (below it the node would be its border alone, with an error of
// the whole relief), but at least twice the perimeter of a square of its shorter side; for a
// block at least width height / 8 (1/16 of its triangles; 8192 for 256-cell blocks, 512 for
// 64-cell ones). For any square of `side` cells a side that is 8 side (8 side 2^level for a whole
// node of blocks of `side` cells), whatever its locked sides. Counting the actual rectangle
// matters where it is far from square: a 10-row strip of 256-cell blocks (every block 4 608
// triangles, below a square block's 8 192) handed every block over at full resolution, and each
// tree level took its children whole; the root held 45 % of the DEM's points and the build did
// 4.7 deletion steps per point (test: Nodata.StripNodesStartFromSimplifiedChildren). Counting
// only the locked sides of squares too (the DEM-edge nodes) was measured and not kept: their
// parents start coarser and draw more (MEASURED.md, twenty-third session). The error rule
// (nodeHandoffError) usually hands a node over first.
std::uint32_t nodeHandoffTriangles(std::uint64_t width, std::uint64_t height,
                                   std::uint64_t lockedCells, std::uint32_t level);

// The hand-over error of a block or node of tree `level` whose blocks are `blockExtent` metres
// on a side, in a model `modelExtent` metres across: its extent (blockExtent 2^level) divided by
// `pixels`, at most modelExtent / kRootPixels. A node hands over before a deletion that would
// cost more (deletion.h DeletionOptions::handoverKey), so its parent starts at most there whatever
// its siblings did. The same target for all nodes of a level: siblings hand over alike, and the
// error doubles per tree level as the node's extent does (chunked LOD): a view in which the node
// spans about `pixels` pixels at P = 1 draws its parent. The cap: once the whole model fits a
// 1920-pixel screen at P = 1, one draw of the root shows it (issue 18's far view).
inline constexpr double kDefaultHandoffPixels = 256;

// The error rule hands a block or node over only once it has at most this share of the
// triangles of the original points under it (about 2 per point; DeletionOptions::
// handoverKeyTriangles). On terrain rougher than the hand-over errors (1 m cells under 2000 m of
// relief: the first deletions of a 256-m block already cost more than 1 m, and the cap of a 1 km
// model is 0.5 m at every level) every state went up whole and the root re-deleted 88 % of the
// points (1M points: 3.4 deletion steps per point, 23 MB, 65 s, 1.4 GB). Now the error rule
// hands no tree level more than this share of the model's triangles (the triangle rule above
// bounds the rest; test: Nodata.RoughTerrainNodesStartFromSimplifiedChildren). A parent then starts
// above its level's hand-over error (drawn only farther away; its children are drawn until then);
// errors stay monotone up the tree. Where the error rule hands over below this share anyway (the
// usual case) nothing changes. A share of the node's own starting state instead (a quarter) bound
// where the cap stops several levels at one error by design (the bundled 64-cell model's upper
// levels at 17 m: 1 node at 20-100 km became 4-12, 50 km 5 587 -> 9 006 triangles).
inline constexpr double kHandoffShare = 0.125;

// Stored levels of a tree node are kNodeLodTriangleRatio apart in triangles (a block's:
// lodindex.h kLodTriangleRatio, 1.3). A node is drawn alone over an area of many blocks, where
// the cut's triangles are the drawn level's: the stored level within h_lim is up to this ratio
// above the exact step (issue 18's 100 m cut of the 16M model: 16 % above it at 1.3). A node's
// levels cost little: the file stores their steps only (the index data is derived on decoding)
// and its geometry is small next to the leaves'.
inline constexpr double kNodeLodTriangleRatio = 1.05;
inline constexpr double kRootPixels = 1920;
double nodeHandoffError(double blockExtent, double modelExtent, std::uint32_t level, double pixels);

// The lines of a node's outer border (cell-centre coordinates of its first and last column and
// row) and whether points on each are locked.
struct NodeBorder {
    double x0 = 0, x1 = 0, y0 = 0, y1 = 0;
    bool lockX0 = true, lockX1 = true, lockY0 = true, lockY1 = true;
};

// The node's starting point set (above): points merged by exact (x, y), rings from the outline
// of the union of the children's triangles (the domain on the left of every ring edge), rivers
// from their river edges at the hand-over. Deterministic for a given child order.
// `riverCover` (optional) gets what each river edge stands for (CoarseState::riverCover), by
// Cdt::edgeKey(min, max).
PointSet nodePointSet(const std::vector<const CoarseState*>& children, const NodeBorder& border,
                      std::unordered_map<std::uint64_t, RiverCover>* riverCover = nullptr);

// Builds a node from its children's hand-over states: `block` (col, row: the node's position in
// its level's grid) and the node's own hand-over state for its parent. `originals` calls its
// argument once for every original point of the node's area; `grid` (optional) names the DEM
// cells among them (NodeErrorInput::grid). Greedy order only (the paper's
// 3D_DP order builds no tree). Returns false with `error` on failure.
bool buildNode(const std::vector<const CoarseState*>& children, const NodeBorder& border,
               std::uint32_t col, std::uint32_t row, const BlockBuildOptions& options,
               const std::function<void(const std::function<void(const Point&)>&)>& originals,
               std::size_t originalCount, format::Block& block, BlockBuildStats& stats,
               CoarseState& coarse, std::string& error, const OriginalGrid* grid = nullptr);

}  // namespace unilod
