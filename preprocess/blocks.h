// Blocks (paper §3, §4.2.1; DESIGN.md "Blocks"): a regular grid of blocks over the (sampled) DEM.
//
// The DEM is sampled every `stride` cells (columns 0, s, 2s, ..., rows likewise). A block spans
// `blockSize / stride` sampled cells; neighbouring blocks share their border row or column of
// sampled points, and every point on a shared block border is locked (the DEM's outer edge only
// with BlockOptions::lockOuterEdge), so neighbouring blocks meet
// without cracks at any pair of levels. Where a river segment crosses a border line, a locked
// crossing vertex (x or y exactly on the line, z from the DEM) is inserted once, globally, so
// both blocks hold the identical vertex. River vertices exactly on a border line are locked too,
// as are river endpoints and junctions (paper §3.1). DEM points closer than the river clearance to
// any river segment are dropped by one global mask, so both blocks of a shared border drop the
// same border points.
//
// Domain (issue 17). The valid data on the sampled lattice: a lattice square with 4 valid corners
// is part of the domain, one with 3 the triangle of those corners, others nothing (a valid cell
// with no such square around it — an isolated cell, a one-cell-wide line — gives no point). A
// block's domain is the part in its rectangle; its outline (outer rings and holes, the block
// rectangle's sides included) goes to PointSet::boundaries as closed rings on the domain's left,
// so no triangle spans nodata by more than half a cell. Ring vertices are never dropped by the
// river clearance; a vertex where the outline touches itself is locked. Rivers are cut where they
// leave the domain: a river vertex outside a full lattice square or closer than kOutlineMargin to
// an outline edge (not the DEM's outer edge, which no river crosses) is dropped, and a segment
// that comes that close is cut to its parts that stay inside full squares and at least 2 cm from
// the outline (each end checked exactly as a vertex and a segment are); the river continues as a
// new piece after each cut, so no river crosses the outline and only the part near it is lost.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "dem.h"
#include "pointset.h"
#include "rivers.h"

namespace unilod {

inline constexpr int kDefaultBlockSize = 256;          // DEM cells per block side
inline constexpr double kDefaultRiverClearance = 1.0;  // metres
inline constexpr double kOutlineMargin = 0.01;          // metres (1 cm: ten grid units)

struct BlockOptions {
    // DEM cells; a multiple of stride is advised. Larger than the DEM in a direction: one block
    // there (the block size is clamped to the DEM).
    int blockSize = kDefaultBlockSize;
    int stride = 1;                     // take every stride-th cell
    // Lock the DEM's outer edge too (it bounds one block only; the 3ddp order keeps it locked as
    // the paper does, the greedy order lets straight stretches of it simplify).
    bool lockOuterEdge = true;
    double riverClearance = kDefaultRiverClearance;
};

struct BlockRect {
    std::uint32_t col = 0, row = 0;  // position in the block grid
    int cellCol0 = 0, cellCol1 = 0;  // DEM cell columns of the border lines (inclusive)
    int cellRow0 = 0, cellRow1 = 0;  // DEM cell rows of the border lines (inclusive)
};

struct BlockSourceStats {
    std::size_t riverPieces = 0;       // river pieces on the DEM (before the block split)
    std::size_t crossings = 0;         // border crossing vertices inserted
    std::size_t droppedDemPoints = 0;  // DEM points dropped by the river clearance
    std::size_t droppedCellVertices = 0;  // river vertices added there (addVerticesAtDroppedCells)
};

// What a block holds before it is built, for the build's memory estimate (build.h
// estimateBuildMemory): the DEM lattice points of its rectangle with data (an upper bound of its
// DEM points: an isolated cell makes none), its river vertices, and of those the ones a tree node
// above it keeps locked (piece ends and junctions: a vertex at the same (x, y) in more than one
// place).
struct BlockLoad {
    std::uint64_t demPoints = 0, riverPoints = 0, lockedRiverPoints = 0;
};

// Produces the point set of each block on demand (thread-safe once initialised).
class BlockSource {
public:
    // Returns false with `error` for invalid options (a stride larger than the DEM, a block
    // narrower than two sampled cells where the DEM is wider); the message names the option.
    bool init(const DemGrid& dem, const RiverLines& rivers, const BlockOptions& options,
              std::string& error);

    std::uint32_t blocksX() const { return blocksX_; }
    std::uint32_t blocksY() const { return blocksY_; }
    std::size_t blockCount() const { return rects_.size(); }
    const BlockRect& rect(std::size_t i) const { return rects_[i]; }  // row-major
    const BlockSourceStats& stats() const { return stats_; }

    // The points of block i: DEM points (row-major) then river points; see the file comment for
    // what is locked.
    PointSet points(std::size_t i) const;

    // Whether block i holds any of the domain (a lattice square with at least 3 valid corners):
    // a block without is left out of the model.
    bool hasDomain(std::size_t i) const;

    // Every block's BlockLoad (row-major), without making its point set.
    std::vector<BlockLoad> loads() const;

private:
    // The domain on the sampled lattice (node (i, j) = cell (i * stride, j * stride)).
    bool nodeValid(int i, int j) const;
    int validCorners(int i, int j) const;  // of square (i, j)..(i + 1, j + 1); 0 outside
    // Cuts river pieces where they come near the outline of the domain (see the file comment).
    std::vector<RiverPiece> cutAtOutline(const std::vector<RiverPiece>& pieces) const;
    int nodesX_ = 0, nodesY_ = 0;  // sampled lattice size
    const DemGrid* dem_ = nullptr;
    BlockOptions options_;
    std::uint32_t blocksX_ = 0, blocksY_ = 0;
    std::vector<int> borderCols_, borderRows_;  // DEM cell indices of the border lines
    std::vector<BlockRect> rects_;
    std::vector<RiverPiece> pieces_;  // with crossing vertices
    std::vector<std::uint8_t> drop_;  // global clearance mask, per lattice node (row-major)
    // Per block, the pieces (index into pieces_ and vertex range) that run inside it.
    struct Run {
        std::uint32_t piece, first, last;
    };
    std::vector<std::vector<Run>> runs_;
    void addNeighbourBorderVertices(std::size_t b, PointSet& set) const;
    BlockSourceStats stats_;
};

}  // namespace unilod
