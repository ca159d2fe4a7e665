// The cut of the model a view draws (paper §3.4, Eq. 11; DESIGN.md "Screen-space error"): which
// nodes are drawn and at which stored level. The one implementation of "cull -> S -> h_lim ->
// level" that the engine, `export`, `stats`, `report` and the grid diagram call.
//
// A node is a block of the file today; the cut walks roots first and, for a node with children,
// draws the node when its coarsest-level h_s fits its h_lim and examines its children otherwise
// (issue 18's block hierarchy). A node with no children is drawn at the level chooseStoredLevel
// picks for its h_lim.
#pragma once

#include <cmath>
#include <cstdint>
#include <vector>

#include "camera.h"
#include "lod.h"
#include "ulod.h"

namespace unilod::engine {

// What the view asks of the model. One of three kinds:
// - `Camera`: a perspective camera. S from the eye to each box (mode `distance`), h_lim from
//   Eq. 11 over `heightPixels` (and, in Nearest mode, the box's place in the view:
//   lod.h effectiveDistance). `direction` false: only the eye is known (export --camera x,y,z):
//   no culling, BoxView{} for every box (the bound for any direction).
// - `Grid`: the 2D grid mode (paper Figures 7-12): levels as the perspective camera would choose
//   them, culling against the top-down rectangle of half height `gridHalfHeight`.
// - `Uniform`: one h_lim (`hLim`, metres) for every node; nothing culled, S = 0.
// `finest`: every drawn node at full resolution (the benchmark's baseline), the cut unchanged.
struct ViewSpec {
    enum class Kind { Camera, Grid, Uniform };
    Kind kind = Kind::Camera;
    Camera camera;
    bool direction = true;
    bool cull = true;
    double widthPixels = 1920, heightPixels = 1080;
    double pixels = 1.0;  // P
    DistanceMode distance = DistanceMode::Nearest;
    double gridHalfHeight = 0;
    double hLim = 0;
    bool finest = false;
};

// What the cut needs of a node: its box, whether its `max` error bounds horizontal
// displacements too (camera.h BoxView::horizontal: it holds river edges, or its outline may
// move) and its stored levels (errors per metric). The levels must outlive the call.
// Tree links (issue 18's block hierarchy): a node's children are the `childCount` nodes from
// `firstChild` on, each inside its parent's box; a node that is no other node's child is a root.
// A list without links is a forest of leaves: today's blocks.
using format::kNoChild;
struct LodNode {
    double boxMin[3] = {}, boxMax[3] = {};
    bool horizontal = false;
    const std::vector<format::Level>* levels = nullptr;
    std::uint32_t col = 0, row = 0;  // grid position (reported back)
    std::uint32_t level = 0;         // tree level (reported back)
    std::uint32_t firstChild = kNoChild, childCount = 0;
};

// A block as a node (horizontal: river edges at full resolution, or format::outlineMoves).
// `block` is whole; an entry of the directory (format version 5) carries its levels and outline
// flag, so the cut needs nothing read from the blocks; the node points at `info.levels`.
LodNode lodNode(const format::Block& block);
LodNode lodNode(const format::BlockInfo& info);

// One drawn node of the cut.
struct NodeChoice {
    std::uint32_t block = 0;  // index into the node list (the file's directory)
    std::uint32_t col = 0, row = 0;
    std::uint32_t treeLevel = 0;    // tree level (0: a leaf block)
    double distance = 0, hLim = 0;  // S of the view's mode (0 for Uniform), h_lim
    // The `max` metric's tolerance of the river part (NodeTolerance::river); infinity where no
    // river part is bounded apart (no rivers and a fixed outline, the `paper` metric, Uniform).
    double hLimRiver = INFINITY;
    BoxView box;                    // how the box lies in the view (Camera/Grid with a direction)
    LevelChoice wanted;             // the level h_lim asks for
};

// True when the view draws a node with this box at all (frustum / grid-rectangle culling).
bool nodeVisible(const ViewSpec& view, const double boxMin[3], const double boxMax[3]);

// S and h_lim of a node for the view. `distance` / `box` receive S and the box's place in the
// view when not null (the whole box's).
//
// In Nearest mode with a view direction, h_lim is the smallest bound (lod.h blockTolerance) over
// kToleranceColumns x kToleranceColumns columns of the box (its x/y extent split evenly, its
// whole z range each) that meet the frustum (every column when `cull` is off), and never less than
// the whole box's bound. Valid: the P-pixel bound is needed for the points on screen only; a
// point p on screen lies in a column that meets the frustum, and a vertical error's surface point
// q lies above or below p, in the same column, so that column's S, view angles and depth bound
// hold for the segment (lod.h effectiveDistance). A river's drawn point may lie in another
// column, up to h_lim from p, so for a node whose `max` error bounds horizontal displacements the
// column's bound is reduced by f / (f + P c) (f: focal length in pixels, c the column's cos
// bound; under 0.2 % at 1080p): depth >= D - h then. What it buys: a node partly below or
// behind the eye, or reaching far from it, is no longer held to the tolerance of its nearest
// corner where that corner is off screen (bench_order --view measured the per-node tolerance at
// 1.85x the triangles of a per-point one on the bundled fly-over).
// A node whose x/y diagonal is at most kColumnsBelowDistance times its S keeps the whole box's
// bound (columns would gain little there and cost up to kToleranceColumns^2 box tests).
inline constexpr int kToleranceColumns = 8;
inline constexpr double kColumnsBelowDistance = 0.25;
//
// Two tolerances (format version 4 stores the river part of the `max` error apart,
// format::Level::errorRiver): `vertical` bounds vertical errors, with the sin(phi) factor and no
// river factor (a vertical error's surface point is in the point's own column); `river` bounds
// horizontal displacements (river edges, a moving outline): no sin(phi) factor, the river factor
// above. A node without rivers whose outline stays (LodNode::horizontal false) has no horizontal
// displacement: `river` is infinity. The `max` metric draws a level when errorMax <= vertical
// and errorRiver <= river (errorMax = max(vertical part, river part) and river <= vertical, so
// both parts are bounded); the `paper` metric, which has no river part, keeps the single
// tolerance nodeTolerance returns: `river` for a horizontal node, `vertical` otherwise.
struct NodeTolerance {
    double vertical = 0, river = INFINITY;
};
NodeTolerance nodeTolerances(const ViewSpec& view, const LodNode& node, double* distance = nullptr,
                             BoxView* box = nullptr);
// The same with the camera's basis already computed (cameraBasis(view.camera)): per-step loops
// (refine.h).
NodeTolerance nodeTolerances(const ViewSpec& view, const CameraBasis& basis, const LodNode& node,
                             double* distance = nullptr, BoxView* box = nullptr);
// The single tolerance (above): S and h_lim of a node for the view.
double nodeTolerance(const ViewSpec& view, const LodNode& node, double* distance = nullptr,
                     BoxView* box = nullptr);


// One node's choice (culling aside): S, h_lim and the wanted level. `index`: the node's index,
// reported back in NodeChoice::block.
NodeChoice chooseNode(const ViewSpec& view, const LodNode& node, std::uint32_t index,
                      std::uint32_t metric);

// The cut for the view, nearest first (ties in node order), under `metric` (format::kMetricMax /
// kMetricPaper). From every root: a node outside the view is skipped with its subtree; a node
// with children whose starting (finest) level does not fit its tolerances (format::levelFits) — or any node with children in
// `finest` mode — gives way to its children; every other visible node is drawn at its wanted
// level. Children lie inside their parent and meet it without cracks (its own outer border stays
// locked), so any such cut covers the visible model once. `out` is cleared first.
void selectCut(const ViewSpec& view, const std::vector<LodNode>& nodes, std::uint32_t metric,
               std::vector<NodeChoice>& out);

}  // namespace unilod::engine
