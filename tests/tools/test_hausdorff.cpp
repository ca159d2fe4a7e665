// 2D Hausdorff distance of the report's river comparison (tools/report/report.h) on polylines
// whose distance is known in closed form.
#include <gtest/gtest.h>

#include <cmath>

#include "report.h"

using namespace unilod;
using report::directedHausdorff;
using report::hausdorff2D;
using report::pointSegmentDistance;

TEST(Hausdorff, PointSegment) {
    EXPECT_DOUBLE_EQ(pointSegmentDistance({0, 1}, {-1, 0}, {1, 0}), 1.0);       // foot inside
    EXPECT_DOUBLE_EQ(pointSegmentDistance({2, 1}, {0, 0}, {1, 0}), std::sqrt(2.0));  // past b
    EXPECT_DOUBLE_EQ(pointSegmentDistance({-3, -4}, {0, 0}, {1, 0}), 5.0);      // before a
    EXPECT_DOUBLE_EQ(pointSegmentDistance({3, 4}, {0, 0}, {0, 0}), 5.0);        // a == b
    EXPECT_DOUBLE_EQ(pointSegmentDistance({0.5, 0}, {0, 0}, {1, 0}), 0.0);      // on it
}

TEST(Hausdorff, TriangleOverBase) {
    // B = base with an apex at height 3: every apex-side point is within 3 of the base, the apex
    // exactly 3; the base's midpoint is 15 / sqrt(34) from the sides (the base's farthest point).
    const std::vector<XY> base = {{0, 0}, {10, 0}};
    const std::vector<XY> tent = {{0, 0}, {5, 3}, {10, 0}};
    EXPECT_DOUBLE_EQ(directedHausdorff(tent, base), 3.0);
    EXPECT_NEAR(directedHausdorff(base, tent), 15.0 / std::sqrt(34.0), 1e-12);
    EXPECT_DOUBLE_EQ(hausdorff2D(base, tent), 3.0);
    EXPECT_DOUBLE_EQ(hausdorff2D(tent, base), 3.0);
}

TEST(Hausdorff, SimplifiedZigzag) {
    // A zigzag and its chord: the dropped vertices are 1 away; the chord's points at most
    // 1 / sqrt(2) from the zigzag.
    const std::vector<XY> zigzag = {{0, 0}, {1, 1}, {2, 0}, {3, 1}, {4, 0}};
    const std::vector<XY> chord = {{0, 0}, {4, 0}};
    EXPECT_DOUBLE_EQ(directedHausdorff(zigzag, chord), 1.0);
    EXPECT_NEAR(directedHausdorff(chord, zigzag), 1.0 / std::sqrt(2.0), 1e-12);
    EXPECT_DOUBLE_EQ(hausdorff2D(zigzag, chord), 1.0);
}

TEST(Hausdorff, IdenticalReversedAndPoint) {
    const std::vector<XY> line = {{0, 0}, {3, 4}, {6, 0}, {9, 4}};
    const std::vector<XY> reversed(line.rbegin(), line.rend());
    EXPECT_EQ(hausdorff2D(line, line), 0.0);
    EXPECT_EQ(hausdorff2D(line, reversed), 0.0);
    // A single point: the distance to the farthest vertex of the other.
    const std::vector<XY> point = {{0, 0}};
    EXPECT_DOUBLE_EQ(hausdorff2D(point, {{0, 0}, {10, 0}}), 10.0);
    EXPECT_DOUBLE_EQ(hausdorff2D({{0, 0}, {10, 0}}, point), 10.0);
}

TEST(Hausdorff, InteriorMaximumWithinTheSamplingBound) {
    // The maximum of d(., B) over A can lie inside a segment of A, not at a vertex:
    // A = (0,0)-(10,0); B = (0,0)-(5,-20)-(10,0): d((x,0), B) is largest at x = 5 (inside A),
    // where the distance to each side is 5 * 20 / sqrt(5^2 + 20^2) = 100 / sqrt(425).
    const std::vector<XY> a = {{0, 0}, {10, 0}};
    const std::vector<XY> b = {{0, 0}, {5, -20}, {10, 0}};
    const double exact = 100.0 / std::sqrt(425.0);
    EXPECT_NEAR(directedHausdorff(a, b, 64), exact, 1e-12);  // x = 5 is a sample (32 / 64)
    const double coarse = directedHausdorff(a, b, 3);        // samples at 10/3, 20/3 only
    EXPECT_LE(coarse, exact);
    EXPECT_GE(coarse, exact - 10.0 / (2 * 3));  // the documented bound
}
