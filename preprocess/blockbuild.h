// One block of the unified model, end to end (paper §3): importance order of the block's points
// (improved 3D_DP), river-constrained Delaunay triangulation, deletion in that order with
// topology-change records and model error, then the LOD index data the engine draws.
#pragma once

#include <cstdint>
#include <functional>
#include <limits>
#include <string>
#include <unordered_map>
#include <vector>

#include "cdt.h"
#include "deletion.h"
#include "dem.h"
#include "importance.h"
#include "points.h"
#include "ulod.h"

namespace unilod {

// The deletion order (issue 15): `Greedy` (default) deletes, at every step, the vertex whose
// deletion causes the smallest model error (deletion.h runGreedyDeletion); `ThreeDdp` is the
// paper's improved 3D_DP importance order (importance.h), kept to reproduce the paper.
enum class DeletionOrderKind : std::uint8_t { Greedy = 0, ThreeDdp = 1 };
const char* deletionOrderName(DeletionOrderKind kind);  // "greedy" / "3ddp"

struct BlockBuildOptions {
    DeletionOrderKind order = DeletionOrderKind::Greedy;
    ImportanceOptions importance;  // BAI options (both orders); the 3D_DP settings (3ddp)
    bool maxError = true;          // record the `max` metric
    bool paperError = true;        // record the `paper` metric
    double lodRatio = 1.3;         // stored levels: see lodindex.h
    // Greedy order, a block or node with a parent in issue 18's tree (nodebuild.h): the state
    // its parent starts from (buildBlock's `coarse`) is taken at this many alive triangles or
    // before a step whose key exceeds `handoverKey`, whichever comes first
    // (DeletionOptions::handoverTriangles / handoverKey); the block itself simplifies on to the
    // end (its own coarser levels, drawn where its parent does not fit but it does). The key
    // rule applies from `handoverKeyTriangles` alive triangles on (DeletionOptions).
    std::uint32_t handoverTriangles = 0;
    double handoverKey = std::numeric_limits<double>::infinity();
    std::uint32_t handoverKeyTriangles = std::numeric_limits<std::uint32_t>::max();
    // Called after every deletion step with the step count (the build's progress: build.cpp).
    std::function<void(std::uint32_t)> afterStep;
};

struct BlockBuildStats {
    std::size_t points = 0, riverPoints = 0, lockedPoints = 0;
    // The DEM points the river clearance dropped (PointSet::dropped) and the largest vertical
    // distance of one of them from the full-resolution surface (counted in the `max` error).
    std::size_t droppedPoints = 0;
    double droppedDeviation = 0;
    std::size_t vertices = 0;   // after merging duplicates on the grid
    std::size_t steps = 0;      // deletions done
    std::size_t kept = 0;       // ranked vertices never deleted (hull, refused, deferred)
    std::size_t deferrals = 0;  // deferred deletion attempts
    std::size_t fullTriangles = 0, coarsestTriangles = 0;
    std::size_t riverEdges = 0;      // at full resolution
    std::size_t indexTriangles = 0;  // triangles stored in the LOD index data
    double seconds = 0;
};

// The hand-over state of a built block or node (BlockBuildOptions::handoverTriangles; its last
// state when it has none), what its parent in issue 18's tree starts from (nodebuild.h): the
// alive vertices with their exact coordinates, the alive triangles (counter-
// clockwise, indices into `points`) and river edges, and the final `max` error.
struct CoarseState {
    std::vector<Point> points;
    std::vector<TriangleTriple> triangles;
    std::vector<RiverEdge> rivers;
    // Per river edge: the original river points it stands for (DeletionRecords::riverCover).
    std::vector<RiverCover> riverCover;
    double errorMax = 0;
    double errorRiver = 0;  // its river part (DeletionRecords::errorRiver)
};

// The sampled DEM cells of a tree node's area: columns cellCol0, cellCol0 + step, ... up to
// cellCol1, the same for rows (inclusive; the node's border lines, blocks.h BlockRect).
struct OriginalGrid {
    const DemGrid* dem = nullptr;
    int cellCol0 = 0, cellCol1 = -1, cellRow0 = 0, cellRow1 = -1;
    int step = 1;
};

// How a tree node's build differs from a leaf block's (nodebuild.h): its error is measured
// against every original point of its area (`originals` calls its argument once per point), the
// running `max` starts at `errorFloor` and every chain deviation gets it as slack (deletion.h).
struct NodeErrorInput {
    std::function<void(const std::function<void(const Point&)>&)> originals;
    std::size_t originalCount = 0;  // how many points `originals` gives (a capacity hint)
    // The DEM cells under the node (OriginalGrid): an original point at such a cell (its grid
    // position, and a height that is a float exactly) is kept as the cell's reference with its
    // height, 8 bytes instead of 16 (modelerror.h SampleRef); null: every point is kept whole.
    const OriginalGrid* grid = nullptr;
    double errorFloor = 0;
    double riverFloor = 0;  // the same for the river part (DeletionOptions::riverFloor)
    // What each river edge of the node's point set stands for (DeletionOptions::riverCover).
    std::unordered_map<std::uint64_t, RiverCover> riverCover;
};

// Builds `block` (vertices, records, errors, levels, indices; bbox and origin from the points).
// `col`, `row` are stored as given. Returns false with `error` on bad input (e.g. crossing rivers).
bool buildBlock(const PointSet& set, std::uint32_t col, std::uint32_t row,
                const BlockBuildOptions& options, format::Block& block, BlockBuildStats& stats,
                std::string& error, const NodeErrorInput* node = nullptr,
                CoarseState* coarse = nullptr);

}  // namespace unilod
