// Hostile files on every reader path (issue 16, part 1): the bundled model is built, then damaged
// in targeted ways WITH its checksums recomputed (tests/ulodbytes.h), so that only the semantic
// checks can catch the damage: NaN and inverted header extents, a block size of 0 or below, a
// 2^32-1 x 2^32-1 block grid, a NaN block origin, a vertex far above its block's box, a flipped
// and a duplicated triangle. And once without recomputation: a changed block byte. `unilod check`,
// `unilod capture` and `unilod export` must each exit 1 with a message naming the file (and the
// block, for a block's damage) and leave no output behind: capture used to render such blocks and
// export to skip the topology checks.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <string>
#include <vector>

#include "testutil.h"
#include "tools/cliutil.h"
#include "ulod.h"
#include "ulodbytes.h"

using namespace unilod;
namespace fs = std::filesystem;
using unilod::test::q;
using unilod::test::runCli;
using unilod::test::UlodBytes;

namespace {

const std::string kDem = std::string(UNILOD_ASSETS_DIR) + "/jacksboro_dem.tif";
const std::string kRivers = std::string(UNILOD_ASSETS_DIR) + "/jacksboro_rivers_grass.geojson";
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

class Hostile : public ::testing::Test {
protected:
    static inline test::TempDir* dir = nullptr;
    static inline std::string model, camera;
    static inline UlodBytes pristine;

    static void SetUpTestSuite() {
        dir = new test::TempDir("hostile");
        model = dir->file("j.ulod");
        // Raw blocks: the damage below edits arrays in place (tests/ulodbytes.h).
        const auto r = runCli("build -q --encoding raw " + q(kDem) + " " + q(kRivers) + " -o " +
                              q(model));
        ASSERT_EQ(r.code, 0) << r.err;
        format::Reader reader;
        std::string error;
        ASSERT_TRUE(reader.open(model, error)) << error;
        const format::Header& h = reader.header();
        // Straight down from high enough to see the whole model (60 degree field of view); with
        // --pixels 0.001 (capture, below) the view wants every leaf at full resolution, so the
        // engine, which reads an entry below the root when it first streams it (format version
        // 5), reads every block.
        char text[160];
        std::snprintf(text, sizeof text, "%.3f,%.3f,%.3f,0,-90", (h.minX + h.maxX) / 2,
                      (h.minY + h.maxY) / 2,
                      h.maxZ + 1.2 * std::max(h.maxX - h.minX, h.maxY - h.minY));
        camera = text;
        pristine = UlodBytes::load(model);
        ASSERT_GT(pristine.blockCount(), 2u);
    }
    static void TearDownTestSuite() {
        delete dir;
        dir = nullptr;
    }

    // A block in the middle of the file, and its name as the messages give it.
    static std::size_t block() { return pristine.blockCount() / 2; }
    static std::string blockName(const UlodBytes& f, std::size_t i) {
        return "block (" + std::to_string(f.get<std::uint32_t>(f.entry(i))) + "," +
               std::to_string(f.get<std::uint32_t>(f.entry(i) + 4)) + ")";
    }
    // Level 0's first triangle of block i (README: Level = u32 step, vertexCount, triangleFirst).
    static std::uint64_t firstTriangle(const UlodBytes& f, std::size_t i) {
        const auto first = f.get<std::uint32_t>(f.arrayAt(i, UlodBytes::kLevels) + 8);
        return f.arrayAt(i, UlodBytes::kTerrainIndices) + 12 * std::uint64_t(first);
    }

    // Saves `damaged` as NAME.ulod and runs check, capture and export on it: each must exit 1,
    // name the file, the block (when `where` is not empty) and, for check, `why`; no frame and
    // no .glb may be left.
    static void expectRejected(const std::string& name, const UlodBytes& damaged,
                               const std::string& where, const std::string& why) {
        SCOPED_TRACE(name);
        const std::string path = dir->file(name + ".ulod");
        ASSERT_TRUE(damaged.save(path));
        auto named = [&](const test::CliResult& r, const char* command) {
            EXPECT_EQ(r.code, 1) << command << ": " << r.err;
            EXPECT_NE(r.err.find(path), std::string::npos) << command << ": " << r.err;
            EXPECT_NE(r.err.find(where), std::string::npos) << command << ": " << r.err;
        };
        const auto c = runCli("check -q " + q(path));
        named(c, "check");
        EXPECT_NE(c.err.find(why), std::string::npos) << c.err;
        EXPECT_EQ(c.err.find(path), c.err.rfind(path)) << "the file named once: " << c.err;

        const std::string frames = dir->file(name + "_frames");
        const auto capture = runCli("capture --validation " + q(path) + " --camera " + camera +
                                    " --pixels 0.001 --size 64x48 --out " + q(frames));
        named(capture, "capture");
        EXPECT_FALSE(fs::exists(fs::path(frames) / "frame_0000.png"));

        const std::string glb = dir->file(name + ".glb");
        const auto e = runCli("export -q " + q(path) + " --h-lim 1 -o " + q(glb));
        named(e, "export");
        EXPECT_FALSE(fs::exists(glb));
    }
};

// The undamaged model passes all three: the failures below are the damage's.
TEST_F(Hostile, PristineModelPasses) {
    EXPECT_EQ(runCli("check -q " + q(model)).code, 0);
    const std::string frames = dir->file("pristine_frames");
    const auto c = runCli("capture --validation " + q(model) + " --camera " + camera +
                          " --pixels 0.001 --size 64x48 --out " + q(frames));
    EXPECT_EQ(c.code, 0) << c.err;
    EXPECT_TRUE(fs::exists(fs::path(frames) / "frame_0000.png"));
    const auto e = runCli("export -q " + q(model) + " --h-lim 1 -o " + q(dir->file("p.glb")));
    EXPECT_EQ(e.code, 0) << e.err;
}

TEST_F(Hostile, NaNHeaderExtents) {
    UlodBytes f = pristine;
    f.set<double>(UlodBytes::kMinX, kNaN);
    f.resealHeader();
    expectRejected("nan_extents", f, "", "header minX is not finite");
}

TEST_F(Hostile, InvertedHeaderExtents) {
    UlodBytes f = pristine;
    f.set<double>(UlodBytes::kMinY, f.get<double>(UlodBytes::kMaxY) + 1000);
    f.resealHeader();
    expectRejected("inverted_extents", f, "", "extents are inverted");
}

TEST_F(Hostile, BlockWidthZeroOrNegative) {
    for (double width : {0.0, -1920.0}) {
        UlodBytes f = pristine;
        f.set<double>(UlodBytes::kBlockWidth, width);
        f.resealHeader();
        expectRejected(width == 0 ? "width_zero" : "width_negative", f, "", "is not positive");
    }
}

TEST_F(Hostile, HugeBlockGrid) {
    UlodBytes f = pristine;
    f.set<std::uint32_t>(UlodBytes::kBlocksX, 0xffffffffu);
    f.set<std::uint32_t>(UlodBytes::kBlocksY, 0xffffffffu);
    f.resealHeader();
    expectRejected("huge_grid", f, "", "more cells than the file has bytes");
}

TEST_F(Hostile, NaNBlockOrigin) {
    UlodBytes f = pristine;
    f.set<double>(f.blockAt(block()) + UlodBytes::kBlockOriginX, kNaN);
    f.resealBlock(block());
    expectRejected("nan_origin", f, blockName(f, block()), "origin");
}

TEST_F(Hostile, VertexFarAboveItsBox) {
    UlodBytes f = pristine;
    const std::uint64_t z = f.arrayAt(block(), UlodBytes::kVertices) + 16 * 3 + 8;  // vertex 3
    f.set<float>(z, f.get<float>(z) + 5000.0f);
    f.resealBlock(block());
    expectRejected("vertex_z", f, blockName(f, block()),
                   "vertex 3 (");  // "... lies outside the block's bounding box"
}

TEST_F(Hostile, FlippedTriangle) {
    UlodBytes f = pristine;
    const std::uint64_t t = firstTriangle(f, block());
    const auto b = f.get<std::uint32_t>(t + 4), c = f.get<std::uint32_t>(t + 8);
    f.set<std::uint32_t>(t + 4, c);
    f.set<std::uint32_t>(t + 8, b);
    f.resealBlock(block());
    expectRejected("flipped", f, blockName(f, block()), "is not counter-clockwise");
}

TEST_F(Hostile, DuplicatedTriangle) {
    UlodBytes f = pristine;
    const std::uint64_t t = firstTriangle(f, block());
    for (int k = 0; k < 3; ++k)
        f.set<std::uint32_t>(t + 12 + 4 * k, f.get<std::uint32_t>(t + 4 * k));
    f.resealBlock(block());
    expectRejected("duplicated", f, blockName(f, block()), "in the same direction");
}

// No checksum recomputed: the block's CRC must stop every command, capture included.
TEST_F(Hostile, ChangedBlockByte) {
    UlodBytes f = pristine;
    const std::uint64_t z = f.arrayAt(block(), UlodBytes::kVertices) + 16 * 3 + 8;
    f.set<float>(z, f.get<float>(z) + 0.5f);  // a plausible altitude: only the CRC can tell
    expectRejected("crc", f, blockName(f, block()), "checksum mismatch");
}

// Two damaged blocks. A preloading open (bench's preloaded runs) reads and validates every entry
// on several threads and still names the first damaged block in file order, every time; a
// streaming capture reads an entry when the view first wants it (one loader thread, nearest
// first) and names the same one every time.
TEST_F(Hostile, TwoDamagedBlocksTheSameIsNamedEveryTime) {
    UlodBytes f = pristine;
    const std::size_t first = 1, second = f.blockCount() / 2;
    for (std::size_t i : {first, second}) {
        const std::uint64_t z = f.arrayAt(i, UlodBytes::kVertices) + 8;
        f.set<float>(z, f.get<float>(z) + 0.5f);
    }
    const std::string path = dir->file("two.ulod");
    ASSERT_TRUE(f.save(path));
    ASSERT_NE(blockName(f, first), blockName(f, second));
    std::string captureNamed;
    for (int run = 0; run < 3; ++run) {
        const auto b = runCli("bench -q " + q(path) + " --runs full --frames 1 --warmup 0 " +
                              "--warmup-ms 0 --size 64x48 -o " +
                              q(dir->file("two_bench" + std::to_string(run) + ".json")));
        EXPECT_EQ(b.code, 1) << b.err;
        EXPECT_NE(b.err.find(blockName(f, first) + ":"), std::string::npos) << b.err;
        EXPECT_EQ(b.err.find(blockName(f, second) + ":"), std::string::npos) << b.err;

        const std::string frames = dir->file("two_frames" + std::to_string(run));
        const auto r = runCli("capture " + q(path) + " --camera " + camera +
                              " --pixels 0.001 --size 64x48 --out " + q(frames));
        EXPECT_EQ(r.code, 1) << r.err;
        const bool one = r.err.find(blockName(f, first) + ":") != std::string::npos;
        const bool two = r.err.find(blockName(f, second) + ":") != std::string::npos;
        EXPECT_NE(one, two) << r.err;
        const std::string named = one ? blockName(f, first) : blockName(f, second);
        if (run == 0) captureNamed = named;
        EXPECT_EQ(named, captureNamed) << r.err;
        EXPECT_FALSE(fs::exists(fs::path(frames) / "frame_0000.png"));
    }
}

// Extents that are finite but so large that the default view (capture's overview, export's
// default) cannot be made: both commands name the file and the cause instead of the engine's
// "camera position must be finite" without a file name.
TEST_F(Hostile, HugeHeaderExtentsGiveNoDefaultView) {
    UlodBytes f = pristine;
    f.set<double>(UlodBytes::kMinX, -1e300);
    f.set<double>(UlodBytes::kMinY, -1e300);
    f.set<double>(UlodBytes::kMaxX, 1e300);
    f.set<double>(UlodBytes::kMaxY, 1e300);
    f.resealHeader();
    const std::string path = dir->file("huge_extents.ulod");
    ASSERT_TRUE(f.save(path));
    const std::string glb = dir->file("huge_extents.glb");
    const auto e = runCli("export -q " + q(path) + " -o " + q(glb));
    EXPECT_EQ(e.code, 1) << e.err;
    EXPECT_NE(e.err.find(path + ": the model's extent"), std::string::npos) << e.err;
    EXPECT_NE(e.err.find("no valid default view"), std::string::npos) << e.err;
    EXPECT_FALSE(fs::exists(glb));
    const std::string frames = dir->file("huge_extents_frames");
    const auto c = runCli("capture -q " + q(path) + " --size 64x48 -o " + q(frames));
    EXPECT_EQ(c.code, 1) << c.err;
    EXPECT_NE(c.err.find(path + ": the model's extent"), std::string::npos) << c.err;
    EXPECT_FALSE(fs::exists(frames));
}

// --camera of view, capture and export: one check (tools/cli/engineopts.h addCameraOption) while
// parsing, so a bad value is a usage error naming the option and the component, before any
// file, window or device is opened (view used to run with a NaN eye under xvfb, and without a
// display to report only that; capture and export exited 1 without the option's name).
TEST_F(Hostile, BadCameraValuesAreUsageErrorsNamingTheComponent) {
    struct Case {
        std::string value, named;
    };
    const std::vector<Case> cases = {
        {"nan,0,0,0,0", "x 'nan' is not a finite number"},
        {"0,inf,0,0,0", "y 'inf' is not a finite number"},
        {"0,0,1e999,0,0", "z '1e999' is not a finite number"},
        {"0,0,0,-nan,0", "yaw '-nan' is not a finite number"},
        {"746000,4050000,5000,0,-95", "pitch '-95' must be in [-90, 90]"},
        {"746000,4050000,5000,0,91", "pitch '91' must be in [-90, 90]"},
        {"1,,2,3,4,5", "(6 values)"},
        {"1,2,,4,5", "z '' is not a finite number"},
        {"1,2,3,4,5,", "(6 values)"},
    };
    const std::string out = dir->file("camera_refused");
    for (const Case& c : cases) {
        for (const std::string& command :
             {"view " + q(model) + " --frames 1", "capture " + q(model) + " -o " + q(out),
              "export " + q(model) + " -o " + q(out)}) {
            SCOPED_TRACE(command + " --camera " + c.value);
            const auto r = runCli(command + " --camera " + q(c.value));
            EXPECT_EQ(r.code, 2) << r.err;
            EXPECT_NE(r.err.find("--camera: "), std::string::npos) << r.err;
            EXPECT_NE(r.err.find(c.named), std::string::npos) << r.err;
            EXPECT_EQ(r.err.find("display"), std::string::npos) << "checked before the window";
            EXPECT_FALSE(fs::exists(out));
        }
    }
    // Export alone also takes X,Y,Z; the same checks apply to it.
    const auto r = runCli("export " + q(model) + " -o " + q(out) + " --camera nan,0,0");
    EXPECT_EQ(r.code, 2) << r.err;
    EXPECT_NE(r.err.find("--camera: x 'nan' is not a finite number"), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(out));
}

}  // namespace
