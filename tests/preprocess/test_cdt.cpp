// Constrained Delaunay construction (paper §3.3): exact predicates, merging, constraints.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>

#include "cdt.h"
#include "cdt_fixtures.h"
#include "checker.h"

namespace unilod {
namespace {

using testing::BlockSpec;
using testing::makeBlock;

TEST(Predicates, ExactAtTheCoordinateBound) {
    const std::int64_t m = kMaxGridCoordinate;
    EXPECT_GT(orient2d(-m, -m, m, -m, m, m), 0);
    EXPECT_EQ(orient2d(-m, -m, 0, 0, m, m), 0);
    EXPECT_LT(orient2d(-m, -m, m, m, m, m - 1), 0);
    // (m, 0), (0, m), (-m, 0) and (0, -m) are cocircular; moving one unit in or out decides.
    EXPECT_EQ(incircle(m, 0, 0, m, -m, 0, 0, -m), 0);
    EXPECT_GT(incircle(m, 0, 0, m, -m, 0, 0, -m + 1), 0);
    EXPECT_LT(incircle(m, 0, 0, m, -m, 0, 0, -m - 1), 0);
    EXPECT_GT(incircle(-m, -m, m, -m, m, m, -m + 1, m - 1), 0);
}

// Ties broken by one symbolic perturbation (predicates.h incirclePerturbed): never 0 for four
// cocircular points in convex position, exactly one diagonal of such a quadrilateral is legal,
// the same after any translation, and the plain sign wherever that is not 0.
TEST(Predicates, PerturbedIncircleBreaksTiesConsistently) {
    const std::int64_t m = kMaxGridCoordinate;
    struct Quad {
        std::int64_t x[4], y[4];  // counter-clockwise, cocircular
    };
    const Quad quads[] = {{{0, 30, 30, 0}, {0, 0, 30, 30}},
                          {{0, 90, 90, 0}, {0, 0, 30, 30}},
                          {{m, 0, -m, 0}, {0, m, 0, -m}},
                          {{5, 4, -3, -4}, {0, 3, 4, -3}}};  // on the circle of radius 5
    for (const Quad& q : quads) {
        ASSERT_EQ(incircle(q.x[0], q.y[0], q.x[1], q.y[1], q.x[2], q.y[2], q.x[3], q.y[3]), 0);
        for (const std::int64_t t : {std::int64_t(0), std::int64_t(7), std::int64_t(-1000)}) {
            if (std::abs(q.x[0]) == m && t != 0) continue;  // stay within the coordinate bound
            auto at = [&](int i, int k) {
                const int j = (i + k) % 4;
                return std::pair{q.x[j] + t, q.y[j] - 2 * t};
            };
            for (int k = 0; k < 4; ++k) {
                const auto [ax, ay] = at(0, k);
                const auto [bx, by] = at(1, k);
                const auto [cx, cy] = at(2, k);
                const auto [dx, dy] = at(3, k);
                const int s = incirclePerturbed(ax, ay, bx, by, cx, cy, dx, dy);
                EXPECT_NE(s, 0);
                // The other diagonal: triangle (b, c, d) against a.
                EXPECT_EQ(incirclePerturbed(bx, by, cx, cy, dx, dy, ax, ay), -s);
                // Rotating the triangle's corners does not change the answer.
                EXPECT_EQ(incirclePerturbed(bx, by, cx, cy, ax, ay, dx, dy), s);
            }
        }
    }
    EXPECT_GT(incirclePerturbed(m, 0, 0, m, -m, 0, 0, -m + 1), 0);
    EXPECT_LT(incirclePerturbed(m, 0, 0, m, -m, 0, 0, -m - 1), 0);
}

// A regular grid is all ties; the triangulation must not depend on the order of the points (a
// tree node rebuilt from its children's points must get their triangles back, nodebuild.h).
// A triangulation's triangles as sorted corner positions, sorted: comparable across point orders.
std::vector<std::array<std::pair<double, double>, 3>> trianglesByPosition(const PointSet& set,
                                                                         const Cdt& cdt) {
    std::vector<std::array<std::pair<double, double>, 3>> out;
    for (const TriangleTriple& t : collectTriangles(cdt)) {
        std::array<std::pair<double, double>, 3> c;
        for (int k = 0; k < 3; ++k) c[k] = {set.points[t.v[k]].x, set.points[t.v[k]].y};
        std::sort(c.begin(), c.end());
        out.push_back(c);
    }
    std::sort(out.begin(), out.end());
    return out;
}

TEST(Cdt, GridTriangulationIgnoresPointOrder) {
    PointSet set;
    for (int j = 0; j < 12; ++j)
        for (int i = 0; i < 15; ++i) set.points.push_back(Point{30.0 * i, 30.0 * j, double((i * 7 + j * 3) % 5)});
    auto triangulated = [](const PointSet& s) {
        Cdt cdt;
        std::string error;
        EXPECT_TRUE(buildCdt(s, {}, cdt, error)) << error;
        return trianglesByPosition(s, cdt);
    };
    const auto forward = triangulated(set);
    PointSet reversed = set;
    std::reverse(reversed.points.begin(), reversed.points.end());
    PointSet shuffled = set;
    for (std::size_t i = 0; i < shuffled.points.size(); ++i)
        std::swap(shuffled.points[i], shuffled.points[(i * 97 + 13) % shuffled.points.size()]);
    EXPECT_EQ(forward.size(), 2u * 14 * 11);
    EXPECT_EQ(triangulated(reversed), forward);
    EXPECT_EQ(triangulated(shuffled), forward);
}

// Removing a vertex of high degree (holes beyond planHole's first ears, exactly cocircular rims)
// gives the constrained Delaunay triangulation of the remaining points: the same triangles as
// triangulating them from scratch (unique under the symbolic perturbation).
TEST(Cdt, RemovingAHighDegreeVertexGivesTheTriangulationWithoutIt) {
    // Rims round the centre (0, 0): 20 points exactly on a circle of radius 100 (integer
    // Pythagorean positions: every quadruple cocircular, the perturbation decides), and 40 points
    // on it up to the grid's rounding (many flips after the ear clipping). A frame keeps the
    // centre inside.
    std::vector<std::vector<std::pair<double, double>>> rims(2);
    for (const auto& [a, b] : std::vector<std::pair<double, double>>{{100, 0}, {60, 80}, {80, 60}, {28, 96}, {96, 28}}) {
        for (const auto& [sx, sy] : std::vector<std::pair<double, double>>{{1, 1}, {-1, 1}, {1, -1}, {-1, -1}}) {
            if ((a == 100 && sy < 0) || (a == 100 && sx < 0)) continue;
            rims[0].push_back({sx * a, sy * b});
            if (a == 100) rims[0].push_back({sy * b, sx * a});
        }
    }
    rims[0].push_back({-100, 0});
    rims[0].push_back({0, -100});
    for (int i = 0; i < 40; ++i) {
        const double angle = 2 * 3.14159265358979 * i / 40, r = 100.0;
        rims[1].push_back({r * std::cos(angle), r * std::sin(angle)});
    }
    for (const auto& rim : rims) {
        PointSet with, without;
        with.points.push_back(Point{0, 0, 0});
        for (const auto& [x, y] : rim) {
            with.points.push_back(Point{x, y, 0});
            without.points.push_back(Point{x, y, 0});
        }
        for (const auto& [x, y] : std::vector<std::pair<double, double>>{
                 {-300, -300}, {0, -300}, {300, -300}, {300, 0}, {300, 300}, {0, 300}, {-300, 300}, {-300, 0}}) {
            with.points.push_back(Point{x, y, 0});
            without.points.push_back(Point{x, y, 0});
        }
        Cdt cdt, expected;
        std::string error;
        ASSERT_TRUE(buildCdt(with, {}, cdt, error)) << error;
        ASSERT_TRUE(buildCdt(without, {}, expected, error)) << error;
        std::vector<PointId> link;
        std::vector<std::uint32_t> tris;
        ASSERT_TRUE(cdt.star(0, link, tris));
        ASSERT_EQ(link.size(), rim.size()) << "the centre is joined to every rim point";
        cdt.removeVertex(0);
        std::string message;
        EXPECT_TRUE(checkCdt(cdt, captureCheckReference(cdt), nullptr, message)) << message;
        EXPECT_EQ(trianglesByPosition(with, cdt), trianglesByPosition(without, expected))
            << rim.size() << "-point rim";
    }
}

TEST(Cdt, RandomBlockIsValid) {
    BlockSpec spec;
    spec.points = 3000;
    const PointSet set = makeBlock(spec);
    Cdt cdt;
    std::string error;
    ASSERT_TRUE(buildCdt(set, {}, cdt, error)) << error;
    EXPECT_EQ(cdt.vertexCount, set.points.size());
    const CheckReference ref = captureCheckReference(cdt);
    std::string message;
    EXPECT_TRUE(checkCdt(cdt, ref, nullptr, message)) << message;
    std::size_t segments = 0;
    for (const auto& r : set.rivers)
        segments += r.size() - 1;
    EXPECT_EQ(cdt.constraintEdgeCount, segments);
    EXPECT_EQ(ref.rivers.chains.size(),
              set.rivers.size() + spec.rivers);  // mains split at junctions
}

TEST(Cdt, GridBlockWithCocircularPointsIsValid) {
    BlockSpec spec;
    spec.points = 2500;
    spec.grid = true;
    const PointSet set = makeBlock(spec);
    Cdt cdt;
    std::string error;
    ASSERT_TRUE(buildCdt(set, {}, cdt, error)) << error;
    std::string message;
    EXPECT_TRUE(checkCdt(cdt, captureCheckReference(cdt), nullptr, message)) << message;
    // Triangles of a convex domain: 2V - 2 - hull vertices.
    std::uint32_t hull = 0;
    for (std::uint32_t t = 0; t < cdt.triangleSlots(); ++t)
        hull += cdt.triangleAlive(t) && cdt.isGhost(t);
    EXPECT_EQ(cdt.realTriangleCount, 2 * cdt.vertexCount - 2 - hull);
}

TEST(Cdt, DuplicatesMergedFirstIdWins) {
    PointSet set;
    set.points = {{0, 0, 1}, {10, 0, 2}, {0, 10, 3}, {10, 10, 4}, {10.0002, 0.0001, 5}, {5, 5, 6}};
    set.points[4].locked = true;
    Cdt cdt;
    std::string error;
    ASSERT_TRUE(buildCdt(set, {}, cdt, error)) << error;
    EXPECT_EQ(cdt.representative[4], 1u);
    EXPECT_EQ(cdt.mergedPoints, 1u);
    EXPECT_FALSE(cdt.isVertex(4));
    EXPECT_TRUE(cdt.locked[1]);  // locked propagates to the representative
    EXPECT_EQ(cdt.vertexCount, 5u);
}

TEST(Cdt, TraceAlongTheHullInBothDirections) {
    // A 4 x 4 grid: every pair of hull vertices on one side, walked both ways, meets the first
    // hull vertex after a (a river vertex between two border vertices being deleted). Walking
    // one way used to find no start triangle (the neighbour sits in a ghost triangle) and crash.
    PointSet set;
    for (int r = 0; r < 4; ++r) {
        for (int c = 0; c < 4; ++c)
            set.points.push_back({10.0 * c, 10.0 * r, 0.0, PointKind::Dem, false});
    }
    Cdt cdt;
    std::string error;
    ASSERT_TRUE(buildCdt(set, {}, cdt, error)) << error;
    auto id = [](int c, int r) { return PointId(4 * r + c); };
    Cdt::Trace trace;
    for (int side = 0; side < 4; ++side) {
        // Vertices along the side, in order.
        std::vector<PointId> line;
        for (int i = 0; i < 4; ++i) {
            line.push_back(side == 0   ? id(i, 0)
                           : side == 1 ? id(3, i)
                           : side == 2 ? id(3 - i, 3)
                                       : id(0, 3 - i));
        }
        for (int i = 0; i < 4; ++i) {
            for (int j = 0; j < 4; ++j) {
                if (i == j) continue;
                cdt.traceSegment(line[i], line[j], trace);
                const int next = j > i ? i + 1 : i - 1;
                if (next == j) {
                    EXPECT_EQ(trace.end, Cdt::TraceEnd::Reached) << side << " " << i << " " << j;
                } else {
                    EXPECT_EQ(trace.end, Cdt::TraceEnd::Vertex) << side << " " << i << " " << j;
                    EXPECT_EQ(trace.vertex, line[next]) << side << " " << i << " " << j;
                }
            }
        }
    }
}

TEST(Cdt, PointOnAConstraintSplitsIt) {
    PointSet set;
    set.points = {{0, 0, 0}, {10, 0, 0}, {10, 10, 0}, {0, 10, 0}, {1, 5, 0}, {9, 5, 0}, {5, 5, 0}};
    set.rivers = {{4, 5}};
    Cdt cdt;
    std::string error;
    ASSERT_TRUE(buildCdt(set, {}, cdt, error)) << error;
    ASSERT_EQ(cdt.rivers.size(), 1u);
    EXPECT_EQ(cdt.rivers[0], (Polyline{4, 6, 5}));
    EXPECT_EQ(cdt.constraintEdgeCount, 2u);
    std::string message;
    EXPECT_TRUE(checkCdt(cdt, captureCheckReference(cdt), nullptr, message)) << message;
}

TEST(Cdt, CrossingRiversAreRejected) {
    PointSet set;
    set.points = {{0, 0, 0}, {10, 0, 0},  {10, 10, 0}, {0, 10, 0},
                  {1, 5, 0}, {9, 5.5, 0}, {5, 1, 0},   {5.5, 9, 0}};
    set.rivers = {{4, 5}, {6, 7}};
    Cdt cdt;
    std::string error;
    EXPECT_FALSE(buildCdt(set, {}, cdt, error));
    EXPECT_NE(error.find("river segments cross"), std::string::npos) << error;
}

TEST(Cdt, OverlappingRiversAreRejected) {
    PointSet set;
    set.points = {{0, 0, 0}, {10, 0, 0}, {10, 10, 0}, {0, 10, 0}, {1, 5, 0}, {9, 5, 0}, {5, 5, 0}};
    set.rivers = {{4, 5}, {6, 5}};
    Cdt cdt;
    std::string error;
    EXPECT_FALSE(buildCdt(set, {}, cdt, error));
    EXPECT_NE(error.find("overlap"), std::string::npos) << error;
}

TEST(Cdt, DataErrors) {
    Cdt cdt;
    std::string error;
    PointSet line;
    line.points = {{0, 0, 0}, {1, 1, 0}, {2, 2, 0}, {3, 3, 0}};
    EXPECT_FALSE(buildCdt(line, {}, cdt, error));
    EXPECT_NE(error.find("collinear"), std::string::npos);
    PointSet huge;
    huge.points = {{0, 0, 0}, {1e6, 0, 0}, {0, 1e6, 0}};
    EXPECT_FALSE(buildCdt(huge, {}, cdt, error));
    EXPECT_NE(error.find("too large"), std::string::npos);
    PointSet bad;
    bad.points = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
    bad.rivers = {{0, 7}};
    EXPECT_FALSE(buildCdt(bad, {}, cdt, error));
    EXPECT_NE(error.find("out of range"), std::string::npos);
}

}  // namespace
}  // namespace unilod
