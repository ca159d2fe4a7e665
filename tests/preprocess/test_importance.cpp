// Improved 3D_DP importance order (paper §2.1, §3.1): base plane, nearest-neighbour chain,
// threshold consistency with a straightforward recursive 3D_DP, determinism, degenerate inputs.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <set>

#include "importance.h"
#include "testutil.h"

using namespace unilod;
using unilod::test::randomPointSet;

namespace {

ImportanceResult run(const PointSet& set, bool bai = true) {
    ImportanceOptions opt;
    opt.useBai = bai;
    ImportanceResult r;
    std::string err;
    EXPECT_TRUE(computeImportance(set, opt, r, err)) << err;
    return r;
}

std::vector<PointId> unlocked(const PointSet& set) {
    std::vector<PointId> ids;
    for (PointId i = 0; i < set.points.size(); ++i) {
        if (!set.points[i].locked) ids.push_back(i);
    }
    return ids;
}

// Plain recursive 3D_DP with threshold t over the library's chain: split at the farthest point
// when its (pseudo) distance exceeds t, else drop the whole sub-chain. Returns the kept ids.
void plainDp(const std::vector<GridPoint>& g, const std::vector<float>& f, const GridPoint& o,
             std::uint32_t s, std::uint32_t e, double t, std::vector<std::uint32_t>& kept) {
    if (e - s < 2) return;
    const PlaneDistance dist(o, g[s], g[e]);
    std::uint32_t best = s + 1;
    double bestD = -1;
    for (std::uint32_t k = s + 1; k < e; ++k) {
        const double d = dist(g[k]) * double(f[k]);
        if (d > bestD || (d == bestD && preferSplit(k, best, s, e))) {
            bestD = d;
            best = k;
        }
    }
    if (!(bestD > t)) return;
    kept.push_back(best);
    plainDp(g, f, o, s, best, t, kept);
    plainDp(g, f, o, best, e, t, kept);
}

void expectThresholdConsistent(const PointSet& set, const ImportanceResult& r) {
    const Quantizer q = Quantizer::forPoints(set.points);
    std::vector<GridPoint> g;
    std::vector<float> f;
    for (PointId id : r.chain) {
        g.push_back(q(set.points[id]));
        f.push_back(r.baiFactor[id]);
    }
    const GridPoint o = q(set.points[r.origin]);

    // Thresholds: 0, values exactly at effective importances, between them, above the maximum.
    std::vector<double> eff;
    for (PointId id : r.order) {
        if (std::isfinite(r.importance[id])) eff.push_back(r.importance[id]);
    }
    std::sort(eff.begin(), eff.end());
    ASSERT_FALSE(eff.empty());
    std::vector<double> thresholds{0.0, eff.back() * 2 + 1};
    for (int i = 0; i < 12; ++i)
        thresholds.push_back(eff[eff.size() * i / 12]);
    for (int i = 0; i < 12; ++i) {
        const std::size_t k = eff.size() * (2 * i + 1) / 24;
        thresholds.push_back(k + 1 < eff.size() ? (eff[k] + eff[k + 1]) / 2 : eff[k]);
    }
    ASSERT_GE(thresholds.size(), 20u);
    for (double t : thresholds) {
        std::vector<std::uint32_t> keptPos;
        plainDp(g, f, o, 0, static_cast<std::uint32_t>(g.size() - 1), t, keptPos);
        std::set<PointId> kept{r.origin, r.anchor, r.floating};
        for (std::uint32_t k : keptPos)
            kept.insert(r.chain[k]);
        std::set<PointId> byImportance;
        for (PointId id : r.order) {
            if (r.importance[id] > t) byImportance.insert(id);
        }
        ASSERT_EQ(kept, byImportance) << "threshold " << t;
    }
}

}  // namespace

TEST(PlaneDistance, ClosedForms) {
    const GridPoint o{0, 0, 0}, p{1000000, 0, 0}, q{0, 1000000, 0};
    const PlaneDistance plane(o, p, q);
    EXPECT_EQ(plane.kind(), PlaneDistance::Kind::Plane);
    EXPECT_DOUBLE_EQ(plane({5000, 7000, 42000}), 42.0);
    EXPECT_DOUBLE_EQ(plane({5000, 7000, -3000}), 3.0);
    // Tilted plane z = x: distance of (0, 0, 1 m) is 1/sqrt(2) m.
    const PlaneDistance tilted(o, {1000, 0, 1000}, {0, 1000, 0});
    EXPECT_NEAR(tilted({0, 0, 1000}), std::sqrt(0.5), 1e-12);
    // O, P, Q collinear: distance to the line PQ (the x axis).
    const PlaneDistance line(o, {1000, 0, 0}, {2000, 0, 0});
    EXPECT_EQ(line.kind(), PlaneDistance::Kind::Line);
    EXPECT_DOUBLE_EQ(line({5000, 3000, 4000}), 5.0);
    // P == Q != O: distance to the line OP.
    const PlaneDistance op(o, {0, 0, 2000}, {0, 0, 2000});
    EXPECT_EQ(op.kind(), PlaneDistance::Kind::Line);
    EXPECT_DOUBLE_EQ(op({3000, 4000, 9000}), 5.0);
    // P == Q == O: distance to O.
    const PlaneDistance pt(o, o, o);
    EXPECT_EQ(pt.kind(), PlaneDistance::Kind::Point);
    EXPECT_DOUBLE_EQ(pt({3000, 4000, 0}), 5.0);
}

TEST(Importance, OriginAndBasePairAreTheExactMaximum) {
    for (std::uint64_t seed : {1u, 2u, 3u}) {
        const PointSet set = randomPointSet(seed, 400, 2, 30);
        const ImportanceResult r = run(set);
        const Quantizer q = Quantizer::forPoints(set.points);
        const auto ids = unlocked(set);
        // O: nearest to the centre of the unlocked bounding box (ties: lowest id).
        double lo[2] = {1e300, 1e300}, hi[2] = {-1e300, -1e300};
        for (PointId id : ids) {
            const GridPoint g = q(set.points[id]);
            lo[0] = std::min(lo[0], double(g.x));
            hi[0] = std::max(hi[0], double(g.x));
            lo[1] = std::min(lo[1], double(g.y));
            hi[1] = std::max(hi[1], double(g.y));
        }
        PointId o = kNoPoint;
        double bestD = 1e300;
        for (PointId id : ids) {
            const GridPoint g = q(set.points[id]);
            const double dx = 2 * double(g.x) - (lo[0] + hi[0]),
                         dy = 2 * double(g.y) - (lo[1] + hi[1]);
            if (dx * dx + dy * dy < bestD) {
                bestD = dx * dx + dy * dy;
                o = id;
            }
        }
        EXPECT_EQ(r.origin, o);
        // A, B: brute force over all pairs.
        const GridPoint go = q(set.points[o]);
        auto crossNorm = [&](PointId a, PointId b) {
            const GridPoint ga = q(set.points[a]), gb = q(set.points[b]);
            const Int128 ux = ga.x - go.x, uy = ga.y - go.y, uz = ga.z - go.z;
            const Int128 vx = gb.x - go.x, vy = gb.y - go.y, vz = gb.z - go.z;
            const double cx = double(uy * vz - uz * vy), cy = double(uz * vx - ux * vz),
                         cz = double(ux * vy - uy * vx);
            return cx * cx + cy * cy + cz * cz;
        };
        double best = -1;
        PointId ba = kNoPoint, bb = kNoPoint;
        for (std::size_t i = 0; i < ids.size(); ++i) {
            for (std::size_t j = i + 1; j < ids.size(); ++j) {
                if (ids[i] == o || ids[j] == o) continue;
                const double v = crossNorm(ids[i], ids[j]);
                if (v > best) {
                    best = v;
                    ba = ids[i];
                    bb = ids[j];
                }
            }
        }
        EXPECT_EQ(r.anchor, ba);
        EXPECT_EQ(r.floating, bb);
    }
}

TEST(Importance, ChainIsTheNearestNeighbourChainFromAToB) {
    const PointSet set = randomPointSet(7, 1500, 3, 50);
    const ImportanceResult r = run(set);
    const auto ids = unlocked(set);
    ASSERT_EQ(r.chain.size(), ids.size() - 1);  // every unlocked point but O
    EXPECT_EQ(r.chain.front(), r.anchor);
    EXPECT_EQ(r.chain.back(), r.floating);
    std::set<PointId> seen(r.chain.begin(), r.chain.end());
    EXPECT_EQ(seen.size(), r.chain.size());
    EXPECT_EQ(seen.count(r.origin), 0u);
    for (PointId id : r.chain)
        EXPECT_FALSE(set.points[id].locked);

    // Every step goes to the nearest point not yet visited (B excluded until the end).
    const Quantizer q = Quantizer::forPoints(set.points);
    std::vector<char> used(set.points.size(), 0);
    used[r.origin] = used[r.floating] = used[r.anchor] = 1;
    for (std::size_t k = 0; k + 2 < r.chain.size(); ++k) {
        const GridPoint cur = q(set.points[r.chain[k]]);
        PointId best = kNoPoint;
        double bestD = 1e300;
        for (PointId id : ids) {
            if (used[id]) continue;
            const GridPoint g = q(set.points[id]);
            const double dx = double(g.x - cur.x), dy = double(g.y - cur.y),
                         dz = double(g.z - cur.z);
            const double d = dx * dx + dy * dy + dz * dz;
            if (d < bestD) {
                bestD = d;
                best = id;
            }
        }
        ASSERT_EQ(r.chain[k + 1], best) << "step " << k;
        used[best] = 1;
    }
}

TEST(Importance, ThresholdConsistentWithPlain3dDp) {
    for (std::uint64_t seed : {11u, 12u, 13u}) {
        const PointSet terrain = randomPointSet(seed, 2000);
        expectThresholdConsistent(terrain, run(terrain));
        const PointSet withRivers = randomPointSet(seed, 2000, 4, 80);
        expectThresholdConsistent(withRivers, run(withRivers, true));
        expectThresholdConsistent(withRivers, run(withRivers, false));
    }
}

TEST(Importance, EffectiveImportanceIsMinOfOwnAndAncestors) {
    const PointSet set = randomPointSet(5, 3000, 3, 60);
    const ImportanceResult r = run(set);
    for (PointId id : r.order) {
        EXPECT_LE(r.importance[id], r.ownImportance[id]);
        EXPECT_GE(r.importance[id], 0.0);
    }
    // The order is ascending in effective importance, deeper first on ties.
    for (std::size_t i = 0; i + 1 < r.order.size(); ++i) {
        const PointId a = r.order[i], b = r.order[i + 1];
        ASSERT_LE(r.importance[a], r.importance[b]);
        if (r.importance[a] == r.importance[b]) {
            ASSERT_TRUE(r.depth[a] > r.depth[b] || (r.depth[a] == r.depth[b] && a < b));
        }
    }
    // O, A, B are always kept: last, with infinite importance.
    const std::set<PointId> base{r.origin, r.anchor, r.floating};
    const std::set<PointId> tail(r.order.end() - 3, r.order.end());
    EXPECT_EQ(base, tail);
    for (PointId id : base)
        EXPECT_TRUE(std::isinf(r.importance[id]));
}

TEST(Importance, LockedPointsAreNeverRanked) {
    PointSet set = randomPointSet(9, 1000, 2, 40);
    for (PointId i = 0; i < set.points.size(); i += 7)
        set.points[i].locked = true;
    const ImportanceResult r = run(set);
    const auto ids = unlocked(set);
    EXPECT_EQ(r.order.size(), ids.size());
    for (PointId id : r.order)
        EXPECT_FALSE(set.points[id].locked);
    for (PointId i = 0; i < set.points.size(); ++i) {
        if (set.points[i].locked) {
            EXPECT_TRUE(std::isnan(r.importance[i]));
        }
    }
    expectThresholdConsistent(set, r);
}

TEST(Importance, BaiRaisesRiverPointImportance) {
    // With BAI on, river points carry factor C * BAI + 1 >= 1 and DEM points 1.
    const PointSet set = randomPointSet(21, 1500, 4, 80);
    const ImportanceResult on = run(set, true), off = run(set, false);
    int boosted = 0;
    for (PointId i = 0; i < set.points.size(); ++i) {
        EXPECT_EQ(off.baiFactor[i], 1.0f);
        if (set.points[i].kind == PointKind::Dem) {
            EXPECT_EQ(on.baiFactor[i], 1.0f);
        }
        EXPECT_GE(on.baiFactor[i], 1.0f);
        if (on.baiFactor[i] > 1.0f) ++boosted;
    }
    EXPECT_GT(boosted, 100);
    // The chain and base plane do not depend on BAI; only the selection does.
    EXPECT_EQ(on.chain, off.chain);
    EXPECT_NE(on.order, off.order);
}

TEST(Importance, Deterministic) {
    const PointSet set = randomPointSet(31, 5000, 5, 100);
    const ImportanceResult a = run(set), b = run(set);
    EXPECT_EQ(a.order, b.order);
    EXPECT_EQ(a.chain, b.chain);
    for (std::size_t i = 0; i < a.importance.size(); ++i) {
        const double x = a.importance[i], y = b.importance[i];
        EXPECT_TRUE((std::isnan(x) && std::isnan(y)) || x == y);
    }
}

TEST(Importance, FlatTerrainSplitsInHalves) {
    // All z equal: every distance to every base plane is 0. The tie-break picks the middle of
    // each sub-chain, so the split tree is balanced and deletion goes deepest level first.
    PointSet set;
    for (int i = 0; i < 64; ++i) {
        for (int j = 0; j < 64; ++j)
            set.points.push_back({i * 30.0, j * 30.0, 250.0, PointKind::Dem, false});
    }
    const ImportanceResult r = run(set);
    ASSERT_EQ(r.order.size(), set.points.size());
    std::uint32_t maxDepth = 0;
    for (PointId id : r.order) {
        if (std::isfinite(r.importance[id])) {
            EXPECT_EQ(r.importance[id], 0.0);
        }
        maxDepth = std::max(maxDepth, r.depth[id]);
    }
    EXPECT_LE(maxDepth, 13u);  // ceil(log2(4094)) = 12 levels of halving
    for (std::size_t i = 0; i + 4 < r.order.size(); ++i) {
        EXPECT_GE(r.depth[r.order[i]], r.depth[r.order[i + 1]]);
    }
    expectThresholdConsistent(set, r);
}

TEST(Importance, DuplicatesAndCollinearSets) {
    // Many exact duplicates.
    PointSet dup = randomPointSet(41, 300);
    const std::size_t n = dup.points.size();
    for (std::size_t i = 0; i < n; ++i)
        dup.points.push_back(dup.points[i]);
    dup.points.push_back(dup.points[0]);
    ImportanceResult r = run(dup);
    EXPECT_EQ(r.order.size(), dup.points.size());
    EXPECT_EQ(r.chain.size(), dup.points.size() - 1);
    expectThresholdConsistent(dup, r);

    // A 3D line: O is collinear with every pair, all distances are 0.
    PointSet line;
    for (int i = 0; i < 500; ++i)
        line.points.push_back({i * 10.0, i * 5.0, 100 + i * 1.0, PointKind::Dem, false});
    r = run(line);
    EXPECT_EQ(r.order.size(), line.points.size());
    EXPECT_EQ(r.chain.front(), r.anchor);
    EXPECT_EQ(r.chain.back(), r.floating);
    for (PointId id : r.order) {
        if (std::isfinite(r.importance[id])) {
            EXPECT_EQ(r.importance[id], 0.0);
        }
    }
    // The anchor and floating points are the two ends of the line.
    EXPECT_EQ(std::set<PointId>({r.anchor, r.floating}), std::set<PointId>({0, 499}));

    // Every point identical.
    PointSet same;
    for (int i = 0; i < 100; ++i)
        same.points.push_back({5, 5, 5, PointKind::Dem, false});
    r = run(same);
    EXPECT_EQ(r.order.size(), 100u);
    EXPECT_EQ(r.chain.size(), 99u);
}

TEST(Importance, TinyInputs) {
    for (int n = 0; n <= 3; ++n) {
        PointSet set;
        for (int i = 0; i < n; ++i)
            set.points.push_back({i * 1.0, i * 2.0, 0.0, PointKind::Dem, false});
        const ImportanceResult r = run(set);
        EXPECT_EQ(r.order.size(), static_cast<std::size_t>(n));
    }
}

TEST(Importance, RejectsBadInput) {
    ImportanceOptions opt;
    ImportanceResult r;
    std::string err;
    PointSet set = randomPointSet(1, 10);
    set.points[3].z = std::numeric_limits<double>::quiet_NaN();
    EXPECT_FALSE(computeImportance(set, opt, r, err));
    EXPECT_NE(err.find("point 3"), std::string::npos) << err;

    set = randomPointSet(1, 10);
    set.rivers.push_back({0, 1, 99});
    EXPECT_FALSE(computeImportance(set, opt, r, err));
    EXPECT_NE(err.find("point 99"), std::string::npos) << err;

    set = randomPointSet(1, 10);
    opt.baiRow = 123;
    EXPECT_FALSE(computeImportance(set, opt, r, err));
    EXPECT_NE(err.find("123"), std::string::npos) << err;
}
