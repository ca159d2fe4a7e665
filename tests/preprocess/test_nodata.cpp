// Nodata handling and the domain (nodata.h, blocks.h "Domain"; issues 4 and 17): small interior
// holes filled, large ones kept as holes, border-connected nodata left alone; models of DEMs with
// bays, holes, a crescent, an annulus, a coastline and an all-nodata block cover exactly the
// valid data at full resolution, stay within their error of it at every level and pass the full
// check (which recomputes the error of every level).
#include <gdal_priv.h>
#include <gtest/gtest.h>

#include <random>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <set>

#include "blocks.h"
#include "build.h"
#include "cdt.h"
#include "checker.h"
#include "deletion.h"
#include "demfixtures.h"
#include "ingest.h"
#include "modelerror.h"
#include "nodata.h"
#include "pngread.h"
#include "stats.h"
#include "tools/cliutil.h"
#include "ulod.h"
#include "ulodcheck.h"

using namespace unilod;

namespace {

DemGrid plane(int w, int h) {
    DemGrid d;
    d.width = w;
    d.height = h;
    d.originX = 500000;
    d.originY = 4000000;
    d.cellX = 30;
    d.cellY = -30;
    for (int r = 0; r < h; ++r) {
        for (int c = 0; c < w; ++c)
            d.z.push_back(float(100 + 2 * c + 3 * r));
    }
    return d;
}

void punch(DemGrid& d, int c0, int r0, int c1, int r1) {
    for (int r = r0; r <= r1; ++r) {
        for (int c = c0; c <= c1; ++c)
            d.z[std::size_t(r) * d.width + c] = NAN;
    }
}

std::string writeTiff(const DemGrid& d, const std::string& name) {
    GDALAllRegister();
    const std::string path = testing::TempDir() + name;
    GDALDriver* drv = GetGDALDriverManager()->GetDriverByName("GTiff");
    GDALDataset* ds = drv->Create(path.c_str(), d.width, d.height, 1, GDT_Float32, nullptr);
    double gt[6] = {d.originX - 15, 30, 0, d.originY + 15, 0, -30};
    ds->SetGeoTransform(gt);
    OGRSpatialReference srs;
    srs.importFromEPSG(32616);
    ds->SetSpatialRef(&srs);
    std::vector<float> z(d.z.begin(), d.z.end());
    EXPECT_EQ(ds->GetRasterBand(1)->RasterIO(GF_Write, 0, 0, d.width, d.height, z.data(), d.width,
                                             d.height, GDT_Float32, 0, 0),
              CE_None);
    GDALClose(ds);
    return path;
}

// A GeoJSON river network in UTM 16N under the test folder: one LineString per item of `lines`
// (its coordinates, "[[x,y],...]"); by default one short river away from the nodata.
std::string riverFile(const std::string& name,
                      const std::vector<std::string>& lines = {
                          "[[500301,3999499],[500452,3999402],[500607,3999301]]"}) {
    const std::string path = testing::TempDir() + name;
    std::ofstream out(path);
    out << R"({"type":"FeatureCollection","crs":{"type":"name","properties":)"
        << R"({"name":"urn:ogc:def:crs:EPSG::32616"}},"features":[)";
    for (std::size_t i = 0; i < lines.size(); ++i)
        out << (i ? "," : "") << R"({"type":"Feature","properties":{},"geometry":{"type":)"
            << R"("LineString","coordinates":)" << lines[i] << "}}";
    out << "]}";
    return path;
}

// Build options for `d` written as NAME.tif with `rivers`, blocks of `blockSize` cells, output
// NAME.ulod under the test folder (replaced).
BuildOptions modelOptions(const DemGrid& d, const std::string& name, const std::string& rivers,
                          int blockSize) {
    BuildOptions o;
    o.demPath = writeTiff(d, name + ".tif");
    o.riversPath = rivers;
    o.outPath = testing::TempDir() + name + ".ulod";
    o.blockSize = blockSize;
    o.force = true;
    return o;
}

// Builds `o`, checks the model (`unilod check --errors`: the invariants and every level's error
// recomputed) and opens it in `reader`.
void buildAndCheck(const BuildOptions& o, format::Reader& reader) {
    BuildSummary summary;
    std::string err;
    ASSERT_TRUE(runBuild(o, summary, err)) << err;
    UlodCheckOptions co;
    co.errors = true;
    UlodCheckSummary cs;
    ASSERT_TRUE(checkUlod(o.outPath, co, cs, err)) << err;
    ASSERT_TRUE(reader.open(o.outPath, err)) << err;
}

// An afterStep hook (deletion.h) that checks the invariants (checker.h) and that the stored `max`
// error bounds the brute-force one after every step; failures are counted, the first 3 reported.
std::function<void(std::uint32_t)> checkEveryStep(const PointSet& set, const Cdt& cdt,
                                                  const CheckReference& ref,
                                                  const DeletionRecords& rec,
                                                  std::uint32_t& failures) {
    return [&set, &cdt, &ref, &rec, &failures](std::uint32_t step) {
        std::string m;
        if (!checkCdt(cdt, ref, nullptr, m) && failures++ < 3)
            ADD_FAILURE() << "after step " << step << ": " << m;
        const double brute = bruteForceMaxError(set, cdt);
        if (brute > rec.errorMax[step - 1] + 1e-9 && failures++ < 3)
            ADD_FAILURE() << "step " << step << ": vertical " << brute << " > stored "
                          << rec.errorMax[step - 1];
    };
}

}  // namespace

TEST(Nodata, SmallInteriorHoleIsFilled) {
    DemGrid d = plane(20, 20);
    punch(d, 8, 8, 10, 10);  // 9 cells
    NodataStats s;
    std::string err;
    ASSERT_TRUE(fillSmallHoles(d, "dem.tif", 16, s, err)) << err;
    EXPECT_EQ(s.nodataCells, 9u);
    EXPECT_EQ(s.holes, 1u);
    EXPECT_EQ(s.filledCells, 9u);
    for (int r = 8; r <= 10; ++r) {
        for (int c = 8; c <= 10; ++c) {
            const float z = d.at(c, r);
            ASSERT_FALSE(std::isnan(z));
            EXPECT_GE(z, 100 + 2 * 7 + 3 * 7);  // within the surrounding values
            EXPECT_LE(z, 100 + 2 * 11 + 3 * 11);
        }
    }
    // The middle of the left rim has one valid neighbour in the first round: its left one.
    EXPECT_FLOAT_EQ(d.at(8, 9), float(100 + 2 * 7 + 3 * 9));
}

TEST(Nodata, LargeHoleIsKeptAndBorderNodataLeftAlone) {
    DemGrid d = plane(30, 30);
    punch(d, 5, 5, 14, 14);  // 100 interior cells: a hole of the domain, not filled
    NodataStats s;
    std::string err;
    ASSERT_TRUE(fillSmallHoles(d, "big.tif", 16, s, err)) << err;
    EXPECT_EQ(s.holes, 1u);
    EXPECT_EQ(s.keptHoles, 1u);
    EXPECT_EQ(s.keptHoleCells, 100u);
    EXPECT_EQ(s.filledCells, 0u);
    EXPECT_TRUE(std::isnan(d.at(9, 9)));

    DemGrid e = plane(30, 30);
    punch(e, 0, 0, 29, 3);  // a strip along the top border: outside the data
    ASSERT_TRUE(fillSmallHoles(e, "edge.tif", 16, s, err)) << err;
    EXPECT_EQ(s.holes, 0u);
    EXPECT_EQ(s.filledCells, 0u);
    EXPECT_TRUE(std::isnan(e.at(10, 2)));
}

// Holes are 4-connected regions (found by joining runs of nodata along rows): diagonal
// neighbours are two holes, a U whose arms meet only at its bottom row one hole, a region that
// reaches the border by a one-cell channel none.
TEST(Nodata, HolesAreFourConnectedRegions) {
    DemGrid d = plane(30, 30);
    punch(d, 3, 3, 3, 3);
    punch(d, 4, 4, 4, 4);  // diagonal to (3, 3): a hole of its own
    // A U: arms at columns 10 and 14 (rows 10..15), bottom row 16 (columns 10..14); 17 cells.
    punch(d, 10, 10, 10, 15);
    punch(d, 14, 10, 14, 15);
    punch(d, 10, 16, 14, 16);
    // A 5 x 5 block joined to the right border by a channel along row 22.
    punch(d, 20, 20, 24, 24);
    punch(d, 25, 22, 29, 22);
    NodataStats s;
    std::string err;
    ASSERT_TRUE(fillSmallHoles(d, "holes.tif", 16, s, err)) << err;
    EXPECT_EQ(s.nodataCells, 2u + 17u + 25u + 5u);
    EXPECT_EQ(s.holes, 3u);
    EXPECT_EQ(s.filledCells, 2u);
    EXPECT_EQ(s.keptHoles, 1u);
    EXPECT_EQ(s.keptHoleCells, 17u);
    EXPECT_FALSE(std::isnan(d.at(3, 3)));
    EXPECT_FALSE(std::isnan(d.at(4, 4)));
    EXPECT_TRUE(std::isnan(d.at(10, 10)));
    EXPECT_TRUE(std::isnan(d.at(14, 10)));
    EXPECT_TRUE(std::isnan(d.at(22, 22)));
    // The same U with arms a cell shorter (15 cells) is filled.
    DemGrid e = plane(30, 30);
    punch(e, 10, 11, 10, 15);
    punch(e, 14, 11, 14, 15);
    punch(e, 10, 16, 14, 16);
    ASSERT_TRUE(fillSmallHoles(e, "u16.tif", 16, s, err)) << err;
    EXPECT_EQ(s.holes, 1u);
    EXPECT_EQ(s.filledCells, 15u);
}

// Twice the area of the domain (blocks.h "Domain") in grid units^2 (1 mm): every lattice square
// with 4 valid corners counts whole, one with 3 valid corners half.
std::int64_t doubleDomainArea(const DemGrid& d) {
    const std::int64_t cell = std::llround(std::fabs(d.cellX) / format::kGridUnit) *
                              std::llround(std::fabs(d.cellY) / format::kGridUnit);
    std::int64_t twice = 0;
    for (int r = 0; r + 1 < d.height; ++r) {
        for (int c = 0; c + 1 < d.width; ++c) {
            const int valid = int(!std::isnan(d.at(c, r))) + int(!std::isnan(d.at(c + 1, r))) +
                              int(!std::isnan(d.at(c, r + 1))) +
                              int(!std::isnan(d.at(c + 1, r + 1)));
            twice += valid == 4 ? 2 * cell : (valid == 3 ? cell : 0);
        }
    }
    return twice;
}

// Builds `dem` (default options but the block size) and checks the model: `unilod check` with
// the error recomputation passes (every vertex within the level's error of the drawn domain), the
// full-resolution triangles cover exactly the domain (areas sum to the domain's area: holes, bays
// and a concave outline are never bridged), every coarser level's area is within the outline
// length times its error of it, and blocks without data are left out.
// `filled`: the DEM after the small-hole fill (nodata.h), whose domain the model covers.
void expectDomainModel(const DemGrid& dem, const std::string& name, int blockSize,
                       std::size_t expectedBlocks, const DemGrid* filled = nullptr) {
    SCOPED_TRACE(name);
    const BuildOptions o = modelOptions(dem, name, riverFile(name + "_rivers.geojson"), blockSize);
    format::Reader reader;
    ASSERT_NO_FATAL_FAILURE(buildAndCheck(o, reader));
    std::string err;
    std::vector<std::size_t> leaves;  // the blocks (tree level 0; nodes are checked by `check`)
    for (std::size_t i = 0; i < reader.blocks().size(); ++i)
        if (reader.blocks()[i].level == 0) leaves.push_back(i);
    EXPECT_EQ(leaves.size(), expectedBlocks);
    ErrorStatsTable stats;  // `unilod stats` over the blocks present
    ASSERT_TRUE(computeErrorStats(o.outPath, {5, 20}, format::kMetricMax, stats, err)) << err;
    EXPECT_EQ(stats.blocks, expectedBlocks);
    std::vector<std::int64_t> perLevel;  // summed over blocks, by level index (coarse levels
                                         // of blocks with fewer levels count their last one)
    std::size_t maxLevels = 0;
    std::vector<format::Block> blocks(leaves.size());
    for (std::size_t i = 0; i < blocks.size(); ++i) {
        ASSERT_TRUE(reader.readBlock(leaves[i], blocks[i], err)) << err;
        maxLevels = std::max(maxLevels, blocks[i].levels.size());
    }
    // Per block and level: twice the area, and the outline length at full resolution (edges of
    // one triangle only), in grid units.
    auto doubleArea = [](const format::Block& b, const format::Level& level) {
        std::int64_t twice = 0;
        for (std::uint32_t k = 0; k < level.triangleCount; ++k) {
            const format::Triangle& t = b.terrainIndices[level.triangleFirst + k];
            const format::GridXY p = b.grid[t.a], q = b.grid[t.b], r = b.grid[t.c];
            twice += (std::int64_t(q.x) - p.x) * (std::int64_t(r.y) - p.y) -
                     (std::int64_t(q.y) - p.y) * (std::int64_t(r.x) - p.x);
        }
        return twice;
    };
    auto outlineLength = [](const format::Block& b) {
        const format::Level& level = b.levels.front();
        std::set<std::pair<std::uint32_t, std::uint32_t>> directed;
        for (std::uint32_t k = 0; k < level.triangleCount; ++k) {
            const format::Triangle& t = b.terrainIndices[level.triangleFirst + k];
            directed.insert({t.a, t.b}), directed.insert({t.b, t.c}), directed.insert({t.c, t.a});
        }
        double length = 0;
        for (const auto& [u, w] : directed)
            if (!directed.count({w, u}))
                length += std::hypot(double(b.grid[u].x) - b.grid[w].x,
                                     double(b.grid[u].y) - b.grid[w].y);
        return length;
    };
    std::size_t coarser = 0, moved = 0;
    for (std::size_t l = 0; l < maxLevels; ++l) {
        std::int64_t twice = 0;
        double slack = 0;  // twice the area the outline may sweep at this level's error
        for (const format::Block& b : blocks) {
            const format::Level& level = b.levels[std::min(l, b.levels.size() - 1)];
            twice += doubleArea(b, level);
            slack += 2.0 * outlineLength(b) * double(level.errorMax) / format::kGridUnit;
            coarser += l > 0 && l < b.levels.size();
        }
        const std::int64_t domain = doubleDomainArea(filled ? *filled : dem);
        if (l == 0) {
            EXPECT_EQ(twice, domain);  // full resolution: exactly the valid data
        } else {
            // The outline moves by at most the level's error (its planimetric deviation).
            EXPECT_LE(std::fabs(double(twice - domain)), slack) << "level " << l;
            moved += twice != domain;
        }
    }
    // The roots of the block hierarchy (issue 18) cover the whole domain: the same at every
    // level. The blocks hand over to their parents early, so the outline simplifies mostly there.
    {
        std::vector<int> isChild(reader.blocks().size(), 0);
        for (const format::BlockInfo& info : reader.blocks())
            for (std::uint32_t c = 0; c < info.childCount; ++c)
                isChild[info.firstChild + c] = 1;
        std::vector<format::Block> roots;
        for (std::size_t i = 0; i < isChild.size(); ++i) {
            if (isChild[i]) continue;
            roots.emplace_back();
            ASSERT_TRUE(reader.readBlock(i, roots.back(), err)) << err;
        }
        if (roots.size() == 1) {  // a tree (a single block is its own root, checked above)
            const format::Block& root = roots[0];
            const std::int64_t domain = doubleDomainArea(filled ? *filled : dem);
            for (std::size_t l = 0; l < root.levels.size(); ++l) {
                const std::int64_t twice = doubleArea(root, root.levels[l]);
                // The root's grid positions are relative to its own origin; areas do not care.
                const double slack = 2.0 * outlineLength(root) *
                                     double(root.levels[l].errorMax) / format::kGridUnit;
                EXPECT_LE(std::fabs(double(twice - domain)), slack) << "root level " << l;
                moved += twice != domain;
            }
        }
    }
    EXPECT_GT(moved, 0u);  // outline corners are simplified too

    // It exports, and the engine draws it (validation on) with nothing over the nodata: looking
    // down on the whole DEM, the pixels drawn are the valid area's share of those the unmasked
    // DEM (same relief, same camera) draws. A bridged hole or bay would add its whole area.
    auto r = unilod::test::runCli("export -q " + unilod::test::q(o.outPath) + " --h-lim 1 -o " +
                                  unilod::test::q(testing::TempDir() + name + ".glb") +
                                  " --overwrite");
    EXPECT_EQ(r.code, 0) << r.err;
    const DemGrid full = plane(dem.width, dem.height);
    BuildOptions fo = o;
    fo.demPath = writeTiff(full, name + "_unmasked.tif");
    fo.outPath = testing::TempDir() + name + "_unmasked.ulod";
    BuildSummary summary;
    ASSERT_TRUE(runBuild(fo, summary, err)) << err;
    const double cx = full.centreX(0) + 0.5 * (full.width - 1) * full.cellX;
    const double cy = full.centreY(0) + 0.5 * (full.height - 1) * full.cellY;
    const double half = 0.5 * std::max(full.width - 1, full.height - 1) * std::fabs(full.cellX);
    const double f = 240.0 / std::tan(30.0 * 3.14159265358979 / 180.0);
    double top = 0;
    for (float z : full.z) top = std::max(top, double(z));
    const double height = top + 3.0 * half * f / 240.0;  // the DEM within a third of the view
    char camera[256];
    std::snprintf(camera, sizeof camera, "%.3f,%.3f,%.3f,0,-90", cx, cy, height);
    auto drawnPixels = [&](const std::string& file, const std::string& tag) -> double {
        const std::string out = testing::TempDir() + name + "_" + tag;
        const auto c = unilod::test::runCli("capture " + unilod::test::q(file) +
                                            " --validation --camera " + camera +
                                            " --size 640x480 --pixels 1 --fov 60 --overwrite -o " +
                                            unilod::test::q(out));
        EXPECT_EQ(c.code, 0) << c.err;
        unilod::test::Image image;
        EXPECT_TRUE(unilod::test::readPng(out + "/frame_0000.png", image));
        double drawn = 0;
        for (std::size_t i = 0; i + 3 < image.rgba.size(); i += 4)
            drawn += image.rgba[i] || image.rgba[i + 1] || image.rgba[i + 2];
        return drawn;
    };
    const double masked = drawnPixels(o.outPath, "masked");
    const double unmasked = drawnPixels(fo.outPath, "unmasked");
    const double share =
        double(doubleDomainArea(filled ? *filled : dem)) / double(doubleDomainArea(full));
    ASSERT_GT(unmasked, 5000.0);
    EXPECT_NEAR(masked / unmasked, share, 0.08 * share) << masked << " of " << unmasked;
    EXPECT_GT(coarser, 0u);  // the model does simplify
}

TEST(Nodata, DomainFollowsTheValidData) {
    // A bay from the top border (it used to be filled or refused), a 100-cell interior hole,
    // a 1-cell hole (filled), a crescent, an annulus, a coastline (sea as nodata) and an
    // all-nodata block in the middle of a 3 x 3 block grid.
    DemGrid bay = plane(40, 40);
    punch(bay, 15, 0, 24, 19);
    punch(bay, 5, 25, 14, 34);  // 100 cells
    const DemGrid unfilled = bay;
    punch(bay, 30, 30, 30, 30);  // 1 cell: filled
    expectDomainModel(bay, "nodata_bay_holes", 39, 1, &unfilled);

    auto mask = [](DemGrid d, auto inside) {
        for (int r = 0; r < d.height; ++r)
            for (int c = 0; c < d.width; ++c)
                if (!inside(c - d.width / 2.0 + 0.5, r - d.height / 2.0 + 0.5))
                    d.z[std::size_t(r) * std::size_t(d.width) + std::size_t(c)] = NAN;
        return d;
    };
    const DemGrid crescent = mask(plane(48, 48), [](double x, double y) {
        return x * x + y * y < 22.0 * 22.0 && (x - 9) * (x - 9) + y * y > 16.0 * 16.0;
    });
    expectDomainModel(crescent, "nodata_crescent", 47, 1);
    const DemGrid annulus = mask(plane(48, 48), [](double x, double y) {
        const double r2 = x * x + y * y;
        return r2 < 22.0 * 22.0 && r2 > 9.0 * 9.0;
    });
    expectDomainModel(annulus, "nodata_annulus", 16, 9);
    const DemGrid coast = mask(plane(60, 40), [](double x, double y) {
        return y < 6.0 * std::sin(x / 5.0) + 0.3 * x;  // sea above a wavy coastline
    });
    expectDomainModel(coast, "nodata_coast", 20, 5);  // one block all sea
    DemGrid big = plane(150, 150);
    punch(big, 25, 25, 124, 124);  // a 10 000-cell hole
    expectDomainModel(big, "nodata_big_hole", 256, 1);
    DemGrid middle = plane(49, 49);
    punch(middle, 15, 15, 33, 33);  // covers block (1,1) of 16-cell blocks and its borders
    expectDomainModel(middle, "nodata_middle_block", 16, 8);
}

// The greedy order on a block with a concave outline and a hole, with relief: the invariants
// (checker.h: the side of every triangle agrees with the outline) hold after every step while
// outline corners are deleted, and the stored error bounds the vertical error of every point the
// domain still covers.
TEST(Nodata, OutlineCornersSimplifyWithInvariantsAfterEveryStep) {
    const DemGrid d = unilod::test::discWithBiteAndHole();
    BlockSource source;
    BlockOptions bo;
    bo.blockSize = 35;
    bo.lockOuterEdge = false;
    std::string err;
    ASSERT_TRUE(source.init(d, {}, bo, err)) << err;
    ASSERT_EQ(source.blockCount(), 1u);
    const PointSet set = source.points(0);
    ASSERT_GE(set.boundaries.size(), 2u);  // the outer ring and the hole
    Cdt cdt;
    ASSERT_TRUE(buildCdt(set, {}, cdt, err)) << err;
    auto domainArea = [&] {
        std::int64_t twice = 0;
        for (std::uint32_t t = 0; t < cdt.triangleSlots(); ++t)
            if (cdt.inDomain(t))
                twice += cdt.orient(cdt.tv[3 * t], cdt.tv[3 * t + 1], cdt.tv[3 * t + 2]);
        return twice;
    };
    const std::int64_t initialArea = domainArea();
    const CheckReference ref = captureCheckReference(cdt);
    DeletionRecords rec;
    DeletionOptions options;
    std::uint32_t failures = 0, moved = 0;
    const auto check = checkEveryStep(set, cdt, ref, rec, failures);
    options.afterStep = [&](std::uint32_t step) {
        check(step);
        moved += domainArea() != initialArea;
    };
    ASSERT_TRUE(runGreedyDeletion(set, cdt, {}, options, rec, err)) << err;
    EXPECT_EQ(failures, 0u);
    EXPECT_GT(moved, 0u);                    // outline corners were deleted
    EXPECT_GT(rec.steps.size(), set.points.size() / 2);
}

// A step whose new edge a-c is a diagonal of the hole (every ring step; a river vertex on the
// straight segment between its neighbours) makes the edge with the removal (the hole split in
// two: Cdt::removeVertexWithDiagonal) instead of inserting it afterwards by flips, which took
// minutes on a 2-row DEM (a frame vertex meets the whole outline). The invariants (constrained
// Delaunay, the outline and rivers as the constraints, sides) and the stored error hold after
// every step: a 2-row strip of rough heights, and a 3-row strip whose middle row is a straight
// river (its vertices at the dropped DEM points, collinear).
TEST(Nodata, StepsWhoseNewEdgeSplitsTheHoleKeepTheInvariants) {
    for (const bool river : {false, true}) {
        SCOPED_TRACE(river ? "river along a row" : "2-row strip");
        DemGrid d = plane(90, river ? 3 : 2);
        std::mt19937 rng(11);
        for (float& z : d.z)
            z = float(rng() % 5000) / 50.0f;
        RiverLines lines;
        if (river)
            lines.push_back({{d.centreX(1) + 3, d.centreY(1)}, {d.centreX(88) - 3, d.centreY(1)}});
        BlockSource source;
        BlockOptions bo;
        bo.blockSize = 100;
        bo.lockOuterEdge = false;
        std::string err;
        ASSERT_TRUE(source.init(d, lines, bo, err)) << err;
        ASSERT_EQ(source.blockCount(), 1u);
        const PointSet set = source.points(0);
        ASSERT_FALSE(set.boundaries.empty());
        if (river) {
            ASSERT_EQ(set.rivers.size(), 1u);
            EXPECT_GT(set.rivers[0].size(), 80u);  // a vertex at each of the row's cells
        }
        Cdt cdt;
        ASSERT_TRUE(buildCdt(set, {}, cdt, err)) << err;
        const CheckReference ref = captureCheckReference(cdt);
        DeletionRecords rec;
        DeletionOptions options;
        std::uint32_t failures = 0;
        options.afterStep = checkEveryStep(set, cdt, ref, rec, failures);
        ASSERT_TRUE(runGreedyDeletion(set, cdt, {}, options, rec, err)) << err;
        EXPECT_EQ(failures, 0u);
        EXPECT_GT(rec.steps.size(), set.points.size() / 2);
    }
}

// Thin strips of data with scattered nodata and terraced heights (found by a random build
// fuzzer): the outline moves in and out again over the same points. A point on an outline edge
// is in the domain (closed) and its vertical error counts; it used to stay in the bucket of the
// exterior triangle on the other side when a ring step made that edge the outline, so its error
// never counted (a stored bound 1 m where the surface was 7.5 m off). After every step the
// stored `max` error must bound the brute-force one, on many random masks; every other mask also
// with extra original points (a tree node's) on the outline edges, each located after one just
// outside it: they are in the domain from the start (they used to count only once a step
// re-located them).
TEST(Nodata, PointsOnAMovedOutlineCountInTheError) {
    std::uint32_t failures = 0, moved = 0, steps = 0;
    for (std::uint32_t seed = 0; seed < 40; ++seed) {
        std::mt19937 rng(seed);
        DemGrid d = plane(20 + int(seed % 13), 3 + int(seed % 4));
        d.cellX = 1;   // 1 m cells: the outline's deviation is small beside the 10 m terraces, so
        d.cellY = -1;  // outline vertices go early and often
        for (int r = 0; r < d.height; ++r) {
            for (int c = 0; c < d.width; ++c) {
                float& z = d.z[std::size_t(r) * std::size_t(d.width) + std::size_t(c)];
                z = float(100 + 10 * ((c + r) / 5));  // terraces
                if (std::uniform_real_distribution<double>(0, 1)(rng) < 0.2) z = NAN;
            }
        }
        BlockSource source;
        BlockOptions bo;
        bo.blockSize = 64;
        bo.lockOuterEdge = false;
        std::string err;
        if (!source.init(d, {}, bo, err) || source.blockCount() != 1) continue;
        const PointSet set = source.points(0);
        Cdt cdt;
        if (!buildCdt(set, {}, cdt, err)) continue;
        const std::int64_t area = [&] {
            std::int64_t twice = 0;
            for (std::uint32_t t = 0; t < cdt.triangleSlots(); ++t)
                if (cdt.inDomain(t))
                    twice += cdt.orient(cdt.tv[3 * t], cdt.tv[3 * t + 1], cdt.tv[3 * t + 2]);
            return twice;
        }();
        // Extra original points (a tree node's, modelerror.h ExtraSamples) in the middle of
        // outline edges, 3 m above them: on the outline, so in the domain from the start.
        std::vector<ExtraSample> extra;
        if (seed % 2 == 1) {
            for (const Polyline& ring : cdt.boundaryRings) {
                for (std::size_t k = 0; k < ring.size(); ++k) {
                    const PointId u = ring[k], w = ring[(k + 1) % ring.size()];
                    if ((cdt.gx[u] + cdt.gx[w]) % 2 != 0 || (cdt.gy[u] + cdt.gy[w]) % 2 != 0)
                        continue;
                    const std::int32_t mx = (cdt.gx[u] + cdt.gx[w]) / 2,
                                       my = (cdt.gy[u] + cdt.gy[w]) / 2;
                    // First one just outside (the domain is on the left of u -> w), so that the
                    // walk locating the next comes from the exterior side.
                    extra.push_back(
                        {mx + (cdt.gy[w] - cdt.gy[u]) / 4, my - (cdt.gx[w] - cdt.gx[u]) / 4, 0.0});
                    extra.push_back({mx, my, (set.points[u].z + set.points[w].z) / 2 + 3});
                }
            }
            ASSERT_GT(extra.size(), 3u);
        }
        DeletionRecords rec;
        DeletionOptions options;
        ExtraSamples samples;
        samples.points = extra;
        if (!extra.empty()) {
            options.extraSamples = &samples;
            options.paperError = false;
        }
        options.afterStep = [&](std::uint32_t step) {
            ++steps;
            const double brute =
                std::max(bruteForceMaxError(set, cdt), bruteForceExtraError(set, cdt, extra));
            if (brute > rec.errorMax[step - 1] + 1e-9 && failures++ < 3)
                ADD_FAILURE() << "seed " << seed << " step " << step << ": vertical " << brute
                              << " > stored " << rec.errorMax[step - 1];
        };
        ASSERT_TRUE(runGreedyDeletion(set, cdt, {}, options, rec, err)) << err;
        if (!extra.empty() && rec.initialErrorMax < 3 - 1e-9 && failures++ < 3)
            ADD_FAILURE() << "seed " << seed << ": the samples on the outline were not counted ("
                          << rec.initialErrorMax << ")";
        std::int64_t after = 0;
        for (std::uint32_t t = 0; t < cdt.triangleSlots(); ++t)
            if (cdt.inDomain(t))
                after += cdt.orient(cdt.tv[3 * t], cdt.tv[3 * t + 1], cdt.tv[3 * t + 2]);
        moved += after != area;
    }
    EXPECT_EQ(failures, 0u);
    EXPECT_GT(moved, 20u);  // the outline moved in most of them
    EXPECT_GT(steps, 1000u);
}

// Valid cells that hold no triangle (every other cell of every other row: no 2 x 2 cells with 3
// valid; the nodata between them reaches the border, so it is not filled) are refused by build
// and order alike, naming the DEM, with no output.
TEST(Nodata, NoTriangulableDataIsRefused) {
    DemGrid d = plane(12, 12);
    for (int r = 0; r < d.height; ++r)
        for (int c = 0; c < d.width; ++c)
            if (r % 2 || c % 2) d.z[std::size_t(r) * std::size_t(d.width) + std::size_t(c)] = NAN;
    BuildOptions o;
    o.demPath = writeTiff(d, "nodata_checker.tif");
    o.riversPath = testing::TempDir() + "nodata_checker_rivers.geojson";
    std::ofstream(o.riversPath) << "{\"type\": \"FeatureCollection\", \"features\": []}\n";
    o.outPath = testing::TempDir() + "nodata_checker.ulod";
    std::filesystem::remove(o.outPath);
    BuildSummary summary;
    std::string err;
    EXPECT_FALSE(runBuild(o, summary, err));
    EXPECT_NE(err.find("nodata_checker.tif"), std::string::npos) << err;
    EXPECT_NE(err.find("no valid data to triangulate"), std::string::npos) << err;
    EXPECT_FALSE(std::filesystem::exists(o.outPath));
    const auto r = unilod::test::runCli("order " + unilod::test::q(o.demPath) + " " +
                                        unilod::test::q(o.riversPath) + " --json");
    EXPECT_NE(r.code, 0);
    EXPECT_NE(r.err.find("no valid data to triangulate"), std::string::npos) << r.err;
}

// A nodata value the file does not declare (an ASCII grid without NODATA_value, a GeoTIFF whose
// nodata tag was lost) inside the plausible range, -9999 the most common: it built as a pit
// 10 km deep. Refused, naming the value and the fix; a deep trench at -9999 whose neighbours are
// a few hundred metres off builds.
TEST(Nodata, UndeclaredNodataSentinelIsRefused) {
    for (float sentinel : kUndeclaredNodata) {
        DemGrid d = plane(20, 20);
        for (int r = 0; r < 6; ++r)
            for (int c = 0; c < 6; ++c)
                d.z[std::size_t(r) * std::size_t(d.width) + std::size_t(c)] = sentinel;
        IngestOptions o;
        o.demPath = writeTiff(d, "nodata_undeclared.tif");
        Ingested data;
        std::string err;
        EXPECT_FALSE(ingest(o, data, err));
        char value[32];
        std::snprintf(value, sizeof value, "%g", double(sentinel));
        EXPECT_NE(
            err.find(std::string("11 cells hold ") + value + " next to cells more than 3000 m"),
            std::string::npos)
            << err;
        EXPECT_NE(err.find(std::string("gdal_translate -a_nodata ") + value), std::string::npos)
            << err;
    }
    DemGrid trench = plane(20, 20);
    for (std::size_t i = 0; i < trench.z.size(); ++i)
        trench.z[i] = -9000.0f - float(i % 7) * 100.0f;
    trench.z[45] = -9999.0f;
    IngestOptions o;
    o.demPath = writeTiff(trench, "nodata_trench.tif");
    Ingested data;
    std::string err;
    EXPECT_TRUE(ingest(o, data, err)) << err;
}

// A river across a nodata lake keeps both banks (issue 17's domain, 2026-11-29): its segments
// are cut where they leave the valid DEM and where they come near the domain's outline, not
// dropped whole. One 2-vertex line crosses a 10 x 10-cell hole; before, the whole line was lost
// (both its vertices valid, its one segment near the outline). At stride 1 and 2, with blocks
// of 16 cells (the line also crosses block borders): `check --errors` passes, no river vertex
// lies in the squares that touch the hole, and the river edges keep all but a few centimetres of
// the line's length on valid data at each bank.
TEST(Nodata, RiverAcrossAHoleKeepsBothBanks) {
    DemGrid d = plane(40, 40);
    punch(d, 15, 15, 24, 24);  // centres x in [500450, 500720], y in [3999280, 3999550]
    // Squares touching the hole: x in (500420, 500750), y in (3999250, 3999580).
    const std::string rivers =
        riverFile("nodata_lake_rivers.geojson", {"[[500100,3999415],[501100,3999415]]"});
    for (int stride : {1, 2}) {
        SCOPED_TRACE("stride " + std::to_string(stride));
        BuildOptions o = modelOptions(d, "nodata_lake", rivers, 16);
        o.stride = stride;
        format::Reader reader;
        ASSERT_NO_FATAL_FAILURE(buildAndCheck(o, reader));
        std::string err;
        // On the stride-2 lattice (even cells) the squares touching the hole's nodes (cells 16
        // to 24) reach to cell 14 (x 500420) and 26 (x 500780).
        const double lo = 500420, hi = 500750 + 30.0 * (stride - 1);
        double west = 0, east = 0;
        for (std::size_t i = 0; i < reader.blocks().size(); ++i) {
            if (reader.blocks()[i].level != 0) continue;
            format::Block b;
            ASSERT_TRUE(reader.readBlock(i, b, err)) << err;
            const format::Level& full = b.levels.front();
            for (std::uint32_t e = 0; e < full.riverCount; ++e) {
                const format::Edge& edge = b.riverIndices[full.riverFirst + e];
                const double x0 = b.originX + b.vertices[edge.a].x;
                const double x1 = b.originX + b.vertices[edge.b].x;
                for (double x : {x0, x1})
                    EXPECT_TRUE(x <= lo || x >= hi) << x;
                (std::max(x0, x1) <= lo ? west : east) += std::fabs(x1 - x0);
            }
        }
        EXPECT_NEAR(west, lo - 500100, 0.1);
        EXPECT_NEAR(east, 501100 - hi, 0.1);
    }
}

// The build's nodata warning counts the filled small holes and the kept large ones apart: a
// 1-cell hole and a 100-cell hole are one of each (it said "2 interior holes of at most 16 cells
// (1 cells) filled" and counted the large hole among the filled).
TEST(Nodata, WarningCountsFilledAndKeptHolesApart) {
    DemGrid d = plane(40, 40);
    punch(d, 5, 5, 14, 14);    // 100 cells: kept
    punch(d, 30, 30, 30, 30);  // 1 cell: filled
    IngestOptions o;
    o.demPath = writeTiff(d, "nodata_two_holes.tif");
    std::vector<std::string> warnings;
    o.warn = [&warnings](const std::string& w) { warnings.push_back(w); };
    Ingested data;
    std::string err;
    ASSERT_TRUE(ingest(o, data, err)) << err;
    ASSERT_EQ(warnings.size(), 1u);
    EXPECT_NE(warnings[0].find("; 1 interior holes of at most 16 cells (1 cells) filled"),
              std::string::npos)
        << warnings[0];
    EXPECT_NE(warnings[0].find("(1 larger holes)"), std::string::npos) << warnings[0];
}

// A long river segment over a ridge: its heights were interpolated between its two vertices and
// the DEM points along it dropped (river clearance), so at full resolution the river and the
// terrain under it ran along the chord, 275 m below the ridge, in no stored error. Segments
// longer than two cells now get a vertex about every cell, their heights from the DEM.
TEST(Nodata, LongRiverSegmentsGetVerticesEveryCell) {
    DemGrid d = plane(60, 20);
    for (int r = 0; r < d.height; ++r) {
        for (int c = 0; c < d.width; ++c)  // a tent: 100 m at the sides, 400 m on the ridge
            d.z[std::size_t(r) * d.width + c] = float(100 + 10 * std::min(c, 60 - c));
    }
    // Along the cell centres of row 10 (y = 3999700), from column 2 to column 57.
    const std::string rivers =
        riverFile("nodata_ridge_river.geojson", {"[[500060,3999700],[501710,3999700]]"});
    const BuildOptions o = modelOptions(d, "nodata_ridge", rivers, 16);
    BuildSummary summary;
    std::string err;
    ASSERT_TRUE(runBuild(o, summary, err)) << err;
    EXPECT_NE(summary.cleaning.find("densified with"), std::string::npos) << summary.cleaning;
    format::Reader reader;
    ASSERT_TRUE(reader.open(o.outPath, err)) << err;
    double length = 0, highest = 0;
    for (std::size_t i = 0; i < reader.blocks().size(); ++i) {
        if (reader.blocks()[i].level > 0) continue;  // the leaves' full resolution
        format::Block b;
        ASSERT_TRUE(reader.readBlock(i, b, err)) << err;
        const format::Level& full = b.levels.front();
        for (std::uint32_t e = 0; e < full.riverCount; ++e) {
            const format::Edge& edge = b.riverIndices[full.riverFirst + e];
            const auto& p = b.vertices[edge.a];
            const auto& q = b.vertices[edge.b];
            const double dx = double(q.x) - p.x, dy = double(q.y) - p.y;
            EXPECT_LE(std::hypot(dx, dy), 30.0 + 1e-3) << "a river edge longer than a cell";
            length += std::hypot(dx, dy);
            highest = std::max({highest, double(p.z), double(q.z)});
        }
    }
    EXPECT_NEAR(length, 1650.0, 0.1);
    EXPECT_NEAR(highest, 400.0, 0.1);  // the river crosses the ridge at its height
}

// At --stride > 1 a build holds the raster's cells only while it reads them and samples the
// rivers' heights (bilinear, from every cell); its blocks then read the lattice alone, so the
// cells between its points are handed back (DemGrid::keepLattice): a 64th of a 97^2 raster at
// stride 8, where all of it stayed until 2026-12-02. The river still takes its heights from every
// cell: over a narrow ridge between two lattice columns it rises to the ridge's top, which no
// lattice point holds; and `check --errors` passes.
TEST(Nodata, StrideHoldsTheLatticeOnceTheRiversAreSampled) {
    DemGrid d = plane(97, 97);
    for (int r = 0; r < d.height; ++r)
        d.z[std::size_t(r) * d.width + 44] += 250;  // a ridge on column 44 (lattice: 40, 48)
    // A vertex on the ridge (x = 501320, between lattice columns 40 and 48), the river on row 50.
    const std::string rivers = riverFile("stride_ridge_rivers.geojson",
                                         {"[[501200,3998500],[501320,3998500],[501440,3998500]]"});
    BuildOptions o = modelOptions(d, "stride_ridge", rivers, 32);
    o.stride = 8;
    BuildSummary summary;
    std::string err;
    ASSERT_TRUE(runBuild(o, summary, err)) << err;
    EXPECT_EQ(summary.rasterCellsHeld, 13u * 13u);
    format::Reader reader;
    ASSERT_NO_FATAL_FAILURE(buildAndCheck(o, reader));
    double highest = 0;  // of the river's vertices
    for (std::size_t i = 0; i < reader.blocks().size(); ++i) {
        if (reader.blocks()[i].level > 0) continue;
        format::Block b;
        ASSERT_TRUE(reader.readBlock(i, b, err)) << err;
        const format::Level& full = b.levels.front();
        for (std::uint32_t e = 0; e < full.riverCount; ++e) {
            const format::Edge& edge = b.riverIndices[full.riverFirst + e];
            highest =
                std::max({highest, double(b.vertices[edge.a].z), double(b.vertices[edge.b].z)});
        }
    }
    // Column 44 at row 50 (y = 3998500): 100 + 88 + 150 + 250.
    EXPECT_NEAR(highest, 588.0, 0.01);
}

// A DEM point within the river clearance of a river is dropped (it would make slivers). Between
// two river vertices the river's heights ran along the chord, so a dropped point on a spike was
// 40 m off the full-resolution surface, in no stored error. Now the river gets a vertex where it
// passes the point (z from the DEM: the spike's height when it passes over the centre), and what
// is left (a river passing 0.6 m off a spike's centre) is in the leaf's stored error.
TEST(Nodata, DroppedPointsNextToRiversAreOnTheSurfaceAndInTheError) {
    DemGrid d = plane(20, 20);
    d.z[std::size_t(5) * d.width + 6] += 60;    // spike A at (500180, 3999850)
    d.z[std::size_t(12) * d.width + 14] += 60;  // spike B at (500420, 3999640)
    // Segments shorter than two cells (no densification); A's over the centre, B's 0.6 m off.
    const std::string rivers = riverFile(
        "nodata_spike_rivers.geojson",
        {"[[500160,3999850],[500200,3999850]]", "[[500400,3999640.6],[500445,3999640.6]]"});
    const BuildOptions o = modelOptions(d, "nodata_spikes", rivers, 16);
    BuildSummary summary;
    std::string err;
    ASSERT_TRUE(runBuild(o, summary, err)) << err;
    EXPECT_EQ(summary.droppedDemPoints, 2u);
    EXPECT_EQ(summary.droppedCellVertices, 2u);
    EXPECT_GT(summary.droppedDeviation, 0.5);  // B: the DEM's bilinear height 0.6 m off its top
    EXPECT_LT(summary.droppedDeviation, 3.0);  // not the chord's 40 m
    format::Reader reader;
    ASSERT_TRUE(reader.open(o.outPath, err)) << err;
    bool spikeA = false;
    double stored = 0;  // the largest full-resolution error of a leaf
    for (std::size_t i = 0; i < reader.blocks().size(); ++i) {
        if (reader.blocks()[i].level > 0) continue;
        format::Block b;
        ASSERT_TRUE(reader.readBlock(i, b, err)) << err;
        stored = std::max(stored, double(b.errorMax.front()));
        for (const format::Vertex& v : b.vertices) {
            if (std::fabs(b.originX + v.x - 500180) < 1e-3 &&
                std::fabs(b.originY + v.y - 3999850) < 1e-3) {
                spikeA = true;
                EXPECT_NEAR(v.z, 100 + 2 * 6 + 3 * 5 + 60, 0.01);  // the spike's own height
            }
        }
    }
    EXPECT_TRUE(spikeA) << "no river vertex on spike A";
    EXPECT_GT(stored, 0.5);
    EXPECT_GE(stored, summary.droppedDeviation);
}

// Rivers that meet at a very small angle (here both legs of a hairpin bend, millimetres apart
// near the apex) failed the build with "river segments overlap": the vertices added where the
// legs pass a dropped DEM point (pointset.h kRiverSeparation), or the legs' crossings of a block
// border (blocks.cpp), rounded to one point of the exact grid, and the block held the edge from
// the apex to it twice. Both models build and pass the full check.
TEST(Nodata, HairpinBendsBuild) {
    const DemGrid d = plane(20, 20);
    // Apex on the DEM's east edge, legs 3 mm apart there: one block.
    const std::string inBlock = riverFile(
        "nodata_hairpin.geojson", {"[[500000,3999700],[500570,3999700.003],[500000,3999700.006]]"});
    format::Reader reader;
    buildAndCheck(modelOptions(d, "nodata_hairpin", inBlock, 64), reader);
    // Apex 1 m east of the border line x = 500240 of 8-cell blocks, legs 1 cm apart at the apex.
    const std::string atBorder =
        riverFile("nodata_hairpin_border.geojson",
                  {"[[500000,3999700],[500241,3999700.01],[500000,3999700.02]]"});
    format::Reader reader2;
    buildAndCheck(modelOptions(d, "nodata_hairpin_border", atBorder, 8), reader2);
    EXPECT_GT(reader2.blocks().size(), 9u);
}

// A river line entirely outside the DEM was dropped with no word (only the summary's line
// counts said it); it is a warning now, the usual cut at the DEM's edge is not.
TEST(Nodata, RiverLinesOutsideTheDemAreWarnedAbout) {
    const DemGrid d = plane(20, 20);
    const std::string rivers =
        riverFile("nodata_outside_rivers.geojson",
                  {"[[500100,3999800],[500300,3999700]]", "[[600100,3999800],[600300,3999700]]",
                   "[[499000,3999800],[500200,3999750]]"});
    IngestOptions o;
    o.demPath = writeTiff(d, "nodata_outside.tif");
    o.riversPath = rivers;
    std::vector<std::string> warnings;
    o.warn = [&warnings](const std::string& w) { warnings.push_back(w); };
    Ingested data;
    std::string err;
    ASSERT_TRUE(ingest(o, data, err)) << err;
    EXPECT_EQ(data.rivers.size(), 2u);  // the third is cut at the DEM's edge, no warning for it
    ASSERT_EQ(warnings.size(), 1u);
    EXPECT_NE(warnings[0].find("1 of 3 lines lie entirely outside the DEM"), std::string::npos)
        << warnings[0];
}

// Builds `dem` without rivers in blocks of `blockSize` cells, checks it (`check --errors`) and
// returns the vertices of its leaves and of its tree nodes; every node over at least 256 leaf
// vertices must start from at most `nodeShare` of them (a few points of data in a corner cannot
// simplify), and the tree must have `minLevels` levels.
static std::pair<std::uint64_t, std::uint64_t> treeVertices(const DemGrid& dem,
                                                            const std::string& name, int blockSize,
                                                            double nodeShare,
                                                            std::uint32_t minLevels) {
    format::Reader reader;
    buildAndCheck(modelOptions(dem, name, "", blockSize), reader);
    const std::vector<format::BlockInfo>& dir = reader.blocks();
    std::uint64_t leafVertices = 0, nodeVertices = 0;
    std::uint32_t levels = 0, large = 0;
    // The vertices of the leaves under each entry (file order: a node's children before it).
    std::vector<std::uint64_t> under(dir.size(), 0);
    for (std::size_t i = 0; i < dir.size(); ++i) {
        const format::BlockInfo& b = dir[i];
        levels = std::max(levels, b.level);
        (b.level == 0 ? leafVertices : nodeVertices) += b.vertexCount;
        if (b.level == 0) {
            under[i] = b.vertexCount;
            continue;
        }
        for (std::uint32_t c = b.firstChild; c < b.firstChild + b.childCount; ++c)
            under[i] += under[c];
        if (under[i] >= 256 && double(b.vertexCount) > nodeShare * double(under[i]) && large++ < 3)
            ADD_FAILURE() << "node (" << b.col << "," << b.row << ") of level " << b.level
                          << " starts from " << b.vertexCount << " of its leaves' " << under[i]
                          << " vertices";
    }
    EXPECT_GE(levels, minLevels);
    return {leafVertices, nodeVertices};
}

// A DEM far from square: a strip of 8 rows (the long sides are the DEM's outer edge, not locked),
// cut into blocks of 64 cells. Each block's hand-over (nodebuild.h nodeHandoffTriangles) counts
// its actual rectangle and locked sides; with a square block's counts (64^2 / 8 = 512 triangles
// of the block's 1 024, and 8 64 2^L for a node, above what its children hand over) every node
// started from its children whole and the tree stored each point once per level. On a gently
// rough plane (below every hand-over error) every node starts from under a quarter of its
// leaves' vertices, the nodes together hold at most 1.3 times the leaves' (issue 18's file-size
// rule), and the model passes `check --errors`.
TEST(Nodata, StripNodesStartFromSimplifiedChildren) {
    DemGrid d = plane(1000, 8);
    std::mt19937 rng(5);
    for (float& z : d.z)
        z += float(rng() % 100) / 200.0f;  // 0 - 0.5 m
    const auto [leaves, nodes] = treeVertices(d, "strip", 64, 0.25, 4);
    EXPECT_LE(double(nodes), 1.3 * double(leaves));
}

// Terrain rougher than every hand-over error (heights 0 - 100 m at random, blocks of 32 cells
// of 30 m: hand-over errors 3.75 m and above, capped at the model's extent / 1920 = 2 m): the
// first deletion of every block costs more, so the error rule handed every state over whole and
// the root held every point (3.4 deletion steps per point on a 1M-point model of 1 m cells).
// The error rule hands over only below an eighth of the triangles of the original points
// (nodebuild.h kHandoffShare): every node starts from at most a quarter of its leaves' vertices.
TEST(Nodata, RoughTerrainNodesStartFromSimplifiedChildren) {
    DemGrid d = plane(128, 128);
    std::mt19937 rng(7);
    for (float& z : d.z)
        z = float(rng() % 10000) / 100.0f;
    const auto [leaves, nodes] = treeVertices(d, "rough", 32, 0.25, 2);
    EXPECT_LE(double(nodes), 0.5 * double(leaves));
}
