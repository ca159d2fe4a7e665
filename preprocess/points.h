// The merged point set of the unified model (paper §3, DESIGN.md "Point set"): DEM points and
// river points in one array, river polylines as chains of point ids into that array.
#pragma once

#include <cstdint>
#include <limits>
#include <vector>

namespace unilod {

enum class PointKind : std::uint8_t { Dem = 0, River = 1 };

// One point in the working CRS: x, y, z in metres.
struct Point {
    double x = 0, y = 0, z = 0;
    PointKind kind = PointKind::Dem;
    // Locked points (block borders, river endpoints and junctions) are never ranked and never
    // deleted (paper §3.1).
    bool locked = false;
};
static_assert(sizeof(Point) == 32);

using PointId = std::uint32_t;
inline constexpr PointId kNoPoint = std::numeric_limits<PointId>::max();

// A river polyline: consecutive ids are connected by a river segment. A point shared by several
// polylines is a junction.
using Polyline = std::vector<PointId>;

struct PointSet {
    std::vector<Point> points;
    std::vector<Polyline> rivers;
    // The outline of the valid domain (issue 17): closed rings of point ids (the first id is not
    // repeated at the end), the domain on the left of every edge. Each edge is a constraint of
    // the triangulation (cdt.h "Domain"). Empty: the domain is the convex hull of the points.
    std::vector<Polyline> boundaries;
    // Original DEM points left out of `points` by the river clearance (a cell centre on a river
    // edge would make slivers; PointSetOptions::riverClearance). Not triangulated, but original
    // points all the same: the `max` error counts them (modelerror.h ExtraSample).
    std::vector<Point> dropped;
};

}  // namespace unilod
