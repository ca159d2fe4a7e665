// bench_build: `unilod build` (runBuild) time, peak RSS and output size on the bundled data and on
// a synthetic DEM (default 4097 x 4097 cells with its river network, fixed seed). Prints JSON; no
// thresholds here: the goals (bundled <= 1 s; 4097^2 <= 90 s with <= 1 GB peak RSS on the 2-core
// machine) are read off the output. Each case runs in its own child process, so the peak resident
// set size is per case.
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>

#include "benchbuild.h"
#include "benchutil.h"
#include "jsontext.h"

using nlohmann::json;

int main(int argc, char** argv) {
    CLI::App app{"Time, peak RSS and output size of unilod build (prints JSON)"};
    int side = 4097;
    int threads = 0;
    std::string assets = UNILOD_ASSETS_DIR;
    std::string work = (std::filesystem::temp_directory_path() / "unilod-bench-build").string();
    bool skipSynthetic = false;
    app.add_option("--side", side, "synthetic DEM side in cells")->check(CLI::Range(16, 20000));
    app.add_option("--threads", threads, "build threads (0: all cores)");
    app.add_option("--work", work, "scratch folder (synthetic inputs, outputs)");
    app.add_flag("--skip-synthetic", skipSynthetic, "only the bundled data");
    CLI11_PARSE(app, argc, argv);
    std::filesystem::create_directories(work);

    json cases = json::array();
    unilod::BuildOptions base;
    base.threads = threads;
    base.force = true;
    {
        unilod::BuildOptions o = base;
        o.demPath = assets + "/jacksboro_dem.tif";
        o.riversPath = assets + "/jacksboro_rivers_grass.geojson";
        o.outPath = work + "/jacksboro.ulod";
        std::fprintf(stderr, "bench_build: bundled data...\n");
        cases.push_back(unilod::bench::runInChild(
            [&] { return unilod::bench::measureBuild("jacksboro_grass", o); }));
    }
    if (!skipSynthetic) {
        const std::string dir = work + "/synthetic" + std::to_string(side);
        if (!std::filesystem::exists(dir + "/dem.tif")) {
            std::fprintf(stderr, "bench_build: generating a %d x %d synthetic DEM...\n", side,
                         side);
        }
        unilod::SyntheticOptions so;
        so.width = so.height = side;
        so.targetPoints = std::size_t(side) * std::size_t(side);
        so.seed = 1;
        unilod::bench::ensureSyntheticInputs(dir, so);
        unilod::BuildOptions o = base;
        o.demPath = dir + "/dem.tif";
        o.riversPath = dir + "/rivers.geojson";
        o.outPath = work + "/synthetic" + std::to_string(side) + ".ulod";
        std::fprintf(stderr, "bench_build: synthetic %d x %d...\n", side, side);
        cases.push_back(unilod::bench::runInChild(
            [&] { return unilod::bench::measureBuild("synthetic_" + std::to_string(side), o); }));
        std::filesystem::remove(o.outPath);
    }
    const json result = {{"benchmark", "build"},
                         {"hardware_threads", std::thread::hardware_concurrency()},
                         {"goals",
                          {{"bundled_seconds_max", 1.0},
                           {"synthetic_4097_seconds_max", 90.0},
                           {"synthetic_4097_rss_bytes_max", 1000000000}}},
                         {"cases", cases}};
    std::printf("%s\n", unilod::jsonText(result, 2).c_str());
    return 0;
}
