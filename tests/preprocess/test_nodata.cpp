// Nodata handling (nodata.h): small interior holes filled, large ones refused, border-connected
// nodata left alone; bays reaching into a block's hull filled when few, refused when many; the
// built model passes the full check.
#include <gdal_priv.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include "build.h"
#include "nodata.h"
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
    std::vector<float> z = d.z;
    EXPECT_EQ(ds->GetRasterBand(1)->RasterIO(GF_Write, 0, 0, d.width, d.height, z.data(), d.width,
                                             d.height, GDT_Float32, 0, 0),
              CE_None);
    GDALClose(ds);
    return path;
}

// One short river away from the nodata.
std::string riverFile(const std::string& name) {
    const std::string path = testing::TempDir() + name;
    std::ofstream(path)
        << R"({"type":"FeatureCollection","crs":{"type":"name","properties":)"
        << R"({"name":"urn:ogc:def:crs:EPSG::32616"}},"features":[{"type":)"
        << R"("Feature","properties":{},"geometry":{"type":"LineString",)"
        << R"("coordinates":[[500301,3999499],[500452,3999402],[500607,3999301]]}}]})";
    return path;
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

TEST(Nodata, LargeHoleIsRefusedAndBorderNodataLeftAlone) {
    DemGrid d = plane(30, 30);
    punch(d, 5, 5, 14, 14);  // 100 interior cells
    NodataStats s;
    std::string err;
    EXPECT_FALSE(fillSmallHoles(d, "big.tif", 16, s, err));
    EXPECT_NE(err.find("big.tif"), std::string::npos) << err;
    EXPECT_NE(err.find("100 cells"), std::string::npos) << err;

    DemGrid e = plane(30, 30);
    punch(e, 0, 0, 29, 3);  // a strip along the top border: outside the data
    ASSERT_TRUE(fillSmallHoles(e, "edge.tif", 16, s, err)) << err;
    EXPECT_EQ(s.holes, 0u);
    EXPECT_EQ(s.filledCells, 0u);
    EXPECT_TRUE(std::isnan(e.at(10, 2)));
}

TEST(Nodata, BaysInsideABlockHullAreFilledWhenFewRefusedWhenMany) {
    const std::string rivers = riverFile("nodata_rivers.geojson");
    // A 3-cell wide, 3-cell deep notch from the top border: inside the hull of the block's
    // points (the cells beside it are valid) -> filled, and the model passes the full check.
    DemGrid small = plane(40, 40);
    punch(small, 18, 0, 20, 2);
    BuildOptions o;
    o.demPath = writeTiff(small, "nodata_small_bay.tif");
    o.riversPath = rivers;
    o.outPath = testing::TempDir() + "nodata_small_bay.ulod";
    o.blockSize = 39;
    o.force = true;
    BuildSummary summary;
    std::string err;
    ASSERT_TRUE(runBuild(o, summary, err)) << err;
    EXPECT_EQ(summary.nodataCells, 9u);
    EXPECT_GE(summary.filledNodataCells, 6u);  // at least the two rows strictly inside the hull
    UlodCheckSummary cs;
    ASSERT_TRUE(checkUlod(o.outPath, {}, cs, err)) << err;

    // A 10-cell wide, 20-cell deep bay: 200 cells inside the hull -> refused, no output.
    DemGrid big = plane(40, 40);
    punch(big, 15, 0, 24, 19);
    o.demPath = writeTiff(big, "nodata_big_bay.tif");
    o.outPath = testing::TempDir() + "nodata_big_bay.ulod";
    std::filesystem::remove(o.outPath);
    EXPECT_FALSE(runBuild(o, summary, err));
    EXPECT_NE(err.find("nodata_big_bay.tif"), std::string::npos) << err;
    EXPECT_NE(err.find("would bridge"), std::string::npos) << err;
    EXPECT_FALSE(std::filesystem::exists(o.outPath));
}
