// `unilod synth`: writes a synthetic DEM (GeoTIFF) and river network (GeoJSON) of a given size
// and seed (tools/synthetic.h), so that every other command can be run on data of any size.
// The output is the two files: either existing needs --overwrite (outputopts.h; exit 1).
#include <chrono>
#include <cstdio>
#include <limits>
#include <memory>
#include <string>

#include "commands.h"
#include "numbers.h"
#include "outputopts.h"
#include "progress.h"
#include "synthetic.h"

namespace unilod::cli {

namespace {

struct SynthOptions {
    std::size_t points = 100000;
    std::uint64_t seed = 1;
    double cellSize = 30.0;
    int rivers = 0;
    double roughness = kDefaultRoughness;
    OutputFlags output;
    bool quiet = false;
};

int runSynth(const SynthOptions& o) {
    const auto t0 = std::chrono::steady_clock::now();
    // Both files are checked before the work (and again, atomically, when they are written).
    std::string error;
    for (const char* name : {"dem.tif", "rivers.geojson"}) {
        if (!checkOutput({o.output.path + "/" + name, o.output.overwrite}, OutputKind::File,
                         error)) {
            std::fprintf(stderr, "unilod synth: error: %s\n", error.c_str());
            return 1;
        }
    }
    Progress progress("synth", !o.quiet, "generating " + std::to_string(o.points) + " points");
    SyntheticOptions so;
    so.targetPoints = o.points;
    so.seed = o.seed;
    so.cellSize = o.cellSize;
    so.rivers = o.rivers;
    so.roughness = o.roughness;
    const SyntheticData data = generateSyntheticData(so);
    progress.stage("writing " + o.output.path);
    const bool ok = writeSyntheticData(data, o.output.path, error, o.output.overwrite);
    progress.finish();
    if (!ok) {
        std::fprintf(stderr, "unilod synth: error: %s\n", error.c_str());
        return 1;
    }
    std::size_t vertices = 0;
    for (const RiverLine& l : data.rivers)
        vertices += l.size();
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    std::printf(
        "wrote %s/dem.tif (%d x %d cells of %g m, EPSG:%d) and %s/rivers.geojson "
        "(%zu lines: %d main rivers, %zu tributaries; %zu vertices) in %.2f s\n",
        o.output.path.c_str(), data.dem.width, data.dem.height, o.cellSize, kSyntheticEpsg,
        o.output.path.c_str(), data.rivers.size(), data.mainRivers,
        data.rivers.size() - static_cast<std::size_t>(data.mainRivers), vertices, seconds);
    return 0;
}

}  // namespace

void addSynthCommand(CLI::App& app, int& exitCode) {
    auto opts = std::make_shared<SynthOptions>();
    CLI::App* sub = app.add_subcommand(
        "synth", "Write a synthetic DEM (DIR/dem.tif) and river network (DIR/rivers.geojson)");
    sub->add_option("--points", opts->points, "Total DEM + river points, approximately")
        ->transform(integerIn(100, 500000000))
        ->capture_default_str();
    sub->add_option("--seed", opts->seed, "Random seed (same seed, same files)")
        ->transform(integerIn(0, std::numeric_limits<long long>::max()))
        ->capture_default_str();
    sub->add_option("--cell-size", opts->cellSize, "DEM cell size in metres")
        ->check(numberIn(0.01, 100000.0))
        ->capture_default_str();
    sub->add_option("--roughness", opts->roughness,
                    "Terrain roughness: amplitude ratio of successive fBm octaves (0.5 smooth, "
                    "0.75 like real DEMs)")
        ->check(numberIn(0.05, 0.95))
        ->capture_default_str();
    sub->add_option("--rivers", opts->rivers, "Main rivers (0: scale with the size)")
        ->transform(integerIn(0, 1000))
        ->capture_default_str();
    addOutputOptions(sub, opts->output,
                     "output folder (created when missing): DIR/dem.tif and DIR/rivers.geojson");
    addQuietFlag(sub, opts->quiet);
    sub->callback([opts, &exitCode] { exitCode = runSynth(*opts); });
}

}  // namespace unilod::cli
