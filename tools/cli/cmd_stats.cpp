// `unilod stats FILE`: the paper's Tables 2 and 3 (§4.2.1) for a .ulod file; the definitions
// (viewpoint, S, selected state, named blocks) are in preprocess/stats.h. Aligned text like the
// paper's tables, or CSV with --csv. With --error: per uniform model-error threshold, the exact
// and the stored-level network sizes instead (stats.h computeErrorStats), as text or --json.
// Options out of range are usage errors (exit 2).
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "commands.h"
#include "engineopts.h"
#include "jsontext.h"
#include "numbers.h"
#include "outputopts.h"
#include "progress.h"
#include "stats.h"
#include "ulod.h"
#include "workers.h"

namespace unilod::cli {

namespace {

struct StatsCli {
    std::string path;
    std::vector<std::string> distances = {"100km", "200km", "500km", "1000km", "1500km"};
    std::vector<std::string> pixels = {"1"};
    double fov = 60.0;
    double height = 1080.0;
    std::string metric;  // empty: the file's default
    bool csv = false;
    std::vector<std::string> errors;  // --error: model-error thresholds (m / km)
    JsonFlags json;
    bool quiet = false;
    std::size_t threads = 0;  // blocks read at once (0: every core)
};

// The blocks the cuts draw are read on --threads threads, with a progress line on stderr
// (a 4M-point model's `--error 1` reads every leaf: 8.5 s on one thread, silent until
// 2026-12-03).
struct Reading {
    Progress bar;
    StatsReading reading;
    explicit Reading(const StatsCli& c) : bar("stats", !c.quiet, "reading blocks") {
        reading.threads = c.threads;
        reading.progress = [this](std::size_t done, std::size_t total) { bar.update(done, total); };
    }
};

// "12,345" like the paper's tables.
std::string grouped(std::uint64_t v) {
    std::string s = std::to_string(v);
    for (int i = int(s.size()) - 3; i > 0; i -= 3)
        s.insert(std::size_t(i), ",");
    return s;
}

std::string format(const char* fmt, double v) {
    char buf[64];
    std::snprintf(buf, sizeof buf, fmt, v);
    return buf;
}

// The rows of `cells` (the first one the header) as aligned columns two spaces apart: numbers
// right-aligned, the header's first cell left-aligned; no trailing spaces.
void printColumns(const std::vector<std::vector<std::string>>& cells) {
    std::vector<std::size_t> width(cells[0].size(), 0);
    for (const auto& row : cells) {
        for (std::size_t c = 0; c < row.size(); ++c)
            width[c] = std::max(width[c], row[c].size());
    }
    for (const auto& row : cells) {
        std::string line;
        for (std::size_t c = 0; c < row.size(); ++c) {
            const std::string pad(width[c] - row[c].size(), ' ');
            line += c == 0 && &row == &cells[0] ? row[c] + pad : pad + row[c];
            if (c + 1 < row.size()) line += "  ";
        }
        while (!line.empty() && line.back() == ' ')
            line.pop_back();
        std::printf("%s\n", line.c_str());
    }
}

void printText(const StatsTable& t, const std::string& path) {
    std::printf(
        "%s: %s metric; %u x %u blocks; corner (%u,%u), edge (%u,%u), middle (%u,%u); "
        "%s points at full resolution\n",
        path.c_str(), format::metricName(t.metric), t.blocksX, t.blocksY, t.cornerCol, t.cornerRow,
        t.edgeCol, t.edgeRow, t.middleCol, t.middleRow, grouped(t.fullPoints).c_str());
    // The column headers of the paper's Tables 2 and 3.
    const char* header[] = {"View distance (km)",
                            "The tolerance of screen projection error (Pixel)",
                            "The tolerance of model space error (m)",
                            "The number of points to construct a network",
                            "The number of river bound edges",
                            "Total number of triangles",
                            "Percentage of data retention (%)",
                            "Drawn nodes"};
    std::vector<std::vector<std::string>> cells;
    cells.emplace_back(std::begin(header), std::end(header));
    for (std::size_t i = 0; i < t.rows.size(); ++i) {
        const StatsRow& r = t.rows[i];
        const bool newDistance = i == 0 || t.rows[i - 1].distance != r.distance;
        cells.push_back({newDistance ? format("%g", r.distance / 1000.0) : "",
                         format("%g", r.pixels), format("%.2f (edge)", r.hEdge), grouped(r.points),
                         grouped(r.riverEdges), grouped(r.triangles),
                         format("%.1f%%", r.retention), grouped(r.nodes)});
        cells.push_back({"", "", format("%.2f (corner)", r.hCorner), "", "", "", "", ""});
        cells.push_back({"", "", format("%.2f (middle)", r.hMiddle), "", "", "", "", ""});
    }
    printColumns(cells);
}

void printCsv(const StatsTable& t) {
    std::fputs(statsCsv(t).c_str(), stdout);
}

void printErrorText(const ErrorStatsTable& t, const std::string& path) {
    std::printf(
        "%s: %s metric; %zu blocks, %zu tree nodes; %s points, %s triangles at full "
        "resolution\n",
        path.c_str(), format::metricName(t.metric), t.blocks, t.nodes,
        grouped(t.fullPoints).c_str(), grouped(t.fullTriangles).c_str());
    std::vector<std::vector<std::string>> cells = {
        {"error (m)", "exact points", "exact triangles", "level points", "level triangles",
         "drawn nodes"}};
    for (const ErrorStatsRow& r : t.rows) {
        cells.push_back({format("%g", r.error), grouped(r.exactPoints), grouped(r.exactTriangles),
                         grouped(r.levelPoints), grouped(r.levelTriangles), grouped(r.nodes)});
    }
    printColumns(cells);
}

void printErrorJson(const ErrorStatsTable& t, const std::string& path) {
    nlohmann::json rows = nlohmann::json::array();
    for (const ErrorStatsRow& r : t.rows) {
        rows.push_back({{"error_m", r.error},
                        {"exact_points", r.exactPoints},
                        {"exact_triangles", r.exactTriangles},
                        {"level_points", r.levelPoints},
                        {"level_triangles", r.levelTriangles},
                        {"nodes", r.nodes}});
    }
    const nlohmann::json out = {{"file", path},
                                {"metric", format::metricName(t.metric)},
                                {"blocks", t.blocks},
                                {"tree_nodes", t.nodes},
                                {"full_points", t.fullPoints},
                                {"full_triangles", t.fullTriangles},
                                {"rows", rows}};
    std::printf("%s\n", jsonText(out, 2).c_str());
}

int runErrors(const StatsCli& c) {
    const std::vector<double> errors = listLengths(c.errors);
    ErrorStatsTable t;
    std::string error;
    Reading r(c);
    const bool ok = computeErrorStats(c.path, errors, metricOf(c.metric), t, error, r.reading);
    r.bar.finish();
    if (!ok) {
        std::fprintf(stderr, "unilod stats: error: %s\n", error.c_str());
        return 1;
    }
    if (c.json.requested()) {
        printErrorJson(t, c.path);
    } else {
        printErrorText(t, c.path);
    }
    return 0;
}

int run(const StatsCli& c) {
    if (!c.errors.empty()) return runErrors(c);
    StatsOptions o;
    o.distances = listLengths(c.distances);
    o.pixels = listNumbers(c.pixels);
    o.fovDegrees = c.fov;
    o.heightPixels = c.height;
    o.metric = metricOf(c.metric);
    StatsTable t;
    std::string error;
    Reading r(c);
    const bool ok = computeStats(c.path, o, t, error, r.reading);
    r.bar.finish();
    if (!ok) {
        std::fprintf(stderr, "unilod stats: error: %s\n", error.c_str());
        return 1;
    }
    if (c.csv) {
        printCsv(t);
    } else {
        printText(t, c.path);
    }
    return 0;
}

}  // namespace

void addStatsCommand(CLI::App& app, int& exitCode) {
    auto c = std::make_shared<StatsCli>();
    CLI::App* sub = app.add_subcommand(
        "stats",
        "The paper's Tables 2 and 3: per view distance and pixel tolerance, h_lim of the "
        "edge / corner / middle blocks and the size of the selected network");
    sub->add_option("FILE", c->path, ".ulod file")->required();
    CLI::Option* distance =
        sub->add_option("--distance", c->distances,
                        "view distances, comma-separated, with m or km (default "
                        "100km,200km,500km,1000km,1500km; a bare number is metres)")
            ->check(listOf(lengthIn(0, kMaxViewDistance, Bound::Open)));
    CLI::Option* pixels =
        sub->add_option("--pixels", c->pixels,
                        "screen projection error tolerances P in pixels, comma-separated "
                        "(default 1)")
            ->check(listOf(positive()));
    sub->add_option("--fov", c->fov, "vertical field of view in degrees (default 60)")
        ->check(fovRange());
    sub->add_option("--height", c->height, "viewport height in pixels (default 1080)")
        ->check(numberIn(1.0, 1e9));
    addMetricOption(*sub, c->metric);
    CLI::Option* csv = sub->add_flag("--csv", c->csv, "CSV output (header row, '.' decimals)");
    CLI::Option* errors =
        sub->add_option("--error", c->errors,
                        "uniform model-error thresholds e, comma-separated (m or km; a bare "
                        "number is metres): per e, the network at the exact step and at the "
                        "stored level for h_lim = e, instead of the distance table")
            ->check(listOf(lengthIn(0, std::numeric_limits<double>::infinity())));
    addJsonOption(sub, c->json, "JSON output of the --error table on stdout ('-', the default)")
        ->needs(errors);
    sub->add_option("--threads", c->threads,
                    "blocks read at once (default 0: every core, at most " +
                        std::to_string(engine::WorkerPool::kMaxThreads) +
                        "); the tables are the same for any number")
        ->transform(integerIn(0, engine::WorkerPool::kMaxThreads));
    addQuietFlag(sub, c->quiet);
    // The thresholds replace the view: the view's options would be silently ignored.
    errors->excludes(csv)->excludes(distance)->excludes(pixels);
    sub->callback([c, &exitCode] { exitCode = run(*c); });
}

}  // namespace unilod::cli
