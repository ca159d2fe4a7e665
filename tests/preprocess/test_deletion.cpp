// River-constrained deletion sequence (paper §3.3): invariants after every step, deferral,
// replay of the topology-change records, determinism.
#include <gtest/gtest.h>

#include <gdal_priv.h>
#include <ogrsf_frmts.h>

#include <cmath>
#include <cstdio>
#include <set>

#include "cdt.h"
#include "cdt_fixtures.h"
#include "checker.h"
#include "deletion.h"
#include "importance.h"

namespace unilod {
namespace {

using testing::BlockSpec;
using testing::makeBlock;
using testing::shuffledOrder;

// Runs the whole sequence and checks every invariant after every step, with the river edges
// rebuilt from the records (so the records are checked too).
// Checks every `every`-th step and each of the last 1000 steps of `total` (0: of the order).
// Returns the number of steps checked.
std::uint32_t runChecked(const PointSet& set, const std::vector<PointId>& order,
                         DeletionRecords& rec, std::uint32_t every = 1, std::uint32_t total = 0) {
    std::uint32_t checkedSteps = 0;
    if (total == 0) total = std::uint32_t(order.size());
    Cdt cdt;
    std::string error;
    if (!buildCdt(set, {}, cdt, error)) {
        ADD_FAILURE() << error;
        return 0;
    }
    const CheckReference ref = captureCheckReference(cdt);
    const std::vector<RiverEdge> initialEdges = collectRiverEdges(cdt);
    std::set<RiverEdge> edges(initialEdges.begin(), initialEdges.end());
    std::string message;
    EXPECT_TRUE(checkCdt(cdt, ref, nullptr, message)) << message;
    std::uint32_t failures = 0;
    DeletionOptions options;
    options.afterStep = [&](std::uint32_t step) {
        const std::uint32_t s = step - 1;
        for (std::uint32_t i = rec.removedEdgeOffset[s]; i < rec.removedEdgeOffset[s + 1]; ++i)
            edges.erase(rec.removedEdges[i]);
        for (std::uint32_t i = rec.addedEdgeOffset[s]; i < rec.addedEdgeOffset[s + 1]; ++i)
            edges.insert(rec.addedEdges[i]);
        if (failures > 0 || (step % every != 0 && step + 1000 <= total)) return;
        ++checkedSteps;
        const std::vector<RiverEdge> list(edges.begin(), edges.end());
        std::string m;
        if (!checkCdt(cdt, ref, &list, m)) {
            ++failures;
            ADD_FAILURE() << "after step " << step << " (vertex " << rec.steps[s].vertex
                          << "): " << m;
        }
        EXPECT_EQ(rec.steps[s].trianglesAlive, cdt.realTriangleCount);
        EXPECT_EQ(rec.steps[s].riverEdgesAlive, list.size());
    };
    EXPECT_TRUE(runDeletion(set, cdt, order, options, rec, error)) << error;
    EXPECT_EQ(failures, 0u);
    // Everything deletable was deleted: every vertex left is locked, on the hull or kept.
    std::uint32_t kept = 0;
    for (const KeptVertex& k : rec.kept)
        kept += k.reason != KeptReason::Locked;
    EXPECT_EQ(rec.steps.size() + kept, order.size() - rec.mergedSkipped);
    EXPECT_TRUE(checkCdt(cdt, ref, nullptr, message)) << message;
    return checkedSteps;
}

TEST(Deletion, InvariantsAfterEveryStepRandomBlocks) {
    for (std::uint64_t seed : {11u, 12u}) {
        BlockSpec spec;
        spec.seed = seed;
        spec.points = 2500;
        spec.rivers = 3;
        const PointSet set = makeBlock(spec);
        DeletionRecords rec;
        runChecked(set, shuffledOrder(set, seed * 7), rec);
        EXPECT_GT(rec.steps.size(), 2000u);
        EXPECT_GT(rec.removedEdges.size(), 100u);  // river vertices were deleted
    }
}

TEST(Deletion, InvariantsAfterEveryStepGridBlock) {
    BlockSpec spec;
    spec.seed = 5;
    spec.points = 2500;
    spec.grid = true;
    spec.rivers = 4;
    const PointSet set = makeBlock(spec);
    DeletionRecords rec;
    runChecked(set, shuffledOrder(set, 99), rec);
    EXPECT_GT(rec.steps.size(), 2000u);
}

TEST(Deletion, HullVerticesAreRefusedWhenNotLocked) {
    BlockSpec spec;
    spec.seed = 3;
    spec.points = 600;
    spec.lockBorder = false;
    const PointSet set = makeBlock(spec);
    DeletionRecords rec;
    runChecked(set, shuffledOrder(set, 3), rec);
    std::uint32_t hull = 0;
    for (const KeptVertex& k : rec.kept)
        hull += k.reason == KeptReason::Hull;
    EXPECT_GE(hull, 4u);
}

// Four locked corners around a small river scene.
PointSet frame() {
    PointSet set;
    for (auto [x, y] : {std::pair{-20.0, -20.0}, {30.0, -20.0}, {30.0, 20.0}, {-20.0, 20.0}}) {
        set.points.push_back({x, y, 0.0, PointKind::Dem, true});
    }
    for (auto [x, y] :
         {std::pair{-10.0, 12.0}, {20.0, 13.0}, {-12.0, -11.0}, {21.0, -13.0}, {3.0, 15.0}}) {
        set.points.push_back({x, y, 1.0, PointKind::Dem, false});
    }
    return set;
}
PointId add(PointSet& set, double x, double y, bool locked) {
    set.points.push_back({x, y, 2.0, PointKind::River, locked});
    return PointId(set.points.size() - 1);
}

TEST(Deletion, CrossingDeletionIsDeferredUntilTheBlockerGoes) {
    // River 1: A - X - C. River 2: B1 - B2 - B3 with B2 inside triangle A X C, so A-C would
    // cross both edges at B2. Deleting B2 first is not in the order: X comes first.
    PointSet set = frame();
    const PointId a = add(set, 0, 0, true), x = add(set, 5, 5, false), c = add(set, 10, 0, true);
    const PointId b1 = add(set, 5, -4, true), b2 = add(set, 5, 1, false),
                  b3 = add(set, 12, -2, true);
    set.rivers = {{a, x, c}, {b1, b2, b3}};
    DeletionRecords rec;
    runChecked(set, {x, b2}, rec);
    ASSERT_EQ(rec.steps.size(), 2u);
    EXPECT_EQ(rec.steps[0].vertex, b2);  // X waited for B2
    EXPECT_EQ(rec.steps[1].vertex, x);
    EXPECT_EQ(rec.deferrals, 1u);
    EXPECT_EQ(rec.deferredVertices, 1u);
    EXPECT_TRUE(rec.kept.empty());
}

TEST(Deletion, NeverPossibleDeletionIsKeptAndNothingCrosses) {
    // B3 is a river end inside triangle A X C: A-C would always cross the river B.
    PointSet set = frame();
    const PointId a = add(set, 0, 0, true), x = add(set, 5, 5, false), c = add(set, 10, 0, true);
    const PointId b1 = add(set, 5, -4, true), b2 = add(set, 5, -1, false),
                  b3 = add(set, 5, 2, true);
    set.rivers = {{a, x, c}, {b1, b2, b3}};
    DeletionRecords rec;
    runChecked(set, {x, b2, 4, 5, 6, 7, 8}, rec);
    EXPECT_EQ(rec.deferrals, 2u);  // deferred, retried after B2 went, deferred again
    EXPECT_EQ(rec.deferredVertices, 1u);
    ASSERT_EQ(rec.kept.size(), 1u);
    EXPECT_EQ(rec.kept[0].id, x);
    EXPECT_EQ(rec.kept[0].reason, KeptReason::Deferred);
    EXPECT_EQ(rec.steps.size(), 6u);
}

TEST(Deletion, VertexOnTheNewRiverEdgeDefers) {
    // A DEM point D exactly on A-C: A-C would touch it. D goes later in the order.
    PointSet set = frame();
    const PointId a = add(set, 0, 0, true), x = add(set, 5, 5, false), c = add(set, 10, 0, true);
    set.points.push_back({4, 0, 1.0, PointKind::Dem, false});
    const PointId d = PointId(set.points.size() - 1);
    set.rivers = {{a, x, c}};
    DeletionRecords rec;
    runChecked(set, {x, d}, rec);
    ASSERT_EQ(rec.steps.size(), 2u);
    EXPECT_EQ(rec.steps[0].vertex, d);
    EXPECT_EQ(rec.steps[1].vertex, x);
    EXPECT_EQ(rec.deferrals, 1u);
}

TEST(Deletion, NewRiverEdgeAlongTheHullThroughAVertexIsDeferred) {
    // A and C on the block border with a border point W between them: A-C would run along the
    // hull through W. Bottom and top edge (the walk meets W on either side of A's fan).
    PointSet set = frame();
    const PointId a = add(set, 0, -20, true), x = add(set, 5, -15, false),
                  c = add(set, 10, -20, true);
    set.points.push_back({5, -20, 0.0, PointKind::Dem, true});
    const PointId a2 = add(set, 10, 20, true), x2 = add(set, 5, 15, false),
                  c2 = add(set, 0, 20, true);
    set.points.push_back({5, 20, 0.0, PointKind::Dem, true});
    set.rivers = {{a, x, c}, {a2, x2, c2}};
    DeletionRecords rec;
    runChecked(set, {x, x2}, rec);
    EXPECT_TRUE(rec.steps.empty());
    ASSERT_EQ(rec.kept.size(), 2u);
    EXPECT_EQ(rec.kept[0].reason, KeptReason::Deferred);
    EXPECT_EQ(rec.kept[1].reason, KeptReason::Deferred);
}

TEST(Deletion, CollinearRiverVertexIsDeleted) {
    PointSet set = frame();
    const PointId a = add(set, 0, 0, true), x = add(set, 5, 0, false), c = add(set, 10, 0, true);
    set.rivers = {{a, x, c}};
    DeletionRecords rec;
    runChecked(set, {x}, rec);
    ASSERT_EQ(rec.steps.size(), 1u);
    ASSERT_EQ(rec.addedEdges.size(), 1u);
    EXPECT_EQ(rec.addedEdges[0], makeRiverEdge(a, c));
}

TEST(Deletion, ReplayReproducesEveryStep) {
    BlockSpec spec;
    spec.seed = 21;
    spec.points = 1500;
    const PointSet set = makeBlock(spec);
    const std::vector<PointId> order = shuffledOrder(set, 4);
    Cdt full;
    std::string error;
    ASSERT_TRUE(buildCdt(set, {}, full, error)) << error;
    const std::vector<TriangleTriple> initial = collectTriangles(full);
    const std::vector<RiverEdge> initialEdges = collectRiverEdges(full);
    DeletionRecords rec;
    ASSERT_TRUE(runDeletion(set, full, order, {}, rec, error)) << error;
    const auto total = std::uint32_t(rec.steps.size());
    for (std::uint32_t k : {0u, 1u, 2u, 17u, total / 3, total / 2, total - 1, total}) {
        Cdt cdt;
        ASSERT_TRUE(buildCdt(set, {}, cdt, error)) << error;
        DeletionOptions options;
        options.maxSteps = k;
        DeletionRecords partial;
        ASSERT_TRUE(runDeletion(set, cdt, order, options, partial, error)) << error;
        ASSERT_EQ(partial.steps.size(), k);
        EXPECT_EQ(replayTriangles(initial, rec, k), collectTriangles(cdt)) << "step " << k;
        EXPECT_EQ(replayRiverEdges(initialEdges, rec, k), collectRiverEdges(cdt)) << "step " << k;
        if (k > 0) {
            EXPECT_EQ(rec.steps[k - 1].trianglesAlive, cdt.realTriangleCount);
            EXPECT_EQ(replayTriangles(initial, rec, k).size(), cdt.realTriangleCount);
        }
    }
}

TEST(Deletion, IdenticalRecordsForIdenticalInput) {
    BlockSpec spec;
    spec.seed = 8;
    spec.points = 1500;
    const PointSet set = makeBlock(spec);
    const std::vector<PointId> order = shuffledOrder(set, 8);
    DeletionRecords r[2];
    for (auto& rec : r) {
        Cdt cdt;
        std::string error;
        ASSERT_TRUE(buildCdt(set, {}, cdt, error)) << error;
        ASSERT_TRUE(runDeletion(set, cdt, order, {}, rec, error)) << error;
    }
    ASSERT_EQ(r[0].steps.size(), r[1].steps.size());
    for (std::size_t s = 0; s < r[0].steps.size(); ++s) {
        EXPECT_EQ(r[0].steps[s].vertex, r[1].steps[s].vertex);
        EXPECT_EQ(r[0].steps[s].trianglesAlive, r[1].steps[s].trianglesAlive);
    }
    EXPECT_EQ(r[0].removedTriangleOffset, r[1].removedTriangleOffset);
    EXPECT_EQ(r[0].addedTriangleOffset, r[1].addedTriangleOffset);
    EXPECT_TRUE(r[0].removedTriangles == r[1].removedTriangles);
    EXPECT_TRUE(r[0].addedTriangles == r[1].addedTriangles);
    EXPECT_TRUE(r[0].removedEdges == r[1].removedEdges);
    EXPECT_TRUE(r[0].addedEdges == r[1].addedEdges);
    EXPECT_EQ(r[0].errorMax, r[1].errorMax);
    EXPECT_EQ(r[0].errorPaper, r[1].errorPaper);
}

TEST(Deletion, InvalidOrderIsRejected) {
    BlockSpec spec;
    spec.points = 100;
    const PointSet set = makeBlock(spec);
    Cdt cdt;
    std::string error;
    ASSERT_TRUE(buildCdt(set, {}, cdt, error));
    DeletionRecords rec;
    EXPECT_FALSE(runDeletion(set, cdt, {PointId(set.points.size())}, {}, rec, error));
    EXPECT_NE(error.find("out of range"), std::string::npos);
    EXPECT_FALSE(runDeletion(set, cdt, {50, 50}, {}, rec, error));
    EXPECT_NE(error.find("repeated"), std::string::npos);
}

// --- One block of the bundled Jacksboro data (assets/): DEM cell centres + GRASS rivers ------

namespace jacksboro {

// Reads rows [r0, r0 + size) x columns [c0, c0 + size) of the DEM as points (cell centres) and
// the river network inside the block. Lon/lat go to metres by a local equirectangular map
// (enough for a test; the pipeline reprojects with GDAL). River vertices lie on cell centres
// and become those DEM points (what river cleaning does); every river segment is kept once, as
// a two-point polyline; of two diagonal segments crossing inside one 2x2 cell square the second
// is dropped (the cleaning stage would split them). Border cells and river ends and junctions
// are locked.
bool loadBlock(int r0, int c0, int size, PointSet& set, std::string& error) {
    GDALAllRegister();
    GDALDatasetUniquePtr dem(
        GDALDataset::Open(UNILOD_ASSETS_DIR "/jacksboro_dem.tif", GDAL_OF_RASTER));
    if (!dem) {
        error = "cannot open the Jacksboro DEM";
        return false;
    }
    double gt[6];
    dem->GetGeoTransform(gt);
    std::vector<float> z(std::size_t(size) * size);
    if (dem->GetRasterBand(1)->RasterIO(GF_Read, c0, r0, size, size, z.data(), size, size,
                                        GDT_Float32, 0, 0) != CE_None) {
        error = "cannot read the Jacksboro DEM";
        return false;
    }
    const double lat0 = gt[3] + (r0 + size / 2) * gt[5], lon0 = gt[0] + (c0 + size / 2) * gt[1];
    const double kx = 111320.0 * std::cos(lat0 * M_PI / 180.0), ky = 110540.0;
    for (int r = 0; r < size; ++r) {
        for (int c = 0; c < size; ++c) {
            Point p;
            p.x = (gt[0] + (c0 + c + 0.5) * gt[1] - lon0) * kx;
            p.y = (gt[3] + (r0 + r + 0.5) * gt[5] - lat0) * ky;
            p.z = z[std::size_t(r) * size + c];
            p.locked = r == 0 || c == 0 || r + 1 == size || c + 1 == size;
            set.points.push_back(p);
        }
    }
    GDALDatasetUniquePtr rivers(
        GDALDataset::Open(UNILOD_ASSETS_DIR "/jacksboro_rivers_grass.geojson", GDAL_OF_VECTOR));
    if (!rivers) {
        error = "cannot open the Jacksboro rivers";
        return false;
    }
    // River vertex -> cell of the block (or -1).
    auto cellOf = [&](double lon, double lat) {
        const double fc = (lon - gt[0]) / gt[1] - 0.5 - c0, fr = (lat - gt[3]) / gt[5] - 0.5 - r0;
        const long c = std::lround(fc), r = std::lround(fr);
        if (std::fabs(fc - c) > 0.01 || std::fabs(fr - r) > 0.01) return -2L;  // not a centre
        if (c < 0 || r < 0 || c >= size || r >= size) return -1L;
        return r * size + c;
    };
    std::set<std::pair<long, long>> edges;
    for (auto& feature : rivers->GetLayer(0)) {
        const OGRGeometry* g = feature->GetGeometryRef();
        if (g == nullptr || wkbFlatten(g->getGeometryType()) != wkbLineString) continue;
        const auto* line = g->toLineString();
        long prev = -1;
        for (int k = 0; k < line->getNumPoints(); ++k) {
            const long cell = cellOf(line->getX(k), line->getY(k));
            if (cell == -2) {
                error = "river vertex off the cell centres";
                return false;
            }
            if (prev >= 0 && cell >= 0 && cell != prev) {
                edges.insert({std::min(prev, cell), std::max(prev, cell)});
            }
            prev = cell;
        }
    }
    std::set<std::pair<long, long>> kept;
    for (const auto& [a, b] : edges) {
        const long ra = a / size, ca = a % size, rb = b / size, cb = b % size;
        if (std::labs(ra - rb) == 1 && std::labs(ca - cb) == 1) {
            // The other diagonal of the same 2x2 square.
            const long u = ra * size + cb, v = rb * size + ca;
            if (kept.count({std::min(u, v), std::max(u, v)})) continue;
        }
        kept.insert({a, b});
    }
    std::vector<int> degree(set.points.size(), 0);
    for (const auto& [a, b] : kept) {
        set.rivers.push_back({PointId(a), PointId(b)});
        ++degree[a], ++degree[b];
        set.points[a].kind = set.points[b].kind = PointKind::River;
    }
    for (std::size_t i = 0; i < degree.size(); ++i) {
        if (degree[i] != 0 && degree[i] != 2) set.points[i].locked = true;
    }
    return true;
}

}  // namespace jacksboro

TEST(Deletion, JacksboroBlockSampledStepsAndLast1000) {
    PointSet set;
    std::string error;
    ASSERT_TRUE(jacksboro::loadBlock(120, 150, 90, set, error)) << error;
    ASSERT_GT(set.rivers.size(), 100u);
    const std::vector<PointId> order = shuffledOrder(set, 2024);
    // First pass: the number of steps, so that the checked run knows its last 1000.
    std::uint32_t total = 0;
    {
        Cdt cdt;
        ASSERT_TRUE(buildCdt(set, {}, cdt, error)) << error;
        DeletionRecords rec;
        DeletionOptions options;
        options.maxError = options.paperError = false;
        ASSERT_TRUE(runDeletion(set, cdt, order, options, rec, error)) << error;
        total = std::uint32_t(rec.steps.size());
    }
    ASSERT_GT(total, 5000u);
    DeletionRecords rec;
    const std::uint32_t checked = runChecked(set, order, rec, 50, total);
    EXPECT_GE(checked, 1000u + (total - 1000) / 50);
    EXPECT_EQ(rec.steps.size(), total);
    EXPECT_GT(rec.removedEdges.size(), 200u);  // river vertices were deleted
    EXPECT_GT(rec.errorMax.back(), 10.0);
    std::printf(
        "jacksboro block: %zu points, %zu river segments, %u steps, %u deferrals, %zu kept, "
        "%u checked steps, final error max %.1f m paper %.1f m\n",
        set.points.size(), set.rivers.size(), total, rec.deferrals, rec.kept.size(), checked,
        rec.errorMax.back(), rec.errorPaper.back());
}

TEST(Deletion, JacksboroBlockInImportanceOrder) {
    // The real deletion order (improved 3D_DP + BAI, importance.h) on the same block.
    PointSet set;
    std::string error;
    ASSERT_TRUE(jacksboro::loadBlock(120, 150, 90, set, error)) << error;
    ImportanceResult importance;
    ASSERT_TRUE(computeImportance(set, {}, importance, error)) << error;
    std::uint32_t total = 0;
    {
        Cdt cdt;
        ASSERT_TRUE(buildCdt(set, {}, cdt, error)) << error;
        DeletionRecords rec;
        DeletionOptions options;
        options.maxError = options.paperError = false;
        ASSERT_TRUE(runDeletion(set, cdt, importance.order, options, rec, error)) << error;
        total = std::uint32_t(rec.steps.size());
    }
    ASSERT_GT(total, 5000u);
    DeletionRecords rec;
    runChecked(set, importance.order, rec, 50, total);
    for (std::size_t s = 1; s < rec.errorMax.size(); ++s) {
        ASSERT_GE(rec.errorMax[s], rec.errorMax[s - 1]);
        ASSERT_GE(rec.errorPaper[s], rec.errorPaper[s - 1]);
    }
    std::printf(
        "jacksboro block, importance order: %u steps, %u deferrals, %zu kept, error at "
        "half the steps: max %.1f m, paper %.2f m\n",
        total, rec.deferrals, rec.kept.size(), rec.errorMax[total / 2], rec.errorPaper[total / 2]);
}

}  // namespace
}  // namespace unilod
