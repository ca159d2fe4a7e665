// Shared by the build benchmarks (bench_build, bench_order): one runBuild measured (seconds,
// peak RSS, output size; call it inside bench::runInChild so the RSS is the build's) and the
// synthetic inputs written once per folder.
#pragma once

#include <sys/resource.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>

#include "build.h"
#include "synthetic.h"

namespace unilod::bench {

// Runs the build; on failure prints the error and exits 1 (the child's failure ends the
// benchmark in runInChild).
inline nlohmann::json measureBuild(const std::string& name, const BuildOptions& options) {
    BuildSummary s;
    std::string error;
    if (!runBuild(options, s, error)) {
        std::fprintf(stderr, "%s: %s\n", name.c_str(), error.c_str());
        std::exit(1);
    }
    rusage ru{};
    getrusage(RUSAGE_SELF, &ru);
    const double points = double(s.demPoints + s.riverPoints);
    return {{"case", name},
            {"dem_cells", {s.demWidth, s.demHeight}},
            {"points", s.demPoints + s.riverPoints},
            {"river_points", s.riverPoints},
            {"river_lines", s.riverLines},
            {"blocks", s.blocks},
            {"deletion_steps", s.steps},
            {"seconds", s.seconds},
            {"max_rss_bytes", std::size_t(ru.ru_maxrss) * 1024},
            {"output_bytes", s.outputBytes},
            {"output_bytes_per_point", double(s.outputBytes) / points},
            {"index_data_vs_full",
             s.fullTriangles ? double(s.indexTriangles) / double(s.fullTriangles) : 0.0}};
}

// Writes dir/dem.tif and dir/rivers.geojson for `options` unless dir/dem.tif exists (the same
// options and seed give the same files, so a kept folder is reused). Returns the DEM's size in
// cells. Exits 1 with the error on failure.
inline nlohmann::json ensureSyntheticInputs(const std::string& dir,
                                            const SyntheticOptions& options) {
    if (std::filesystem::exists(dir + "/dem.tif")) return {{"generated", false}};
    const SyntheticData data = generateSyntheticData(options);
    std::string error;
    if (!writeSyntheticData(data, dir, error)) {
        std::fprintf(stderr, "%s\n", error.c_str());
        std::exit(1);
    }
    return {{"generated", true},
            {"dem_cells", {data.dem.width, data.dem.height}},
            {"river_lines", data.rivers.size()}};
}

}  // namespace unilod::bench
