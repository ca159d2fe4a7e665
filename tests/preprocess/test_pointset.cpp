// Point set assembly (preprocess/pointset.h) on a hand-made grid: DEM points, stride, nodata,
// river altitudes, splitting at vertices off the DEM, shared junction ids, locks, clearance.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <limits>
#include <map>

#include "pointset.h"

using namespace unilod;

namespace {

// 10 x 8 cells of 10 m, cell (0, 0) centred at (5, 75), north-up; z = x + 2 y.
DemGrid makeGrid() {
    DemGrid dem;
    dem.width = 10;
    dem.height = 8;
    dem.originX = 5;
    dem.originY = 75;
    dem.cellX = 10;
    dem.cellY = -10;
    for (int r = 0; r < dem.height; ++r) {
        for (int c = 0; c < dem.width; ++c) {
            dem.z.push_back(static_cast<float>(dem.centreX(c) + 2 * dem.centreY(r)));
        }
    }
    return dem;
}

std::size_t count(const PointSet& set, PointKind kind) {
    std::size_t n = 0;
    for (const Point& p : set.points)
        n += p.kind == kind;
    return n;
}

}  // namespace

TEST(PointSet, DemPointsAreValidCellCentres) {
    DemGrid dem = makeGrid();
    dem.z[3 * 10 + 4] = std::numeric_limits<float>::quiet_NaN();
    const PointSet set = buildPointSet(dem, {}, {});
    EXPECT_EQ(set.points.size(), 79u);
    EXPECT_TRUE(set.rivers.empty());
    // Row-major order from the first row: the second point is (15, 75).
    EXPECT_EQ(set.points[1].x, 15.0);
    EXPECT_EQ(set.points[1].y, 75.0);
    for (const Point& p : set.points) {
        EXPECT_EQ(p.kind, PointKind::Dem);
        EXPECT_FALSE(p.locked);
        EXPECT_EQ(p.z, p.x + 2 * p.y);
        EXPECT_FALSE(p.x == 45.0 && p.y == 45.0);  // the nodata cell
    }
}

TEST(PointSet, Stride) {
    const DemGrid dem = makeGrid();
    PointSetOptions o;
    o.stride = 3;
    const PointSet set = buildPointSet(dem, {}, o);
    // Columns 0, 3, 6, 9 and rows 0, 3, 6.
    EXPECT_EQ(set.points.size(), 12u);
    for (const Point& p : set.points) {
        const double c = (p.x - 5) / 10, r = (75 - p.y) / 10;
        EXPECT_EQ(std::fmod(c, 3.0), 0.0);
        EXPECT_EQ(std::fmod(r, 3.0), 0.0);
    }
    o.lockBorder = true;
    const PointSet locked = buildPointSet(dem, {}, o);
    std::size_t n = 0;
    for (const Point& p : locked.points) {
        const bool border = p.x == 5 || p.x == 95 || p.y == 75 || p.y == 15;  // rows 0 and 6
        EXPECT_EQ(p.locked, border) << p.x << " " << p.y;
        n += p.locked;
    }
    EXPECT_EQ(n, 10u);  // 4 + 4 + 1 + 1
}

TEST(PointSet, JunctionsSharedAndLocked) {
    const DemGrid dem = makeGrid();
    const RiverLines lines = {
        {{12, 12}, {22, 31}, {33, 33}, {44, 47}, {61, 52}},  // main river
        {{30, 60}, {31, 46}, {33, 33}},                      // joins at (33, 33)
        {{70, 20}, {61, 52}},                                // joins at the main river's end
    };
    const PointSet set = buildPointSet(dem, lines, {});
    const std::size_t dem0 = count(set, PointKind::Dem);
    EXPECT_EQ(dem0, 80u);
    ASSERT_EQ(set.rivers.size(), 3u);
    EXPECT_EQ(count(set, PointKind::River), 5u + 2u + 1u);
    const Polyline& main = set.rivers[0];
    EXPECT_EQ(set.rivers[1].back(), main[2]);
    EXPECT_EQ(set.rivers[2].back(), main[4]);
    // Locked: every end and the junction; the other interior vertices not.
    EXPECT_TRUE(set.points[main[0]].locked);
    EXPECT_FALSE(set.points[main[1]].locked);
    EXPECT_TRUE(set.points[main[2]].locked);
    EXPECT_FALSE(set.points[main[3]].locked);
    EXPECT_TRUE(set.points[main[4]].locked);
    EXPECT_TRUE(set.points[set.rivers[1][0]].locked);
    EXPECT_FALSE(set.points[set.rivers[1][1]].locked);
    EXPECT_TRUE(set.points[set.rivers[2][0]].locked);
    // River altitudes: the DEM is bilinear (z = x + 2y), so sampling is exact.
    for (const Polyline& line : set.rivers) {
        for (PointId id : line) {
            const Point& p = set.points[id];
            EXPECT_EQ(p.kind, PointKind::River);
            EXPECT_DOUBLE_EQ(p.z, p.x + 2 * p.y);
        }
    }
}

TEST(PointSet, VerticesOffTheDemSplitLines) {
    DemGrid dem = makeGrid();
    dem.z[7 * 10 + 9] = std::numeric_limits<float>::quiet_NaN();  // cell (9, 7): (95, 5)
    const RiverLines lines = {
        // Leaves the DEM hull (x < 5) at the third vertex: two pieces.
        {{20, 20}, {30, 30}, {2, 40}, {30, 50}, {40, 60}, {50, 62}},
        // A single vertex before a hole, then one piece: the single vertex is dropped.
        {{10, 10}, {-100, 10}, {20, 40}, {25, 45}},
        // Ends next to the nodata cell: the last vertex goes, a 2-vertex piece remains.
        {{70, 30}, {80, 20}, {92, 8}},
        // Consecutive duplicates are merged; a line of one distinct vertex is dropped.
        {{60, 60}, {60, 60}, {70, 62}, {70, 62}},
        {{40, 40}, {40, 40}},
    };
    const PointSet set = buildPointSet(dem, lines, {});
    ASSERT_EQ(set.rivers.size(), 5u);
    EXPECT_EQ(set.rivers[0].size(), 2u);
    EXPECT_EQ(set.rivers[1].size(), 3u);
    EXPECT_EQ(set.rivers[2].size(), 2u);
    EXPECT_EQ(set.rivers[3].size(), 2u);
    EXPECT_EQ(set.rivers[4].size(), 2u);
    EXPECT_EQ(set.points[set.rivers[0][1]].x, 30.0);  // first line, before the hole
    EXPECT_EQ(set.points[set.rivers[1][0]].x, 30.0);  // first line, after the hole
    EXPECT_EQ(set.points[set.rivers[2][0]].x, 20.0);  // second line without its lone vertex
    EXPECT_EQ(set.points[set.rivers[3][1]].x, 80.0);  // third line without its nodata end
    EXPECT_EQ(set.points[set.rivers[4][1]].x, 70.0);
    for (const Polyline& line : set.rivers) {
        EXPECT_TRUE(set.points[line.front()].locked);
        EXPECT_TRUE(set.points[line.back()].locked);
    }
}

TEST(PointSet, RiverClearanceDropsDemPointsOnRivers) {
    const DemGrid dem = makeGrid();
    // A river along the row of centres y = 45, from x = 10 to x = 50: passes over the centres
    // (15, 45) .. (45, 45). A diagonal one passes exactly over (65, 65) and (75, 55).
    const RiverLines lines = {{{10, 45}, {50, 45}}, {{60, 70}, {80, 50}}};
    PointSetOptions o;
    const PointSet keep = buildPointSet(dem, lines, o);
    EXPECT_EQ(count(keep, PointKind::Dem), 80u);
    o.riverClearance = 0.1;
    const PointSet set = buildPointSet(dem, lines, o);
    EXPECT_EQ(count(set, PointKind::Dem), 80u - 4u - 2u);
    std::map<std::pair<double, double>, int> dem2;
    for (const Point& p : set.points) {
        if (p.kind == PointKind::Dem) ++dem2[{p.x, p.y}];
    }
    EXPECT_EQ(dem2.count({15, 45}), 0u);
    EXPECT_EQ(dem2.count({45, 45}), 0u);
    EXPECT_EQ(dem2.count({65, 65}), 0u);
    EXPECT_EQ(dem2.count({75, 55}), 0u);
    EXPECT_EQ(dem2.count({55, 45}), 1u);  // beyond the river's end
    EXPECT_EQ(dem2.count({65, 55}), 1u);  // 7 m off the diagonal
    // The dropped points are kept apart, with their DEM heights (the error counts them).
    std::map<std::pair<double, double>, double> dropped;
    for (const Point& p : set.dropped) {
        EXPECT_EQ(p.kind, PointKind::Dem);
        dropped[{p.x, p.y}] = p.z;
    }
    const std::map<std::pair<double, double>, double> expected = {{{15, 45}, 105}, {{25, 45}, 115},
                                                                  {{35, 45}, 125}, {{45, 45}, 135},
                                                                  {{65, 65}, 195}, {{75, 55}, 185}};
    EXPECT_EQ(dropped, expected);
    EXPECT_TRUE(keep.dropped.empty());
    // Each river has a vertex where it passes a dropped point, z from the DEM.
    auto line = [](const PointSet& s, std::size_t i) {
        std::vector<std::array<double, 3>> v;
        for (PointId id : s.rivers[i])
            v.push_back({s.points[id].x, s.points[id].y, s.points[id].z});
        return v;
    };
    using V = std::vector<std::array<double, 3>>;
    EXPECT_EQ(line(set, 0), (V{{10, 45, 100},
                               {15, 45, 105},
                               {25, 45, 115},
                               {35, 45, 125},
                               {45, 45, 135},
                               {50, 45, 140}}));
    EXPECT_EQ(line(set, 1), (V{{60, 70, 200}, {65, 65, 195}, {75, 55, 185}, {80, 50, 180}}));
    EXPECT_EQ(line(keep, 0), (V{{10, 45, 100}, {50, 45, 140}}));
}

// The river's vertex goes where the river passes the dropped point (its projection), not onto
// the point; none where a vertex of the river is already closer than the clearance.
TEST(PointSet, RiverVerticesAtDroppedPointsLieOnTheRiver) {
    const DemGrid dem = makeGrid();
    const RiverLines lines = {{{15.05, 45.3}, {45.6, 45.3}}};
    PointSetOptions o;
    o.riverClearance = 0.5;
    const PointSet set = buildPointSet(dem, lines, o);
    ASSERT_EQ(set.dropped.size(), 4u);  // (15, 45) .. (45, 45), 0.3 m off the river
    ASSERT_EQ(set.rivers.size(), 1u);
    std::vector<std::array<double, 2>> xy;
    for (PointId id : set.rivers[0]) {
        const Point& p = set.points[id];
        xy.push_back({p.x, p.y});
        EXPECT_EQ(p.z, dem.sample(p.x, p.y));
    }
    // (15, 45) projects 0.05 m from the first vertex: none there; (45, 45) 0.6 m from the last.
    using V = std::vector<std::array<double, 2>>;
    EXPECT_EQ(xy, (V{{15.05, 45.3}, {25, 45.3}, {35, 45.3}, {45, 45.3}, {45.6, 45.3}}));
    o.riverClearance = 0.7;
    const PointSet wider = buildPointSet(dem, lines, o);
    EXPECT_EQ(wider.dropped.size(), 4u);
    EXPECT_EQ(wider.rivers[0].size(), 4u);  // no vertex 0.6 m from the last one
}

// A hairpin bend (two legs 2.7 mm apart a cell from the apex, 5.3 mm two cells away): a vertex
// at the dropped point next to the apex on each leg rounded to one grid point, so the block's
// triangulation found the river edge apex - vertex twice and the build failed. A new vertex
// closer than kRiverSeparation to another segment is left out; the others stay.
TEST(PointSet, NoVertexAtDroppedPointsNextToAnotherRiver) {
    const DemGrid dem = makeGrid();
    std::vector<RiverPiece> pieces = {{{5, 45, 0}, {95, 45.012, 0}, {5, 45.024, 0}}};
    ASSERT_EQ(addVerticesAtDroppedCells(dem, 1.0, 1, pieces), 14u);
    ASSERT_EQ(pieces.size(), 1u);
    const RiverPiece& p = pieces[0];
    ASSERT_EQ(p.size(), 17u);
    std::vector<double> xs;
    for (const RiverVertex& v : p)
        xs.push_back(std::round(v.x * 1000) / 1000);
    const std::vector<double> expected = {5,  15, 25, 35, 45, 55, 65, 75, 95,
                                          75, 65, 55, 45, 35, 25, 15, 5};
    EXPECT_EQ(xs, expected);  // none at x = 85 on either leg
    const RiverVertex apex = p[8];
    auto offLeg = [&](const RiverVertex& v, const RiverVertex& end) {  // distance to apex-end
        const double dx = end.x - apex.x, dy = end.y - apex.y;
        return std::fabs((v.x - apex.x) * dy - (v.y - apex.y) * dx) / std::hypot(dx, dy);
    };
    for (std::size_t i = 1; i < 8; ++i) {
        EXPECT_LT(offLeg(p[i], p[0]), 1e-9);
        EXPECT_GE(offLeg(p[i], p[16]), kRiverSeparation) << i;
        EXPECT_LT(offLeg(p[16 - i], p[16]), 1e-9);
        EXPECT_GE(offLeg(p[16 - i], p[0]), kRiverSeparation) << i;
    }
}
