// DEM ingestion (preprocess/dem.h): the bundled geographic DEM warped to UTM, exact bilinear
// sampling on small hand-made GeoTIFFs, nodata -> NaN, and every error case naming the file.
#include <gtest/gtest.h>

#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>
#include "testutil.h"

#include <bit>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <optional>

#include <cpl_vsi.h>
#include <gdal_priv.h>
#include <gdal_utils.h>
#include <ogr_spatialref.h>

#include "dem.h"
#include "ingest.h"

using namespace unilod;
namespace fs = std::filesystem;

namespace {

const std::string kAssets = UNILOD_ASSETS_DIR;

using unilod::test::TempDir;

// Writes a north-up GeoTIFF whose cell (c, r) of band b holds values[b][r * w + c].
void writeTiff(const std::string& path, int w, int h,
               const std::vector<std::vector<double>>& values, GDALDataType type,
               const double gt[6], int epsg, std::optional<double> noData = std::nullopt) {
    GDALAllRegister();
    GDALDriver* driver = GetGDALDriverManager()->GetDriverByName("GTiff");
    ASSERT_NE(driver, nullptr);
    GDALDatasetUniquePtr ds(
        driver->Create(path.c_str(), w, h, static_cast<int>(values.size()), type, nullptr));
    ASSERT_TRUE(ds);
    double g[6];
    std::copy(gt, gt + 6, g);
    ds->SetGeoTransform(g);
    if (epsg != 0) {
        OGRSpatialReference srs;
        srs.importFromEPSG(epsg);
        ds->SetSpatialRef(&srs);
    }
    for (std::size_t b = 0; b < values.size(); ++b) {
        GDALRasterBand* band = ds->GetRasterBand(static_cast<int>(b) + 1);
        if (noData) band->SetNoDataValue(*noData);
        std::vector<double> v = values[b];
        ASSERT_EQ(band->RasterIO(GF_Write, 0, 0, w, h, v.data(), w, h, GDT_Float64, 0, 0, nullptr),
                  CE_None);
    }
}

// Sets band 1's scale, offset and unit type of the raster at `path`.
void describeBand(const std::string& path, double scale, double offset, const char* unit) {
    GDALDatasetUniquePtr ds(GDALDataset::Open(path.c_str(), GDAL_OF_RASTER | GDAL_OF_UPDATE));
    ASSERT_TRUE(ds);
    GDALRasterBand* band = ds->GetRasterBand(1);
    ASSERT_EQ(band->SetScale(scale), CE_None);
    ASSERT_EQ(band->SetOffset(offset), CE_None);
    ASSERT_EQ(band->SetUnitType(unit), CE_None);
}

// Load options whose warnings go to `warnings`.
DemLoadOptions collecting(std::vector<std::string>& warnings) {
    DemLoadOptions o;
    o.warn = [&warnings](const std::string& w) { warnings.push_back(w); };
    return o;
}

// 4 x 3 grid of 10 m cells, upper-left corner (500000, 4000000), EPSG:32616.
const double kGt[6] = {500000.0, 10.0, 0.0, 4000000.0, 0.0, -10.0};

}  // namespace

TEST(Dem, BundledDemIsWarpedToUtm) {
    DemGrid dem;
    std::string error;
    ASSERT_TRUE(loadDem(kAssets + "/jacksboro_dem.tif", {}, dem, error)) << error;
    EXPECT_GT(dem.width, 300);
    EXPECT_GT(dem.height, 300);
    EXPECT_EQ(dem.z.size(), static_cast<std::size_t>(dem.width) * dem.height);
    // 3 arc-seconds is ~75 m (east) by ~93 m (north) at 36.5 N; GDAL picks square cells between.
    EXPECT_GT(std::abs(dem.cellX), 60.0);
    EXPECT_LT(std::abs(dem.cellX), 100.0);
    EXPECT_LT(dem.cellY, 0.0);

    // The working CRS is the UTM zone of the centre, longitude ~ -84.1: zone 16 or 17 north.
    OGRSpatialReference srs;
    ASSERT_EQ(srs.importFromWkt(dem.wkt.c_str()), OGRERR_NONE);
    EXPECT_TRUE(srs.IsProjected());
    int north = 0;
    const int zone = srs.GetUTMZone(&north);
    EXPECT_TRUE(zone == 16 || zone == 17) << zone;
    EXPECT_TRUE(north);
    // The grid centre, back in longitude / latitude, is the DEM's centre.
    OGRSpatialReference wgs84;
    wgs84.importFromEPSG(4326);
    wgs84.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
    srs.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
    std::unique_ptr<OGRCoordinateTransformation> ct(
        OGRCreateCoordinateTransformation(&srs, &wgs84));
    ASSERT_TRUE(ct);
    double x = dem.centreX(dem.width / 2), y = dem.centreY(dem.height / 2);
    ASSERT_TRUE(ct->Transform(1, &x, &y));
    EXPECT_NEAR(x, -84.413750 + 0.5 * 403 * 0.000833333, 0.01);
    EXPECT_NEAR(y, 36.732917 - 0.5 * 344 * 0.000833333, 0.01);

    // The source spans 236..1076 m; bilinear resampling can only shrink that range a little.
    float zMin = 1e9f, zMax = -1e9f;
    std::size_t valid = 0;
    for (float z : dem.z) {
        if (std::isnan(z)) continue;
        ++valid;
        zMin = std::min(zMin, z);
        zMax = std::max(zMax, z);
    }
    EXPECT_GE(zMin, 236.0f - 0.01f);
    EXPECT_LE(zMin, 236.0f + 15.0f);
    EXPECT_LE(zMax, 1076.0f + 0.01f);
    EXPECT_GE(zMax, 1076.0f - 40.0f);
    // The rotated footprint leaves nodata corners, but most of the grid is data.
    EXPECT_GT(valid, dem.z.size() * 8 / 10);
    EXPECT_LT(valid, dem.z.size());
}

// The reprojection warps straight into the grid (dem.cpp warpInto): the cells are GDAL's own
// gdalwarp output (the same options into a MEM dataset, as loadDem made it until 2026-12-02),
// bit for bit, on one thread or all of them.
TEST(Dem, ReprojectedCellsAreGdalwarpsOnAnyThreadCount) {
    const std::string path = kAssets + "/jacksboro_dem.tif";
    GDALAllRegister();
    GDALDatasetUniquePtr src(GDALDataset::Open(path.c_str(), GDAL_OF_RASTER));
    ASSERT_TRUE(src);
    for (int threads : {1, 0}) {
        SCOPED_TRACE(threads);
        DemLoadOptions options;
        options.threads = threads;
        DemGrid dem;
        std::string error;
        ASSERT_TRUE(loadDem(path, options, dem, error)) << error;
        std::vector<std::string> args{"-of",     "MEM",        "-r",  "bilinear", "-ot",
                                      "Float32", "-dstnodata", "nan", "-t_srs",   dem.wkt};
        std::vector<char*> argv;
        for (std::string& a : args)
            argv.push_back(a.data());
        argv.push_back(nullptr);
        GDALWarpAppOptions* opts = GDALWarpAppOptionsNew(argv.data(), nullptr);
        ASSERT_NE(opts, nullptr);
        GDALDatasetH srcHandle = GDALDataset::ToHandle(src.get());
        GDALDatasetUniquePtr ref(
            GDALDataset::FromHandle(GDALWarp("", nullptr, 1, &srcHandle, opts, nullptr)));
        GDALWarpAppOptionsFree(opts);
        ASSERT_TRUE(ref);
        ASSERT_EQ(ref->GetRasterXSize(), dem.width);
        ASSERT_EQ(ref->GetRasterYSize(), dem.height);
        double gt[6];
        ASSERT_EQ(ref->GetGeoTransform(gt), CE_None);
        EXPECT_EQ(gt[1], dem.cellX);
        EXPECT_EQ(gt[5], dem.cellY);
        EXPECT_EQ(gt[0] + 0.5 * gt[1], dem.originX);
        EXPECT_EQ(gt[3] + 0.5 * gt[5], dem.originY);
        std::vector<float> cells(dem.z.size());
        ASSERT_EQ(
            ref->GetRasterBand(1)->RasterIO(GF_Read, 0, 0, dem.width, dem.height, cells.data(),
                                            dem.width, dem.height, GDT_Float32, 0, 0, nullptr),
            CE_None);
        std::size_t differ = 0, valid = 0;
        for (std::size_t i = 0; i < cells.size(); ++i) {
            const bool nan = std::isnan(cells[i]);
            valid += nan ? 0 : 1;
            if (nan != std::isnan(dem.z[i]) || (!nan && cells[i] != dem.z[i])) ++differ;
        }
        EXPECT_EQ(differ, 0u);
        EXPECT_GT(valid, cells.size() / 2);
    }
}

// A raster is held once while it is read (dem.cpp, 2026-12-02): the grid, 4 bytes a cell, and
// not GDAL's block cache of the whole file beside it (which it was: a projected Float32 raster
// took 8 bytes a cell), nor, for a reprojected one, a warped copy as well (12 bytes a cell and
// more). Measured in a forked child, as the growth of its peak resident memory over what it
// started with: 6 000 x 6 000 cells (a 144 MB grid) read in UTM and in degrees; the bounds leave
// 64 MB for the first (a row of blocks cached, the libraries' own) and 192 MB for the second
// (the warp's capped block cache and chunk buffers, 64 MB each), where holding it twice adds
// 144 MB (the previous code grew 298 and 479 MB). The child warps on its own thread: GDAL's warp
// threads, started by an earlier test, stay in the parent, and a child waiting for them hangs.
TEST(Dem, RasterIsHeldOnceWhileRead) {
    if (unilod::test::kAddressSanitizer)
        GTEST_SKIP() << "resident memory is not the program's own under AddressSanitizer";
    TempDir dir("dem_memory");
    const int side = 6000;
    auto writeRaster = [&](const std::string& name, int epsg, const double gt[6]) {
        const std::string path = dir.file(name);
        GDALAllRegister();
        GDALDriver* driver = GetGDALDriverManager()->GetDriverByName("GTiff");
        CPLStringList create;
        create.AddString("TILED=YES");
        GDALDatasetUniquePtr ds(
            driver->Create(path.c_str(), side, side, 1, GDT_Float32, create.List()));
        EXPECT_TRUE(ds);
        if (!ds) return path;
        double g[6];
        std::copy(gt, gt + 6, g);
        ds->SetGeoTransform(g);
        OGRSpatialReference srs;
        srs.importFromEPSG(epsg);
        ds->SetSpatialRef(&srs);
        std::vector<float> row(side);
        for (int r = 0; r < side; ++r) {
            for (int c = 0; c < side; ++c)
                row[c] = float(300 + 200 * std::sin(c * 0.01) * std::cos(r * 0.013));
            EXPECT_EQ(ds->GetRasterBand(1)->RasterIO(GF_Write, 0, r, side, 1, row.data(), side, 1,
                                                     GDT_Float32, 0, 0, nullptr),
                      CE_None);
        }
        return path;
    };
    const double utm[6] = {500000, 30, 0, 4200000, 0, -30};
    const double geo[6] = {-84.5, 0.0003, 0, 36.9, 0, -0.0003};
    const std::string projected = writeRaster("utm.tif", 32616, utm);
    const std::string degrees = writeRaster("geo.tif", 4326, geo);

    // Peak resident growth of loadDem(path) in a child, in bytes, with the grid's cells.
    auto growth = [](const std::string& path, double& cells) {
        int fd[2];
        if (pipe(fd) != 0) return -1.0;
        const pid_t pid = fork();
        if (pid == 0) {
            close(fd[0]);
            long pages = 0, resident = 0;
            if (FILE* f = std::fopen("/proc/self/statm", "r")) {
                if (std::fscanf(f, "%ld %ld", &pages, &resident) != 2) resident = 0;
                std::fclose(f);
            }
            const double start = double(resident) * double(sysconf(_SC_PAGESIZE));
            DemLoadOptions options;
            options.threads = 1;
            DemGrid dem;
            std::string error;
            const bool ok = loadDem(path, options, dem, error);
            rusage usage{};
            getrusage(RUSAGE_SELF, &usage);
            const double out[2] = {ok ? double(usage.ru_maxrss) * 1024.0 - start : -1.0,
                                   double(dem.z.size())};
            const bool written = ::write(fd[1], out, sizeof out) == sizeof out;
            _exit(written ? 0 : 1);
        }
        close(fd[1]);
        double in[2] = {-1, 0};
        const bool read = ::read(fd[0], in, sizeof in) == sizeof in;
        close(fd[0]);
        int status = 0;
        waitpid(pid, &status, 0);
        cells = in[1];
        return read && WIFEXITED(status) && WEXITSTATUS(status) == 0 ? in[0] : -1.0;
    };
    double cells = 0;
    const double mb = 1 << 20;
    const double projectedGrowth = growth(projected, cells);
    EXPECT_EQ(cells, double(side) * side);
    EXPECT_GT(projectedGrowth, cells * 4);
    EXPECT_LT(projectedGrowth, cells * 4 + 64 * mb);
    const double degreesGrowth = growth(degrees, cells);
    EXPECT_GT(cells, double(side) * side * 0.9);
    EXPECT_GT(degreesGrowth, cells * 4);
    EXPECT_LT(degreesGrowth, cells * 4 + 192 * mb);
    std::printf("read %.0f MB, %.0f MB reprojected (grids %.0f MB)\n", projectedGrowth / mb,
                degreesGrowth / mb, cells * 4 / mb);
}

TEST(Dem, TargetSrsIsHonoured) {
    DemGrid dem;
    std::string error;
    DemLoadOptions o;
    o.targetSrs = "EPSG:32617";
    ASSERT_TRUE(loadDem(kAssets + "/jacksboro_dem.tif", o, dem, error)) << error;
    OGRSpatialReference srs;
    ASSERT_EQ(srs.importFromWkt(dem.wkt.c_str()), OGRERR_NONE);
    int north = 0;
    EXPECT_EQ(srs.GetUTMZone(&north), 17);

    o.targetSrs = "EPSG:4326";  // not metric
    EXPECT_FALSE(loadDem(kAssets + "/jacksboro_dem.tif", o, dem, error));
    EXPECT_NE(error.find("jacksboro_dem.tif"), std::string::npos) << error;
    o.targetSrs = "no such crs";
    EXPECT_FALSE(loadDem(kAssets + "/jacksboro_dem.tif", o, dem, error));
}

TEST(Dem, ProjectedGridKeptAndSampledBilinearly) {
    TempDir dir("bilinear");
    const std::string path = dir.file("grid.tif");
    // z(c, r) = c^2 + 7 r + c r: not bilinear overall, so only the right four cells give the
    // right value.
    std::vector<double> v;
    for (int r = 0; r < 3; ++r) {
        for (int c = 0; c < 4; ++c)
            v.push_back(c * c + 7.0 * r + c * r);
    }
    writeTiff(path, 4, 3, {v}, GDT_Float32, kGt, 32616);

    DemGrid dem;
    std::string error;
    ASSERT_TRUE(loadDem(path, {}, dem, error)) << error;
    EXPECT_EQ(dem.width, 4);
    EXPECT_EQ(dem.height, 3);
    EXPECT_DOUBLE_EQ(dem.originX, 500005.0);
    EXPECT_DOUBLE_EQ(dem.originY, 3999995.0);
    EXPECT_DOUBLE_EQ(dem.cellX, 10.0);
    EXPECT_DOUBLE_EQ(dem.cellY, -10.0);
    for (std::size_t i = 0; i < v.size(); ++i)
        EXPECT_EQ(dem.z[i], static_cast<float>(v[i]));
    OGRSpatialReference srs;
    ASSERT_EQ(srs.importFromWkt(dem.wkt.c_str()), OGRERR_NONE);
    EXPECT_STREQ(srs.GetAuthorityCode(nullptr), "32616");

    auto z = [&](int c, int r) { return c * c + 7.0 * r + c * r; };
    // Cell centres: exact values.
    for (int r = 0; r < 3; ++r) {
        for (int c = 0; c < 4; ++c) {
            EXPECT_DOUBLE_EQ(dem.sample(dem.centreX(c), dem.centreY(r)), z(c, r));
        }
    }
    // Between centres (1, 0), (2, 0), (1, 1), (2, 1) at fractions tx = 0.25, ty = 0.5.
    const double tx = 0.25, ty = 0.5;
    const double expected = (1 - tx) * (1 - ty) * z(1, 0) + tx * (1 - ty) * z(2, 0) +
                            (1 - tx) * ty * z(1, 1) + tx * ty * z(2, 1);
    EXPECT_NEAR(dem.sample(500015.0 + 2.5, 3999995.0 - 5.0), expected, 1e-12);
    // The far corner centre and the edges are inside; beyond the last centres is outside.
    EXPECT_DOUBLE_EQ(dem.sample(dem.centreX(3), dem.centreY(2)), z(3, 2));
    EXPECT_NEAR(dem.sample(dem.centreX(3), dem.centreY(0) - 2.0),
                z(3, 0) + 0.2 * (z(3, 1) - z(3, 0)), 1e-12);
    EXPECT_TRUE(std::isnan(dem.sample(dem.centreX(3) + 0.001, dem.centreY(0))));
    EXPECT_TRUE(std::isnan(dem.sample(dem.centreX(0), dem.centreY(0) + 0.001)));
    EXPECT_TRUE(std::isnan(dem.sample(500000.0, 4000000.0)));  // the grid corner: half a cell out
}

TEST(Dem, NodataBecomesNaN) {
    TempDir dir("nodata");
    const std::string path = dir.file("nodata.tif");
    std::vector<double> v(12, 100.0);
    v[1 * 4 + 2] = -9999.0;  // nodata at (2, 1)
    v[0] = std::nan("");     // NaN cell
    v[11] = INFINITY;        // infinite cell
    writeTiff(path, 4, 3, {v}, GDT_Float32, kGt, 32616, -9999.0);
    DemGrid dem;
    std::string error;
    ASSERT_TRUE(loadDem(path, {}, dem, error)) << error;
    EXPECT_TRUE(std::isnan(dem.at(2, 1)));
    EXPECT_TRUE(std::isnan(dem.at(0, 0)));
    EXPECT_TRUE(std::isnan(dem.at(3, 2)));
    EXPECT_EQ(dem.at(1, 1), 100.0f);
    // Touching the nodata cell: NaN; on a centre row that does not use it: a value.
    EXPECT_TRUE(std::isnan(dem.sample(dem.centreX(1) + 5.0, dem.centreY(1) - 5.0)));
    EXPECT_TRUE(std::isnan(dem.sample(dem.centreX(2), dem.centreY(1))));
    EXPECT_EQ(dem.sample(dem.centreX(1) + 5.0, dem.centreY(2)), 100.0);
    EXPECT_EQ(dem.sample(dem.centreX(1), dem.centreY(1) - 5.0), 100.0);
    // Next to the nodata column, a hair off the centre column still counts as on it.
    EXPECT_EQ(dem.sample(dem.centreX(1) + 5e-9, dem.centreY(1) - 5.0), 100.0);
    EXPECT_TRUE(std::isnan(dem.sample(dem.centreX(1) + 1e-6, dem.centreY(1) - 5.0)));
}

TEST(Dem, IntegerNodataBecomesNaN) {
    TempDir dir("int16");
    const std::string path = dir.file("int16.tif");
    std::vector<double> v(12, 5.0);
    v[5] = -32768;
    writeTiff(path, 4, 3, {v}, GDT_Int16, kGt, 32616, -32768);
    DemGrid dem;
    std::string error;
    ASSERT_TRUE(loadDem(path, {}, dem, error)) << error;
    EXPECT_TRUE(std::isnan(dem.z[5]));
    EXPECT_EQ(dem.z[4], 5.0f);
}

TEST(Dem, MultiBandNeedsABand) {
    TempDir dir("multiband");
    const std::string path = dir.file("two.tif");
    writeTiff(path, 4, 3, {std::vector<double>(12, 1.0), std::vector<double>(12, 2.0)}, GDT_Float32,
              kGt, 32616);
    DemGrid dem;
    std::string error;
    EXPECT_FALSE(loadDem(path, {}, dem, error));
    EXPECT_NE(error.find(path), std::string::npos) << error;
    EXPECT_NE(error.find("2 bands"), std::string::npos) << error;

    DemLoadOptions o;
    o.band = 2;
    ASSERT_TRUE(loadDem(path, o, dem, error)) << error;
    EXPECT_EQ(dem.z[0], 2.0f);
    o.band = 3;
    EXPECT_FALSE(loadDem(path, o, dem, error));
    EXPECT_NE(error.find("out of range"), std::string::npos) << error;
}

TEST(Dem, GeographicMultiBandWarpsTheChosenBand) {
    TempDir dir("geo");
    const std::string path = dir.file("geo.tif");
    const double gt[6] = {-84.2, 0.001, 0, 36.5, 0, -0.001};
    writeTiff(path, 4, 3, {std::vector<double>(12, 1.0), std::vector<double>(12, 250.0)},
              GDT_Float32, gt, 4326);
    DemGrid dem;
    std::string error;
    DemLoadOptions o;
    o.band = 2;
    ASSERT_TRUE(loadDem(path, o, dem, error)) << error;
    OGRSpatialReference srs;
    ASSERT_EQ(srs.importFromWkt(dem.wkt.c_str()), OGRERR_NONE);
    int north = 0;
    EXPECT_EQ(srs.GetUTMZone(&north), 16);  // -84.2 is in zone 16 (-90..-84)
    std::size_t valid = 0;
    for (float z : dem.z) {
        if (std::isnan(z)) continue;
        ++valid;
        EXPECT_NEAR(z, 250.0f, 1e-3f);
    }
    EXPECT_GT(valid, 0u);
}

// A clipped DEM often marks the cells outside the clip with a mask instead of a nodata value:
// an alpha band (gdalwarp -cutline -dstalpha: of the DEM's type, 0 outside, the type's maximum
// inside) or a per-dataset mask (gdal_translate -mask, GDAL_TIFF_INTERNAL_MASK). Those cells
// hold 0, which is a valid altitude: they are nodata, in a projected DEM (read as it is) and in
// a geographic one (warped), and the alpha band is no altitude band to choose.
TEST(Dem, MaskedCellsAreNodata) {
    TempDir dir("mask");
    std::vector<double> z(12, 300.0), alpha(12, 32767.0);
    for (int i : {0, 1, 4, 11}) {
        z[std::size_t(i)] = 0.0;
        alpha[std::size_t(i)] = 0.0;
    }
    const double geo[6] = {-84.2, 0.001, 0, 36.5, 0, -0.001};
    for (int epsg : {32616, 4326}) {
        const double* gt = epsg == 4326 ? geo : kGt;
        const std::string alphaPath = dir.file("alpha" + std::to_string(epsg) + ".tif");
        writeTiff(alphaPath, 4, 3, {z, alpha}, GDT_Int16, gt, epsg);
        {
            GDALDatasetUniquePtr ds(
                GDALDataset::Open(alphaPath.c_str(), GDAL_OF_RASTER | GDAL_OF_UPDATE));
            ASSERT_TRUE(ds);
            ASSERT_EQ(ds->GetRasterBand(2)->SetColorInterpretation(GCI_AlphaBand), CE_None);
        }
        const std::string maskPath = dir.file("mask" + std::to_string(epsg) + ".tif");
        writeTiff(maskPath, 4, 3, {z}, GDT_Int16, gt, epsg);
        {
            CPLSetConfigOption("GDAL_TIFF_INTERNAL_MASK", "YES");
            GDALDatasetUniquePtr ds(
                GDALDataset::Open(maskPath.c_str(), GDAL_OF_RASTER | GDAL_OF_UPDATE));
            ASSERT_TRUE(ds);
            ASSERT_EQ(ds->CreateMaskBand(GMF_PER_DATASET), CE_None);
            std::vector<std::uint8_t> m(12);
            for (std::size_t i = 0; i < 12; ++i)
                m[i] = alpha[i] > 0 ? 255 : 0;
            ASSERT_EQ(ds->GetRasterBand(1)->GetMaskBand()->RasterIO(GF_Write, 0, 0, 4, 3, m.data(),
                                                                    4, 3, GDT_Byte, 0, 0, nullptr),
                      CE_None);
            CPLSetConfigOption("GDAL_TIFF_INTERNAL_MASK", nullptr);
        }
        for (const std::string& path : {alphaPath, maskPath}) {
            DemGrid dem;
            std::string error;
            ASSERT_TRUE(loadDem(path, {}, dem, error)) << path << ": " << error;
            std::size_t valid = 0;
            for (float v : dem.z) {
                if (std::isnan(v)) continue;
                ++valid;
                EXPECT_NEAR(v, 300.0f, 1e-3f) << path << ": a masked cell kept its 0";
            }
            if (epsg == 32616) {
                EXPECT_EQ(valid, 8u) << path;
                EXPECT_TRUE(std::isnan(dem.at(0, 0)) && std::isnan(dem.at(3, 2))) << path;
            } else {
                EXPECT_GT(valid, 0u) << path;
            }
        }
    }
}

// A container of several rasters (a GeoPackage with two tables; netCDF and HDF5 alike) has no
// bands itself: the error names its subdatasets, and a subdataset name is a DEM like a path.
TEST(Dem, SubdatasetsAreNamedAndReadable) {
    TempDir dir("subdatasets");
    const std::string tif = dir.file("src.tif"), gpkg = dir.file("two.gpkg");
    std::vector<double> z(12, 120.0);
    z[5] = 150.0;
    writeTiff(tif, 4, 3, {z}, GDT_Float32, kGt, 32616);
    GDALDriver* driver = GetGDALDriverManager()->GetDriverByName("GPKG");
    ASSERT_NE(driver, nullptr);
    {
        GDALDatasetUniquePtr src(GDALDataset::Open(tif.c_str(), GDAL_OF_RASTER));
        ASSERT_TRUE(src);
        const char* first[] = {"RASTER_TABLE=elev", nullptr};
        GDALDatasetUniquePtr(driver->CreateCopy(gpkg.c_str(), src.get(), false,
                                                const_cast<char**>(first), nullptr, nullptr));
        const char* second[] = {"RASTER_TABLE=other", "APPEND_SUBDATASET=YES", nullptr};
        GDALDatasetUniquePtr(driver->CreateCopy(gpkg.c_str(), src.get(), false,
                                                const_cast<char**>(second), nullptr, nullptr));
    }
    DemGrid dem;
    std::string error;
    EXPECT_FALSE(loadDem(gpkg, {}, dem, error));
    EXPECT_NE(error.find("holds 2 rasters (subdatasets)"), std::string::npos) << error;
    EXPECT_NE(error.find("'GPKG:" + gpkg + ":elev', 'GPKG:" + gpkg + ":other'"), std::string::npos)
        << error;
    ASSERT_TRUE(loadDem("GPKG:" + gpkg + ":elev", {}, dem, error)) << error;
    EXPECT_EQ(dem.width, 4);
    EXPECT_FLOAT_EQ(dem.at(1, 1), 150.0f);
    EXPECT_FALSE(loadDem("GPKG:" + dir.file("none.gpkg") + ":elev", {}, dem, error));
    EXPECT_NE(error.find("no such file"), std::string::npos) << error;
}

// A DEM in a zip archive: GDAL reads it by a /vsizip/ name only; the archive's own path gets
// an error naming its files as such names, and that name reads.
TEST(Dem, ArchivesNameTheirFiles) {
    TempDir dir("archive");
    const std::string tif = dir.file("dem.tif"), zip = dir.file("dem.zip");
    std::vector<double> z(12, 80.0);
    writeTiff(tif, 4, 3, {z}, GDT_Float32, kGt, 32616);
    {
        std::ifstream in(tif, std::ios::binary);
        const std::string bytes((std::istreambuf_iterator<char>(in)), {});
        VSILFILE* f = VSIFOpenL(("/vsizip/" + zip + "/dem.tif").c_str(), "wb");
        ASSERT_NE(f, nullptr);
        ASSERT_EQ(VSIFWriteL(bytes.data(), 1, bytes.size(), f), bytes.size());
        ASSERT_EQ(VSIFCloseL(f), 0);
    }
    DemGrid dem;
    std::string error;
    EXPECT_FALSE(loadDem(zip, {}, dem, error));
    EXPECT_NE(error.find("it is an archive: give the file inside it by a name such as '/vsizip/" +
                         zip + "/dem.tif'"),
              std::string::npos)
        << error;
    ASSERT_TRUE(loadDem("/vsizip/" + zip + "/dem.tif", {}, dem, error)) << error;
    EXPECT_FLOAT_EQ(dem.at(2, 1), 80.0f);
}

TEST(Dem, Errors) {
    TempDir dir("errors");
    DemGrid dem;
    std::string error;

    const std::string missing = dir.file("missing.tif");
    EXPECT_FALSE(loadDem(missing, {}, dem, error));
    EXPECT_NE(error.find(missing), std::string::npos) << error;
    EXPECT_NE(error.find("no such file"), std::string::npos) << error;

    const std::string text = dir.file("notes.txt");
    std::ofstream(text) << "this is not a raster\n";
    EXPECT_FALSE(loadDem(text, {}, dem, error));
    EXPECT_NE(error.find(text), std::string::npos) << error;
    EXPECT_NE(error.find("not a raster"), std::string::npos) << error;

    const std::string empty = dir.file("nodata.tif");
    writeTiff(empty, 4, 3, {std::vector<double>(12, -1.0)}, GDT_Float32, kGt, 32616, -1.0);
    EXPECT_FALSE(loadDem(empty, {}, dem, error));
    EXPECT_NE(error.find(empty), std::string::npos) << error;
    EXPECT_NE(error.find("nodata"), std::string::npos) << error;
    EXPECT_TRUE(dem.z.empty());

    // Degrees beyond the poles: a wrong georeferencing, named as such.
    const std::string pole = dir.file("beyond_pole.tif");
    const double beyond[6] = {-54.0, 1.0, 0.0, 116.5, 0.0, -1.0};
    writeTiff(pole, 4, 54, {std::vector<double>(4 * 54, 100.0)}, GDT_Float32, beyond, 4326);
    EXPECT_FALSE(loadDem(pole, {}, dem, error));
    EXPECT_NE(error.find(pole), std::string::npos) << error;
    EXPECT_NE(error.find("latitudes 62.5 to 116.5"), std::string::npos) << error;
    EXPECT_NE(error.find("beyond the poles"), std::string::npos) << error;

    // A vector file is not a raster either.
    EXPECT_FALSE(loadDem(kAssets + "/jacksboro_rivers_grass.geojson", {}, dem, error));
    EXPECT_NE(error.find("jacksboro_rivers_grass.geojson"), std::string::npos) << error;
}

// A rotated grid (rotation terms in the geotransform, as some survey rasters have) is resampled
// to a north-up grid in its own CRS, or in its own coordinates when it declares none. Its cells
// hold a plane of the CRS coordinates, which bilinear resampling reproduces exactly wherever the
// new cell lies inside the rotated footprint.
TEST(Dem, RotatedGridIsResampledNorthUp) {
    TempDir dir("rotated");
    const int n = 24;
    const double angle = 30.0 * 3.14159265358979323846 / 180, cell = 10.0;
    const double gt[6] = {500000.0,  cell * std::cos(angle), cell * std::sin(angle),
                          4000000.0, cell * std::sin(angle), -cell * std::cos(angle)};
    auto plane = [](double x, double y) { return 300.0 + 0.02 * (x - 500000) - 0.03 * (y - 4e6); };
    std::vector<double> v;
    for (int r = 0; r < n; ++r) {
        for (int c = 0; c < n; ++c) {
            const double x = gt[0] + (c + 0.5) * gt[1] + (r + 0.5) * gt[2];
            const double y = gt[3] + (c + 0.5) * gt[4] + (r + 0.5) * gt[5];
            v.push_back(plane(x, y));
        }
    }
    for (const int epsg : {32616, 0}) {
        SCOPED_TRACE(epsg);
        const std::string path = dir.file("rotated" + std::to_string(epsg) + ".tif");
        writeTiff(path, n, n, {v}, GDT_Float64, gt, epsg);
        DemGrid dem;
        std::string error;
        ASSERT_TRUE(loadDem(path, {}, dem, error)) << error;
        EXPECT_LT(dem.cellY, 0.0);
        EXPECT_GT(dem.cellX, 0.0);
        EXPECT_EQ(dem.wkt.empty(), epsg == 0);
        ASSERT_FALSE(dem.conversions.empty());
        EXPECT_NE(dem.conversions.back().find("rotated"), std::string::npos);
        // About the source's footprint: a square of n * cell turned by 30 degrees.
        const double side = n * cell * (std::cos(angle) + std::sin(angle));
        EXPECT_NEAR(dem.width * dem.cellX, side, 4 * cell);
        EXPECT_NEAR(dem.height * -dem.cellY, side, 4 * cell);
        // Exact inside the source cell centres' hull (GDAL's kernel is partial at its rim).
        const double det = gt[1] * gt[5] - gt[2] * gt[4];
        std::size_t valid = 0, inner = 0;
        for (int r = 0; r < dem.height; ++r) {
            for (int c = 0; c < dem.width; ++c) {
                const float z = dem.z[static_cast<std::size_t>(r) * dem.width + c];
                if (std::isnan(z)) continue;
                ++valid;
                const double dx = dem.centreX(c) - gt[0], dy = dem.centreY(r) - gt[3];
                const double col = (dx * gt[5] - dy * gt[2]) / det;
                const double row = (dy * gt[1] - dx * gt[4]) / det;
                if (col < 1 || col > n - 1 || row < 1 || row > n - 1) continue;
                ++inner;
                EXPECT_NEAR(z, plane(dem.centreX(c), dem.centreY(r)), 0.01) << c << ", " << r;
            }
        }
        // The turned square covers half of its bounding box or more; the corners are nodata.
        EXPECT_GT(valid, dem.z.size() / 2);
        EXPECT_LT(valid, dem.z.size());
        EXPECT_GT(inner, valid / 2);
    }

    // A singular geotransform places no cell anywhere: refused, naming the file.
    const std::string flat = dir.file("singular.tif");
    const double singular[6] = {500000.0, 10.0, 20.0, 4000000.0, 5.0, 10.0};
    writeTiff(flat, 4, 3, {std::vector<double>(12, 1.0)}, GDT_Float32, singular, 32616);
    DemGrid dem;
    std::string error;
    EXPECT_FALSE(loadDem(flat, {}, dem, error));
    EXPECT_NE(error.find(flat), std::string::npos) << error;
    EXPECT_NE(error.find("degenerate"), std::string::npos) << error;
}

// A DEM without a CRS is read in metres; degrees read that way (an ASCII grid without its .prj)
// would make a terrain a third of a metre wide with 800 m of relief: refused, pointing at
// --s-srs; with --s-srs it loads. Small cells alone only warn; a metric grid says nothing.
TEST(Dem, UndeclaredDegreesAreRefused) {
    TempDir dir("undeclared");
    const int n = 40;
    std::vector<double> relief, flat;
    for (int i = 0; i < n * n; ++i) {
        relief.push_back(236.0 + 20.0 * (i % n) + 0.5 * (i / n));  // 236 .. 1035.5 m
        flat.push_back(100.0 + 0.001 * i);
    }
    const double degrees[6] = {-84.4, 1.0 / 1200, 0.0, 36.7, 0.0, -1.0 / 1200};
    const std::string path = dir.file("degrees.tif");
    writeTiff(path, n, n, {relief}, GDT_Float32, degrees, 0);
    DemGrid dem;
    std::string error;
    std::vector<std::string> warnings;
    EXPECT_FALSE(loadDem(path, collecting(warnings), dem, error));
    EXPECT_NE(error.find(path), std::string::npos) << error;
    EXPECT_NE(error.find("look like degrees"), std::string::npos) << error;
    EXPECT_NE(error.find("--s-srs"), std::string::npos) << error;
    EXPECT_TRUE(dem.z.empty());

    DemLoadOptions assumed = collecting(warnings);
    assumed.assumeSrs = "EPSG:4326";
    ASSERT_TRUE(loadDem(path, assumed, dem, error)) << error;
    EXPECT_GT(dem.cellX, 50.0);  // warped to UTM: about 75 m
    EXPECT_TRUE(warnings.empty());

    // Degree-sized cells without the relief that gives them away: built, with a warning.
    const std::string plain = dir.file("flat.tif");
    writeTiff(plain, n, n, {flat}, GDT_Float32, degrees, 0);
    ASSERT_TRUE(loadDem(plain, collecting(warnings), dem, error)) << error;
    ASSERT_EQ(warnings.size(), 1u);
    EXPECT_NE(warnings[0].find("declares no CRS"), std::string::npos) << warnings[0];

    // A local metric grid without a CRS: no warning.
    warnings.clear();
    const double metres[6] = {0.0, 10.0, 0.0, 400.0, 0.0, -10.0};
    const std::string local = dir.file("local.tif");
    writeTiff(local, n, n, {relief}, GDT_Float32, metres, 0);
    ASSERT_TRUE(loadDem(local, collecting(warnings), dem, error)) << error;
    EXPECT_TRUE(warnings.empty());
}

// Near a pole a geographic DEM goes to the polar stereographic grid (UPS), not to a UTM zone
// stretched far beyond its latitudes.
TEST(Dem, PolarDemIsWarpedToUps) {
    TempDir dir("polar");
    const std::string path = dir.file("antarctic.tif");
    const double gt[6] = {10.0, 0.01, 0.0, -84.0, 0.0, -0.01};
    writeTiff(path, 20, 20, {std::vector<double>(400, 2500.0)}, GDT_Float32, gt, 4326);
    DemGrid dem;
    std::string error;
    ASSERT_TRUE(loadDem(path, {}, dem, error)) << error;
    OGRSpatialReference srs;
    ASSERT_EQ(srs.importFromWkt(dem.wkt.c_str()), OGRERR_NONE);
    const char* code = srs.GetAuthorityCode(nullptr);
    ASSERT_NE(code, nullptr);
    EXPECT_STREQ(code, "32761");
}

TEST(Dem, UtmZoneChoice) {
    EXPECT_EQ(utmEpsgFor(-84.1, 36.5), 32616);
    EXPECT_EQ(utmEpsgFor(-83.9, 36.5), 32617);
    EXPECT_EQ(utmEpsgFor(3.0, -10.0), 32731);
    EXPECT_EQ(utmEpsgFor(-180.0, 0.0), 32601);
    EXPECT_EQ(utmEpsgFor(179.9, 1.0), 32660);
    EXPECT_EQ(utmEpsgFor(181.0, 1.0), 32601);  // wraps
    EXPECT_EQ(utmEpsgFor(10.0, 84.5), 32661);  // beyond UTM: UPS North
    EXPECT_EQ(utmEpsgFor(10.0, 84.0), 32632);
    EXPECT_EQ(utmEpsgFor(-60.0, -80.5), 32761);  // UPS South
    EXPECT_EQ(utmEpsgFor(-60.0, -80.0), 32721);
}

TEST(Dem, ElevationUnitNames) {
    EXPECT_EQ(metresPerUnit(""), 1.0);
    EXPECT_EQ(metresPerUnit("m"), 1.0);
    EXPECT_EQ(metresPerUnit("Metre"), 1.0);
    EXPECT_EQ(metresPerUnit("meters"), 1.0);
    EXPECT_EQ(metresPerUnit("ft"), 0.3048);
    EXPECT_EQ(metresPerUnit("Foot"), 0.3048);
    EXPECT_EQ(metresPerUnit("US survey foot"), 1200.0 / 3937.0);
    EXPECT_EQ(metresPerUnit("ftUS"), 1200.0 / 3937.0);
    EXPECT_EQ(metresPerUnit("us-ft"), 1200.0 / 3937.0);
    EXPECT_EQ(metresPerUnit("cm"), 0.01);
    EXPECT_EQ(metresPerUnit("km"), 1000.0);
    EXPECT_EQ(metresPerUnit("furlong"), 0.0);
    EXPECT_EQ(metresPerUnit("elevation"), 0.0);
}

TEST(Dem, ScaledIntegersAndFeetBecomeMetres) {
    TempDir dir("scaled");
    std::vector<double> raw(12);
    for (std::size_t i = 0; i < raw.size(); ++i)
        raw[i] = 1000.0 + 37.0 * double(i);
    raw[5] = -32768;  // nodata: compared before the scale
    const std::string path = dir.file("scaled.tif");
    writeTiff(path, 4, 3, {raw}, GDT_Int16, kGt, 32616, -32768);
    describeBand(path, 0.1, 250.0, "ft");
    std::vector<std::string> warnings;
    const DemLoadOptions o = collecting(warnings);
    DemGrid dem;
    std::string error;
    ASSERT_TRUE(loadDem(path, o, dem, error)) << error;
    EXPECT_TRUE(warnings.empty());
    EXPECT_TRUE(std::isnan(dem.z[5]));
    for (std::size_t i = 0; i < raw.size(); ++i) {
        if (i == 5) continue;
        EXPECT_EQ(dem.z[i], static_cast<float>((raw[i] * 0.1 + 250.0) * 0.3048)) << i;
    }
    ASSERT_EQ(dem.conversions.size(), 2u);
    EXPECT_NE(dem.conversions[0].find("x 0.1 + 250"), std::string::npos) << dem.conversions[0];
    EXPECT_NE(dem.conversions[1].find("ft"), std::string::npos) << dem.conversions[1];

    // An unknown unit: read as metres, with a warning naming the file and the unit.
    describeBand(path, 1.0, 0.0, "furlong");
    ASSERT_TRUE(loadDem(path, o, dem, error)) << error;
    EXPECT_EQ(dem.z[0], 1000.0f);
    EXPECT_TRUE(dem.conversions.empty());
    ASSERT_EQ(warnings.size(), 1u);
    EXPECT_NE(warnings[0].find(path), std::string::npos) << warnings[0];
    EXPECT_NE(warnings[0].find("furlong"), std::string::npos) << warnings[0];

    // A scale of 0 would flatten the terrain: refused.
    describeBand(path, 0.0, 0.0, "m");
    EXPECT_FALSE(loadDem(path, o, dem, error));
    EXPECT_NE(error.find(path), std::string::npos) << error;
    EXPECT_NE(error.find("scale"), std::string::npos) << error;
}

TEST(Dem, ProjectedCrsInFeetIsReprojectedToUtm) {
    // The same ground as kGt in NAD83 / Tennessee (ftUS), EPSG:2274: 100 ft cells.
    TempDir dir("feet");
    const std::string path = dir.file("feet.tif");
    const double gt[6] = {1800000.0, 100.0, 0.0, 600000.0, 0.0, -100.0};
    std::vector<double> v(20 * 20, 300.0);
    writeTiff(path, 20, 20, {v}, GDT_Float32, gt, 2274);
    DemGrid dem;
    std::string error;
    ASSERT_TRUE(loadDem(path, {}, dem, error)) << error;
    OGRSpatialReference srs;
    ASSERT_EQ(srs.importFromWkt(dem.wkt.c_str()), OGRERR_NONE);
    EXPECT_TRUE(srs.IsProjected());
    EXPECT_DOUBLE_EQ(srs.GetLinearUnits(), 1.0);
    EXPECT_STREQ(srs.GetAuthorityCode(nullptr), "32616");  // Tennessee: UTM zone 16N
    // 100 US survey feet = 30.48 m: the warped cells are metres, within the warp's rounding.
    EXPECT_NEAR(std::fabs(dem.cellX), 30.48, 1.0);
    EXPECT_NEAR(std::fabs(dem.cellY), 30.48, 1.0);
    ASSERT_EQ(dem.conversions.size(), 1u);
    EXPECT_NE(dem.conversions[0].find("US survey foot"), std::string::npos) << dem.conversions[0];

    // Heights with no unit in a CRS in feet are read as metres, with a warning (a DEM in feet
    // throughout had 3.28x its relief, silently); a band unit of metres says it all.
    std::vector<std::string> warnings;
    ASSERT_TRUE(loadDem(path, collecting(warnings), dem, error)) << error;
    ASSERT_EQ(warnings.size(), 1u);
    EXPECT_NE(warnings[0].find("heights declare no unit"), std::string::npos) << warnings[0];
    EXPECT_NE(warnings[0].find(path), std::string::npos) << warnings[0];
    describeBand(path, 1.0, 0.0, "m");
    warnings.clear();
    ASSERT_TRUE(loadDem(path, collecting(warnings), dem, error)) << error;
    EXPECT_TRUE(warnings.empty()) << warnings[0];

    // A target CRS in feet is refused (the model works in metres).
    DemLoadOptions o;
    o.targetSrs = "EPSG:2274";
    EXPECT_FALSE(loadDem(path, o, dem, error));
    EXPECT_NE(error.find(path), std::string::npos) << error;
    EXPECT_NE(error.find("not metres"), std::string::npos) << error;
}

// A compound CRS whose heights are in US survey feet (NAD83 / Tennessee (ftUS) + NAVD88 height
// (ftUS)): reprojected to UTM, the heights are converted to metres once. GDAL's warper converted
// them itself when given the vertical CRS, and the vertical unit was applied again (300 ft became
// 27.9 m instead of 91.4 m).
TEST(Dem, FeetHeightsOfACompoundCrsAreConvertedOnceWhenReprojected) {
    TempDir dir("compound");
    const std::string path = dir.file("compound.tif");
    const double gt[6] = {1800000.0, 100.0, 0.0, 600000.0, 0.0, -100.0};
    writeTiff(path, 20, 20, {std::vector<double>(20 * 20, 300.0)}, GDT_Float32, gt, 0);
    {
        GDALDatasetUniquePtr ds(GDALDataset::Open(path.c_str(), GDAL_OF_RASTER | GDAL_OF_UPDATE));
        ASSERT_TRUE(ds);
        OGRSpatialReference srs;
        ASSERT_EQ(srs.SetFromUserInput("EPSG:2274+6360"), OGRERR_NONE);
        ASSERT_TRUE(srs.IsCompound());
        ASSERT_EQ(ds->SetSpatialRef(&srs), CE_None);
    }
    DemGrid dem;
    std::string error;
    ASSERT_TRUE(loadDem(path, {}, dem, error)) << error;
    const float expected = static_cast<float>(300.0 * 1200.0 / 3937.0);  // 91.44 m
    std::size_t valid = 0;
    for (const float z : dem.z) {
        if (std::isnan(z)) continue;  // the warped grid's skewed corners
        EXPECT_NEAR(z, expected, 1e-3);
        ++valid;
    }
    EXPECT_GT(valid, 200u);
}

// A raster placed by ground control points only is refused with the way to grid it (it was
// built in pixel units, a 4.6 km DEM as a 155 m model); one with no georeferencing at all is
// built in pixel units with a warning.
TEST(Dem, GroundControlPointsAreRefusedAndNoGeoreferencingIsWarned) {
    TempDir dir("gcp");
    GDALAllRegister();
    GDALDriver* driver = GetGDALDriverManager()->GetDriverByName("GTiff");
    ASSERT_NE(driver, nullptr);
    auto write = [&](const std::string& path, bool gcps) {
        GDALDatasetUniquePtr ds(driver->Create(path.c_str(), 8, 6, 1, GDT_Float32, nullptr));
        ASSERT_TRUE(ds);
        std::vector<float> v(48, 100.0f);
        ASSERT_EQ(ds->GetRasterBand(1)->RasterIO(GF_Write, 0, 0, 8, 6, v.data(), 8, 6, GDT_Float32,
                                                 0, 0, nullptr),
                  CE_None);
        if (gcps) {
            OGRSpatialReference srs;
            srs.importFromEPSG(32616);
            GDAL_GCP points[3];
            GDALInitGCPs(3, points);
            const double pixel[3][4] = {
                {0, 0, 300000, 3903720}, {8, 0, 300240, 3903720}, {0, 6, 300000, 3903540}};
            for (int i = 0; i < 3; ++i) {
                points[i].dfGCPPixel = pixel[i][0];
                points[i].dfGCPLine = pixel[i][1];
                points[i].dfGCPX = pixel[i][2];
                points[i].dfGCPY = pixel[i][3];
            }
            ASSERT_EQ(ds->SetGCPs(3, points, &srs), CE_None);
            GDALDeinitGCPs(3, points);
        }
    };
    const std::string gcp = dir.file("gcp.tif"), bare = dir.file("bare.tif");
    write(gcp, true);
    write(bare, false);
    std::vector<std::string> warnings;
    const DemLoadOptions o = collecting(warnings);
    DemGrid dem;
    std::string error;
    EXPECT_FALSE(loadDem(gcp, o, dem, error));
    EXPECT_NE(error.find(gcp), std::string::npos) << error;
    EXPECT_NE(error.find("3 ground control points"), std::string::npos) << error;
    EXPECT_NE(error.find("gdalwarp"), std::string::npos) << error;

    ASSERT_TRUE(loadDem(bare, o, dem, error)) << error;
    EXPECT_EQ(dem.width, 8);
    EXPECT_DOUBLE_EQ(dem.cellX, 1.0);
    ASSERT_EQ(warnings.size(), 1u);
    EXPECT_NE(warnings[0].find("no georeferencing"), std::string::npos) << warnings[0];
}

TEST(Dem, DistortingMetricCrsIsWarnedAbout) {
    // Web Mercator at about 36 degrees north stretches distances by about 1.24.
    TempDir dir("mercator");
    const std::string path = dir.file("mercator.tif");
    const double gt[6] = {-9500000.0, 100.0, 0.0, 4300000.0, 0.0, -100.0};
    writeTiff(path, 4, 3, {std::vector<double>(12, 300.0)}, GDT_Float32, gt, 3857);
    std::vector<std::string> warnings;
    const DemLoadOptions o = collecting(warnings);
    DemGrid dem;
    std::string error;
    ASSERT_TRUE(loadDem(path, o, dem, error)) << error;
    EXPECT_DOUBLE_EQ(dem.cellX, 100.0);  // kept as it is
    ASSERT_EQ(warnings.size(), 1u);
    EXPECT_NE(warnings[0].find("scale of 1.2"), std::string::npos) << warnings[0];
    EXPECT_NE(warnings[0].find("--t-srs EPSG:326"), std::string::npos) << warnings[0];

    // A UTM grid in its own zone is true to scale within 0.1 %: no warning.
    warnings.clear();
    const std::string utm = dir.file("utm.tif");
    writeTiff(utm, 4, 3, {std::vector<double>(12, 300.0)}, GDT_Float32, kGt, 32616);
    ASSERT_TRUE(loadDem(utm, o, dem, error)) << error;
    EXPECT_TRUE(warnings.empty());
}

// A geographic DEM too wide for the UTM zone of its centre (a continent, the world) is refused,
// naming --t-srs, instead of being warped into one zone (a world DEM became a model 39 000 km
// tall with blocks cut to 3 cells); a wide one that still fits gets the scale warning, and so
// does a distorting --t-srs (Web Mercator at 36 degrees north). An exact UTM zone: no warning.
TEST(Dem, ReprojectionThatStretchesTheTerrainIsRefusedOrWarned) {
    TempDir dir("widegeo");
    std::vector<std::string> warnings;
    const DemLoadOptions o = collecting(warnings);
    DemGrid dem;
    std::string error;
    const std::string world = dir.file("world.tif");
    const double worldGt[6] = {-180.0, 1.5, 0.0, 80.0, 0.0, -1.5};
    writeTiff(world, 240, 106, {std::vector<double>(240 * 106, 100.0)}, GDT_Float32, worldGt, 4326);
    EXPECT_FALSE(loadDem(world, o, dem, error));
    EXPECT_NE(error.find(world), std::string::npos) << error;
    EXPECT_NE(error.find("too large for one UTM zone"), std::string::npos) << error;
    EXPECT_NE(error.find("--t-srs"), std::string::npos) << error;
    const std::string continent = dir.file("continent.tif");
    const double continentGt[6] = {-30.0, 0.5, 0.0, 20.0, 0.0, -0.5};  // 60 x 40 degrees
    writeTiff(continent, 120, 80, {std::vector<double>(120 * 80, 100.0)}, GDT_Float32, continentGt,
              4326);
    EXPECT_FALSE(loadDem(continent, o, dem, error));
    EXPECT_NE(error.find("too large for one UTM zone"), std::string::npos) << error;

    // 20 degrees at the equator in zone 31 (central meridian 3 E): 13 degrees out, about 1.026.
    const std::string wide = dir.file("wide.tif");
    const double wideGt[6] = {-10.0, 0.25, 0.0, 4.0, 0.0, -0.25};
    writeTiff(wide, 80, 32, {std::vector<double>(80 * 32, 100.0)}, GDT_Float32, wideGt, 4326);
    ASSERT_TRUE(loadDem(wide, o, dem, error)) << error;
    ASSERT_EQ(warnings.size(), 1u);
    EXPECT_NE(warnings[0].find("has a scale of 1.0"), std::string::npos) << warnings[0];

    warnings.clear();
    const std::string small = dir.file("small.tif");  // 0.1 degrees: true to scale
    const double smallGt[6] = {-84.1, 0.001, 0.0, 36.6, 0.0, -0.001};
    writeTiff(small, 100, 100, {std::vector<double>(100 * 100, 100.0)}, GDT_Float32, smallGt, 4326);
    ASSERT_TRUE(loadDem(small, o, dem, error)) << error;
    EXPECT_TRUE(warnings.empty());
    DemLoadOptions mercator = o;
    mercator.targetSrs = "EPSG:3857";
    ASSERT_TRUE(loadDem(small, mercator, dem, error)) << error;
    ASSERT_EQ(warnings.size(), 1u);
    EXPECT_NE(warnings[0].find("has a scale of 1.24"), std::string::npos) << warnings[0];
}

// Cells so large that two of them exceed the exact grid's 537 km are refused by what they are,
// not with a --block-size advice no value can follow ("use --block-size 2 or more", then "use
// --block-size 0 or less"); cells of 200 km still fit.
// A flat 20 x 20 DEM (100 m) of cells `cell` wide, north up.
static DemGrid flatDem(double cell) {
    DemGrid dem;
    dem.width = dem.height = 20;
    dem.cellX = cell;
    dem.cellY = -cell;
    dem.z.assign(400, 100.0f);
    return dem;
}

TEST(Dem, CellsTooLargeForTheExactGridAreNamed) {
    DemGrid dem = flatDem(300000);
    std::string error;
    EXPECT_FALSE(checkCellsFitExactGrid(dem, 1, error));
    EXPECT_NE(error.find("its cells are 300 km wide"), std::string::npos) << error;
    EXPECT_EQ(error.find("--block-size"), std::string::npos) << error;
    dem.cellX = 200000;
    dem.cellY = -200000;
    EXPECT_TRUE(checkCellsFitExactGrid(dem, 1, error)) << error;
    EXPECT_FALSE(checkCellsFitExactGrid(dem, 2, error));  // 400 km at --stride 2
    EXPECT_NE(error.find("(at --stride 2)"), std::string::npos) << error;
}

// Cells below 1 cm are refused too: on the 1 mm grid their points merged silently (a 20 x 20 DEM
// of 0.5 mm cells became 121 vertices); --stride sampling them 1 cm apart is suggested.
TEST(Dem, CellsTooSmallForTheExactGridAreNamed) {
    DemGrid dem = flatDem(0.0005);
    std::string error;
    EXPECT_FALSE(checkCellsFitExactGrid(dem, 1, error));
    EXPECT_NE(error.find("its cells are 0.5 mm wide: too small"), std::string::npos) << error;
    EXPECT_NE(error.find("--stride 20"), std::string::npos) << error;
    EXPECT_TRUE(checkCellsFitExactGrid(dem, 20, error)) << error;
    dem.cellX = 0.01;  // 1 cm x 0.5 mm: the smaller side counts
    EXPECT_FALSE(checkCellsFitExactGrid(dem, 1, error));
    dem.cellY = -0.01;
    EXPECT_TRUE(checkCellsFitExactGrid(dem, 1, error)) << error;
}

// Cells held in a temporary file (DemLoadOptions::spillDir, dem.h CellAllocator): the same
// values as on the heap, projected and reprojected; the file is deleted from the folder at once
// and lives as a mapping until keepLattice takes the lattice to the heap; the memory check
// sends a raster there only when its lattice fits and the file does not fit, and names both.
TEST(Dem, CellsCanBeHeldInATemporaryFile) {
    TempDir dir("spill"), spillDir("spill_cells");
    const int w = 37, h = 29;
    std::vector<double> v;
    for (int r = 0; r < h; ++r)
        for (int c = 0; c < w; ++c)
            v.push_back(300 + 50 * std::sin(c * 0.37) * std::cos(r * 0.23) + 0.5 * c);
    const std::string projected = dir.file("utm.tif"), degrees = dir.file("geo.tif");
    writeTiff(projected, w, h, {v}, GDT_Float32, kGt, 32616);
    const double geo[6] = {-84.5, 0.0003, 0, 36.9, 0, -0.0003};
    writeTiff(degrees, w, h, {v}, GDT_Float32, geo, 4326);
    // The mappings of files from `folder` that are deleted ("(deleted)" in /proc/self/maps).
    auto mapped = [](const fs::path& folder) {
        std::ifstream maps("/proc/self/maps");
        std::size_t n = 0;
        for (std::string line; std::getline(maps, line);)
            n += line.find(folder.string() + "/.unilod-cells-") != std::string::npos &&
                 line.find("(deleted)") != std::string::npos;
        return n;
    };
    for (const std::string& path : {projected, degrees}) {
        SCOPED_TRACE(path);
        DemGrid heap, disk;
        std::string error;
        ASSERT_TRUE(loadDem(path, {}, heap, error)) << error;
        std::vector<std::string> warnings;
        DemLoadOptions o = collecting(warnings);
        o.spillDir = spillDir.path.string();
        o.spillStride = 4;
        o.spillAlways = true;
        ASSERT_TRUE(loadDem(path, o, disk, error)) << error;
        EXPECT_FALSE(heap.cellsOnDisk());
        ASSERT_TRUE(disk.cellsOnDisk());
        EXPECT_EQ(mapped(spillDir.path), 1u);
        EXPECT_EQ(spillDir.entries(), 0u);
        ASSERT_EQ(warnings.size(), 1u);
        EXPECT_NE(warnings[0].find("are held in a temporary file in '" + o.spillDir +
                                   "' while it is read (asked for); the --stride 4 lattice"),
                  std::string::npos)
            << warnings[0];
        ASSERT_EQ(disk.width, heap.width);
        ASSERT_EQ(disk.height, heap.height);
        ASSERT_EQ(disk.z.size(), heap.z.size());
        for (std::size_t i = 0; i < heap.z.size(); ++i)
            ASSERT_EQ(std::bit_cast<std::uint32_t>(disk.z[i]),
                      std::bit_cast<std::uint32_t>(heap.z[i]))
                << "cell " << i;
        const DemGrid copy = disk;  // a copy goes to the heap
        EXPECT_FALSE(copy.cellsOnDisk());
        EXPECT_EQ(mapped(spillDir.path), 1u);
        heap.keepLattice(4);
        disk.keepLattice(4);
        EXPECT_FALSE(disk.cellsOnDisk());
        EXPECT_EQ(mapped(spillDir.path), 0u);
        ASSERT_EQ(disk.z.size(), heap.z.size());
        for (std::size_t i = 0; i < heap.z.size(); ++i)
            EXPECT_EQ(std::bit_cast<std::uint32_t>(disk.z[i]),
                      std::bit_cast<std::uint32_t>(heap.z[i]));
    }

    // A folder that cannot take the file: the error names the DEM, the folder and the reason.
    DemGrid dem;
    std::string error;
    DemLoadOptions o;
    o.spillDir = dir.file("missing");
    o.spillStride = 2;
    o.spillAlways = true;
    EXPECT_FALSE(loadDem(projected, o, dem, error));
    EXPECT_NE(error.find("DEM '" + projected + "': its cells: cannot create a temporary file in '" +
                         o.spillDir + "': No such file or directory"),
              std::string::npos)
        << error;
    EXPECT_TRUE(dem.z.empty());

    // The memory check: 37 x 29 cells at 5 bytes a cell (5 365 bytes) over a 3 000-byte bound go
    // to the file, whose lattice of --stride 4 (10 x 8 cells, 400 bytes) and reading buffers
    // (1 073 bytes) fit; a spill folder left out, or a lattice that does not fit either, refuses.
    o = DemLoadOptions{};
    o.bytesPerCell = 5;
    o.memoryBytes = 3000;
    o.memoryWhat = "--memory-limit";
    EXPECT_FALSE(loadDem(projected, o, dem, error));
    EXPECT_NE(error.find("37 x 29 cells need at least 0.00 GB of memory"), std::string::npos)
        << error;
    EXPECT_EQ(error.find("temporary file"), std::string::npos) << error;
    o.spillDir = spillDir.path.string();
    o.spillStride = 4;
    ASSERT_TRUE(loadDem(projected, o, dem, error)) << error;
    EXPECT_TRUE(dem.cellsOnDisk());
    o.spillStride = 1;  // the lattice is every cell: 5 365 + 1 073 bytes
    EXPECT_FALSE(loadDem(projected, o, dem, error));
    EXPECT_NE(
        error.find("(a temporary file of them needs 0.00 GB of disk, '" + o.spillDir + "' has"),
        std::string::npos)
        << error;
}
