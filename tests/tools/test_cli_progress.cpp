// Progress lines (tools/cli/progress.h, issue 20 item 4): `unilod build` on the bundled DEM
// prints, on stderr, a first line before it reads its inputs and lines with the elapsed time and
// an ETA while it builds the blocks; -q prints none of them (errors and the summary stay). The
// ETA follows the recent rate (EtaEstimator), and the build's share of work weighs its items by
// their cost and moves while an item runs (BuildOptions::progress).
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <sstream>
#include <string>
#include <vector>

#include "build.h"
#include "cli/progress.h"
#include "cliutil.h"
#include "testutil.h"

namespace {

namespace fs = std::filesystem;
using unilod::test::CliResult;
using unilod::test::q;
using unilod::test::runCli;

std::vector<std::string> progressLines(const std::string& err) {
    std::vector<std::string> out;
    std::istringstream in(err);
    for (std::string l; std::getline(in, l);)
        if (l.rfind("build: ", 0) == 0) out.push_back(l);
    return out;
}

TEST(CliProgress, BuildPrintsElapsedAndEta) {
    const fs::path dir = fs::temp_directory_path() / ("unilod_progress_" + std::to_string(getpid()));
    fs::remove_all(dir);
    fs::create_directories(dir);
    const std::string inputs = q(std::string(UNILOD_ASSETS_DIR) + "/jacksboro_dem.tif") + " " +
                               q(std::string(UNILOD_ASSETS_DIR) + "/jacksboro_rivers_grass.geojson");
    // stderr is a file here (not a terminal): one line per state, no \r.
    const CliResult r = runCli("build " + inputs + " --stride 2 -o " + q((dir / "a.ulod").string()));
    ASSERT_EQ(r.code, 0) << r.err;
    const std::vector<std::string> lines = progressLines(r.err);
    ASSERT_GE(lines.size(), 3u) << r.err;
    EXPECT_EQ(r.err.find('\r'), std::string::npos);
    // The first line comes before the inputs are read (so within a second of the start).
    EXPECT_EQ(lines.front().rfind("build: reading the DEM and the rivers  elapsed ", 0), 0u)
        << lines.front();
    bool counted = false, done = false, cleaning = false;
    for (const std::string& l : lines) {
        cleaning = cleaning || l.rfind("build: cleaning the rivers  elapsed ", 0) == 0;
        EXPECT_NE(l.find("  elapsed "), std::string::npos) << l;
        EXPECT_NE(l.find("  ETA "), std::string::npos) << l;
        if (l.find("blocks") != std::string::npos && l.find('/') != std::string::npos)
            counted = true;
        if (l.find("100 %") != std::string::npos && l.find("ETA 0 s") != std::string::npos)
            done = true;
    }
    EXPECT_TRUE(cleaning) << r.err;
    EXPECT_TRUE(counted) << r.err;
    EXPECT_TRUE(done) << r.err;
    EXPECT_NE(r.out.find("unilod build summary"), std::string::npos);

    const CliResult quiet =
        runCli("build " + inputs + " --stride 2 -q -o " + q((dir / "b.ulod").string()));
    ASSERT_EQ(quiet.code, 0) << quiet.err;
    EXPECT_TRUE(progressLines(quiet.err).empty()) << quiet.err;
    EXPECT_EQ(quiet.err.find("elapsed"), std::string::npos) << quiet.err;
    EXPECT_NE(quiet.out.find("unilod build summary"), std::string::npos);
    // Errors still print with -q.
    const CliResult exists =
        runCli("build " + inputs + " --stride 2 -q -o " + q((dir / "b.ulod").string()));
    EXPECT_EQ(exists.code, 1);
    EXPECT_NE(exists.err.find("already exists (use --overwrite to replace it)"), std::string::npos)
        << exists.err;
    if (!HasFailure()) fs::remove_all(dir);
}

// A stage that slows down: 90 % in its first 10 s, then 5 % in the next 20 s (a build's tree
// nodes running alone at the end). The whole stage's rate would say 1.6 s left; the recent rate
// says 20 s.
TEST(CliProgress, EtaFollowsTheRecentRate) {
    using unilod::cli::EtaEstimator;
    EtaEstimator e;
    EXPECT_EQ(e.eta(1.0, 0.0), -1);  // nothing done: unknown
    e.add(0, 0);
    for (int i = 1; i <= 40; ++i)
        e.add(0.25 * i, 0.09 * 0.25 * i);                   // 0.09 a second up to 10 s
    EXPECT_NEAR(e.eta(10.0, 0.9), 10.0 * 0.1 / 0.9, 1e-9);  // constant rate: the whole stage's
    for (int i = 1; i <= 80; ++i)
        e.add(10 + 0.25 * i, 0.9 + 0.05 * i / 80.0);  // 0.0025 a second from 10 to 30 s
    EXPECT_NEAR(e.eta(30.0, 0.95), 20.0, 1e-6);
    EXPECT_GT(e.eta(30.0, 0.95), 10 * (30.0 * 0.05 / 0.95));
    // Nothing moved within the window: the whole stage's rate (not "never").
    for (int i = 1; i <= 80; ++i)
        e.add(30 + 0.25 * i, 0.95);
    EXPECT_NEAR(e.eta(50.0, 0.95), 50.0 * 0.05 / 0.95, 1e-9);
    EXPECT_EQ(e.eta(50.0, 1.0), 0);
    // The window is the last 10 s or the last quarter of the stage: at 100 s, the last 25 s.
    EXPECT_EQ(EtaEstimator::window(4), 10);
    EXPECT_EQ(EtaEstimator::window(100), 25);
}

// The build's progress: item counts and the share of work both only grow and end at n / n and
// 1; the share moves while an item runs (the tree's last nodes run alone for a while on large
// models); the root weighs more than an even share of the items (it locates every original
// point: itemWork in build.h), so that with only the root left the share is well below (n - 1) / n.
TEST(CliProgress, BuildShareMovesWithinItemsAndWeighsTheTree) {
    unilod::test::TempDir dir("share");
    unilod::BuildOptions o;
    o.demPath = std::string(UNILOD_ASSETS_DIR) + "/jacksboro_dem.tif";
    o.riversPath = std::string(UNILOD_ASSETS_DIR) + "/jacksboro_rivers_grass.geojson";
    o.outPath = (dir.path / "m.ulod").string();
    o.blockSize = 64;
    o.threads = 2;
    o.progressInterval = 0.001;
    struct Call {
        std::size_t done, total;
        double share;
    };
    std::vector<Call> calls;
    o.progress = [&](std::size_t done, std::size_t total, double share) {
        calls.push_back({done, total, share});
    };
    unilod::BuildSummary summary;
    std::string error;
    ASSERT_TRUE(unilod::runBuild(o, summary, error)) << error;
    ASSERT_FALSE(calls.empty());
    const std::size_t n = calls.back().total;
    ASSERT_GT(n, 40u);  // 42 blocks and their tree nodes
    EXPECT_EQ(calls.back().done, n);
    EXPECT_EQ(calls.back().share, 1.0);
    bool movedWithin = false;
    double rootAlone = 2;  // the least share with only the root left
    for (std::size_t k = 0; k < calls.size(); ++k) {
        const Call& c = calls[k];
        EXPECT_EQ(c.total, n);
        EXPECT_GE(c.share, 0.0);
        EXPECT_LE(c.share, 1.0);
        if (k > 0) {
            EXPECT_GE(c.done, calls[k - 1].done) << k;
            EXPECT_GE(c.share, calls[k - 1].share) << k;
            if (c.done == calls[k - 1].done && c.share > calls[k - 1].share) movedWithin = true;
        }
        if (c.done == n - 1) rootAlone = std::min(rootAlone, c.share);
    }
    EXPECT_TRUE(movedWithin);
    // The root is about a tenth of this build's work (an even share: under 2 %).
    EXPECT_LT(rootAlone, 0.95) << "an even share: " << double(n - 1) / double(n);
}

}  // namespace
