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

struct BlockOptions {
    int blockSize = kDefaultBlockSize;  // DEM cells; a multiple of stride is advised
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
};

// Produces the point set of each block on demand (thread-safe once initialised).
class BlockSource {
public:
    // Returns false with `error` for invalid options (block size / stride against the DEM).
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

    // nodata.h rule 2: the nodata cells (row-major indices) of block i's rectangle whose centres
    // lie strictly inside the convex hull of `set` (the block's points).
    std::vector<std::size_t> bridgedNodataCells(std::size_t i, const PointSet& set) const;
    // Whether block i's rectangle has a nodata cell at all (a cheap scan: without one nothing can
    // be bridged, and the block's points need not be made for bridgedNodataCells).
    bool hasNodataCells(std::size_t i) const;

private:
    const DemGrid* dem_ = nullptr;
    BlockOptions options_;
    std::uint32_t blocksX_ = 0, blocksY_ = 0;
    std::vector<int> borderCols_, borderRows_;  // DEM cell indices of the border lines
    std::vector<BlockRect> rects_;
    std::vector<RiverPiece> pieces_;  // with crossing vertices
    std::vector<std::uint8_t> drop_;  // global clearance mask
    // Per block, the pieces (index into pieces_ and vertex range) that run inside it.
    struct Run {
        std::uint32_t piece, first, last;
    };
    std::vector<std::vector<Run>> runs_;
    BlockSourceStats stats_;
};

}  // namespace unilod
