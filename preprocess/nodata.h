// Nodata handling (issue 4, issue 17). Nodata cells are outside the domain: the triangulation
// covers only the valid data, with holes and a concave outline (blocks.h "Domain"). One rule
// fills small specks: a hole (a 4-connected region of nodata cells that does not touch the raster
// border) of at most `maxFillCells` cells is filled from its rim inwards, each cell taking the
// mean of its valid 4-neighbours (single missing cells, SRTM specks); larger holes stay holes.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "dem.h"

namespace unilod {

inline constexpr std::size_t kDefaultMaxFillCells = 16;

struct NodataStats {
    std::size_t nodataCells = 0;     // before filling
    std::size_t holes = 0;           // interior holes found
    std::size_t filledCells = 0;     // hole cells filled
    std::size_t keptHoles = 0, keptHoleCells = 0;  // holes larger than maxFillCells
};

// Fills the given nodata cells from their rim inwards: each round fills the cells that have a
// valid 4-neighbour with the mean of those neighbours (values of earlier rounds only). Cells
// with no valid neighbour reachable stay NaN. Returns the number filled.
std::size_t fillCells(DemGrid& dem, std::vector<std::size_t> cells);

// Fills the small interior holes of `dem` (the rule above); larger ones are counted in `stats`.
// Always returns true (`path`, `error`: kept for the callers).
bool fillSmallHoles(DemGrid& dem, const std::string& path, std::size_t maxFillCells,
                    NodataStats& stats, std::string& error);

}  // namespace unilod
