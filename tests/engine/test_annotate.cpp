// Annotated images (engine/annotate.h, issue 20 item 5): annotateImage changes only the regions
// it reports and draws text; `capture --annotate` differs from the plain capture of the same view
// only inside the annotation regions its JSON lists, its colour key shows the renderer's ramp
// (shaders/shared.h hypsometricTint) pixel for pixel with the file's max z at the top, its scale
// bar and north arrow follow the camera; without --annotate the image is the plain render.
// Captures run on lavapipe with the validation layer on.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "annotate.h"
#include "capture.h"
#include "pngread.h"
#include "shared.h"
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

bool inside(const nlohmann::json& regions, std::uint32_t x, std::uint32_t y) {
    for (const nlohmann::json& r : regions) {
        const long rx = r[0], ry = r[1], rw = r[2], rh = r[3];
        if (long(x) >= rx && long(x) < rx + rw && long(y) >= ry && long(y) < ry + rh) return true;
    }
    return false;
}

std::array<std::uint8_t, 3> rampByte(double t) {
    const engine::shader::vec3 c = engine::shader::hypsometricTint(float(t));
    auto b = [](float v) {
        return std::uint8_t(std::lround(std::clamp(double(v), 0.0, 1.0) * 255));
    };
    return {b(c.r), b(c.g), b(c.b)};
}

// Pixels that differ between two images of the same size: inside / outside `regions`.
void countDifferences(const Image& a, const Image& b, const nlohmann::json& regions,
                      std::size_t& in, std::size_t& out) {
    in = out = 0;
    for (std::uint32_t y = 0; y < a.height; ++y) {
        for (std::uint32_t x = 0; x < a.width; ++x) {
            const std::size_t i = (std::size_t(y) * a.width + x) * 4;
            if (std::equal(&a.rgba[i], &a.rgba[i] + 4, &b.rgba[i])) continue;
            (inside(regions, x, y) ? in : out) += 1;
        }
    }
}

}  // namespace

// No Vulkan: a patterned image, annotated in memory.
TEST(Annotate, ChangesOnlyItsRegionsAndDrawsText) {
    const std::uint32_t w = 400, h = 300;
    std::vector<std::uint8_t> image(std::size_t(w) * h * 4);
    for (std::size_t i = 0; i < image.size(); i += 4) {
        image[i] = std::uint8_t(i * 7);
        image[i + 1] = std::uint8_t(i / 13);
        image[i + 2] = std::uint8_t(i / 4 % 251);
        image[i + 3] = 255;
    }
    const std::vector<std::uint8_t> before = image;
    engine::Annotation a;
    a.colourKey = true;
    a.keyMinZ = 245;
    a.keyMaxZ = 1072;
    a.scaleBar = true;
    a.metresPerPixel = 37.5;
    a.scaleExact = false;
    a.northArrow = true;
    a.northX = 1;  // north to the right
    a.northY = 0;
    engine::AnnotationLayout layout;
    engine::annotateImage(image, w, h, a, &layout);
    ASSERT_EQ(layout.regions.size(), 3u);
    EXPECT_NEAR(layout.northDegrees, 90.0, 1e-9);
    // The bar: a round length (1, 2 or 5 x 10^k m) about a fifth of the width.
    EXPECT_EQ(layout.scaleMetres, engine::niceFloor(layout.scaleMetres));
    EXPECT_NEAR(layout.scalePixels, layout.scaleMetres / 37.5, 0.5);
    EXPECT_GT(layout.scalePixels, 0.22 * w / 2.5 - 1);
    EXPECT_LE(layout.scalePixels, 0.22 * w + 1);
    std::size_t changedIn = 0;
    for (std::uint32_t y = 0; y < h; ++y) {
        for (std::uint32_t x = 0; x < w; ++x) {
            const std::size_t i = (std::size_t(y) * w + x) * 4;
            const bool changed = !std::equal(&image[i], &image[i] + 4, &before[i]);
            bool in = false;
            for (const engine::PixelRect& r : layout.regions)
                in = in || (long(x) >= r.x && long(x) < r.x + r.width && long(y) >= r.y &&
                            long(y) < r.y + r.height);
            if (changed) {
                ASSERT_TRUE(in) << x << "," << y;
                ++changedIn;
            }
        }
    }
    EXPECT_GT(changedIn, 3000u);
    // Text: dark glyph pixels in the key panel beside the bar (the labels), none of them
    // part of the pattern (the panel is white under them).
    const engine::PixelRect& key = layout.keyBar;
    std::size_t dark = 0;
    for (std::int32_t y = key.y; y < key.y + key.height; ++y) {
        for (std::int32_t x = key.x + key.width + 2; x < std::int32_t(w); ++x) {
            const std::uint8_t* p = &image[(std::size_t(y) * w + std::size_t(x)) * 4];
            dark += p[0] < 90 && p[1] < 90 && p[2] < 90;
        }
    }
    EXPECT_GT(dark, 40u) << "no tick labels: is a font installed (fonts-dejavu-core)?";

    // Nothing to draw: nothing changes.
    std::vector<std::uint8_t> copy = before;
    engine::annotateImage(copy, w, h, engine::Annotation{});
    EXPECT_EQ(copy, before);
}

TEST(Annotate, NorthAndScaleFromTheCamera) {
    engine::FrameView v;
    v.width = 800;
    v.height = 600;
    v.minZ = 100;
    v.maxZ = 300;
    v.camera.eye[0] = v.camera.eye[1] = 0;
    v.camera.eye[2] = 1200;
    v.camera.fovDegrees = 60;
    v.camera.yawDegrees = 0;
    v.camera.pitchDegrees = -90;  // straight down, looking north: north is image up
    engine::Annotation a = engine::annotationFor(v);
    EXPECT_TRUE(a.colourKey);
    EXPECT_EQ(a.keyMinZ, 100);
    EXPECT_EQ(a.keyMaxZ, 300);
    EXPECT_NEAR(a.northX, 0, 1e-9);
    EXPECT_LT(a.northY, 0);
    // The centre ray meets z = 200 at depth 1000: 2 * 1000 * tan(30 deg) / 600 m per pixel.
    ASSERT_TRUE(a.scaleBar);
    EXPECT_FALSE(a.scaleExact);
    EXPECT_NEAR(a.metresPerPixel, 2000 * std::tan(M_PI / 6) / 600, 1e-9);
    // Looking east and down: north is to the left.
    v.camera.yawDegrees = 90;
    v.camera.pitchDegrees = -40;
    a = engine::annotationFor(v);
    EXPECT_NEAR(std::atan2(a.northX, -a.northY) * 180 / M_PI, -90, 1e-6);
    // Looking south: north points down the image.
    v.camera.yawDegrees = 180;
    a = engine::annotationFor(v);
    EXPECT_GT(a.northY, 0);
    EXPECT_NEAR(a.northX, 0, 1e-9);
    // Level, looking north: north is straight ahead; no ground at the centre, no scale bar.
    v.camera.yawDegrees = 0;
    v.camera.pitchDegrees = 0;
    a = engine::annotationFor(v);
    EXPECT_EQ(a.northAlongView, 1);
    EXPECT_FALSE(a.scaleBar);
    // Grid mode: orthographic, north up, exact scale, no colour key (flat line colour).
    v.grid = true;
    v.gridHalfHeight = 3000;
    a = engine::annotationFor(v);
    EXPECT_FALSE(a.colourKey);
    EXPECT_TRUE(a.scaleExact);
    EXPECT_DOUBLE_EQ(a.metresPerPixel, 10.0);
    EXPECT_EQ(a.northY, -1);
}

class AnnotatedCapture : public ::testing::Test {
protected:
    static void SetUpTestSuite() {
        dir_ = fs::temp_directory_path() / ("unilod_test_annotate_" + std::to_string(getpid()));
        fs::create_directories(dir_);
        file_ = (dir_ / "jacksboro.ulod").string();
        const auto r = runCli("build -q " + q(kAssets + "/jacksboro_dem.tif") + " " +
                              q(kAssets + "/jacksboro_rivers_grass.geojson") + " -o " + q(file_));
        ASSERT_EQ(r.code, 0) << r.err;
        std::string error;
        format::Reader reader;
        ASSERT_TRUE(reader.open(file_, error)) << error;
        header_ = reader.header();
    }
    static void TearDownTestSuite() { fs::remove_all(dir_); }

    static nlohmann::json capture(const std::string& name, const std::string& camera,
                                  const std::string& extra, Image& image) {
        const fs::path out = dir_ / name;
        const auto r = runCli("capture " + q(file_) + " --validation --camera " + camera +
                              " --size 480x360 " + extra + " --out " + q(out.string()));
        EXPECT_EQ(r.code, 0) << r.err;
        EXPECT_TRUE(readPng((out / "frame_0000.png").string(), image));
        return nlohmann::json::parse(slurp((out / "frame_0000.json").string()), nullptr, false);
    }

    // A camera south of the data looking north-east and down, `height` above its top.
    static std::string oblique(double yaw, double pitch) {
        char c[256];
        std::snprintf(c, sizeof c, "%.3f,%.3f,%.3f,%g,%g", (header_.minX + header_.maxX) / 2,
                      header_.minY - 0.3 * (header_.maxY - header_.minY), header_.maxZ + 15000, yaw,
                      pitch);
        return c;
    }

    static fs::path dir_;
    static std::string file_;
    static format::Header header_;
};

fs::path AnnotatedCapture::dir_;
std::string AnnotatedCapture::file_;
format::Header AnnotatedCapture::header_;

TEST_F(AnnotatedCapture, DiffersOnlyInTheAnnotation) {
    const std::string camera = oblique(20, -35);
    Image plain, annotated;
    const nlohmann::json pj = capture("plain", camera, "", plain);
    const nlohmann::json aj = capture("annotated", camera, "--annotate", annotated);
    ASSERT_FALSE(pj.is_discarded());
    ASSERT_FALSE(aj.is_discarded());
    EXPECT_EQ(pj["annotated"], false);
    EXPECT_TRUE(pj["annotation"].is_null());
    EXPECT_EQ(aj["annotated"], true);
    ASSERT_EQ(plain.width, annotated.width);
    ASSERT_EQ(plain.height, annotated.height);
    const nlohmann::json& an = aj["annotation"];
    ASSERT_EQ(an["regions"].size(), 3u);  // colour key, scale bar, north arrow

    std::size_t in = 0, out = 0;
    countDifferences(plain, annotated, an["regions"], in, out);
    EXPECT_EQ(out, 0u) << "pixels changed outside the annotation regions";
    EXPECT_GT(in, 2000u);

    // The colour key: the file's z range, max at the top, each row the ramp's colour.
    const nlohmann::json& key = an["colour_key"];
    EXPECT_DOUBLE_EQ(key["min_z"].get<double>(), header_.minZ);
    EXPECT_DOUBLE_EQ(key["max_z"].get<double>(), header_.maxZ);
    const int bx = key["bar"][0], by = key["bar"][1], bw = key["bar"][2], bh = key["bar"][3];
    EXPECT_GT(bx, int(annotated.width) / 2);  // top right
    EXPECT_LT(by + bh, int(annotated.height) * 2 / 3);
    ASSERT_GT(bw, 4);
    ASSERT_GT(bh, 40);
    for (int row = 0; row < bh; ++row) {
        const auto want = rampByte(1.0 - (row + 0.5) / bh);
        for (int x : {bx, bx + bw / 2, bx + bw - 1}) {
            const std::uint8_t* p =
                &annotated.rgba[(std::size_t(by + row) * annotated.width + std::size_t(x)) * 4];
            ASSERT_EQ(p[0], want[0]) << "row " << row;
            ASSERT_EQ(p[1], want[1]) << "row " << row;
            ASSERT_EQ(p[2], want[2]) << "row " << row;
        }
    }
    const auto top = rampByte(1.0), bottom = rampByte(0.0);
    EXPECT_GT(top[0], 230);           // pale summits at the top
    EXPECT_GT(bottom[1], bottom[0]);  // lowland green at the bottom

    // Scale bar at the image centre (perspective) and the north arrow: looking 20 degrees east
    // of north, north leans 20 degrees left of image up.
    EXPECT_EQ(an["scale_bar"]["exact"], false);
    EXPECT_EQ(an["scale_bar"]["where"], "image centre");
    EXPECT_GT(an["scale_bar"]["pixels"].get<int>(), 0);
    const double north = an["north_arrow"]["degrees_clockwise_from_up"];
    EXPECT_LT(north, -5);
    EXPECT_GT(north, -45);
}

TEST_F(AnnotatedCapture, GridModeScaleIsExact) {
    char camera[256];
    const double top = header_.maxZ + 40000;
    std::snprintf(camera, sizeof camera, "%.3f,%.3f,%.3f,0,-90", (header_.minX + header_.maxX) / 2,
                  (header_.minY + header_.maxY) / 2, top);
    Image plain, annotated;
    capture("grid_plain", camera, "--grid", plain);
    const nlohmann::json aj = capture("grid_annotated", camera, "--grid --annotate", annotated);
    const nlohmann::json& an = aj["annotation"];
    ASSERT_EQ(an["regions"].size(), 2u);  // scale bar and north arrow: no tint, no key
    EXPECT_FALSE(an.contains("colour_key"));
    std::size_t in = 0, out = 0;
    countDifferences(plain, annotated, an["regions"], in, out);
    EXPECT_EQ(out, 0u);
    EXPECT_GT(in, 500u);
    engine::Camera c;
    c.eye[2] = top;
    c.fovDegrees = 60;
    const double mpp = 2 * engine::gridHalfHeight(c, header_.maxZ) / 360;
    EXPECT_NEAR(an["scale_bar"]["metres_per_pixel"].get<double>(), mpp,
                1e-6 * mpp);  // eye printed %.3f
    EXPECT_EQ(an["scale_bar"]["exact"], true);
    EXPECT_NEAR(an["scale_bar"]["pixels"].get<double>(),
                an["scale_bar"]["metres"].get<double>() / mpp, 0.5);
    EXPECT_EQ(an["north_arrow"]["degrees_clockwise_from_up"], 0.0);
}
