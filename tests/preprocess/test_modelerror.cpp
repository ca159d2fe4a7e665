// Model error per deletion step (paper §3.2, Eq. 3-6): the incremental values equal a
// from-scratch recomputation, and both sequences are non-decreasing.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iterator>
#include <random>

#include "build.h"
#include "cdt.h"
#include "cdt_fixtures.h"
#include "deletion.h"
#include "modelerror.h"
#include "synthbuild.h"
#include "testutil.h"

namespace unilod {
namespace {

using testing::BlockSpec;
using testing::makeBlock;
using testing::shuffledOrder;

double tolerance(double v) {
    return 1e-9 * std::max(1.0, std::fabs(v));
}

TEST(ModelError, EveryStepEqualsBruteForce) {
    BlockSpec spec;
    spec.seed = 31;
    spec.points = 300;
    spec.rivers = 2;
    PointSet set = makeBlock(spec);
    // A few duplicates on the grid (merged) with their own heights: they count in M.
    for (PointId i = 40; i < 46; ++i) {
        Point p = set.points[i];
        p.z += 5.0 + i;
        p.locked = false;
        set.points.push_back(p);
    }
    Cdt cdt;
    std::string error;
    ASSERT_TRUE(buildCdt(set, {}, cdt, error)) << error;
    EXPECT_EQ(cdt.mergedPoints, 6u);
    DeletionRecords rec;
    double bruteMax = bruteForceMaxError(set, cdt), brutePaper = bruteForcePaperError(set, cdt);
    EXPECT_GT(bruteMax, 5.0);
    const double initialMax = bruteMax, initialPaper = brutePaper;
    std::uint32_t mismatches = 0;
    DeletionOptions options;
    options.afterStep = [&](std::uint32_t step) {
        bruteMax = std::max(
            {bruteMax, bruteForceMaxError(set, cdt), bruteForceRiverDeviation(set, cdt)});
        brutePaper = std::max(brutePaper, bruteForcePaperError(set, cdt));
        const double m = rec.errorMax[step - 1], p = rec.errorPaper[step - 1];
        if (std::fabs(m - bruteMax) > tolerance(bruteMax) ||
            std::fabs(p - brutePaper) > tolerance(brutePaper)) {
            if (mismatches++ == 0) {
                ADD_FAILURE() << "step " << step << ": max " << m << " vs " << bruteMax
                              << ", paper " << p << " vs " << brutePaper;
            }
        }
    };
    ASSERT_TRUE(runDeletion(set, cdt, shuffledOrder(set, 5), options, rec, error)) << error;
    EXPECT_EQ(mismatches, 0u);
    EXPECT_GT(rec.steps.size(), 200u);
    EXPECT_NEAR(rec.initialErrorMax, initialMax, tolerance(initialMax));
    EXPECT_NEAR(rec.initialErrorPaper, initialPaper, tolerance(initialPaper));
    EXPECT_GT(rec.errorMax.back(), 1.0);
    EXPECT_GT(rec.errorPaper.back(), 0.5);
}

TEST(ModelError, SampledStepsOfALargerBlockEqualBruteForce) {
    BlockSpec spec;
    spec.seed = 32;
    spec.points = 3000;
    const PointSet set = makeBlock(spec);
    Cdt cdt;
    std::string error;
    ASSERT_TRUE(buildCdt(set, {}, cdt, error)) << error;
    // The per-step values (not yet maximised) are checked through a second, instrumented run:
    // the running maximum of the brute-force values over all steps must equal the records.
    DeletionRecords rec;
    double bruteMax = 0, brutePaper = bruteForcePaperError(set, cdt);
    std::uint32_t checked = 0;
    DeletionOptions options;
    options.afterStep = [&](std::uint32_t step) {
        // The max metric is cheap enough to recompute at every step only through the buckets:
        // sample every 97th step for the full brute force, and check monotonicity everywhere.
        if (step > 1) {
            ASSERT_GE(rec.errorMax[step - 1], rec.errorMax[step - 2]);
            ASSERT_GE(rec.errorPaper[step - 1], rec.errorPaper[step - 2]);
        }
        if (step % 97 != 0) return;
        ++checked;
        const double m = bruteForceMaxError(set, cdt), p = bruteForcePaperError(set, cdt);
        bruteMax = std::max(bruteMax, m);
        brutePaper = std::max(brutePaper, p);
        // The running maximum bounds every sampled value, and is reached by a sampled value or
        // lies between consecutive samples' maxima.
        EXPECT_GE(rec.errorMax[step - 1] + tolerance(m), m) << "step " << step;
        EXPECT_GE(rec.errorPaper[step - 1] + tolerance(p), p) << "step " << step;
        EXPECT_GE(rec.errorMax[step - 1] + tolerance(bruteMax), bruteMax);
    };
    ASSERT_TRUE(runDeletion(set, cdt, shuffledOrder(set, 6), options, rec, error)) << error;
    EXPECT_GT(checked, 20u);
    // At the very end the current values are recomputed exactly: the last running maxima
    // are at least them.
    EXPECT_GE(rec.errorMax.back() + 1e-9, bruteForceMaxError(set, cdt));
}

// A tree node's situation (issue 18): the triangulation holds a subset of a block's points (every
// DEM point but those with i % modulo == 1, plus every locked and river point); the others are
// extra original points, on the grid of the subset's triangulation.
struct NodeCase {
    PointSet set;
    std::vector<ExtraSample> extra;
};
NodeCase splitBlock(std::uint64_t seed, int points, PointId modulo) {
    BlockSpec spec;
    spec.seed = seed;
    spec.points = points;
    spec.rivers = 2;
    const PointSet all = makeBlock(spec);
    NodeCase c;
    std::vector<PointId> newId(all.points.size(), kNoPoint);
    std::vector<PointId> extraIds;
    for (PointId i = 0; i < all.points.size(); ++i) {
        const Point& p = all.points[i];
        if (p.kind == PointKind::Dem && !p.locked && i % modulo == 1) {
            extraIds.push_back(i);
            continue;
        }
        newId[i] = PointId(c.set.points.size());
        c.set.points.push_back(p);
    }
    for (const Polyline& line : all.rivers) {
        Polyline mapped;
        for (PointId v : line) mapped.push_back(newId[v]);
        c.set.rivers.push_back(mapped);
    }
    Cdt cdt;
    std::string error;
    EXPECT_TRUE(buildCdt(c.set, {}, cdt, error)) << error;
    for (PointId i : extraIds) {
        const Point& p = all.points[i];
        c.extra.push_back({std::int32_t(std::llround((p.x - cdt.originX) / cdt.gridUnit)),
                           std::int32_t(std::llround((p.y - cdt.originY) / cdt.gridUnit)), p.z});
    }
    return c;
}

TEST(ModelError, ExtraOriginalPointsCountInTheMaxMetric) {
    // splitBlock: every DEM point but one in three in the triangulation, the others extra
    // original points. The recorded `max` error after every step equals the brute-force maximum
    // over both.
    NodeCase c = splitBlock(47, 400, 3);
    const PointSet& set = c.set;
    const std::vector<ExtraSample>& extra = c.extra;
    ExtraSamples samples;
    samples.points = extra;
    Cdt cdt;
    std::string error;
    ASSERT_TRUE(buildCdt(set, {}, cdt, error)) << error;
    ASSERT_GT(extra.size(), 80u);
    DeletionRecords rec;
    DeletionOptions options;
    options.paperError = false;
    options.extraSamples = &samples;
    double brute = std::max(bruteForceMaxError(set, cdt), bruteForceExtraError(set, cdt, extra));
    EXPECT_GT(bruteForceExtraError(set, cdt, extra), 0.0);  // the extra points are off the mesh
    std::uint32_t mismatches = 0;
    options.afterStep = [&](std::uint32_t step) {
        brute = std::max({brute, bruteForceMaxError(set, cdt), bruteForceExtraError(set, cdt, extra),
                          bruteForceRiverDeviation(set, cdt)});
        if (std::fabs(rec.errorMax[step - 1] - brute) > tolerance(brute) && mismatches++ == 0)
            ADD_FAILURE() << "step " << step << ": " << rec.errorMax[step - 1] << " vs " << brute;
    };
    ASSERT_TRUE(runGreedyDeletion(set, cdt, {}, options, rec, error)) << error;
    EXPECT_EQ(mismatches, 0u);
    EXPECT_GT(rec.steps.size(), 150u);
    // Without them the same deletion reports less at the start: they were counted.
    Cdt plain;
    ASSERT_TRUE(buildCdt(set, {}, plain, error)) << error;
    DeletionRecords recPlain;
    DeletionOptions plainOptions;
    plainOptions.paperError = false;
    ASSERT_TRUE(runGreedyDeletion(set, plain, {}, plainOptions, recPlain, error)) << error;
    EXPECT_LT(recPlain.initialErrorMax, rec.initialErrorMax);
    // With the paper metric recorded too (the same order), the extra points count in `max`
    // alone: the paper metric (Eq. 3-6) is over the set's points, as without them.
    std::vector<PointId> order;
    for (const DeletionStep& st : rec.steps)
        order.push_back(st.vertex);
    auto replay = [&](bool withExtra, DeletionRecords& out) {
        Cdt again;
        ASSERT_TRUE(buildCdt(set, {}, again, error)) << error;
        DeletionOptions both;
        both.paperError = true;
        both.extraSamples = withExtra ? &samples : nullptr;
        ASSERT_TRUE(runDeletion(set, again, order, both, out, error)) << error;
    };
    DeletionRecords withExtra, withoutExtra;
    replay(true, withExtra);
    replay(false, withoutExtra);
    ASSERT_EQ(withExtra.steps.size(), rec.steps.size());
    EXPECT_EQ(withExtra.initialErrorMax, rec.initialErrorMax);
    EXPECT_EQ(withExtra.errorMax, rec.errorMax);
    EXPECT_EQ(withExtra.initialErrorPaper, withoutExtra.initialErrorPaper);
    EXPECT_EQ(withExtra.errorPaper, withoutExtra.errorPaper);
    EXPECT_NE(withExtra.errorMax, withoutExtra.errorMax);
}

// The greedy deletion of `set` (max metric only) with extra original points.
void greedyWithExtra(const PointSet& set, ExtraSamples& samples, bool release,
                     DeletionRecords& rec) {
    Cdt cdt;
    std::string error;
    ASSERT_TRUE(buildCdt(set, {}, cdt, error)) << error;
    DeletionOptions options;
    options.paperError = false;
    options.extraSamples = &samples;
    options.releaseExtraSamples = release;
    ASSERT_TRUE(runGreedyDeletion(set, cdt, {}, options, rec, error)) << error;
}

// Released samples (DeletionOptions::releaseExtraSamples, a tree root's every original point):
// their references become the pool, permuted in place (modelerror.h ModelError::init): the
// records equal those of the copying path exactly, also with the samples in shuffled order (long
// cycles) and with samples outside the hull (left out), and the buffers are taken over.
TEST(ModelError, ReleasedExtraSamplesGiveTheSameRecordsAsCopiedOnes) {
    const NodeCase node = splitBlock(48, 600, 2);
    const PointSet& set = node.set;
    std::vector<ExtraSample> extra = node.extra;
    std::string error;
    // Outside the hull: left out by both paths.
    for (int k = 1; k <= 5; ++k)
        extra.push_back({-1000000 * k, 1000000 * k, 7.0 * k});
    std::mt19937 rng(3);
    std::shuffle(extra.begin(), extra.end(), rng);
    ASSERT_GT(extra.size(), 150u);
    auto run = [&](bool release, ExtraSamples& samples, DeletionRecords& rec) {
        greedyWithExtra(set, samples, release, rec);
    };
    // Copied: the points alone. Released: the same points through references in reverse order
    // (the pool is filled by references, in the samples' order).
    ExtraSamples copied, released;
    copied.points = extra;
    released.points.assign(extra.rbegin(), extra.rend());
    for (std::size_t i = 0; i < extra.size(); ++i)
        released.refs.push_back({std::uint32_t(extra.size() - 1 - i), 0.0f});
    released.refs.reserve(released.refs.size() * 2);  // the pool's room (no reallocation)
    DeletionRecords a, b;
    run(false, copied, a);
    run(true, released, b);
    EXPECT_EQ(copied.points.size(), extra.size());  // the copying path leaves them
    EXPECT_EQ(released.refs.capacity(), 0u);        // the released buffer became the pool
    EXPECT_EQ(released.points.capacity(), 0u);      // the points were taken over
    ASSERT_GT(a.steps.size(), 200u);
    ASSERT_EQ(a.steps.size(), b.steps.size());
    EXPECT_EQ(a.initialErrorMax, b.initialErrorMax);
    EXPECT_EQ(a.errorMax, b.errorMax);
    EXPECT_EQ(a.errorRiver, b.errorRiver);
    for (std::size_t k = 0; k < a.steps.size(); ++k)
        ASSERT_EQ(a.steps[k].vertex, b.steps[k].vertex) << "step " << k;
    // Released without room: the pool reserves it (a reallocation), the same records.
    ExtraSamples tight;
    tight.points.assign(extra.rbegin(), extra.rend());
    for (std::size_t i = 0; i < extra.size(); ++i)
        tight.refs.push_back({std::uint32_t(extra.size() - 1 - i), 0.0f});
    tight.refs.shrink_to_fit();
    DeletionRecords c;
    run(true, tight, c);
    EXPECT_EQ(a.errorMax, c.errorMax);
}

// Original points known by their DEM cell (modelerror.h SampleRef, SampleGrid: 8 bytes each in the
// pool, as a tree node's are): the same records as the same points given explicitly, with cells
// and explicit points mixed in one order, released or copied.
TEST(ModelError, GridCellSamplesGiveTheSameRecordsAsExplicitOnes) {
    BlockSpec spec;
    spec.seed = 49;
    spec.points = 900;
    spec.rivers = 2;
    spec.grid = true;
    PointSet all = makeBlock(spec);
    const std::uint32_t side = 30;  // makeBlock's grid of 900 points: row-major, then the rivers
    ASSERT_EQ(std::size_t(std::count_if(all.points.begin(), all.points.end(),
                                        [](const Point& p) { return p.kind == PointKind::Dem; })),
              std::size_t(side) * side);
    // Heights of a float's precision (a cell's height is held as a float).
    for (std::uint32_t i = 0; i < side * side; ++i)
        all.points[i].z = double(float(all.points[i].z));  // DEM points first, row-major
    // The triangulation holds the DEM points with (i + j) % 3 != 1 and every river point.
    PointSet set;
    std::vector<PointId> newId(all.points.size(), kNoPoint);
    std::vector<std::uint32_t> extraCells;
    for (PointId m = 0; m < all.points.size(); ++m) {
        const Point& p = all.points[m];
        if (m < side * side && !p.locked && (m % side + m / side) % 3 == 1) {
            extraCells.push_back(m);
            continue;
        }
        newId[m] = PointId(set.points.size());
        set.points.push_back(p);
    }
    for (const Polyline& line : all.rivers) {
        Polyline mapped;
        for (PointId v : line)
            mapped.push_back(newId[v]);
        set.rivers.push_back(mapped);
    }
    std::string error;
    Cdt probe;
    ASSERT_TRUE(buildCdt(set, {}, probe, error)) << error;
    auto gridOf = [&](double v, double origin) {
        return std::int32_t(std::llround((v - origin) / probe.gridUnit));
    };
    // The grid's columns and rows; explicit points after every fifth cell, some outside the hull.
    ExtraSamples cells, plain;
    for (std::uint32_t i = 0; i < side; ++i) {
        cells.grid.gx.push_back(gridOf(all.points[i].x, probe.originX));
        cells.grid.gy.push_back(gridOf(all.points[std::size_t(i) * side].y, probe.originY));
    }
    const auto gridCells = std::uint32_t(cells.grid.cells());
    ASSERT_EQ(gridCells, 30u * 32u);  // rows of a power-of-two pitch
    for (std::size_t k = 0; k < extraCells.size(); ++k) {
        const Point& p = all.points[extraCells[k]];
        const ExtraSample e{gridOf(p.x, probe.originX), gridOf(p.y, probe.originY), p.z};
        cells.refs.push_back({extraCells[k] / side * 32 + extraCells[k] % side, float(p.z)});
        plain.points.push_back(e);
        EXPECT_EQ(cells.at(cells.refs.size() - 1).gx, e.gx);
        EXPECT_EQ(cells.at(cells.refs.size() - 1).z, e.z);
        if (k % 5 == 4) {
            const ExtraSample x{e.gx + 3, e.gy - 2, e.z + double(k % 7) - 3.0};
            const ExtraSample far{-1000000, std::int32_t(1000000 + k), 5.0};
            for (const ExtraSample& q : {x, far}) {
                cells.refs.push_back({gridCells + std::uint32_t(cells.points.size()), 0.0f});
                cells.points.push_back(q);
                plain.points.push_back(q);
            }
        }
    }
    ASSERT_GT(extraCells.size(), 200u);
    auto run = [&](ExtraSamples samples, bool release, DeletionRecords& rec) {
        greedyWithExtra(set, samples, release, rec);
    };
    DeletionRecords a, b, c;
    run(plain, false, a);
    run(cells, false, b);
    run(cells, true, c);
    ASSERT_GT(a.steps.size(), 200u);
    for (const DeletionRecords* r : {&b, &c}) {
        ASSERT_EQ(a.steps.size(), r->steps.size());
        EXPECT_EQ(a.initialErrorMax, r->initialErrorMax);
        EXPECT_EQ(a.errorMax, r->errorMax);
        for (std::size_t k = 0; k < a.steps.size(); ++k)
            ASSERT_EQ(a.steps[k].vertex, r->steps[k].vertex) << "step " << k;
    }
    // The cells are counted: without them the start error is lower.
    DeletionRecords none;
    ExtraSamples empty;
    run(empty, false, none);
    EXPECT_LT(none.initialErrorMax, a.initialErrorMax);
}

TEST(ModelError, MetricsCanBeSwitchedOff) {
    BlockSpec spec;
    spec.points = 200;
    const PointSet set = makeBlock(spec);
    Cdt cdt;
    std::string error;
    ASSERT_TRUE(buildCdt(set, {}, cdt, error)) << error;
    DeletionOptions options;
    options.maxError = false;
    options.paperError = false;
    DeletionRecords rec;
    ASSERT_TRUE(runDeletion(set, cdt, shuffledOrder(set, 1), options, rec, error)) << error;
    EXPECT_TRUE(rec.errorMax.empty());
    EXPECT_TRUE(rec.errorPaper.empty());
    EXPECT_FALSE(rec.steps.empty());
}

// A file's bytes ("" when it cannot be read).
std::string fileBytes(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// Points of a large star are located by walking across the created triangles
// (ModelError::walkFrom) instead of scanning them all: the scan made a 2-row DEM with rough heights
// build in about cubic time. The walk gives the scan's answers, ties at shared edges and corners
// included (they decide which triangle keeps a point), so a model built either way is the same
// file, byte for byte: a 2-row strip of rough heights (stars of hundreds of triangles: the case
// the walk is for) and a synthetic DEM with rivers in 2 x 2 blocks (tree nodes, whose extra samples
// lie on their vertices: the corner ties).
TEST(ModelError, WalkingToAPointGivesTheScansAnswer) {
    const test::TempDir dir("walk");
    std::string strip = "ncols 400\nnrows 2\nxllcorner 0\nyllcorner 0\ncellsize 30\n";
    test::Rng rng{5};
    for (int r = 0; r < 2; ++r) {
        for (int c = 0; c < 400; ++c)
            strip += std::to_string(double(rng.next() % 10000) / 100.0) + " ";
        strip += "\n";
    }
    BuildOptions stripOptions;
    stripOptions.demPath = dir.write("strip.asc", strip);
    BuildOptions worldOptions;
    std::string error;
    ASSERT_TRUE(test::writeTwoByTwoWorld(dir, 6000, 3, worldOptions, error)) << error;
    const std::size_t walkFrom = ModelError::walkFrom;
    for (BuildOptions o : {stripOptions, worldOptions}) {
        SCOPED_TRACE(o.demPath);
        std::string bytes[2];
        for (int walk = 0; walk < 2; ++walk) {
            ModelError::walkFrom = walk ? 0 : SIZE_MAX;
            o.outPath = dir.file("model" + std::to_string(walk) + ".ulod");
            o.force = true;
            BuildSummary summary;
            ASSERT_TRUE(runBuild(o, summary, error)) << error;
            bytes[walk] = fileBytes(o.outPath);
        }
        ModelError::walkFrom = walkFrom;
        EXPECT_GT(bytes[0].size(), 1000u);
        EXPECT_TRUE(bytes[0] == bytes[1]) << "walking and scanning built different models";
    }
    ModelError::walkFrom = walkFrom;
}

}  // namespace
}  // namespace unilod
