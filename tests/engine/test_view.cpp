// The windowed target end to end (issue 5): `unilod view` under Xvfb on Mesa lavapipe with the
// validation layer on opens a window, renders 30 frames through the swapchain, writes the last
// one as a screenshot and closes cleanly (exit 0, no validation message). The screenshot must
// not be blank; in grid mode it shows the grid line and river colours; a window resized half way
// gets a new swapchain and the screenshot has the new size. Without a display the
// command exits 1 with a clear message. CI installs Xvfb, so these tests only skip (and say so)
// where `xvfb-run` is absent.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <set>

#include "annotate.h"
#include "pngread.h"
#include "shared.h"
#include "testutil.h"
#include "tools/cliutil.h"
#include "ulod.h"
#include "view.h"

namespace fs = std::filesystem;
using namespace unilod;
using unilod::test::CliResult;
using unilod::test::Image;
using unilod::test::q;
using unilod::test::readPng;
using unilod::test::runCli;
using unilod::test::slurp;

namespace {

const std::string kAssets = UNILOD_ASSETS_DIR;

bool haveXvfb() {
    return std::system("command -v xvfb-run >/dev/null 2>&1") == 0;
}

// Runs `PREFIX 'unilod' ARGS` through the shell (PREFIX: a wrapper such as xvfb-run). The exit
// code is unilod's own, written by a script inside the wrapper: xvfb-run can fail its own
// clean-up (exit 5, "problem while cleaning up temporary directory") after a command that ends
// very quickly, and that is not what the tests check.
CliResult runWrapped(const std::string& prefix, const std::string& args, const fs::path& dir) {
    static int counter = 0;
    const std::string base = (dir / ("run_" + std::to_string(counter++))).string();
    {
        std::ofstream script(base + ".sh");
        script << "'" << UNILOD_CLI << "' " << args << " >'" << base << ".out' 2>'" << base
               << ".err'\necho $? >'" << base << ".code'\n";
    }
    const std::string command = prefix + " sh '" + base + ".sh' >'" + base + ".wrap' 2>&1";
    const int status = std::system(command.c_str());
    CliResult r;
    const std::string code = slurp(base + ".code");
    if (!code.empty())
        r.code = std::atoi(code.c_str());
    else  // the wrapper did not run the command at all
        r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    r.out = slurp(base + ".out");
    r.err = slurp(base + ".err") + slurp(base + ".wrap");
    return r;
}

const std::string kXvfb = "xvfb-run -a -s '-screen 0 1280x1024x24'";

int channel(float c) {
    return int(std::lround(c * 255));
}

bool near(const std::uint8_t* p, const engine::shader::vec3& c) {
    return std::abs(p[0] - channel(c.r)) <= 2 && std::abs(p[1] - channel(c.g)) <= 2 &&
           std::abs(p[2] - channel(c.b)) <= 2;
}

// The frame count of view's closing line "FILE: N frames on DEVICE" (0 without one): at least
// the --frames asked for, more where the screenshot waited for the view to settle (view.cpp).
unsigned long framesRun(const std::string& out) {
    const std::size_t on = out.find(" frames on ");
    if (on == std::string::npos || on == 0) return 0;
    const std::size_t start = out.find_last_not_of("0123456789", on - 1) + 1;
    return start < on ? std::stoul(out.substr(start, on - start)) : 0;
}

class View : public ::testing::Test {
protected:
    static void SetUpTestSuite() {
        dir_ = fs::temp_directory_path() / ("unilod_test_view_" + std::to_string(getpid()));
        fs::create_directories(dir_);
        file_ = (dir_ / "jacksboro.ulod").string();
        const auto r = runCli("build -q " + q(kAssets + "/jacksboro_dem.tif") + " " +
                              q(kAssets + "/jacksboro_rivers_grass.geojson") + " -o " + q(file_));
        ASSERT_EQ(r.code, 0) << r.err;
    }
    static void TearDownTestSuite() { fs::remove_all(dir_); }

    // 30 validated frames at 640x480 under Xvfb, the last one written to `name`.png.
    static Image view(const std::string& name, const std::string& extra, CliResult& r) {
        const std::string png = (dir_ / (name + ".png")).string();
        r = runWrapped(kXvfb,
                       "view " + q(file_) + " --validation --frames 30 --size 640x480" + extra +
                           " --screenshot " + q(png),
                       dir_);
        Image image;
        EXPECT_EQ(r.code, 0) << r.out << r.err;
        EXPECT_EQ(r.err.find("validation"), std::string::npos) << r.err;
        EXPECT_TRUE(readPng(png, image)) << png;
        return image;
    }

    static fs::path dir_;
    static std::string file_;
};

fs::path View::dir_;
std::string View::file_;

#define SKIP_WITHOUT_XVFB()                                                                  \
    if (!haveXvfb())                                                                         \
    GTEST_SKIP() << "xvfb-run not found (Debian: xvfb): this window test needs a display"

TEST_F(View, RendersThirtyFramesAndScreenshot) {
    SKIP_WITHOUT_XVFB();
    CliResult r;
    const Image image = view("perspective", "", r);
    // The stats line (FPS, triangles, blocks, GPU memory) and the frame count.
    EXPECT_NE(r.out.find(" fps, "), std::string::npos) << r.out;
    EXPECT_NE(r.out.find(" triangles, blocks "), std::string::npos) << r.out;
    EXPECT_NE(r.out.find(" MiB"), std::string::npos) << r.out;
    EXPECT_GE(framesRun(r.out), 30u) << r.out;
    ASSERT_EQ(image.width, 640u);
    ASSERT_EQ(image.height, 480u);
    // Not blank: many colours, most pixels terrain rather than the black clear colour, and the
    // rivers drawn.
    std::set<std::uint32_t> colours;
    std::size_t covered = 0, river = 0;
    const std::size_t pixels = std::size_t(image.width) * image.height;
    for (std::size_t i = 0; i < pixels; ++i) {
        const std::uint8_t* p = &image.rgba[i * 4];
        colours.insert(std::uint32_t(p[0]) << 16 | std::uint32_t(p[1]) << 8 | p[2]);
        if (p[0] || p[1] || p[2]) ++covered;
        if (near(p, engine::shader::kRiverColour)) ++river;
    }
    EXPECT_GT(colours.size(), 50u);
    EXPECT_GT(covered, pixels / 2);
    EXPECT_GT(river, 50u);
}

TEST_F(View, GridModeShowsGridAndRivers) {
    SKIP_WITHOUT_XVFB();
    CliResult r;
    const Image image = view("grid", " --grid", r);
    ASSERT_EQ(image.width, 640u);
    ASSERT_EQ(image.height, 480u);
    std::size_t grid = 0, river = 0;
    const std::size_t pixels = std::size_t(image.width) * image.height;
    for (std::size_t i = 0; i < pixels; ++i) {
        const std::uint8_t* p = &image.rgba[i * 4];
        if (near(p, engine::shader::kGridColour)) ++grid;
        if (near(p, engine::shader::kRiverColour)) ++river;
    }
    EXPECT_GT(grid, pixels / 20);
    EXPECT_GT(river, 50u);
    EXPECT_NE(r.out.find(", grid"), std::string::npos) << r.out;
}

// --annotate: the screenshot carries the colour key (the renderer's ramp over the file's z range,
// max at the top) where annotateImage lays it out for a 640x480 image.
TEST_F(View, AnnotatedScreenshotHasTheColourKey) {
    SKIP_WITHOUT_XVFB();
    CliResult r;
    const Image image = view("annotated", " --annotate", r);
    ASSERT_EQ(image.width, 640u);
    ASSERT_EQ(image.height, 480u);
    format::Reader reader;
    std::string error;
    ASSERT_TRUE(reader.open(file_, error)) << error;
    engine::FrameView v;
    v.width = 640;
    v.height = 480;
    v.minZ = reader.header().minZ;
    v.maxZ = reader.header().maxZ;
    v.camera = engine::defaultViewCamera(reader.header(), 60);
    std::vector<std::uint8_t> scratch(640 * 480 * 4, 0);
    engine::AnnotationLayout layout;
    engine::annotateImage(scratch, 640, 480, engine::annotationFor(v), &layout);
    const engine::PixelRect bar = layout.keyBar;
    ASSERT_GT(bar.height, 40);
    for (std::int32_t row = 0; row < bar.height; ++row) {
        const engine::shader::vec3 want =
            engine::shader::hypsometricTint(float(1.0 - (row + 0.5) / bar.height));
        const std::uint8_t* p =
            &image.rgba[(std::size_t(bar.y + row) * image.width + std::size_t(bar.x + 2)) * 4];
        EXPECT_TRUE(near(p, want)) << "row " << row << ": " << int(p[0]) << "," << int(p[1])
                                   << "," << int(p[2]);
    }
}

// The window is resized half way (as a window manager would): the swapchain is recreated, the
// frames go on at the new size without a validation message, and the screenshot has that size.
TEST_F(View, ResizeRecreatesTheSwapchain) {
    SKIP_WITHOUT_XVFB();
    CliResult r;
    const Image image = view("resized", " --resize 400x300", r);
    EXPECT_EQ(image.width, 400u);
    EXPECT_EQ(image.height, 300u);
    EXPECT_GE(framesRun(r.out), 30u) << r.out;
}

TEST_F(View, ErrorsExitOneWithAMessage) {
    // No display at all (no Xvfb): a clear error naming the file, no crash.
    const std::string png = (dir_ / "nodisplay.png").string();
    CliResult r = runWrapped("env -u DISPLAY -u WAYLAND_DISPLAY",
                             "view " + q(file_) + " --frames 1 --screenshot " + q(png), dir_);
    EXPECT_EQ(r.code, 1) << r.out << r.err;
    EXPECT_NE(r.err.find("display"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("jacksboro.ulod"), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(png));
    // --screenshot without --frames is a usage error.
    r = runCli("view " + q(file_) + " --screenshot " + q(png));
    EXPECT_EQ(r.code, 2) << r.err;
    SKIP_WITHOUT_XVFB();
    // A missing file under a display: exit 1 naming it, no screenshot.
    const std::string missing = (dir_ / "missing.ulod").string();
    r = runWrapped(kXvfb, "view " + q(missing) + " --frames 1 --screenshot " + q(png), dir_);
    EXPECT_EQ(r.code, 1) << r.out << r.err;
    EXPECT_NE(r.err.find("missing.ulod"), std::string::npos) << r.err;
    EXPECT_EQ(r.err.find(missing), r.err.rfind(missing)) << "named once: " << r.err;
    EXPECT_FALSE(fs::exists(png));
}

}  // namespace
