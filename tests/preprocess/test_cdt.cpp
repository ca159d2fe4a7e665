// Constrained Delaunay construction (paper §3.3): exact predicates, merging, constraints.
#include <gtest/gtest.h>

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
