// Progress lines (tools/cli/progress.h, issue 20 item 4): `unilod build` on the bundled DEM
// prints, on stderr, a first line before it reads its inputs and lines with the elapsed time and
// an ETA while it builds the blocks; -q prints none of them (errors and the summary stay).
#include <gtest/gtest.h>

#include <filesystem>
#include <sstream>
#include <string>
#include <vector>

#include "cliutil.h"

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

}  // namespace
