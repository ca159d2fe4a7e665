// `unilod build` on random small inputs (a property test with fixed seeds): DEMs of 2 to 60 cells a
// side with scattered nodata, holes and terraces, in 1 m or 30 m cells, and river networks that
// cross, double back on themselves, repeat vertices, run along block border lines, touch them and
// leave the DEM; random block sizes, orders, strides and the flat grid. Every input must either
// build or be refused for a problem of its data (kDataProblems) with a message naming the input
// (exit 1, no output, no temporary left; UNILOD_KEEP_REFUSED=DIR keeps such inputs); every
// built model must pass `check --errors` (checksums, topology at every level, neighbours meeting
// edge to edge, and stored errors that bound the true ones) and `stats`. A random search of this
// kind (eighth session) found a crack where a river touches a border, a node build that failed on
// it, and stored error bounds that lied on thin strips with nodata (tests in test_cli_build.cpp,
// test_nodata.cpp pin those cases), and rivers along block borders and the outline refused as
// "river segments overlap" (CliBuildAnyDem.RiversAlongBlockBordersAndTheOutline).
#include <gdal_priv.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include "testutil.h"
#include "tools/cliutil.h"

namespace fs = std::filesystem;

namespace {

using unilod::test::q;
using unilod::test::runCli;

constexpr double kX0 = 400000, kY0 = 4000000;  // UTM 16N, north-west corner of the raster

struct Input {
    int width = 0, height = 0;
    double cell = 30;
    std::vector<float> z;  // row-major, north row first; NaN = nodata
    std::vector<std::vector<std::pair<double, double>>> rivers;  // world coordinates
    int blockSize = 16;
    std::string options;
};

// World coordinates of (column, row) in cell units from the north-west cell centre.
double wx(const Input& in, double col) {
    return kX0 + (col + 0.5) * in.cell;
}
double wy(const Input& in, double row) {
    return kY0 - (row + 0.5) * in.cell;
}

Input randomInput(std::uint32_t seed) {
    std::mt19937 rng(seed);
    auto uniform = [&](double a, double b) {
        return std::uniform_real_distribution<double>(a, b)(rng);
    };
    auto pick = [&](int n) { return int(rng() % std::uint32_t(n)); };
    Input in;
    in.width = 2 + pick(59);
    in.height = 2 + pick(59);
    if (pick(6) == 0) in.height = 2 + pick(3);  // thin strips
    in.cell = pick(2) == 0 ? 1.0 : 30.0;
    const int terrain = pick(4), holes = pick(5);
    for (int r = 0; r < in.height; ++r) {
        for (int c = 0; c < in.width; ++c) {
            double v = 0;
            switch (terrain) {
                case 0:
                    v = 300 + 80 * std::sin(c / 7.0) * std::cos(r / 5.0);
                    break;
                case 1:
                    v = 100.0;
                    break;  // flat: cocircular everywhere
                case 2:
                    v = 100 + 10 * ((c + r) / 5);
                    break;  // terraces
                default:
                    v = uniform(-50, 900);
                    break;  // noise
            }
            bool cut = false;
            switch (holes) {
                case 1:
                    cut = uniform(0, 1) < 0.2;
                    break;
                case 2:
                    cut = std::hypot(c - in.width / 3.0, r - in.height / 2.0) <
                          std::min(in.width, in.height) / 4.0;
                    break;
                case 3:
                    cut = c < in.width / 4 || r > 3 * in.height / 4;
                    break;
                case 4:
                    cut = c == in.width / 2;
                    break;
                default:
                    break;
            }
            in.z.push_back(cut ? NAN : float(v));
        }
    }
    const int blockSizes[] = {2, 3, 4, 8, 16, 64};
    in.blockSize = blockSizes[pick(6)];
    const int lines = pick(4) == 0 ? 0 : 1 + pick(12);
    for (int l = 0; l < lines; ++l) {
        std::vector<std::pair<double, double>> line;
        const int n = 2 + pick(6);
        auto point = [&](bool snap) {
            if (snap)
                return std::make_pair(wx(in, pick(in.width + 1) + 0.5 * pick(2)) - 0.5 * in.cell,
                                      wy(in, pick(in.height + 1) + 0.5 * pick(2)) + 0.5 * in.cell);
            return std::make_pair(wx(in, uniform(-2, in.width + 1)),
                                  wy(in, uniform(-2, in.height + 1)));
        };
        switch (pick(5)) {
            case 0:  // random vertices, crossing anything
                for (int i = 0; i < n; ++i)
                    line.push_back(point(pick(2) == 0));
                break;
            case 1: {  // doubling back on itself, a repeated vertex
                const auto a = point(pick(2) == 0), b = point(pick(2) == 0);
                line = {a, a, b, a};
                break;
            }
            case 2: {  // along a block border line (cell centres), then off it
                const int k = pick(std::max(1, (in.width - 1) / in.blockSize + 1));
                const double x = wx(in, k * in.blockSize);
                std::vector<double> ys;
                for (int i = 0; i < n; ++i)
                    ys.push_back(wy(in, uniform(0, in.height - 1)));
                std::sort(ys.begin(), ys.end());
                for (double y : ys)
                    line.push_back({x, y});
                if (pick(2) == 0)
                    line.push_back(
                        {x + uniform(-2, 2) * in.cell, ys.back() + uniform(0, 2) * in.cell});
                break;
            }
            case 3: {  // touches a border line at a vertex and turns back
                const int k = pick(std::max(1, (in.height - 1) / in.blockSize + 1));
                const double y = wy(in, k * in.blockSize);
                const double x = wx(in, uniform(0, in.width - 1));
                const double side = pick(2) == 0 ? 1 : -1;
                line = {{x - 2 * in.cell, y + side * uniform(0.5, 3) * in.cell},
                        {x, y},
                        {x + 2 * in.cell, y + side * uniform(0.5, 3) * in.cell}};
                break;
            }
            default: {  // a random walk
                line.push_back(point(false));
                for (int i = 0; i < n; ++i)
                    line.push_back({line.back().first + uniform(-3, 3) * in.cell,
                                    line.back().second + uniform(-3, 3) * in.cell});
                break;
            }
        }
        in.rivers.push_back(line);
    }
    if (pick(5) == 0) in.options += " --order 3ddp";
    if (pick(5) == 0) in.options += " --no-tree";
    if (pick(8) == 0) in.options += " --stride 2";
    if (pick(8) == 0) in.options += " --no-bai";
    return in;
}

void writeInput(const Input& in, const std::string& dem, const std::string& rivers) {
    GDALAllRegister();
    GDALDriver* driver = GetGDALDriverManager()->GetDriverByName("GTiff");
    ASSERT_NE(driver, nullptr);
    GDALDatasetUniquePtr ds(
        driver->Create(dem.c_str(), in.width, in.height, 1, GDT_Float32, nullptr));
    ASSERT_TRUE(ds);
    double gt[6] = {kX0, in.cell, 0, kY0, 0, -in.cell};
    ds->SetGeoTransform(gt);
    OGRSpatialReference srs;
    srs.importFromEPSG(32616);
    ds->SetSpatialRef(&srs);
    std::vector<float> z = in.z;
    ASSERT_EQ(ds->GetRasterBand(1)->RasterIO(GF_Write, 0, 0, in.width, in.height, z.data(),
                                             in.width, in.height, GDT_Float32, 0, 0, nullptr),
              CE_None);
    std::ofstream out(rivers);
    out << "{\"type\":\"FeatureCollection\",\"crs\":{\"type\":\"name\",\"properties\":{\"name\":"
           "\"urn:ogc:def:crs:EPSG::32616\"}},\"features\":[";
    char buf[96];
    for (std::size_t l = 0; l < in.rivers.size(); ++l) {
        out << (l ? "," : "")
            << "{\"type\":\"Feature\",\"properties\":{},\"geometry\":{\"type\":"
               "\"LineString\",\"coordinates\":[";
        for (std::size_t i = 0; i < in.rivers[l].size(); ++i) {
            std::snprintf(buf, sizeof buf, "%s[%.6f,%.6f]", i ? "," : "", in.rivers[l][i].first,
                          in.rivers[l][i].second);
            out << buf;
        }
        out << "]}}";
    }
    out << "]}";
}

// The refusals a random input may earn: problems of the data, not of the program.
const char* const kDataProblems[] = {
    "no river vertex lies on the DEM",  // every river off the valid data
    "is less than twice --stride",      // options that cannot work on it
    "is larger than the DEM",
    "too small to triangulate",      // fewer than 2 x 2 cells
    "no valid data to triangulate",  // no 2 x 2 cells with 3 valid
    "every cell is nodata",
};

TEST(CliRandom, EveryInputBuildsAndChecksOrIsRefusedCleanly) {
    unilod::test::TempDir dir("random_inputs");
    std::uint32_t built = 0, refused = 0;
    // A longer search: UNILOD_RANDOM_SEEDS=N (default 48) from UNILOD_RANDOM_FIRST (default 0).
    const char* count = std::getenv("UNILOD_RANDOM_SEEDS");
    const char* first = std::getenv("UNILOD_RANDOM_FIRST");
    const std::uint32_t seeds = count ? std::uint32_t(std::strtoul(count, nullptr, 10)) : 48;
    const std::uint32_t from = first ? std::uint32_t(std::strtoul(first, nullptr, 10)) : 0;
    for (std::uint32_t seed = from; seed < from + seeds; ++seed) {
        SCOPED_TRACE("seed " + std::to_string(seed));
        const Input in = randomInput(seed);
        const fs::path inputs = fs::path(dir.file("in" + std::to_string(seed)));
        const fs::path outputs = fs::path(dir.file("out" + std::to_string(seed)));
        fs::create_directories(inputs);
        fs::create_directories(outputs);
        const std::string dem = (inputs / "dem.tif").string();
        const std::string rivers = (inputs / "rivers.geojson").string();
        writeInput(in, dem, rivers);
        const std::string model = (outputs / "m.ulod").string();
        const auto b = runCli("build -q " + q(dem) + " " + q(rivers) + " -o " + q(model) +
                              " --block-size " + std::to_string(in.blockSize) + in.options);
        ASSERT_TRUE(b.code == 0 || b.code == 1) << b.code << ": " << b.err;
        EXPECT_EQ(b.err.find("terminate"), std::string::npos) << b.err;
        if (b.code == 1) {
            ++refused;
            std::printf("[ refused   ] seed %u: %s", seed, b.err.c_str());
            if (const char* keep = std::getenv("UNILOD_KEEP_REFUSED"))  // to look at one
                fs::copy(inputs, fs::path(keep) / inputs.filename(), fs::copy_options::recursive);
            // Only a data problem of the input may refuse it, named with the input.
            const bool dataProblem =
                std::any_of(std::begin(kDataProblems), std::end(kDataProblems),
                            [&](const char* m) { return b.err.find(m) != std::string::npos; });
            EXPECT_TRUE(dataProblem) << "refused for a reason that is not the input's: " << b.err;
            EXPECT_TRUE(b.err.find(dem) != std::string::npos ||
                        b.err.find(rivers) != std::string::npos)
                << "the message names an input: " << b.err;
            EXPECT_TRUE(fs::is_empty(outputs)) << "no output and no temporary left";
            continue;
        }
        ++built;
        const auto c = runCli("check -q --errors " + q(model));
        EXPECT_EQ(c.code, 0) << "build" << in.options << " --block-size " << in.blockSize << ": "
                             << c.err;
        const auto s = runCli("stats " + q(model) + " --error 0,1,5,50 --json");
        EXPECT_EQ(s.code, 0) << s.err;
        fs::remove_all(inputs);
        fs::remove_all(outputs);
    }
    std::printf("[ random    ] %u built, %u refused\n", built, refused);
    EXPECT_GT(built, seeds * 5 / 8);  // most inputs are valid: the test exercises the build
}

}  // namespace
