// One block of the unified model, end to end (paper §3): importance order of the block's points
// (improved 3D_DP), river-constrained Delaunay triangulation, deletion in that order with
// topology-change records and model error, then the LOD index data the engine draws.
#pragma once

#include <cstdint>
#include <string>

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
    bool maxError = true;    // record the `max` metric
    bool paperError = true;  // record the `paper` metric
    double lodRatio = 1.3;   // stored levels: see lodindex.h
};

struct BlockBuildStats {
    std::size_t points = 0, riverPoints = 0, lockedPoints = 0;
    std::size_t vertices = 0;   // after merging duplicates on the grid
    std::size_t steps = 0;      // deletions done
    std::size_t kept = 0;       // ranked vertices never deleted (hull, refused, deferred)
    std::size_t deferrals = 0;  // deferred deletion attempts
    std::size_t fullTriangles = 0, coarsestTriangles = 0;
    std::size_t riverEdges = 0;      // at full resolution
    std::size_t indexTriangles = 0;  // triangles stored in the LOD index data
    double seconds = 0;
};

// Builds `block` (vertices, records, errors, levels, indices; bbox and origin from the points).
// `col`, `row` are stored as given. Returns false with `error` on bad input (e.g. crossing rivers).
bool buildBlock(const PointSet& set, std::uint32_t col, std::uint32_t row,
                const BlockBuildOptions& options, format::Block& block, BlockBuildStats& stats,
                std::string& error);

}  // namespace unilod
