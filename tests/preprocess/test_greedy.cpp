// The greedy deletion order (deletion.h runGreedyDeletion, issue 15): every step deletes the
// candidate whose deletion causes the smallest model error; the key is that error, evaluated on a
// trial deletion that is rolled back (cdt.h beginTrial). Checked against an independent oracle
// (a copy of the mesh, the vertex removed, every original point located by brute force), plus
// the invariants, the errors and determinism.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <set>

#include "bai.h"
#include "cdt.h"
#include "cdt_fixtures.h"
#include "checker.h"
#include "deletion.h"
#include "modelerror.h"

namespace unilod {
namespace {

using testing::BlockSpec;
using testing::makeBlock;

double tolerance(double v) {
    return 1e-9 * std::max(1.0, std::fabs(v));
}

bool inClosedTriangle(const Cdt& cdt, std::uint32_t t, PointId m) {
    const PointId a = cdt.tv[3 * t], b = cdt.tv[3 * t + 1], c = cdt.tv[3 * t + 2];
    return cdt.orient(a, b, m) >= 0 && cdt.orient(b, c, m) >= 0 && cdt.orient(c, a, m) >= 0;
}

// Surface height at m's position by scanning every alive real triangle.
double surfaceAt(const PointSet& set, const Cdt& cdt, PointId m) {
    for (std::uint32_t t = 0; t < cdt.triangleSlots(); ++t) {
        if (cdt.triangleAlive(t) && !cdt.isGhost(t) && inClosedTriangle(cdt, t, m))
            return surfaceHeight(set, cdt, t, m);
    }
    return NAN;
}

// Oracle key of an interior vertex v without river edges: remove v from a copy of the mesh; the
// largest vertical distance of the original points in v's star to the new surface, over the
// points inside the star (`open`) and over the closed star (`closed`). A point on the star's
// outline keeps its surface and its error; the model's bookkeeping re-evaluates it or not,
// depending on which side's triangle holds it, so a key lies in [open, closed] (equal for points
// in general position). NaN when v is not a candidate (locked, on the hull, a river vertex).
struct OracleKey {
    double open = NAN, closed = NAN;
};
OracleKey oracleKey(const PointSet& set, const Cdt& before, PointId v) {
    if (!before.isVertex(v) || before.locked[v]) return {};
    std::vector<PointId> link;
    std::vector<std::uint32_t> tris;
    if (!before.star(v, link, tris)) return {};
    for (std::uint32_t h : tris) {
        const std::uint32_t t = h / 3;
        for (int i = 0; i < 3; ++i) {
            if (before.isConstrained(3 * t + std::uint32_t(i))) return {};
        }
    }
    Cdt after = before;
    after.removeVertex(v);
    OracleKey key{0, 0};
    for (PointId m = 0; m < set.points.size(); ++m) {
        bool inStar = false;
        for (std::uint32_t h : tris)
            inStar = inStar || inClosedTriangle(before, h / 3, m);
        if (!inStar) continue;
        bool onOutline = false;
        for (std::size_t i = 0; i < link.size(); ++i) {
            const PointId a = link[i], b = link[(i + 1) % link.size()];
            onOutline = onOutline ||
                        (before.orient(a, b, m) == 0 &&
                         betweenCollinear(before.gx[a], before.gy[a], before.gx[b], before.gy[b],
                                          before.gx[m], before.gy[m]));
        }
        const double e = std::fabs(set.points[m].z - surfaceAt(set, after, m));
        key.closed = std::max(key.closed, e);
        if (!onOutline) key.open = std::max(key.open, e);
    }
    return key;
}

// Without rivers every key is local to the star: each step's own error is the oracle key of the
// deleted vertex, and no other candidate had a smaller one.
void expectGreedyAgainstOracle(const PointSet& set, bool generalPosition) {
    Cdt cdt;
    std::string error;
    ASSERT_TRUE(buildCdt(set, {}, cdt, error)) << error;
    Cdt before = cdt;
    DeletionRecords rec;
    DeletionOptions options;
    options.paperError = false;
    std::uint32_t failures = 0, candidatesSeen = 0;
    options.afterStep = [&](std::uint32_t step) {
        const PointId x = rec.steps[step - 1].vertex;
        const OracleKey oracle = oracleKey(set, before, x);
        const double key = rec.stepErrorMax[step - 1];
        if (generalPosition) {
            EXPECT_EQ(oracle.open, oracle.closed);
        }
        if (!(key >= oracle.open - tolerance(key) && key <= oracle.closed + tolerance(key)) &&
            failures++ < 3) {
            ADD_FAILURE() << "step " << step << " vertex " << x << ": realised error " << key
                          << ", oracle key in [" << oracle.open << ", " << oracle.closed << "]";
        }
        for (PointId v = 0; v < set.points.size(); ++v) {
            if (v == x) continue;
            const double other = oracleKey(set, before, v).closed;
            if (std::isnan(other)) continue;
            ++candidatesSeen;
            // (Exact ties cannot be told apart from rounding here: the oracle sums the plane
            // equation in another vertex order.)
            if (other < key - tolerance(key) && failures++ < 3) {
                ADD_FAILURE() << "step " << step << ": deleted " << x << " with key " << key
                              << " while " << v << " had " << other;
            }
        }
        before = cdt;
    };
    ASSERT_TRUE(runGreedyDeletion(set, cdt, {}, options, rec, error)) << error;
    EXPECT_EQ(failures, 0u);
    EXPECT_GT(candidatesSeen, 1000u);
    EXPECT_GT(rec.steps.size(), 20u);
}

TEST(GreedyOrder, KeyIsTheRealisedErrorAndTheSmallestRandomPoints) {
    expectGreedyAgainstOracle(makeBlock({.seed = 7, .points = 90, .rivers = 0}), true);
}

TEST(GreedyOrder, KeyIsTheRealisedErrorAndTheSmallestGrid) {
    // An exact grid: every square is cocircular, so ties in the re-triangulation are everywhere.
    expectGreedyAgainstOracle(makeBlock({.points = 81, .rivers = 0, .grid = true}), false);
}

// After every step (DeletionOptions::afterStep): the river edges replayed from the records, the
// invariants with them, the alive triangle count, and the `max` error against the brute force
// (vertical and river deviation, running maximum). Construct after buildCdt.
class StepChecks {
public:
    StepChecks(const PointSet& set, const Cdt& cdt, const DeletionRecords& rec)
        : set_(set), cdt_(cdt), rec_(rec), ref_(captureCheckReference(cdt)),
          brute_(bruteForceMaxError(set, cdt)) {
        const std::vector<RiverEdge> initial = collectRiverEdges(cdt);
        edges_.insert(initial.begin(), initial.end());
    }
    void operator()(std::uint32_t step) {
        const std::uint32_t s = step - 1;
        for (std::uint32_t i = rec_.removedEdgeOffset[s]; i < rec_.removedEdgeOffset[s + 1]; ++i)
            edges_.erase(rec_.removedEdges[i]);
        for (std::uint32_t i = rec_.addedEdgeOffset[s]; i < rec_.addedEdgeOffset[s + 1]; ++i)
            edges_.insert(rec_.addedEdges[i]);
        const std::vector<RiverEdge> list(edges_.begin(), edges_.end());
        std::string m;
        if (!checkCdt(cdt_, ref_, &list, m) && failures++ < 3)
            ADD_FAILURE() << "after step " << step << ": " << m;
        EXPECT_EQ(rec_.steps[s].trianglesAlive, cdt_.realTriangleCount);
        brute_ = std::max(
            {brute_, bruteForceMaxError(set_, cdt_), bruteForceRiverDeviation(set_, cdt_)});
        if (!(std::fabs(rec_.errorMax[s] - brute_) <= tolerance(brute_)) && failures++ < 3)
            ADD_FAILURE() << "step " << step << ": max " << rec_.errorMax[s] << " vs " << brute_;
    }
    std::uint32_t failures = 0;

private:
    const PointSet& set_;
    const Cdt& cdt_;
    const DeletionRecords& rec_;
    const CheckReference ref_;
    std::set<RiverEdge> edges_;
    double brute_;
};

// With rivers: invariants after every step, errors equal to the brute force (vertical and river
// deviation) at every step, keys non-decreasing where the order is free, BAI weights respected.
TEST(GreedyOrder, InvariantsAndErrorsWithRivers) {
    const PointSet set = makeBlock({.seed = 23, .points = 700, .rivers = 3});
    Cdt cdt;
    std::string error;
    ASSERT_TRUE(buildCdt(set, {}, cdt, error)) << error;
    DeletionRecords rec;
    DeletionOptions options;
    StepChecks checks(set, cdt, rec);
    std::uint32_t riverSteps = 0;
    options.afterStep = [&](std::uint32_t step) {
        checks(step);
        riverSteps += rec.addedEdgeOffset[step] > rec.addedEdgeOffset[step - 1];
    };
    ASSERT_TRUE(runGreedyDeletion(set, cdt, {}, options, rec, error)) << error;
    EXPECT_EQ(checks.failures, 0u);
    EXPECT_GT(riverSteps, 20u);
    EXPECT_EQ(rec.stepErrorMax.size(), rec.steps.size());
    EXPECT_EQ(rec.errorPaper.size(), rec.steps.size());
    // The river part (format version 4): a running maximum of its own, raised only by steps that
    // replace river edges (a DEM vertex's deletion moves no river), never above errorMax.
    ASSERT_EQ(rec.errorRiver.size(), rec.steps.size());
    std::uint32_t raised = 0;
    for (std::size_t k = 0; k < rec.steps.size(); ++k) {
        const double before = k == 0 ? rec.initialErrorRiver : rec.errorRiver[k - 1];
        EXPECT_GE(rec.errorRiver[k], before);
        EXPECT_LE(rec.errorRiver[k], rec.errorMax[k]);
        if (rec.errorRiver[k] > before) {
            ++raised;
            EXPECT_GT(rec.addedEdgeOffset[k + 1], rec.addedEdgeOffset[k]) << "step " << k;
            EXPECT_LE(rec.errorRiver[k], rec.stepErrorMax[k]) << "step " << k;
        }
    }
    EXPECT_GT(raised, 5u);
    // The parts differ (the vertical one leads at many steps): the river part is a bound of
    // its own, not a copy of errorMax.
    std::size_t below = 0;
    for (std::size_t k = 0; k < rec.steps.size(); ++k)
        below += rec.errorRiver[k] < rec.errorMax[k];
    EXPECT_GT(below, rec.steps.size() / 10);
    // Everything deletable went: what is left is locked, on the hull or refused.
    std::uint32_t unlocked = 0;
    for (PointId v = 0; v < set.points.size(); ++v)
        unlocked += cdt.representative[v] == v && !set.points[v].locked;
    std::uint32_t kept = 0;
    for (const KeptVertex& k : rec.kept)
        kept += k.reason != KeptReason::Locked;
    EXPECT_EQ(rec.steps.size() + kept, unlocked);
}

// The paper metric stays exact where the greedy order empties whole regions (a flat half is
// deleted at zero error first), so the nearest-vertex search runs far from any alive vertex.
TEST(GreedyOrder, PaperMetricExactOnEmptiedFlats) {
    BlockSpec spec;
    spec.points = 576;
    spec.rivers = 0;
    spec.grid = true;
    PointSet set = makeBlock(spec);
    for (Point& p : set.points) {
        if (p.x < 700) p.z = 100.0;
    }
    Cdt cdt;
    std::string error;
    ASSERT_TRUE(buildCdt(set, {}, cdt, error)) << error;
    DeletionRecords rec;
    DeletionOptions options;
    double brute = bruteForcePaperError(set, cdt);
    std::uint32_t failures = 0, checked = 0, zeroSteps = 0;
    options.afterStep = [&](std::uint32_t step) {
        zeroSteps += rec.stepErrorMax[step - 1] == 0;
        ++checked;
        brute = std::max(brute, bruteForcePaperError(set, cdt));
        if (!(std::fabs(rec.errorPaper[step - 1] - brute) <= tolerance(brute)) && failures++ < 3)
            ADD_FAILURE() << "step " << step << ": paper " << rec.errorPaper[step - 1] << " vs "
                          << brute;
    };
    ASSERT_TRUE(runGreedyDeletion(set, cdt, {}, options, rec, error)) << error;
    EXPECT_EQ(failures, 0u);
    EXPECT_GT(checked, 400u);
    EXPECT_GT(zeroSteps, 250u);  // the flat part went first, at zero error
}

// Ties go in a scattered order (deletion.h tieRank): on a flat grid every key is 0, and ties by
// id (raster order) deleted it row by row, growing triangles across the rows already deleted
// whose original points every later step located again (quadratic: a flat 300 x 300 block took
// 120 s). Half-way through, the triangles must still be about the same size: the largest covers
// a few cells, not a band of rows.
TEST(GreedyOrder, FlatAreasShrinkEvenly) {
    BlockSpec spec;
    spec.points = 64 * 64;
    spec.rivers = 0;
    spec.grid = true;
    PointSet set = makeBlock(spec);
    for (Point& p : set.points)
        p.z = 0;
    Cdt cdt;
    std::string error;
    ASSERT_TRUE(buildCdt(set, {}, cdt, error)) << error;
    const double cell = double(cdt.gx[1] - cdt.gx[0]) * double(cdt.gy[64] - cdt.gy[0]);
    ASSERT_GT(cell, 0);
    DeletionRecords rec;
    DeletionOptions options;
    double largest = 0;  // in cells, half-way
    std::uint32_t steps = 0;
    options.afterStep = [&](std::uint32_t step) {
        steps = step;
        if (step != set.points.size() / 2) return;
        for (std::uint32_t t = 0; t < cdt.triangleSlots(); ++t) {
            if (!cdt.inDomain(t)) continue;
            const PointId a = cdt.tv[3 * t], b = cdt.tv[3 * t + 1], c = cdt.tv[3 * t + 2];
            const double area = 0.5 * std::fabs(double(cdt.orient(a, b, c)));
            largest = std::max(largest, area / cell);
        }
    };
    ASSERT_TRUE(runGreedyDeletion(set, cdt, {}, options, rec, error)) << error;
    EXPECT_GT(steps, set.points.size() / 2);
    EXPECT_GT(largest, 0);
    EXPECT_LT(largest, 12.0);
}

// A straight raster edge simplifies: hull vertices between two collinear hull neighbours are
// deleted (the domain stays: the checker compares its area), corners stay, and after every step
// the triangulation is valid and the max error equals the brute force.
TEST(GreedyOrder, StraightHullVerticesAreDeleted) {
    BlockSpec spec;
    spec.points = 400;
    spec.rivers = 2;
    spec.grid = true;
    spec.lockBorder = false;
    const PointSet set = makeBlock(spec);
    Cdt cdt;
    std::string error;
    ASSERT_TRUE(buildCdt(set, {}, cdt, error)) << error;
    double lo = INFINITY, hi = -INFINITY;
    for (const Point& p : set.points) {
        if (p.kind == PointKind::Dem) lo = std::min({lo, p.x, p.y}), hi = std::max({hi, p.x, p.y});
    }
    auto onBorder = [&](PointId v) {
        const Point& p = set.points[v];
        return p.x == lo || p.y == lo || p.x == hi || p.y == hi;
    };
    DeletionRecords rec;
    DeletionOptions options;
    StepChecks checks(set, cdt, rec);
    std::uint32_t hullSteps = 0;
    options.afterStep = [&](std::uint32_t step) {
        checks(step);
        hullSteps += onBorder(rec.steps[step - 1].vertex);
    };
    ASSERT_TRUE(runGreedyDeletion(set, cdt, {}, options, rec, error)) << error;
    EXPECT_EQ(checks.failures, 0u);
    EXPECT_GT(hullSteps, 20u);
    std::uint32_t corners = 0;
    for (PointId v = 0; v < set.points.size(); ++v) {
        const Point& p = set.points[v];
        if ((p.x == lo || p.x == hi) && (p.y == lo || p.y == hi)) {
            ++corners;
            EXPECT_TRUE(cdt.isVertex(v)) << p.x << ", " << p.y;
        }
    }
    EXPECT_EQ(corners, 4u);
}

// The BAI factor delays river vertices: with a huge weight on every river vertex, all DEM
// deletions whose key is below the smallest weighted river key come first.
TEST(GreedyOrder, RiverWeightsDelayRiverVertices) {
    const PointSet set = makeBlock({.seed = 5, .points = 400, .rivers = 2});
    auto firstRiverStep = [&](const std::vector<float>& weight) {
        Cdt cdt;
        std::string error;
        EXPECT_TRUE(buildCdt(set, {}, cdt, error)) << error;
        DeletionRecords rec;
        DeletionOptions options;
        options.paperError = false;
        EXPECT_TRUE(runGreedyDeletion(set, cdt, BaiKeys(weight), options, rec, error)) << error;
        for (std::size_t s = 0; s < rec.steps.size(); ++s) {
            if (set.points[rec.steps[s].vertex].kind == PointKind::River) return s;
        }
        return rec.steps.size();
    };
    std::vector<float> heavy(set.points.size(), 1.0f);
    for (PointId v = 0; v < set.points.size(); ++v) {
        if (set.points[v].kind == PointKind::River) heavy[v] = 1e6f;
    }
    const std::size_t plain = firstRiverStep({}), weighted = firstRiverStep(heavy);
    EXPECT_LT(plain, weighted);
    EXPECT_EQ(firstRiverStep(std::vector<float>(set.points.size(), 1.0f)), plain);
}

TEST(GreedyOrder, IdenticalRecordsForIdenticalInput) {
    const PointSet set = makeBlock({.seed = 3, .points = 1500, .rivers = 2});
    DeletionRecords first, second;
    for (DeletionRecords* rec : {&first, &second}) {
        Cdt cdt;
        std::string error;
        ASSERT_TRUE(buildCdt(set, {}, cdt, error)) << error;
        ASSERT_TRUE(runGreedyDeletion(set, cdt, {}, {}, *rec, error)) << error;
    }
    ASSERT_EQ(first.steps.size(), second.steps.size());
    for (std::size_t s = 0; s < first.steps.size(); ++s)
        ASSERT_EQ(first.steps[s].vertex, second.steps[s].vertex) << "step " << s;
    EXPECT_EQ(first.removedTriangles, second.removedTriangles);
    EXPECT_EQ(first.addedTriangles, second.addedTriangles);
    EXPECT_EQ(first.errorMax, second.errorMax);
}

// The hand-over (DeletionOptions::handoverKey / handoverTriangles, issue 18's tree): called
// once, with exactly the state a run stopped there ends in (mesh, records, river cover), and the
// deletion goes on past it with the same order as a run without a hand-over.
TEST(GreedyOrder, HandoverIsTheStoppedStateAndTheOrderGoesOn) {
    const PointSet set = makeBlock({.seed = 29, .points = 900, .rivers = 3});
    std::string error;
    DeletionRecords all;
    {
        Cdt cdt;
        ASSERT_TRUE(buildCdt(set, {}, cdt, error)) << error;
        ASSERT_TRUE(runGreedyDeletion(set, cdt, {}, {}, all, error)) << error;
    }
    ASSERT_GT(all.steps.size(), 300u);
    const double key = all.stepErrorMax[all.steps.size() / 2];
    for (int byCount = 0; byCount < 2; ++byCount) {
        DeletionOptions stop, hand;
        if (byCount) {
            stop.stopTriangles = hand.handoverTriangles = 400;
        } else {
            stop.stopKey = hand.handoverKey = key;
        }
        DeletionRecords stopped, handed;
        Cdt a, b;
        ASSERT_TRUE(buildCdt(set, {}, a, error)) << error;
        ASSERT_TRUE(runGreedyDeletion(set, a, {}, stop, stopped, error)) << error;
        ASSERT_TRUE(buildCdt(set, {}, b, error)) << error;
        int calls = 0;
        std::size_t atStep = 0;
        std::vector<TriangleTriple> triangles;
        std::vector<RiverEdge> rivers;
        std::vector<std::pair<RiverEdge, RiverCover>> cover;
        hand.onHandover = [&] {
            ++calls;
            atStep = handed.steps.size();
            triangles = collectTriangles(b);
            rivers = collectRiverEdges(b);
            cover = handed.riverCover;
        };
        ASSERT_TRUE(runGreedyDeletion(set, b, {}, hand, handed, error)) << error;
        EXPECT_EQ(calls, 1);
        ASSERT_GT(stopped.steps.size(), 10u);
        EXPECT_EQ(atStep, stopped.steps.size()) << "by count " << byCount;
        EXPECT_LT(atStep, handed.steps.size());  // and on past it
        EXPECT_EQ(triangles, collectTriangles(a));
        EXPECT_EQ(rivers, collectRiverEdges(a));
        ASSERT_EQ(cover.size(), stopped.riverCover.size());
        for (std::size_t e = 0; e < cover.size(); ++e) {
            EXPECT_EQ(cover[e].first, stopped.riverCover[e].first);
            EXPECT_EQ(cover[e].second.points, stopped.riverCover[e].second.points);
            EXPECT_EQ(cover[e].second.slack, stopped.riverCover[e].second.slack);
        }
        // The whole sequence is the one without a hand-over.
        ASSERT_EQ(handed.steps.size(), all.steps.size());
        for (std::size_t k = 0; k < all.steps.size(); ++k)
            ASSERT_EQ(handed.steps[k].vertex, all.steps[k].vertex) << "step " << k;
        EXPECT_EQ(handed.errorMax, all.errorMax);
    }
}

// A trial deletion rolled back leaves the mesh exactly as it was, slots and free list included.
TEST(GreedyOrder, TrialRollbackRestoresTheMeshExactly) {
    const PointSet set = makeBlock({.seed = 9, .points = 600, .rivers = 2});
    Cdt cdt;
    std::string error;
    ASSERT_TRUE(buildCdt(set, {}, cdt, error)) << error;
    // Some real deletions first, so that the free list is in use.
    DeletionOptions options;
    options.maxSteps = 100;
    DeletionRecords rec;
    ASSERT_TRUE(runGreedyDeletion(set, cdt, {}, options, rec, error)) << error;
    ASSERT_EQ(rec.steps.size(), 100u);
    std::uint32_t tried = 0;
    std::vector<PointId> link;
    std::vector<std::uint32_t> tris;
    for (PointId v = 0; v < set.points.size(); ++v) {
        if (!cdt.isVertex(v) || cdt.locked[v] || !cdt.star(v, link, tris)) continue;
        bool river = false;
        for (std::uint32_t h : tris)
            river = river || cdt.isConstrained(h - h % 3 + (h % 3 + 2) % 3);
        if (river) continue;
        const Cdt saved = cdt;
        cdt.beginTrial();
        cdt.removeVertex(v);
        EXPECT_NE(cdt.tv, saved.tv);
        cdt.rollbackTrial();
        ASSERT_EQ(cdt.tv, saved.tv) << "vertex " << v;
        ASSERT_EQ(cdt.tn, saved.tn);
        ASSERT_EQ(cdt.tc, saved.tc);
        ASSERT_EQ(cdt.stamp, saved.stamp);
        ASSERT_EQ(cdt.freeSlots, saved.freeSlots);
        ASSERT_EQ(cdt.vertexTriangle, saved.vertexTriangle);
        ASSERT_EQ(cdt.vertexCount, saved.vertexCount);
        ASSERT_EQ(cdt.realTriangleCount, saved.realTriangleCount);
        ++tried;
    }
    EXPECT_GT(tried, 100u);
}

}  // namespace
}  // namespace unilod
