// The first engine slice end to end on Mesa lavapipe with the validation layer on (any warning
// or error fails the capture, hence the test): the bundled data set is built into a temporary
// folder, captured from a near and a far camera over its centre, and the outputs checked:
// (a) the far view draws fewer triangles; (b) every block's level is the coarsest stored one
// with h_s <= h_lim (paper §3.4); (c) the image is not blank; (d) rivers are visible;
// (e) a bad file or camera exits != 0 and leaves no frame behind. There is no skip when no
// Vulkan device exists: CI installs lavapipe, so a missing device is a failure.
#include <gdal_priv.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <set>

#include "cut.h"
#include "dem.h"
#include "shared.h"
#include "synthetic.h"
#include "pngread.h"
#include "tools/cliutil.h"
#include "ulod.h"

namespace fs = std::filesystem;
using namespace unilod;
using unilod::test::Image;
using unilod::test::q;
using unilod::test::readPng;
using unilod::test::runCli;
using unilod::test::slurp;

namespace {

const std::string kAssets = UNILOD_ASSETS_DIR;

class Capture : public ::testing::Test {
protected:
    static void SetUpTestSuite() {
        dir_ = fs::temp_directory_path() / ("unilod_test_capture_" + std::to_string(getpid()));
        fs::create_directories(dir_);
        file_ = (dir_ / "jacksboro.ulod").string();
        const auto r = runCli("build -q " + q(kAssets + "/jacksboro_dem.tif") + " " +
                              q(kAssets + "/jacksboro_rivers_grass.geojson") + " -o " + q(file_));
        ASSERT_EQ(r.code, 0) << r.err;
    }
    static void TearDownTestSuite() { fs::remove_all(dir_); }

    // Runs a validated capture looking straight down from `height` metres above the data's top,
    // over its centre; returns the parsed JSON.
    static nlohmann::json capture(const std::string& name, double height, Image* image) {
        format::Reader reader;
        std::string error;
        EXPECT_TRUE(reader.open(file_, error)) << error;
        const format::Header& h = reader.header();
        const double cx = (h.minX + h.maxX) / 2, cy = (h.minY + h.maxY) / 2;
        char camera[256];
        std::snprintf(camera, sizeof camera, "%.3f,%.3f,%.3f,0,-90", cx, cy, h.maxZ + height);
        const fs::path out = dir_ / name;
        const auto r = runCli("capture " + q(file_) + " --validation --camera " + camera +
                              " --size 640x480 --pixels 1 --fov 60 --out " + q(out.string()));
        EXPECT_EQ(r.code, 0) << r.err;
        EXPECT_EQ(r.err.find("validation"), std::string::npos) << r.err;
        if (image) {
            EXPECT_TRUE(readPng((out / "frame_0000.png").string(), *image));
        }
        return nlohmann::json::parse(slurp((out / "frame_0000.json").string()), nullptr, false);
    }

    static fs::path dir_;
    static std::string file_;
};

fs::path Capture::dir_;
std::string Capture::file_;

TEST_F(Capture, NearAndFarViews) {
    Image nearImage;
    const nlohmann::json nearView = capture("near", 6000, &nearImage);
    const nlohmann::json farView = capture("far", 150000, nullptr);
    ASSERT_FALSE(nearView.is_discarded());
    ASSERT_FALSE(farView.is_discarded());

    // (a) fewer triangles far away.
    const auto nearTriangles = nearView["totals"]["triangles"].get<std::uint64_t>();
    const auto farTriangles = farView["totals"]["triangles"].get<std::uint64_t>();
    EXPECT_GT(nearTriangles, 0u);
    EXPECT_LT(farTriangles, nearTriangles);

    // (b) the level choice, checked against the file itself.
    format::Reader reader;
    std::string error;
    ASSERT_TRUE(reader.open(file_, error)) << error;
    std::size_t refined = 0, refinedNodes = 0;
    for (const nlohmann::json* view : {&nearView, &farView}) {
        // Frustum culling: only blocks in view are listed; none is drawn coarser than wanted
        // (a capture settles its residency first).
        ASSERT_GT((*view)["blocks"].size(), 0u);
        ASSERT_LE((*view)["blocks"].size(), reader.blocks().size());
        EXPECT_EQ((*view)["totals"]["fallback_blocks"].get<int>(), 0);
        for (const nlohmann::json& b : (*view)["blocks"]) {
            format::Block block;
            // The directory index; the position and tree level reported agree with it.
            const std::size_t index = b["index"].get<std::size_t>();
            ASSERT_LT(index, reader.blocks().size());
            EXPECT_EQ(reader.blocks()[index].col, b["col"].get<std::uint32_t>());
            EXPECT_EQ(reader.blocks()[index].row, b["row"].get<std::uint32_t>());
            EXPECT_EQ(reader.blocks()[index].level, b["tree_level"].get<std::uint32_t>());
            ASSERT_TRUE(reader.readBlock(index, block, error)) << error;
            const auto level = b["level"].get<std::size_t>();
            ASSERT_LT(level, block.levels.size());
            // Format version 4: the `max` error is held to h_lim (with sin phi) and its river
            // part to h_lim_river (without; null: no river part bounded apart).
            const double hLim = b["h_lim"];
            const double hLimRiver =
                b["h_lim_river"].is_null() ? INFINITY : b["h_lim_river"].get<double>();
            const double hs = block.errorMax[block.levels[level].step];
            const double hsRiver = block.errorRiver[block.levels[level].step];
            EXPECT_EQ(b["step"].get<std::uint32_t>(), block.levels[level].step);
            EXPECT_DOUBLE_EQ(b["h_s"].get<double>(), hs);
            EXPECT_DOUBLE_EQ(b["h_s_river"].get<double>(), hsRiver);
            EXPECT_TRUE((hs <= hLim && hsRiver <= hLimRiver) || level == 0) << "block " << b.dump();
            if (level + 1 < block.levels.size()) {
                const std::uint32_t next = block.levels[level + 1].step;
                EXPECT_TRUE(block.errorMax[next] > hLim || block.errorRiver[next] > hLimRiver)
                    << b.dump();
            }
            // An entry (leaf or tree node) is drawn refined from its records (scene.h
            // SceneOptions::refine): from its stored level on (at least that level's steps, no
            // more triangles), else exactly its stored level.
            if (b["refined"].get<bool>()) {
                EXPECT_LE(b["triangles"].get<std::uint32_t>(), block.levels[level].triangleCount);
                EXPECT_GE(b["steps_done"].get<std::uint32_t>(), block.levels[level].step);
                refinedNodes += block.level > 0;
                EXPECT_GT(b["triangles"].get<std::uint32_t>(), 0u);
                EXPECT_LE(b["steps_done"].get<std::uint32_t>(), block.steps.size());
                ++refined;
            } else {
                EXPECT_EQ(b["triangles"].get<std::uint32_t>(), block.levels[level].triangleCount);
            }
            // h_lim by Eq. 11 with P = 1, 60 degrees, 480 px and S' = c max(zMin, S cos) / sin
            // (engine/lod/lod.h): cos of the frustum's corner angle from tan^2 = tan^2(30 deg) *
            // (1 + (4/3)^2); zMin the smallest view depth of the box's corners; c = the larger
            // of that cos and the smallest cos of the angle between a corner ray and the view
            // axis (0 if a corner is not ahead); sin = the largest sin of the angle between a
            // corner ray and the vertical, or 1 when the eye is within the box's z range.
            // Recomputed here by brute force from the documented camera.
            const double t = std::tan(3.14159265358979 / 6);
            const double edge = 1.0 / (1.0 + t * t * (1.0 + 16.0 / 9.0));
            EXPECT_NEAR((*view)["edge_factor"].get<double>(), edge, 1e-12);
            const nlohmann::json& cam = (*view)["camera"];
            const double yaw = cam["yaw"].get<double>() * M_PI / 180;
            const double pitch = cam["pitch"].get<double>() * M_PI / 180;
            const double fwd[3] = {std::sin(yaw) * std::cos(pitch), std::cos(yaw) * std::cos(pitch),
                                   std::sin(pitch)};
            const format::BlockInfo& info = reader.blocks()[index];
            const double lo[3] = {info.minX, info.minY, info.minZ};
            const double hi[3] = {info.maxX, info.maxY, info.maxZ};
            double zMin = 1e300, axisCos = 1, verticalSin = 0;
            for (int corner = 0; corner < 8; ++corner) {
                double p[3], z = 0;
                for (int k = 0; k < 3; ++k) {
                    p[k] = (corner >> k & 1 ? hi[k] : lo[k]) - cam["eye"][k].get<double>();
                    z += fwd[k] * p[k];
                }
                const double len = std::sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]);
                zMin = std::min(zMin, z);
                axisCos = std::min(axisCos, z / len);
                verticalSin = std::max(verticalSin, std::sqrt(p[0] * p[0] + p[1] * p[1]) / len);
            }
            const double eyeZ = cam["eye"][2].get<double>();
            if (eyeZ >= lo[2] && eyeZ <= hi[2]) verticalSin = 1;
            axisCos = std::max(axisCos, 0.0);
            EXPECT_NEAR(b["min_depth"].get<double>(), zMin, 1e-6 * (1 + std::abs(zMin)));
            EXPECT_NEAR(b["axis_cos"].get<double>(), axisCos, 1e-9);
            EXPECT_NEAR(b["vertical_sin"].get<double>(), verticalSin, 1e-9);
            const double s = b["S"].get<double>();
            const double c = std::max(std::sqrt(edge), axisCos);
            // h_lim has the sin factor; a block with rivers has h_lim_river without it (the
            // river part bounds the rivers' 3D deviation); the file says which blocks have river
            // edges.
            format::BlockGeometry levels;
            std::string why;
            ASSERT_TRUE(reader.readGeometry(index, format::kLevelsOnly, levels, why)) << why;
            const bool rivers = levels.levels.front().riverCount > 0;
            EXPECT_EQ(b["rivers"].get<bool>(), rivers);
            const double sEff = c * std::max(zMin, s * std::sqrt(edge)) / verticalSin;
            EXPECT_GE(sEff, s * edge);  // never finer than the box-free bound
            // The whole box's bound, exactly where the box is small against S (cut.h: no
            // tolerance columns there); never below it elsewhere (columns can only raise it).
            const bool whole = std::hypot(hi[0] - lo[0], hi[1] - lo[1]) <=
                               engine::kColumnsBelowDistance * s;
            auto expectBound = [&](double h, double bound) {
                if (whole)
                    EXPECT_NEAR(h, bound, 1e-6 * (1 + h)) << b.dump();
                else
                    EXPECT_GE(h, bound * (1 - 1e-9)) << b.dump();
            };
            expectBound(hLim, 2.0 * sEff * t / 480);
            if (rivers) {
                const double sRiver = c * std::max(zMin, s * std::sqrt(edge));
                expectBound(hLimRiver, 2.0 * sRiver * t / 480);
                EXPECT_LE(hLimRiver, hLim);
            } else {
                EXPECT_TRUE(b["h_lim_river"].is_null()) << b.dump();
            }
        }
    }
    EXPECT_GT(refined, 0u);       // the default refines the entries it draws from their records
    EXPECT_GT(refinedNodes, 0u);  // the far view's tree node too

    // (c) not blank: many colours, terrain over most of the image (the near view looks at the
    // middle of a ~30 km data set from ~6 km: the whole frame is terrain).
    ASSERT_EQ(nearImage.width, 640u);
    ASSERT_EQ(nearImage.height, 480u);
    std::set<std::uint32_t> colours;
    std::size_t covered = 0, river = 0;
    const std::size_t pixels = std::size_t(nearImage.width) * nearImage.height;
    const int riverR = int(std::lround(engine::shader::kRiverColour.r * 255));
    const int riverG = int(std::lround(engine::shader::kRiverColour.g * 255));
    const int riverB = int(std::lround(engine::shader::kRiverColour.b * 255));
    for (std::size_t i = 0; i < pixels; ++i) {
        const std::uint8_t* p = &nearImage.rgba[i * 4];
        colours.insert(std::uint32_t(p[0]) << 16 | std::uint32_t(p[1]) << 8 | p[2]);
        if (p[0] || p[1] || p[2]) ++covered;
        if (std::abs(p[0] - riverR) <= 2 && std::abs(p[1] - riverG) <= 2 &&
            std::abs(p[2] - riverB) <= 2)
            ++river;
    }
    EXPECT_GT(colours.size(), 50u);
    EXPECT_GT(covered, pixels * 9 / 10);
    // (d) rivers drawn, and not everywhere.
    EXPECT_GT(river, 100u);
    EXPECT_LT(river, pixels / 4);
    EXPECT_GT(nearView["totals"]["river_edges"].get<std::uint64_t>(), 0u);
}

TEST_F(Capture, BadInputExitsNonZeroWithoutOutput) {
    const fs::path out = dir_ / "bad";
    const std::string frame = (out / "frame_0000.png").string();
    // Not a .ulod file.
    const fs::path junk = dir_ / "junk.ulod";
    std::ofstream(junk) << "not a ulod file\n";
    auto r =
        runCli("capture " + q(junk.string()) + " --camera 0,0,1000,0,-45 --out " + q(out.string()));
    EXPECT_EQ(r.code, 1);
    EXPECT_NE(r.err.find("junk.ulod"), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(frame));
    // Missing file.
    r = runCli("capture " + q((dir_ / "missing.ulod").string()) +
               " --camera 0,0,1000,0,-45 --out " + q(out.string()));
    EXPECT_EQ(r.code, 1);
    EXPECT_FALSE(fs::exists(frame));
    // The message names the file once: "unilod capture: error: PATH: cannot open: ...".
    const std::string missing = (dir_ / "missing.ulod").string();
    ASSERT_NE(r.err.find(missing + ": cannot open"), std::string::npos) << r.err;
    EXPECT_EQ(r.err.find(missing), r.err.rfind(missing)) << r.err;
    // Pitch out of range: a usage error naming the option (engineopts.h parseCamera).
    r = runCli("capture " + q(file_) + " --camera 0,0,1000,0,-120 --out " + q(out.string()));
    EXPECT_EQ(r.code, 2);
    EXPECT_NE(r.err.find("--camera"), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(frame));
    // Malformed camera and size: usage errors.
    r = runCli("capture " + q(file_) + " --camera 0,0,1000 --out " + q(out.string()));
    EXPECT_EQ(r.code, 2);
    r = runCli("capture " + q(file_) + " --camera 0,0,1000,0,-45 --size 12 --out " +
               q(out.string()));
    EXPECT_EQ(r.code, 2);
    EXPECT_FALSE(fs::exists(frame));
}

// Without --camera or --path a capture renders one overview of the whole model: every corner of
// the image is background (the model fits) and the middle is terrain; both options at once are a
// usage error.
TEST_F(Capture, WithoutACameraOneOverviewFrame) {
    const fs::path out = dir_ / "default";
    auto r =
        runCli("capture " + q(file_) + " --validation --size 160x120 --out " + q(out.string()));
    ASSERT_EQ(r.code, 0) << r.err;
    EXPECT_EQ(r.err.find("validation"), std::string::npos) << r.err;
    Image image;
    ASSERT_TRUE(readPng((out / "frame_0000.png").string(), image));
    ASSERT_EQ(image.width, 160u);
    auto pixel = [&](std::uint32_t x, std::uint32_t y) {
        const std::size_t i = 4 * (std::size_t(y) * image.width + x);
        return std::uint32_t(image.rgba[i]) << 16 | std::uint32_t(image.rgba[i + 1]) << 8 |
               image.rgba[i + 2];
    };
    const std::uint32_t background = pixel(0, 0);
    EXPECT_EQ(pixel(159, 0), background);
    EXPECT_EQ(pixel(0, 119), background);
    EXPECT_EQ(pixel(159, 119), background);
    std::set<std::uint32_t> colours;
    for (std::uint32_t y = 50; y < 70; ++y)
        for (std::uint32_t x = 70; x < 90; ++x)
            colours.insert(pixel(x, y));
    EXPECT_FALSE(colours.count(background)) << "the middle of the image is terrain";
    EXPECT_GT(colours.size(), 20u);
    EXPECT_FALSE(fs::exists(out / "frame_0001.png"));
    const fs::path both = dir_ / "both";
    r = runCli("capture " + q(file_) + " --camera 0,0,1000,0,-45 --path x.json --out " +
               q(both.string()));
    EXPECT_EQ(r.code, 2);
    EXPECT_NE(r.err.find("not both"), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(both / "frame_0000.png"));
}

}  // namespace

// Issue 17: a DEM with a round nodata hole in its middle that covers the middle block of a 3 x 3
// grid (left out of the file) and a bay of nodata along one side builds, passes `check --errors`,
// exports, gives stats, and the engine draws nothing over the hole: looking straight down on its
// centre, the image is empty (the clear colour) well inside the hole's outline and terrain all
// around it (read back from the PNG).
TEST_F(Capture, NodataHoleIsNotDrawn) {
    DemGrid dem;
    dem.width = dem.height = 121;
    dem.cellX = 30, dem.cellY = -30;
    dem.originX = 500015, dem.originY = 4000015;
    const double hole = 30;  // cells: covers block (1,1) of 40-cell blocks, which is left out
    for (int r = 0; r < dem.height; ++r) {
        for (int c = 0; c < dem.width; ++c) {
            const double x = c - 60, y = r - 60;
            const bool inHole = x * x + y * y < hole * hole;
            const bool bay = c > 112 && r > 20 && r < 40;
            dem.z.push_back(inHole || bay ? NAN
                                          : float(300 + 15 * std::sin(c / 7.0) * std::cos(r / 9.0)));
        }
    }
    GDALAllRegister();
    OGRSpatialReference srs;
    srs.importFromEPSG(32616);
    std::string error;
    const std::string demPath = (dir_ / "hole_dem.tif").string();
    ASSERT_TRUE(writeDemFile(dem, srs, demPath, error)) << error;
    const std::string rivers = (dir_ / "hole_rivers.geojson").string();
    std::ofstream(rivers) << "{\"type\": \"FeatureCollection\", \"features\": []}\n";
    const std::string file = (dir_ / "hole.ulod").string();
    auto r = runCli("build -q " + q(demPath) + " " + q(rivers) + " --block-size 40 -o " + q(file));
    ASSERT_EQ(r.code, 0) << r.err;
    r = runCli("check --errors " + q(file));
    EXPECT_EQ(r.code, 0) << r.err;
    r = runCli("export -q " + q(file) + " --h-lim 5 -o " + q((dir_ / "hole.glb").string()));
    EXPECT_EQ(r.code, 0) << r.err;
    EXPECT_GT(fs::file_size(dir_ / "hole.glb"), 1000u);
    format::Reader reader;
    ASSERT_TRUE(reader.open(file, error)) << error;
    // 3 x 3 grid, the middle block all nodata; above them 2 x 2 tree nodes and the root.
    std::size_t leaves = 0;
    for (const format::BlockInfo& b : reader.blocks()) leaves += b.level == 0;
    EXPECT_EQ(leaves, 8u);
    EXPECT_EQ(reader.blocks().size(), 13u);
    r = runCli("stats " + q(file) + " --error 5,20 --json");
    EXPECT_EQ(r.code, 0) << r.err;
    r = runCli("report " + q(file) + " -o " + q((dir_ / "hole_report").string()));
    EXPECT_EQ(r.code, 0) << r.err;
    EXPECT_TRUE(fs::exists(dir_ / "hole_report" / "report.md"));

    // Camera 2800 m above the top, straight down on the hole's centre (cell (60, 60)).
    const double d = 2800, top = 315;
    char camera[256];
    std::snprintf(camera, sizeof camera, "%.3f,%.3f,%.3f,0,-90", dem.centreX(60),
                  dem.centreY(60), top + d);
    const fs::path out = dir_ / "hole_capture";
    r = runCli("capture " + q(file) + " --validation --camera " + camera +
               " --size 640x480 --pixels 1 --fov 60 --out " + q(out.string()));
    ASSERT_EQ(r.code, 0) << r.err;
    Image image;
    ASSERT_TRUE(readPng((out / "frame_0000.png").string(), image));
    ASSERT_EQ(image.width, 640u);
    // The hole's radius on screen: R * f / distance, f = 240 px / tan(30 deg); the terrain lies
    // 0-30 m below the top, so its distance is d to d + 30.
    const double f = 240.0 / std::tan(30.0 * 3.14159265358979 / 180.0);
    const double radiusPx = hole * 30.0 * f / (d + 30.0);
    std::size_t inside = 0, insideDrawn = 0, around = 0, aroundEmpty = 0;
    for (std::uint32_t y = 0; y < image.height; ++y) {
        for (std::uint32_t x = 0; x < image.width; ++x) {
            const double rx = x + 0.5 - 320.0, ry = y + 0.5 - 240.0;
            const double rr = std::hypot(rx, ry);
            const std::uint8_t* p = &image.rgba[(std::size_t(y) * image.width + x) * 4];
            const bool drawn = p[0] || p[1] || p[2];
            if (rr < 0.85 * radiusPx) {
                ++inside;
                insideDrawn += drawn;
            } else if (rr > 1.2 * radiusPx * (d + 30.0) / d && rr < 230) {
                ++around;
                aroundEmpty += !drawn;
            }
        }
    }
    EXPECT_GT(inside, 10000u);
    EXPECT_EQ(insideDrawn, 0u);  // nothing drawn over the hole
    EXPECT_GT(around, 5000u);
    EXPECT_EQ(aroundEmpty, 0u);  // terrain all around it
}
