// Nodata handling (issue 4: "triangles never bridge a nodata region"). Two rules:
//  1. Small interior holes are filled. A hole is a 4-connected region of nodata cells that does not
//     touch the raster border. Holes of at most `maxFillCells` cells are filled from their rim
//     inwards, each cell taking the mean of its valid 4-neighbours (a documented, local fill of
//     small gaps such as single missing cells); a larger hole is refused with an error naming the
//     file, the hole's size and a cell of it.
//  2. Nodata connected to the raster border is outside the data and produces no points. A block's
//     domain is the convex hull of its points, so nodata cell centres strictly inside that hull (a
//     bay of nodata reaching into the block, e.g. the ragged edge of a warped raster) would be
//     bridged by triangles. Up to kMaxBridgedCells such cells per block are filled like holes
//     (repeated until no block's hull contains a nodata centre); a block with more is refused.
//     So no triangle ever spans the centre of a nodata cell that was not filled.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "dem.h"

namespace unilod {

inline constexpr std::size_t kDefaultMaxFillCells = 16;
inline constexpr std::size_t kMaxBridgedCells = 64;

struct NodataStats {
    std::size_t nodataCells = 0;     // before filling
    std::size_t holes = 0;           // interior holes found
    std::size_t filledCells = 0;     // hole cells filled
    std::size_t bayCellsFilled = 0;  // rule 2 cells filled
};

// Fills the given nodata cells from their rim inwards: each round fills the cells that have a
// valid 4-neighbour with the mean of those neighbours (values of earlier rounds only). Cells
// with no valid neighbour reachable stay NaN. Returns the number filled.
std::size_t fillCells(DemGrid& dem, std::vector<std::size_t> cells);

// Fills the small interior holes of `dem` (rule 1). Returns false with `error` (naming `path`)
// when a hole is larger than maxFillCells.
bool fillSmallHoles(DemGrid& dem, const std::string& path, std::size_t maxFillCells,
                    NodataStats& stats, std::string& error);

}  // namespace unilod
