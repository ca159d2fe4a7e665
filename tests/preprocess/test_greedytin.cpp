// Greedy-insertion TIN baseline (greedytin.h, Garland and Heckbert 1995): at every reported count
// the brute-force vertical error of the TIN is within the threshold, counts do not increase with
// the threshold, a plane needs only its hull, and the result is deterministic.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <set>

#include "build.h"
#include "cdt.h"
#include "greedytin.h"
#include "lod.h"
#include "modelerror.h"
#include "synthbuild.h"
#include "testutil.h"
#include "trianglepool.h"
#include "ulod.h"
#include "viewtin.h"

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

// Both ways of compacting a pool (copy for small pools, in place by start for large ones) keep
// every live triangle's points, in order, and drop the garbage between and after the ranges.
TEST(TrianglePool, CopyAndInPlaceCompactionKeepEveryLiveRange) {
    const PointSet set = makeGrid(12, 9, 10.0, 7);
    Cdt cdt;
    std::string error;
    ASSERT_TRUE(buildCdt(set, {}, cdt, error)) << error;
    struct P {
        std::int32_t gx, gy;
        double z;
    };
    const std::uint32_t slots = cdt.triangleSlots();
    std::vector<P> pool;
    std::vector<std::uint32_t> start(slots, 0), count(slots, 0);
    Lcg rng{11};
    // Ranges appended in a scrambled slot order, each after some garbage (points no range
    // covers), as the deletions leave them.
    std::vector<std::uint32_t> order;
    for (std::uint32_t t = 0; t < slots; ++t)
        order.push_back((t * 7919u) % slots);
    for (std::uint32_t t : order) {
        for (int g = int(rng.next() * 3); g > 0; --g)
            pool.push_back({-1, -1, -1.0});
        start[t] = std::uint32_t(pool.size());
        count[t] = std::uint32_t(rng.next() * 4);
        for (std::uint32_t i = 0; i < count[t]; ++i)
            pool.push_back({std::int32_t(t), std::int32_t(i), rng.next()});
    }
    pool.push_back({-1, -1, -1.0});
    const std::vector<P> before = pool;
    const std::vector<std::uint32_t> startBefore = start;
    std::size_t live = 0;
    for (std::uint32_t t = 0; t < slots; ++t)
        if (cdt.triangleAlive(t)) live += count[t];
    ASSERT_GT(live, 0u);
    for (const std::size_t limit : {std::size_t(0), pool.size()}) {  // in place, copy
        std::vector<P> p = before, spare;
        std::vector<std::uint32_t> s = startBefore;
        std::vector<std::uint64_t> scratch;
        compactTrianglePool(cdt, p, s, count, spare, scratch, limit);
        EXPECT_EQ(p.size(), live) << "limit " << limit;
        for (std::uint32_t t = 0; t < slots; ++t) {
            if (!cdt.triangleAlive(t) || count[t] == 0) continue;
            ASSERT_LE(std::size_t(s[t]) + count[t], p.size());
            for (std::uint32_t i = 0; i < count[t]; ++i) {
                const P& q = p[s[t] + i];
                const P& o = before[startBefore[t] + i];
                EXPECT_TRUE(q.gx == o.gx && q.gy == o.gy && q.z == o.z)
                    << "limit " << limit << " triangle " << t << " point " << i;
            }
        }
    }
}

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

// Per-point weights (the view-dependent baseline, bench_order --view): refineTo(1) brings every
// point within 1 / w of the surface, by brute force, and needs no point of weight 0.
TEST(GreedyTin, WeightedPointsAreWithinTheirOwnTolerance) {
    const PointSet set = makeGrid(48, 40, 30.0, 7);
    // Columns 0-15: 2 m, 16-31: 10 m, 32-47: not needed (weight 0).
    std::vector<double> weights(set.points.size());
    for (std::size_t m = 0; m < set.points.size(); ++m) {
        const std::size_t c = m % 48;
        weights[m] = c < 16 ? 0.5 : c < 32 ? 0.1 : 0.0;
    }
    GreedyTin tin;
    tin.setWeights(&weights);
    std::string error;
    ASSERT_TRUE(tin.init(set, error)) << error;
    tin.refineTo(1.0);
    EXPECT_LE(tin.maxError(), 1.0);
    const Cdt& cdt = tin.cdt();
    std::vector<ExtraSample> tight, loose;
    for (PointId m = 0; m < set.points.size(); ++m) {
        EXPECT_FALSE(weights[m] == 0 && cdt.isVertex(m) && m / 48 > 0 &&
                     m / 48 < 39)
            << "point " << m << " of weight 0 inserted";
        const ExtraSample e{cdt.gx[m], cdt.gy[m], set.points[m].z};
        if (weights[m] == 0.5) tight.push_back(e);
        if (weights[m] == 0.1) loose.push_back(e);
    }
    EXPECT_LE(bruteForceExtraError(set, cdt, tight), 2.0 + 1e-9);
    EXPECT_LE(bruteForceExtraError(set, cdt, loose), 10.0 + 1e-9);
    EXPECT_GT(bruteForceExtraError(set, cdt, loose), 2.0) << "the loose part was not refined to 2 m";

    // Between the uniform TINs of the tightest and the loosest tolerance.
    std::vector<std::uint64_t> uniform;
    ASSERT_TRUE(greedyTinTriangles(set, {2.0, 10.0}, uniform, error)) << error;
    EXPECT_LT(tin.triangleCount(), uniform[0]);
    EXPECT_GT(tin.triangleCount(), uniform[1] / 2);

    // Weights of 1 are the unweighted TIN.
    const std::vector<double> ones(set.points.size(), 1.0);
    GreedyTin one;
    one.setWeights(&ones);
    ASSERT_TRUE(one.init(set, error)) << error;
    one.refineTo(2.0);
    EXPECT_EQ(one.triangleCount(), uniform[0]);
}

TEST(GreedyTin, BadWeights) {
    const PointSet set = makeGrid(6, 5, 10.0, 1);
    std::string error;
    for (const std::vector<double>& w :
         {std::vector<double>(29, 1.0), std::vector<double>(30, -1.0),
          std::vector<double>(30, NAN), std::vector<double>(30, INFINITY)}) {
        GreedyTin tin;
        tin.setWeights(&w);
        EXPECT_FALSE(tin.init(set, error)) << w.size() << " " << w[0];
        EXPECT_NE(error.find("weight"), std::string::npos) << error;
    }
}

// ---------------------------------------------------------------------------------------------
// With rivers as constraints (the baseline of a model that holds its rivers).

// Appends a river chain (local metres, the grid's origin added) at a flat 100 m; returns its ids.
Polyline addChain(PointSet& set, std::initializer_list<std::pair<double, double>> xy) {
    Polyline chain;
    for (const auto& [x, y] : xy) {
        chain.push_back(PointId(set.points.size()));
        set.points.push_back({1000.0 + x, 2000.0 + y, 100.0});
    }
    return chain;
}

// After init: every pair of consecutive placed vertices of each chain is a constraint edge, every
// chain vertex between them is within `tol` (3D) of it, and nothing else is a constraint.
// Returns the placed vertices per chain.
std::vector<Polyline> expectPlacedWithin(const PointSet& set, const GreedyTin& tin,
                                         const std::vector<Polyline>& chains, double tol) {
    const Cdt& cdt = tin.cdt();
    std::vector<Polyline> kept;
    std::uint32_t pairs = 0;
    for (const Polyline& chain : chains) {
        Polyline k;
        std::size_t prev = 0;
        for (std::size_t i = 0; i < chain.size(); ++i) {
            if (!cdt.isVertex(chain[i])) continue;
            k.push_back(chain[i]);
            if (i == 0) continue;
            const std::uint32_t h = cdt.findEdge(chain[prev], chain[i]);
            EXPECT_NE(h, Cdt::kNone) << chain[prev] << "-" << chain[i];
            if (h != Cdt::kNone) {
                EXPECT_TRUE(cdt.isConstrained(h));
            }
            const Point &a = set.points[chain[prev]], &c = set.points[chain[i]];
            for (std::size_t m = prev + 1; m < i; ++m) {
                const Point& p = set.points[chain[m]];
                const double da[3] = {a.x, a.y, a.z}, dc[3] = {c.x, c.y, c.z},
                             dm[3] = {p.x, p.y, p.z};
                EXPECT_LE(std::sqrt(segmentDistance2(da, dc, dm)), tol + 1e-9);
            }
            prev = i;
            ++pairs;
        }
        EXPECT_EQ(k.front(), chain.front());
        EXPECT_EQ(k.back(), chain.back());
        kept.push_back(k);
    }
    EXPECT_EQ(tin.riverEdgeCount(), pairs);
    return kept;
}

TEST(GreedyTinRivers, ShortcutsWithinTheToleranceAndTheSurfaceWithinTheThreshold) {
    PointSet set = makeGrid(41, 41, 5.0, 7);
    std::vector<Polyline> chains;
    // A meander with bends of about 11 m: at 20 m they go, at 0.5 m they stay.
    chains.push_back(addChain(set, {{10.3, 20.1}, {40.2, 31.7}, {70.4, 22.2}, {100.1, 33.9},
                                    {130.6, 24.4}, {160.2, 35.3}, {190.3, 26.1}}));
    for (const double tol : {0.5, 5.0, 20.0}) {
        SCOPED_TRACE(tol);
        GreedyTin tin;
        std::string error;
        ASSERT_TRUE(tin.init(set, chains, tol, error)) << error;
        const std::vector<Polyline> kept = expectPlacedWithin(set, tin, chains, tol);
        if (tol != 5.0) {
            EXPECT_EQ(kept[0].size(), tol < 5.0 ? 7u : 2u);
        }
        for (const double e : {20.0, 5.0, 1.0}) {
            tin.refineTo(e);
            EXPECT_LE(bruteForceMaxError(set, tin.cdt()), e + 1e-9);
            EXPECT_EQ(tin.riverEdgeCount(), kept[0].size() - 1);  // constraints stay
        }
    }
    // Deterministic, and more triangles than without the river.
    GreedyTin a, b, bare;
    std::string error;
    ASSERT_TRUE(a.init(set, chains, 5.0, error));
    ASSERT_TRUE(b.init(set, chains, 5.0, error));
    PointSet noRiver = makeGrid(41, 41, 5.0, 7);
    ASSERT_TRUE(bare.init(noRiver, error));
    a.refineTo(5.0), b.refineTo(5.0), bare.refineTo(5.0);
    EXPECT_EQ(collectTriangles(a.cdt()), collectTriangles(b.cdt()));
    EXPECT_GT(a.triangleCount(), bare.triangleCount());
}

TEST(GreedyTinRivers, AShortcutThatWouldCrossIsSplit) {
    // A's shortcut (its 3.1 m bend dropped at 5 m) would cross B, which runs down from just below
    // A's bend; A keeps its bend whichever chain is placed first.
    for (const bool aFirst : {true, false}) {
        SCOPED_TRACE(aFirst);
        PointSet set = makeGrid(41, 41, 5.0, 3);
        const Polyline a = addChain(set, {{10.3, 100.1}, {100.2, 103.3}, {190.1, 100.2}});
        const Polyline b = addChain(set, {{100.4, 101.2}, {100.6, 60.3}});
        const std::vector<Polyline> chains = aFirst ? std::vector{a, b} : std::vector{b, a};
        GreedyTin tin;
        std::string error;
        ASSERT_TRUE(tin.init(set, chains, 5.0, error)) << error;
        const std::vector<Polyline> kept = expectPlacedWithin(set, tin, chains, 5.0);
        EXPECT_EQ(kept[aFirst ? 0 : 1], a);
        EXPECT_EQ(tin.riverEdgeCount(), 3u);
        tin.refineTo(2.0);
        EXPECT_LE(bruteForceMaxError(set, tin.cdt()), 2.0 + 1e-9);
        EXPECT_EQ(tin.riverEdgeCount(), 3u);
    }
    // Without B, A is one segment at 5 m.
    PointSet set = makeGrid(41, 41, 5.0, 3);
    const Polyline a = addChain(set, {{10.3, 100.1}, {100.2, 103.3}, {190.1, 100.2}});
    GreedyTin tin;
    std::string error;
    ASSERT_TRUE(tin.init(set, {a}, 5.0, error)) << error;
    EXPECT_EQ(tin.riverEdgeCount(), 1u);
}

TEST(GreedyTinRivers, CrossingOriginalSegmentsAreAnError) {
    PointSet set = makeGrid(21, 21, 5.0, 1);
    const Polyline a = addChain(set, {{10.3, 50.1}, {90.2, 50.3}});
    const Polyline b = addChain(set, {{50.4, 10.2}, {50.6, 90.3}});
    GreedyTin tin;
    std::string error;
    EXPECT_FALSE(tin.init(set, {a, b}, 1.0, error));
    EXPECT_NE(error.find("cross"), std::string::npos) << error;
    EXPECT_FALSE(tin.init(set, {a}, -1.0, error));
    const Polyline bad{0, PointId(set.points.size())};
    EXPECT_FALSE(tin.init(set, {bad}, 1.0, error));
    EXPECT_NE(error.find("out of range"), std::string::npos) << error;
}

// The view-dependent TIN (viewtin.h, the baseline of `bench --runs tin` and `bench_order
// --view`): points outside the view frustum weigh nothing, every point on screen is within its
// own P-pixel bound (brute force over the triangles, independent of the TIN's bookkeeping), the
// bounds differ point by point, and a smaller P needs more triangles.
TEST(ViewTin, EveryPointOnScreenIsWithinItsOwnBound) {
    const PointSet set = makeGrid(64, 48, 30.0, 11);
    engine::Camera camera;
    camera.eye[0] = 1500, camera.eye[1] = 1500, camera.eye[2] = 600;
    camera.yawDegrees = 0, camera.pitchDegrees = -20;
    const TinView view{camera, 1920, 1080, 1.0};
    std::vector<double> weights;
    const std::uint64_t onScreen = viewWeights(set, view, weights);
    ASSERT_EQ(weights.size(), set.points.size());
    std::uint64_t inFrustum = 0;
    for (std::size_t m = 0; m < set.points.size(); ++m) {
        const double at[3] = {set.points[m].x, set.points[m].y, set.points[m].z};
        const bool in = engine::boxInFrustum(camera, 1920.0 / 1080.0, at, at);
        inFrustum += in;
        EXPECT_EQ(weights[m] > 0, in) << "point " << m;
        if (!in) continue;
        // The engine's bound for a box that is the point alone (lod.h, Eq. 11, nearest distance).
        const engine::ViewTolerance tolerance{1.0, 60 * 3.14159265358979323846 / 180, 1920, 1080,
                                              engine::DistanceMode::Nearest};
        const double hLim =
            engine::blockTolerance(tolerance, engine::nearestBoxDistance(camera.eye, at, at),
                                   engine::boxView(camera, at, at));
        EXPECT_NEAR(weights[m], 1 / hLim, 1e-12 / hLim) << "point " << m;
    }
    EXPECT_EQ(onScreen, inFrustum);
    ASSERT_GT(onScreen, set.points.size() / 4);
    ASSERT_LT(onScreen, set.points.size()) << "the view should leave some points out";
    // Each point its own bound (distance and view angles), not one for the whole view.
    double lo = 0, hi = 0;
    for (double w : weights)
        if (w > 0) lo = lo == 0 ? w : std::min(lo, w), hi = std::max(hi, w);
    EXPECT_GT(hi, 1.5 * lo);

    std::vector<TriangleTriple> triangles;
    std::uint32_t vertices = 0;
    std::string error;
    ASSERT_TRUE(weightedTin(set, weights, triangles, vertices, error)) << error;
    EXPECT_GT(triangles.size(), 2u);
    EXPECT_LT(triangles.size(), std::size_t(2 * 63 * 47)) << "no coarser than the grid";
    // Brute force: the TIN's height under every point on screen (any triangle that holds it;
    // the surface is continuous) within 1 / weight.
    double worst = 0;
    for (std::size_t m = 0; m < set.points.size(); ++m) {
        if (weights[m] == 0) continue;
        const Point& p = set.points[m];
        bool found = false;
        for (const TriangleTriple& t : triangles) {
            const Point &a = set.points[t.v[0]], &b = set.points[t.v[1]], &c = set.points[t.v[2]];
            const double det = (b.x - a.x) * (c.y - a.y) - (c.x - a.x) * (b.y - a.y);
            const double l1 = ((p.x - a.x) * (c.y - a.y) - (c.x - a.x) * (p.y - a.y)) / det;
            const double l2 = ((b.x - a.x) * (p.y - a.y) - (p.x - a.x) * (b.y - a.y)) / det;
            const double l0 = 1 - l1 - l2;
            if (l0 < -1e-9 || l1 < -1e-9 || l2 < -1e-9) continue;
            const double z = l0 * a.z + l1 * b.z + l2 * c.z;
            worst = std::max(worst, std::abs(z - p.z) * weights[m]);
            EXPECT_LE(std::abs(z - p.z), 1.0 / weights[m] + 1e-6) << "point " << m;
            found = true;
            break;
        }
        EXPECT_TRUE(found) << "point " << m << " outside the TIN";
    }
    EXPECT_GT(worst, 0.5) << "the bound should be used, not met by accident";

    // A tighter P: more triangles; the same inputs: the same TIN.
    std::vector<double> tight;
    viewWeights(set, TinView{camera, 1920, 1080, 0.25}, tight);
    std::vector<TriangleTriple> more, again;
    ASSERT_TRUE(weightedTin(set, tight, more, vertices, error)) << error;
    EXPECT_GT(more.size(), triangles.size());
    ASSERT_TRUE(weightedTin(set, weights, again, vertices, error)) << error;
    EXPECT_EQ(again, triangles);
}

// mergedLeaves (the whole model as one block, what the view TIN starts from): every leaf point
// once, a border point shared by two leaves merged, at its world position; the same from blocks
// that store no exact grid positions (valid: the float offsets then place them).
TEST(ViewTin, MergedLeavesHoldEveryLeafPointOnce) {
    const test::TempDir dir("merged");
    BuildOptions o;
    std::string error;
    ASSERT_TRUE(test::writeTwoByTwoWorld(dir, 4000, 9, o, error)) << error;
    o.outPath = dir.file("model.ulod");
    BuildSummary summary;
    ASSERT_TRUE(runBuild(o, summary, error)) << error;
    format::Reader reader;
    ASSERT_TRUE(reader.open(o.outPath, error)) << error;
    format::Block merged;
    ASSERT_TRUE(mergedLeaves(reader, merged, error)) << error;
    const PointSet all = blockPoints(merged);
    std::set<std::pair<long long, long long>> positions;
    for (const Point& p : all.points)
        EXPECT_TRUE(positions.insert({std::llround(p.x * 1000), std::llround(p.y * 1000)}).second)
            << "a point twice";
    std::size_t leafVertices = 0;
    std::vector<format::Block> blocks;
    for (std::size_t i = 0; i < reader.blocks().size(); ++i) {
        format::Block b;
        ASSERT_TRUE(reader.readBlock(i, b, error)) << error;
        if (b.level == 0) {
            leafVertices += b.vertices.size();
            for (const Point& p : blockPoints(b).points)
                EXPECT_TRUE(positions.count({std::llround(p.x * 1000), std::llround(p.y * 1000)}))
                    << "a leaf point missing";
        }
        b.grid.clear();
        blocks.push_back(std::move(b));
    }
    EXPECT_LT(all.points.size(), leafVertices) << "the shared borders are merged";
    EXPECT_FALSE(merged.riverIndices.empty());

    const std::string noGrid = dir.file("nogrid.ulod");
    ASSERT_TRUE(format::writeUlod(noGrid, reader.header(), blocks, error)) << error;
    format::Reader plain;
    ASSERT_TRUE(plain.open(noGrid, error)) << error;
    format::Block mergedPlain;
    ASSERT_TRUE(mergedLeaves(plain, mergedPlain, error)) << error;
    ASSERT_EQ(mergedPlain.vertices.size(), merged.vertices.size());
    for (std::size_t k = 0; k < merged.vertices.size(); ++k) {
        EXPECT_EQ(mergedPlain.grid[k].x, merged.grid[k].x) << k;
        EXPECT_EQ(mergedPlain.grid[k].y, merged.grid[k].y) << k;
    }
}

}  // namespace
}  // namespace unilod
