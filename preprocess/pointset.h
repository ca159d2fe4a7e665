// The merged point set of paper §3 from a loaded DEM and river lines (DESIGN.md "Point set").
//
// buildPointSet is the plain assembly of an in-memory DEM and lines taken as given (the synthetic
// data of benchmarks and tests): cell centres, river vertices with bilinear DEM altitudes,
// junctions as shared ids, endpoints and junctions locked. Files go through ingest.h instead
// (`build`, `order`, `report`: river cleaning, nodata, the block point sets of blocks.h), which
// shares the building blocks below.
#pragma once

#include <cstdint>
#include <vector>

#include "dem.h"
#include "grid.h"
#include "points.h"
#include "rivers.h"

namespace unilod {

struct PointSetOptions {
    int stride = 1;  // DEM points: every stride-th row and column, starting at (0, 0); >= 1
    // DEM points closer than this (metres, horizontally) to a river segment are dropped: a cell
    // centre on a river edge would make sliver triangles. 0 = keep every DEM point.
    double riverClearance = 0;
    // Lock the DEM points of the first / last kept row and column (a block border).
    bool lockBorder = false;
};

// DEM points (kind Dem) come first, in row-major order; then river points in line order.
//
// River points: the vertices of each line whose DEM altitude (DemGrid::sample) is finite; a vertex
// outside the DEM or on nodata ends the current piece and the line continues as a new polyline
// after it. Consecutive duplicate vertices are dropped; pieces with fewer than two vertices are
// dropped. Vertices with exactly equal (x, y) in any lines become one point id (a junction).
// Locked: first and last vertex of every polyline, and every id used more than once (junctions).
PointSet buildPointSet(const DemGrid& dem, const RiverLines& rivers,
                       const PointSetOptions& options);

// --- Building blocks shared with the block partition (blocks.h) ------------------------------

struct RiverVertex {
    double x = 0, y = 0, z = 0;
};
using RiverPiece = std::vector<RiverVertex>;

// The river pieces of buildPointSet: runs of vertices whose bilinear DEM altitude is finite,
// consecutive duplicates dropped, pieces of fewer than two vertices dropped.
std::vector<RiverPiece> sampleRiverPieces(const DemGrid& dem, const RiverLines& rivers);

// One byte per DEM point of the `stride` lattice (row-major, ((height - 1) / stride + 1) rows of
// (width - 1) / stride + 1): 1 where the cell centre is closer than `clearance` (horizontally) to
// a segment of `pieces`. Empty when clearance <= 0 or there are no pieces.
std::vector<std::uint8_t> riverClearanceMask(const DemGrid& dem,
                                             const std::vector<RiverPiece>& pieces,
                                             double clearance, int stride = 1);

// Four units of the exact grid (grid.h): a vertex this far from a segment stays off it (and
// off its side) when both are rounded to the grid.
inline constexpr double kRiverSeparation = 4 * kGridUnit;

// Where a river passes within `clearance` of a DEM point on the stride's lattice (a point the
// clearance drops, riverClearanceMask), a river vertex at the point's projection onto the
// segment, z from the DEM (DemGrid::sample): the river's surface then meets the DEM at the
// dropped point instead of interpolating over it between vertices up to two cells apart (on the
// bundled data the dropped points were up to 6 m off the river's chord). A projection closer than
// the clearance to a vertex (an end of the segment or one added before it), or closer than
// kRiverSeparation to another segment of `pieces`, adds none. Returns how many were added.
std::size_t addVerticesAtDroppedCells(const DemGrid& dem, double clearance, int stride,
                                      std::vector<RiverPiece>& pieces);

// Appends the pieces to `set` as river points and polylines: one id per distinct (x, y) (a
// junction), first and last vertex of every piece and every junction locked.
void appendRiverPieces(const std::vector<RiverPiece>& pieces, PointSet& set);

}  // namespace unilod
