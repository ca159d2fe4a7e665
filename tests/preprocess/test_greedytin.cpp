// Greedy-insertion TIN baseline (greedytin.h, Garland and Heckbert 1995): at every reported count
// the brute-force vertical error of the TIN is within the threshold, counts do not increase with
// the threshold, a plane needs only its hull, and the result is deterministic.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>

#include "cdt.h"
#include "greedytin.h"
#include "modelerror.h"

namespace unilod {
namespace {

// Own generator: the same numbers everywhere.
struct Lcg {
    std::uint64_t s;
    double next() {
        s = s * 6364136223846793005ull + 1442695040888963407ull;
        return double(s >> 11) / double(1ull << 53);
    }
};

// A w x h grid with `cell` metres spacing: hills plus noise, like a small DEM.
PointSet makeGrid(int w, int h, double cell, std::uint64_t seed) {
    PointSet set;
    Lcg rng{seed};
    for (int r = 0; r < h; ++r) {
        for (int c = 0; c < w; ++c) {
            const double x = 1000.0 + c * cell, y = 2000.0 + r * cell;
            const double z = 100.0 + 40.0 * std::sin(c * 0.21) * std::cos(r * 0.17) + 0.05 * c * r +
                             6.0 * rng.next();
            set.points.push_back({x, y, z});
        }
    }
    return set;
}

const std::vector<double> kErrors = {0.0, 0.5, 1, 2, 5, 10, 20, 50, 200};

TEST(GreedyTin, BruteForceErrorIsWithinEachThreshold) {
    const PointSet set = makeGrid(33, 27, 30.0, 5);
    std::vector<std::uint64_t> counts;
    std::string error;
    ASSERT_TRUE(greedyTinTriangles(set, kErrors, counts, error)) << error;
    ASSERT_EQ(counts.size(), kErrors.size());
    for (std::size_t i = 0; i < kErrors.size(); ++i) {
        // A fresh run to the same threshold: the TIN the count describes.
        GreedyTin tin;
        ASSERT_TRUE(tin.init(set, error)) << error;
        tin.refineTo(kErrors[i]);
        EXPECT_EQ(tin.triangleCount(), counts[i]) << "e " << kErrors[i];
        const double brute = bruteForceMaxError(set, tin.cdt());
        EXPECT_LE(brute, kErrors[i] + 1e-9) << "e " << kErrors[i];
        EXPECT_NEAR(tin.maxError(), brute, 1e-9) << "e " << kErrors[i];
        // Every vertex is an input point and the triangulation is a proper one of the hull.
        EXPECT_EQ(tin.triangleCount(), collectTriangles(tin.cdt()).size());
    }
    EXPECT_EQ(counts.front(), std::uint64_t(2 * (33 - 1) * (27 - 1))) << "e = 0 with noise: all";
    EXPECT_EQ(counts.back(), 2u) << "e above the relief: the hull alone";
}

TEST(GreedyTin, CountsDoNotIncreaseWithTheThreshold) {
    const PointSet set = makeGrid(60, 45, 30.0, 11);
    std::vector<double> errors;
    for (double e = 0.25; e < 100; e *= 1.5)
        errors.push_back(e);
    std::vector<std::uint64_t> counts;
    std::string error;
    ASSERT_TRUE(greedyTinTriangles(set, errors, counts, error)) << error;
    for (std::size_t i = 1; i < counts.size(); ++i)
        EXPECT_LE(counts[i], counts[i - 1]) << "e " << errors[i];
    EXPECT_LT(counts.back(), counts.front());
    // The thresholds' order does not matter.
    std::vector<double> reversed(errors.rbegin(), errors.rend());
    std::vector<std::uint64_t> again;
    ASSERT_TRUE(greedyTinTriangles(set, reversed, again, error)) << error;
    for (std::size_t i = 0; i < counts.size(); ++i)
        EXPECT_EQ(again[counts.size() - 1 - i], counts[i]);
}

TEST(GreedyTin, PlaneNeedsOnlyTheHull) {
    // Integer heights of an integer-slope plane at whole-metre positions: every interpolation
    // is exact, so e = 0 holds with the rectangle's two triangles.
    PointSet set;
    for (int r = 0; r < 20; ++r) {
        for (int c = 0; c < 31; ++c)
            set.points.push_back({10.0 * c, 10.0 * r, 7.0 + 2.0 * c - 3.0 * r});
    }
    std::vector<std::uint64_t> counts;
    std::string error;
    ASSERT_TRUE(greedyTinTriangles(set, {0.0, 1.0}, counts, error)) << error;
    EXPECT_EQ(counts, (std::vector<std::uint64_t>{2, 2}));
    GreedyTin tin;
    ASSERT_TRUE(tin.init(set, error)) << error;
    EXPECT_EQ(tin.vertexCount(), 4u);
    EXPECT_EQ(tin.maxError(), 0.0);
}

TEST(GreedyTin, ScatteredPointsInADisc) {
    // A round hull with many corners and points on no grid.
    PointSet set;
    Lcg rng{3};
    while (set.points.size() < 800) {
        const double x = 2 * rng.next() - 1, y = 2 * rng.next() - 1;
        if (x * x + y * y > 1) continue;
        set.points.push_back({5000 * x, 5000 * y, 300 * x * y + 50 * std::sin(7 * x) + rng.next()});
    }
    std::string error;
    for (double e : {0.5, 3.0, 30.0}) {
        GreedyTin tin;
        ASSERT_TRUE(tin.init(set, error)) << error;
        tin.refineTo(e);
        EXPECT_LE(bruteForceMaxError(set, tin.cdt()), e + 1e-9);
    }
}

TEST(GreedyTin, Deterministic) {
    const PointSet set = makeGrid(50, 40, 25.0, 2);
    std::string error;
    GreedyTin a, b;
    ASSERT_TRUE(a.init(set, error)) << error;
    ASSERT_TRUE(b.init(set, error)) << error;
    a.refineTo(1.5);
    b.refineTo(1.5);
    EXPECT_EQ(collectTriangles(a.cdt()), collectTriangles(b.cdt()));
    std::vector<std::uint64_t> c1, c2;
    ASSERT_TRUE(greedyTinTriangles(set, {1, 4, 16}, c1, error));
    ASSERT_TRUE(greedyTinTriangles(set, {1, 4, 16}, c2, error));
    EXPECT_EQ(c1, c2);
}

TEST(GreedyTin, BadInput) {
    const PointSet set = makeGrid(5, 5, 10.0, 1);
    std::vector<std::uint64_t> counts;
    std::string error;
    EXPECT_FALSE(greedyTinTriangles(set, {-1.0}, counts, error));
    EXPECT_FALSE(greedyTinTriangles(set, {NAN}, counts, error));
    PointSet line;
    for (int i = 0; i < 10; ++i)
        line.points.push_back({double(i), 2.0 * i, 1.0});
    EXPECT_FALSE(greedyTinTriangles(line, {1.0}, counts, error));
    EXPECT_NE(error.find("collinear"), std::string::npos) << error;
}

}  // namespace
}  // namespace unilod
