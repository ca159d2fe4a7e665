// Outputs and inputs of the `unilod` commands (issue 16; format::AtomicFile and
// format::checkInputFile, engine/format/atomicfile.h): an output that is one of the command's
// inputs is refused (also with --force) and the input stays byte for byte; a write that fails
// (a file size limit: EFBIG, as a full disk gives ENOSPC) fails the command and leaves no output;
// a command writing OUT removes the temporaries of OUT left by killed runs and keeps those of
// running ones; a FIFO given as input is refused at once instead of blocking in open(); a
// directory given as a file input is refused with a message saying so. The model is a small
// synthetic one (`unilod synth` + `unilod build`).
#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <set>
#include <string>
#include <thread>
#include <tuple>
#include <vector>

#include "testutil.h"
#include "tools/cliutil.h"

namespace fs = std::filesystem;
using unilod::test::q;
using unilod::test::runCli;
using unilod::test::slurp;

namespace {

// Under `timeout`, so that a command blocking on a FIFO fails the test (exit 124) instead of
// hanging it.
const std::string kTimeout = "timeout 20";
// The synthetic DEM is about 47 x 38 cells.
const std::string kBlocks = " --block-size 16";

class CliOutputs : public ::testing::Test {
protected:
    static inline unilod::test::TempDir* dir = nullptr;
    static inline std::string dem, rivers, model;

    static void SetUpTestSuite() {
        dir = new unilod::test::TempDir("outputs");
        const std::string data = dir->file("data");
        auto r = runCli("synth --points 2000 -o " + q(data));
        ASSERT_EQ(r.code, 0) << r.err;
        dem = data + "/dem.tif";
        rivers = data + "/rivers.geojson";
        model = dir->file("model.ulod");
        r = runCli("build -q " + q(dem) + " " + q(rivers) + " -o " + q(model) + kBlocks);
        ASSERT_EQ(r.code, 0) << r.err;
    }
    static void TearDownTestSuite() {
        delete dir;
        dir = nullptr;
    }

    // The entries of a folder whose name starts with `prefix`.
    static std::set<std::string> entries(const fs::path& folder, const std::string& prefix) {
        std::set<std::string> out;
        for (const auto& e : fs::directory_iterator(folder)) {
            const std::string n = e.path().filename().string();
            if (n.rfind(prefix, 0) == 0) out.insert(n);
        }
        return out;
    }
};

using unilod::test::deadPid;

// Starts `unilod ARGS...` with stdout and stderr to /dev/null and SIGINT and SIGPIPE at their
// defaults, as in a terminal (a background job or a test runner may ignore them).
pid_t startCli(const std::vector<std::string>& args) {
    std::vector<char*> argv{const_cast<char*>(UNILOD_CLI)};  // before the fork: no allocation
    for (const std::string& a : args)                        // in the child
        argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    const pid_t child = fork();
    if (child != 0) return child;
    const int devnull = ::open("/dev/null", O_WRONLY);
    dup2(devnull, 1);
    dup2(devnull, 2);
    signal(SIGINT, SIG_DFL);
    signal(SIGPIPE, SIG_DFL);
    execv(UNILOD_CLI, argv.data());
    _exit(127);
}

// Waits up to 60 s for an entry of `folder` whose name starts with `prefix` to appear while
// `child` runs: a failure when it ends first or none appears.
::testing::AssertionResult waitForEntry(const fs::path& folder, const std::string& prefix,
                                        pid_t child) {
    for (int i = 0; i < 6000; ++i) {
        for (const auto& e : fs::directory_iterator(folder))
            if (e.path().filename().string().rfind(prefix, 0) == 0)
                return ::testing::AssertionSuccess();
        int status = 0;
        if (waitpid(child, &status, WNOHANG) == child)
            return ::testing::AssertionFailure()
                   << "the command ended before '" << prefix << "...' appeared";
        usleep(10000);
    }
    return ::testing::AssertionFailure() << "no '" << prefix << "...' appeared in 60 s";
}

}  // namespace

TEST_F(CliOutputs, ExportOntoItsInputRefused) {
    const std::string before = slurp(model);
    ASSERT_FALSE(before.empty());
    auto r = runCli("export -q " + q(model) + " --h-lim 50 -o " + q(model));
    EXPECT_EQ(r.code, 1) << r.out;
    EXPECT_NE(r.err.find(model), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("input"), std::string::npos) << r.err;
    EXPECT_EQ(slurp(model), before);
    // Through another name of the same file.
    const std::string alias = dir->file("alias.glb");
    ASSERT_EQ(link(model.c_str(), alias.c_str()), 0);
    r = runCli("export -q " + q(model) + " --h-lim 50 -o " + q(alias));
    EXPECT_EQ(r.code, 1) << r.out;
    EXPECT_NE(r.err.find("input"), std::string::npos) << r.err;
    EXPECT_EQ(slurp(model), before);
    fs::remove(alias);
    EXPECT_EQ(entries(dir->path, "model.ulod"), std::set<std::string>{"model.ulod"});
}

TEST_F(CliOutputs, BuildOntoItsInputsRefusedEvenWithForce) {
    for (const std::string& input : {dem, rivers}) {
        const std::string before = slurp(input);
        ASSERT_FALSE(before.empty());
        const auto r = runCli("build -q " + q(dem) + " " + q(rivers) + " -o " + q(input) +
                              " --force" + kBlocks);
        EXPECT_EQ(r.code, 1) << r.out;
        EXPECT_NE(r.err.find(input), std::string::npos) << r.err;
        EXPECT_NE(r.err.find("input"), std::string::npos) << r.err;
        EXPECT_EQ(slurp(input), before);
        const fs::path folder = fs::path(input).parent_path();
        const std::string name = fs::path(input).filename().string();
        EXPECT_EQ(entries(folder, name), std::set<std::string>{name});
    }
}

TEST_F(CliOutputs, FailingWriteFailsTheExportAndLeavesNothing) {
    // A 8 KiB file size limit (dash counts 512-byte blocks) with SIGXFSZ ignored: writes past it
    // fail with EFBIG, as they fail with ENOSPC on a full disk. The model at full resolution is
    // far larger than 8 KiB as glTF.
    const std::string out = dir->file("full.glb");
    const auto r = runCli("export -q " + q(model) + " --h-lim 0 -o " + q(out),
                          "trap '' XFSZ; ulimit -f 16; exec");
    EXPECT_EQ(r.code, 1) << r.out << r.err;
    EXPECT_NE(r.err.find(out), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("File too large"), std::string::npos) << r.err;
    EXPECT_TRUE(entries(dir->path, "full.glb").empty());
    // Without the limit the same export succeeds and reports the size of the file written.
    const auto ok = runCli("export -q " + q(model) + " --h-lim 0 -o " + q(out));
    ASSERT_EQ(ok.code, 0) << ok.err;
    EXPECT_NE(ok.out.find("(" + std::to_string(fs::file_size(out)) + " bytes)"), std::string::npos)
        << ok.out;
    EXPECT_GT(fs::file_size(out), 8192u);
    fs::remove(out);
}

// Under a memory limit (ulimit -v: allocations fail with std::bad_alloc, as with overcommit off)
// the build of a DEM too large for it fails with exit 1 and a message naming the DEM and the
// problem, and leaves no output and no temporary, instead of aborting (terminate, core dump) in a
// worker thread: before the work, from the memory estimate (build.h checkMemory against
// availableMemory, which reads the address-space limit), or, with --no-memory-check, when an
// allocation fails. The limit is found first: the smallest multiple of 10 MB under which the
// binary starts at all (`build --help`), plus 40 MB, far below what a 1M-point DEM needs (about
// 30 B a point). AddressSanitizer reserves terabytes of address space, so not under it.
TEST_F(CliOutputs, BuildOutOfMemoryFailsWithAClearErrorAndNoOutput) {
    if (unilod::test::kAddressSanitizer)
        GTEST_SKIP() << "address space limits do not apply under AddressSanitizer";
    const std::string data = dir->file("large");
    auto r = runCli("synth --points 1000000 -o " + q(data));
    ASSERT_EQ(r.code, 0) << r.err;
    int startMb = 0;
    for (int mb = 100; mb <= 2000 && startMb == 0; mb += 10) {
        const auto help =
            runCli("build --help", "ulimit -v " + std::to_string(mb * 1024) + "; exec");
        if (help.code == 0) startMb = mb;
    }
    ASSERT_GT(startMb, 0) << "unilod does not start under a 2 GB address space limit";
    const std::string out = dir->file("large.ulod");
    const std::string demPath = data + "/dem.tif";
    const std::string build =
        "build -q " + q(demPath) + " " + q(data + "/rivers.geojson") + " -o " + q(out);
    const std::string limit = "ulimit -v " + std::to_string((startMb + 40) * 1024) + "; exec";
    r = runCli(build, limit);
    EXPECT_EQ(r.code, 1) << r.out << r.err;
    EXPECT_NE(r.err.find(demPath), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("more than the address-space limit allows"), std::string::npos) << r.err;
    EXPECT_TRUE(entries(dir->path, "large.ulod").empty());
    r = runCli(build + " --no-memory-check", limit);
    EXPECT_EQ(r.code, 1) << r.out << r.err;
    EXPECT_NE(r.err.find(demPath), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("out of memory"), std::string::npos) << r.err;
    EXPECT_EQ(r.err.find("terminate"), std::string::npos) << r.err;
    EXPECT_TRUE(entries(dir->path, "large.ulod").empty());
    fs::remove_all(data);
}

// --memory-limit MB: the estimate is checked against it; --no-memory-check skips the check.
TEST_F(CliOutputs, BuildMemoryLimitRefusesBeforeTheWork) {
    const std::string out = dir->file("limited.ulod");
    const std::string build = "build -q " + q(dem) + " " + q(rivers) + " -o " + q(out) + kBlocks;
    auto r = runCli(build + " --memory-limit 1");
    EXPECT_EQ(r.code, 1) << r.out << r.err;
    EXPECT_NE(r.err.find(dem), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("more than --memory-limit allows (0.00 GB)"), std::string::npos)
        << r.err;
    EXPECT_FALSE(fs::exists(out));
    r = runCli(build + " --memory-limit 1 --no-memory-check");
    EXPECT_EQ(r.code, 0) << r.err;
    EXPECT_TRUE(fs::exists(out));
    r = runCli(build + " --memory-limit 0");
    EXPECT_EQ(r.code, 2) << r.err;
    fs::remove(out);
}

// A river network denser than the DEM weighs in the estimate (build.h estimateBuildMemory):
// 10 000 crossing lines over the demo DEM (about 115 000 river points beside 139 000 DEM points,
// 0.28 GB peak resident) are refused under a 200 MB limit that the demo's own rivers fit (about
// 0.17 GB), with the advice of one thread (two blocks of 0.12 M points in flight at a time); an
// estimate of the DEM points alone (68 MB) let it through.
TEST_F(CliOutputs, BuildMemoryEstimateCountsTheRivers) {
    const std::string demo = std::string(UNILOD_ASSETS_DIR) + "/jacksboro_dem.tif";
    const std::string dense = dir->file("dense.geojson");
    {
        std::ofstream f(dense);
        f << "{\"type\":\"FeatureCollection\",\"features\":[";
        std::uint64_t state = 12345;
        auto next = [&state] {
            state = state * 6364136223846793005ULL + 1442695040888963407ULL;
            return double(state >> 11) / double(1ULL << 53);
        };
        f.precision(10);
        for (int i = 0; i < 10000; ++i) {
            double x = -84.41 + 0.33 * next(), y = 36.45 + 0.28 * next();
            f << (i ? "," : "")
              << "{\"type\":\"Feature\",\"properties\":{},\"geometry\":{\"type\":"
                 "\"LineString\",\"coordinates\":[["
              << x << "," << y << "]";
            for (int k = 0; k < 3; ++k) {
                const double a = 6.283185307179586 * next();
                x += 0.002 * std::cos(a);
                y += 0.002 * std::sin(a);
                f << ",[" << x << "," << y << "]";
            }
            f << "]}}";
        }
        f << "]}";
    }
    const std::string out = dir->file("dense.ulod");
    const std::string limit = " -o " + q(out) + " --threads 2 --memory-limit 200";
    auto r = runCli("build -q " + q(demo) + " " + q(dense) + limit);
    EXPECT_EQ(r.code, 1) << r.out << r.err;
    EXPECT_NE(r.err.find("M river)"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("more than --memory-limit allows"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("--threads 1 builds one block at a time"), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(out));
    r = runCli("build -q " + q(demo) + " " +
               q(std::string(UNILOD_ASSETS_DIR) + "/jacksboro_rivers_grass.geojson") + limit);
    EXPECT_EQ(r.code, 0) << r.err;
    EXPECT_NE(r.out.find("GB peak resident (estimated"), std::string::npos) << r.out;
    fs::remove(out);
    fs::remove(dense);
}

// Without --threads the build chooses its thread count: where the estimate with all cores
// exceeds the bound and with fewer does not, it builds with fewer and says so; a thread count
// given is kept (and refused). The bound is set between the demo build's estimates for one and
// two threads, read from the refusals under a 70 MB limit (which the raster's read, the build's
// 64 MB base and about 1 MB, fits: loadDem checks that first).
TEST_F(CliOutputs, BuildUsesFewerThreadsWhereMemoryAllowsOnlyFewer) {
    if (std::thread::hardware_concurrency() < 2) GTEST_SKIP() << "one core: nothing to reduce";
    const std::string build =
        "build -q " + q(std::string(UNILOD_ASSETS_DIR) + "/jacksboro_dem.tif") + " " +
        q(std::string(UNILOD_ASSETS_DIR) + "/jacksboro_rivers_grass.geojson") + " -o " +
        q(dir->file("fewer.ulod")) + " --overwrite";
    auto estimate = [&](const std::string& threads) {
        const auto r = runCli(build + " --memory-limit 70 --threads " + threads);
        EXPECT_EQ(r.code, 1) << r.err;
        const std::size_t at = r.err.find("need about ");
        return at == std::string::npos ? 0.0 : std::stod(r.err.substr(at + 11)) * 1000.0;
    };
    const double one = estimate("1"), two = estimate("2");
    ASSERT_GT(one, 0.0);
    ASSERT_GT(two, one + 15.0) << "the second block in flight should weigh";
    const std::string limit = " --memory-limit " + std::to_string(int((one + two) / 2));
    auto r = runCli(build + limit);
    EXPECT_EQ(r.code, 0) << r.err;
    EXPECT_NE(r.err.find("warning: 1 of "), std::string::npos) << r.err;
    EXPECT_NE(r.out.find("(1 thread)"), std::string::npos) << r.out;
    r = runCli(build + limit + " --threads 2");
    EXPECT_EQ(r.code, 1) << r.err;
    EXPECT_NE(r.err.find("--threads 1 builds one block at a time"), std::string::npos) << r.err;
    fs::remove(dir->file("fewer.ulod"));
}

// `order` ranks the whole DEM as one point set: the same check, at its own bytes per point,
// before the point set is made; nothing written when refused. 64.1 MB hold the 64 MB base and
// the raster (the check before reading, since 2026-12-03 with the base as in `build`), not the
// points' 130 bytes each as well.
TEST_F(CliOutputs, OrderMemoryLimitRefusesBeforeTheWork) {
    const std::string out = dir->file("limited.csv");
    const std::string order = "order -q " + q(dem) + " " + q(rivers) + " -o " + q(out);
    auto r = runCli(order + " --memory-limit 64.1");
    EXPECT_EQ(r.code, 1) << r.out << r.err;
    EXPECT_NE(r.err.find(dem), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("to rank as one block (130 bytes per point"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("more than --memory-limit allows (0.06 GB)"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("--stride 2 ranks a quarter of the DEM points"), std::string::npos)
        << r.err;
    EXPECT_FALSE(fs::exists(out));
    r = runCli(order + " --memory-limit 1");  // the raster and the base: before reading
    EXPECT_EQ(r.code, 1) << r.out << r.err;
    EXPECT_NE(r.err.find("cells need at least 0.06 GB of memory"), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(out));
    r = runCli(order + " --memory-limit 1 --no-memory-check");
    EXPECT_EQ(r.code, 0) << r.err;
    EXPECT_TRUE(fs::exists(out));
    fs::remove(out);
}

// A raster whose copy in memory exceeds the bound is refused before a cell is read (dem.h
// DemLoadOptions::memoryBytes), by `build` and `order` alike: a 70 000 x 70 000 raster used to be
// read for minutes and then killed for lack of memory (signal 9, no message) on a 23 GB machine.
// Raster header only (VRT bands without sources): nothing is ever read.
TEST_F(CliOutputs, RasterLargerThanTheMemoryRefusedBeforeReading) {
    auto vrt = [&](const std::string& name, int side, const char* srs, const char* transform) {
        const std::string path = dir->file(name);
        std::ofstream f(path);
        f << "<VRTDataset rasterXSize=\"" << side << "\" rasterYSize=\"" << side << "\">"
          << "<SRS>" << srs << "</SRS><GeoTransform>" << transform << "</GeoTransform>"
          << "<VRTRasterBand dataType=\"Float32\" band=\"1\"/></VRTDataset>";
        return path;
    };
    // 60 000 x 60 000 cells of 1 m in UTM: 14.4 GB as 4-byte heights, 18.0 GB at the build's 5
    // bytes a cell and its 64 MB base (at --stride 1 the raster is held to its end; no
    // temporary file helps).
    const std::string utm = vrt("huge_utm.vrt", 60000, "EPSG:32616", "500000,1,0,4000000,0,-1");
    // The same in degrees: reprojected to UTM (warped straight into the grid).
    const std::string geo =
        vrt("huge_geo.vrt", 60000, "EPSG:4326", "-84.5,0.00001,0,36.5,0,-0.00001");
    const std::string out = dir->file("huge.ulod");
    struct Case {
        std::string command, dem, needs;
    };
    for (const Case& c :
         {Case{"build", utm,
               "60000 x 60000 cells need at least 18.06 GB of memory (5 bytes a cell to read and "
               "hold them)"},
          Case{"build", geo, "60000 x 60000 cells (reprojected) need at least"},
          Case{"order", utm,
               "60000 x 60000 cells need at least 14.46 GB of memory (4 bytes a cell to read and "
               "hold them)"}}) {
        SCOPED_TRACE(c.command + " " + c.dem);
        const std::string cmd = c.command + " -q " + q(c.dem) + " -o " + q(out);
        auto r = runCli(cmd + " --memory-limit 1000");
        EXPECT_EQ(r.code, 1) << r.out << r.err;
        EXPECT_NE(r.err.find("DEM '" + c.dem + "': " + c.needs), std::string::npos) << r.err;
        EXPECT_NE(r.err.find("more than --memory-limit allows (1.00 GB)"), std::string::npos)
            << r.err;
        EXPECT_NE(r.err.find("gdalwarp -tr"), std::string::npos) << r.err;
        EXPECT_FALSE(fs::exists(out));
    }
    // Without a limit given: the memory this process can get (the reprojected grid alone of a
    // 1 000 000 x 1 000 000 raster is 4 TB).
    const std::string vast =
        vrt("vast_geo.vrt", 1000000, "EPSG:4326", "-84.5,0.0000001,0,36.5,0,-0.0000001");
    auto r = runCli("build -q " + q(vast) + " -o " + q(out));
    EXPECT_EQ(r.code, 1) << r.out << r.err;
    EXPECT_NE(r.err.find("(reprojected) need at least"), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(out));
}

TEST_F(CliOutputs, StaleTemporariesOfKilledRunsRemoved) {
    const std::string out = dir->file("stale.glb");
    const std::string dead = "stale.glb.tmp-" + std::to_string(deadPid()) + "-a1b2c3";
    const std::string living = "stale.glb.tmp-" + std::to_string(getpid()) + "-a1b2c3";
    dir->write(dead, "left by a killed export");
    dir->write(living, "an export still running");
    const auto r = runCli("export -q " + q(model) + " --h-lim 50 -o " + q(out));
    ASSERT_EQ(r.code, 0) << r.err;
    EXPECT_EQ(entries(dir->path, "stale.glb"), (std::set<std::string>{"stale.glb", living}));
    fs::remove(out);
    fs::remove(dir->file(living));

    // The same for a build killed with SIGKILL before it could clean up.
    const std::string built = dir->file("stale.ulod");
    const std::string deadBuild = "stale.ulod.tmp-" + std::to_string(deadPid()) + "-d4e5f6";
    dir->write(deadBuild, "left by a killed build");
    const auto b = runCli("build -q " + q(dem) + " " + q(rivers) + " -o " + q(built) + kBlocks);
    ASSERT_EQ(b.code, 0) << b.err;
    EXPECT_EQ(entries(dir->path, "stale.ulod"), std::set<std::string>{"stale.ulod"});
    fs::remove(built);
}

// A build stopped by SIGTERM, SIGINT or SIGPIPE (kill, Ctrl-C, a reader of its output gone)
// removes its temporary output and ends by the signal: no partial file is left (before, the
// temporary stayed until a later run to the same output removed it as stale; SIGPIPE until
// 2026-12-03). The build of a 1M-point model runs for seconds; the signal is sent as soon as its
// temporary output appears.
TEST_F(CliOutputs, BuildStoppedBySignalLeavesNoTemporary) {
    const std::string data = dir->file("bigdata");
    auto r = runCli("synth -q --points 1000000 -o " + q(data));
    ASSERT_EQ(r.code, 0) << r.err;
    for (int sig : {SIGTERM, SIGINT, SIGPIPE}) {
        SCOPED_TRACE(strsignal(sig));
        const std::string out = dir->file("signalled.ulod");
        const pid_t child = startCli({"build", "-q", data + "/dem.tif", data + "/rivers.geojson",
                                      "-o", out, "--threads", "1"});
        ASSERT_GE(child, 0);
        ASSERT_TRUE(
            waitForEntry(dir->path, "signalled.ulod.tmp-" + std::to_string(child) + "-", child));
        kill(child, sig);
        int status = 0;
        ASSERT_EQ(waitpid(child, &status, 0), child);
        EXPECT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == sig) << status;
        EXPECT_TRUE(entries(dir->path, "signalled.ulod").empty());
    }
}

// report --overwrite moves the old folder aside (PATH.old-<pid>) while it writes the new one; a
// SIGTERM or SIGINT then left it there and nothing at PATH. Now the signal puts it back
// (format::renameOnSignal), as a failure does.
TEST_F(CliOutputs, ReportStoppedBySignalPutsTheOldFolderBack) {
    const std::string folder = dir->file("stopped_report");
    auto r = runCli("report -q " + q(model) + " -o " + q(folder) +
                    " --no-rivers --bench-frames 0 --distance 100km --image-size 64");
    ASSERT_EQ(r.code, 0) << r.err;
    const std::string before = slurp(folder + "/report.json");
    const std::set<std::string> old = entries(folder, "");
    for (int sig : {SIGTERM, SIGINT}) {
        SCOPED_TRACE(strsignal(sig));
        // Large grid diagrams: seconds of work after the old folder is moved aside.
        const pid_t child = startCli({"report", "-q", model, "-o", folder, "--overwrite",
                                      "--no-rivers", "--bench-frames", "0", "--image-size", "8192",
                                      "--distance", "100km,200km,300km,400km"});
        ASSERT_GE(child, 0);
        const std::string aside = "stopped_report.old-" + std::to_string(child);
        ASSERT_TRUE(waitForEntry(dir->path, aside, child));
        kill(child, sig);
        int status = 0;
        ASSERT_EQ(waitpid(child, &status, 0), child);
        EXPECT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == sig) << status;
        EXPECT_TRUE(entries(dir->path, aside).empty());
        EXPECT_EQ(entries(folder, ""), old);
        EXPECT_EQ(slurp(folder + "/report.json"), before);
    }
}

// An output folder that holds the command's input is refused with --overwrite, before the folder
// is moved aside (the input was moved away with it and the command failed with "cannot open: No
// such file or directory").
// The files GDAL reads with an input are inputs too (preprocess/ingest.h addInputFiles):
// `build dem.vrt -o src.tif --overwrite` replaced the VRT's source raster, and `-o rivers.dbf
// --overwrite` the Shapefile's attribute table; order and report the same.
TEST_F(CliOutputs, FilesReadWithAnInputRefusedEvenWithOverwrite) {
    const std::string folder = dir->file("parts");
    fs::create_directories(folder);
    fs::create_directories(folder + "/sources");
    const std::string src = folder + "/sources/src.tif", vrt = folder + "/dem.vrt";
    const std::string shp = folder + "/rivers.shp", dbf = folder + "/rivers.dbf";
    fs::copy_file(dem, src);
    ASSERT_EQ(std::system(("gdalbuildvrt -q " + q(vrt) + " " + q(src)).c_str()), 0);
    ASSERT_EQ(std::system(("ogr2ogr " + q(shp) + " " + q(rivers) + " 2>/dev/null").c_str()), 0);
    ASSERT_TRUE(fs::exists(dbf));
    const std::string srcBefore = slurp(src), dbfBefore = slurp(dbf);
    const std::string inputs = " " + q(vrt) + " " + q(shp) + " --overwrite -o ";
    for (const auto& [command, target, input] :
         {std::tuple{"build -q" + inputs + q(src) + kBlocks, src, vrt},
          {"build -q" + inputs + q(dbf) + kBlocks, dbf, shp},
          {"order -q" + inputs + q(src), src, vrt},
          {"order -q" + inputs + q(dbf), dbf, shp}}) {
        SCOPED_TRACE(command);
        const auto r = runCli(command);
        EXPECT_EQ(r.code, 1) << r.out << r.err;
        EXPECT_NE(r.err.find(target + ": is a file of the input '" + input + "'"),
                  std::string::npos)
            << r.err;
    }
    // report: its output folder may not hold a file of an input either.
    const auto r = runCli("report -q " + q(model) + " --dem " + q(vrt) + " -o " +
                          q(folder + "/sources") + " --overwrite --bench-frames 0");
    EXPECT_EQ(r.code, 1) << r.out << r.err;
    EXPECT_NE(r.err.find("holds '" + src + "', an input of this command"), std::string::npos)
        << r.err;
    EXPECT_EQ(slurp(src), srcBefore);
    EXPECT_EQ(slurp(dbf), dbfBefore);
    // The same inputs build, writing elsewhere.
    const auto ok = runCli("build -q" + inputs + q(folder + "/m.ulod") + kBlocks);
    EXPECT_EQ(ok.code, 0) << ok.err;
    // report without --dem / --rivers reads those the model's build info names: they are its
    // inputs as well (until 2026-12-03 only --dem / --rivers were).
    const auto fromInfo = runCli("report -q " + q(folder + "/m.ulod") + " -o " +
                                 q(folder + "/sources") + " --overwrite --bench-frames 0");
    EXPECT_EQ(fromInfo.code, 1) << fromInfo.out << fromInfo.err;
    EXPECT_NE(fromInfo.err.find("holds '" + src + "', an input of this command"), std::string::npos)
        << fromInfo.err;
    EXPECT_EQ(slurp(src), srcBefore);
}

TEST_F(CliOutputs, OutputFolderHoldingTheInputRefused) {
    const std::string folder = dir->file("holds_input");
    fs::create_directories(folder);
    const std::string input = folder + "/m.ulod";
    fs::copy_file(model, input);
    const std::string before = slurp(input);
    for (const std::string& command :
         {"export -q " + q(input) + " --3dtiles " + q(folder) + " --overwrite",
          "report -q " + q(input) + " -o " + q(folder) +
              " --overwrite --no-rivers --bench-frames 0"}) {
        SCOPED_TRACE(command);
        const auto r = runCli(command);
        EXPECT_EQ(r.code, 1) << r.out << r.err;
        EXPECT_NE(r.err.find("an input of this command"), std::string::npos) << r.err;
        EXPECT_EQ(slurp(input), before);
        EXPECT_EQ(entries(folder, ""), std::set<std::string>{"m.ulod"});
    }
}

// capture --overwrite replaces the frames all together or not at all: here the second frame's
// JSON cannot be written (a folder holds its name), and the first frame, which could, must not
// replace its old file either (the frames were written one by one and the written ones removed
// on failure, which lost the old frame_0000 files).
TEST_F(CliOutputs, FailedCaptureOverwriteKeepsEveryOldFrame) {
    const std::string frames = dir->file("keepframes");
    fs::create_directories(frames + "/frame_0001.json/blocker");
    std::ofstream(frames + "/frame_0000.png") << "old png 0";
    std::ofstream(frames + "/frame_0000.json") << "old json 0";
    std::ofstream(frames + "/frame_0001.png") << "old png 1";
    const std::string path = dir->file("twoframes.json");
    std::ofstream(path) << R"({"keyframes": [{"eye": [0, 0, 3000], "yaw": 0, "pitch": -60},
                                              {"eye": [0, 0, 2500], "yaw": 10, "pitch": -60}]})";
    const auto r = runCli("capture -q " + q(model) + " --path " + q(path) +
                          " --frames 2 --size 32x24 --overwrite -o " + q(frames));
    EXPECT_EQ(r.code, 1) << r.out << r.err;
    EXPECT_NE(r.err.find("frame_0001.json"), std::string::npos) << r.err;
    EXPECT_EQ(slurp(frames + "/frame_0000.png"), "old png 0");
    EXPECT_EQ(slurp(frames + "/frame_0000.json"), "old json 0");
    EXPECT_EQ(slurp(frames + "/frame_0001.png"), "old png 1");
    EXPECT_EQ(entries(frames, ""), (std::set<std::string>{"frame_0000.json", "frame_0000.png",
                                                          "frame_0001.json", "frame_0001.png"}));
    // Once the name is free, the same capture replaces the old frames.
    fs::remove_all(frames + "/frame_0001.json");
    const auto ok = runCli("capture -q " + q(model) + " --path " + q(path) +
                           " --frames 2 --size 32x24 --overwrite -o " + q(frames));
    ASSERT_EQ(ok.code, 0) << ok.err;
    EXPECT_EQ(slurp(frames + "/frame_0000.png").rfind("\x89PNG", 0), 0u);
    EXPECT_EQ(entries(frames, ""), (std::set<std::string>{"frame_0000.json", "frame_0000.png",
                                                          "frame_0001.json", "frame_0001.png"}));
}

TEST_F(CliOutputs, ViewScreenshotRefusesAnExistingFileBeforeAWindowOpens) {
    // No display is needed: the rule is checked before the window (and exit 1, not a GLFW error).
    const std::string shot = dir->file("shot.png");
    std::ofstream(shot) << "keep";
    const auto r = runCli("view " + q(model) + " --frames 1 --screenshot " + q(shot));
    EXPECT_EQ(r.code, 1) << r.err;
    EXPECT_NE(r.err.find(shot + ": already exists (use --overwrite"), std::string::npos) << r.err;
    EXPECT_EQ(unilod::test::slurp(shot), "keep");
}

TEST_F(CliOutputs, ViewScreenshotRefusesAMissingFolderOrItsInputBeforeAWindowOpens) {
    // Both used to be refused only when the screenshot was written, after rendering (or, without
    // a display, not at all: the window's error came first).
    const std::string missing = dir->file("no_such_folder") + "/shot.png";
    const auto r = runCli("view " + q(model) + " --frames 1 --screenshot " + q(missing));
    EXPECT_EQ(r.code, 1) << r.err;
    EXPECT_NE(r.err.find(missing + ": folder '"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("does not exist"), std::string::npos) << r.err;
    EXPECT_EQ(r.err.find("window"), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(dir->file("no_such_folder")));

    const std::string before = slurp(model);
    const auto i = runCli("view " + q(model) + " --frames 1 --overwrite --screenshot " + q(model));
    EXPECT_EQ(i.code, 1) << i.err;
    EXPECT_NE(i.err.find(model + ": is also an input of this command"), std::string::npos) << i.err;
    EXPECT_EQ(i.err.find("window"), std::string::npos) << i.err;
    EXPECT_EQ(slurp(model), before);
}

TEST_F(CliOutputs, FifoInputRefusedWithoutBlocking) {
    const std::string fifo = dir->file("pipe.ulod");
    ASSERT_EQ(mkfifo(fifo.c_str(), 0644), 0);
    for (const std::string command : {"check -q ", "info ", "stats "}) {
        const auto r = runCli(command + q(fifo), kTimeout);
        EXPECT_EQ(r.code, 1) << command << r.err;
        EXPECT_NE(r.err.find(fifo), std::string::npos) << command << r.err;
        EXPECT_NE(r.err.find("FIFO"), std::string::npos) << command << r.err;
    }
    // The DEM, the rivers and a camera path (read before any GPU work).
    auto r =
        runCli("build -q " + q(fifo) + " " + q(rivers) + " -o " + q(dir->file("f.ulod")), kTimeout);
    EXPECT_EQ(r.code, 1) << r.err;
    EXPECT_NE(r.err.find("FIFO"), std::string::npos) << r.err;
    r = runCli("build -q " + q(dem) + " " + q(fifo) + " -o " + q(dir->file("f.ulod")), kTimeout);
    EXPECT_EQ(r.code, 1) << r.err;
    EXPECT_NE(r.err.find("FIFO"), std::string::npos) << r.err;
    r = runCli("capture " + q(model) + " --path " + q(fifo) + " --out " + q(dir->file("frames")),
               kTimeout);
    EXPECT_EQ(r.code, 1) << r.err;
    EXPECT_NE(r.err.find("FIFO"), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(dir->file("f.ulod")));
    fs::remove(fifo);
}

// A CRS option is text, never a file to open (preprocess/srs.h): GDAL's parser would otherwise
// open a path it is given, and a FIFO there blocks forever. A .ulod header's CRS text takes the
// same parser (export --3dtiles).
TEST_F(CliOutputs, FifoAsCrsTextIsNotOpened) {
    const std::string fifo = dir->file("crs.fifo");
    ASSERT_EQ(mkfifo(fifo.c_str(), 0644), 0);
    auto r = runCli("build -q " + q(dem) + " " + q(rivers) + " --t-srs " + q(fifo) + " -o " +
                        q(dir->file("crs.ulod")),
                    kTimeout);
    EXPECT_EQ(r.code, 1) << r.err;
    EXPECT_NE(r.err.find("--t-srs"), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(dir->file("crs.ulod")));
    r = runCli("order -q " + q(dem) + " " + q(rivers) + " --t-srs " + q(fifo), kTimeout);
    EXPECT_EQ(r.code, 1) << r.err;
    EXPECT_NE(r.err.find("--t-srs"), std::string::npos) << r.err;
    r = runCli(
        "export -q " + q(model) + " --3dtiles " + q(dir->file("crs_tiles")) + " --s-srs " + q(fifo),
        kTimeout);
    EXPECT_EQ(r.code, 1) << r.err;  // 124: blocked on the FIFO until `timeout` killed it
    EXPECT_NE(r.err.find("cannot read the CRS"), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(dir->file("crs_tiles")));
    fs::remove(fifo);
}

TEST_F(CliOutputs, DirectoryInputRefusedWithAClearMessage) {
    const std::string folder = dir->file("a_folder");
    fs::create_directories(folder);
    auto r = runCli("info " + q(folder), kTimeout);
    EXPECT_EQ(r.code, 1);
    EXPECT_NE(r.err.find(folder + ": is a directory"), std::string::npos) << r.err;
    r = runCli("build -q " + q(dem) + " " + q(rivers) + " --bai-table " + q(folder) + " -o " +
                   q(dir->file("d.ulod")),
               kTimeout);
    EXPECT_EQ(r.code, 1);
    EXPECT_NE(r.err.find(folder + ": is a directory"), std::string::npos) << r.err;
    r = runCli("capture " + q(model) + " --path " + q(folder) + " --out " + q(dir->file("frames")),
               kTimeout);
    EXPECT_EQ(r.code, 1);
    EXPECT_NE(r.err.find(folder + ": is a directory"), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(dir->file("d.ulod")));
}
