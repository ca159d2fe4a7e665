// `unilod report FILE -o DIR`: the paper's evaluation for one .ulod file (issue 6, item 3):
// Tables 2 / 3, error-vs-retention curves, BAI vs plain 3D_DP river shapes, grid diagrams.
// What each file holds and the definitions: tools/report/report.h. Usage errors exit 2, data
// errors 1; DIR appears only when everything was written. An existing non-empty DIR needs
// --overwrite (outputopts.h): then the old folder is replaced only when the new one is complete.
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>
#include <vector>

#include "commands.h"
#include "engineopts.h"
#include "numbers.h"
#include "outputopts.h"
#include "progress.h"
#include "report.h"
#include "ulod.h"
#include "workers.h"

namespace unilod::cli {

namespace {

struct ReportCli {
    report::ReportOptions o;
    OutputFlags output;
    std::vector<std::string> distances = {"100km", "200km", "500km", "1000km", "1500km"};
    std::vector<std::string> budgets = {"5", "10", "20", "40"};
    std::vector<std::string> pixels = {"1"};
    std::string metric;
    bool noRivers = false;
    bool quiet = false;
};

int run(ReportCli& c) {
    c.o.stats.distances = listLengths(c.distances);
    c.o.stats.pixels = listNumbers(c.pixels);
    c.o.stats.metric = metricOf(c.metric);
    c.o.budgets.clear();
    for (double b : listNumbers(c.budgets))
        c.o.budgets.push_back(b / 100.0);
    c.o.rivers = !c.noRivers;
    c.o.outDir = c.output.path;
    std::string error;
    ReplacedFolder old;
    if (!checkOutput(c.output, OutputKind::Folder, error) ||
        (c.output.overwrite &&
         !old.moveAside(c.output.path, report::reportInputs(c.o),
                        report::reportForeignPart(c.output.path), "a report", error))) {
        std::fprintf(stderr, "unilod report: error: %s\n", error.c_str());
        return 1;
    }
    Progress progress("report", !c.quiet, "reading " + c.o.path);
    c.o.progress = [&progress](const std::string& s) { progress.stage(s); };
    c.o.progressCount = [&progress](std::size_t done, std::size_t total) {
        progress.update(done, total);
    };
    report::ReportSummary summary;
    const bool ok = report::runReport(c.o, summary, error);
    progress.finish();
    if (!ok) {
        std::fprintf(stderr, "unilod report: error: %s\n", error.c_str());
        return 1;  // `old` goes back in place
    }
    old.keep();
    std::printf("%s: report of %s\n", c.o.outDir.c_str(), c.o.path.c_str());
    for (const std::string& f : summary.files)
        std::printf("  %s/%s\n", c.o.outDir.c_str(), f.c_str());
    return 0;
}

}  // namespace

void addReportCommand(CLI::App& app, int& exitCode) {
    auto c = std::make_shared<ReportCli>();
    CLI::App* sub = app.add_subcommand(
        "report",
        "The paper's evaluation of a .ulod file in a folder: Tables 2/3 (Markdown + CSV), error "
        "vs retention curves (SVG), BAI vs plain 3D_DP river shapes, grid diagrams (PNG)");
    sub->add_option("FILE", c->o.path, ".ulod file")->required();
    addOutputOptions(sub, c->output,
                     "output folder (a missing or empty one; an existing one with --overwrite)");
    sub->add_option("--distance", c->distances,
                    "view distances for the tables and the grid diagrams, comma-separated, with m "
                    "or km (default 100km,200km,500km,1000km,1500km, as `unilod stats`)")
        ->check(listOf(lengthIn(0, kMaxViewDistance, Bound::Open)));
    sub->add_option("--pixels", c->pixels,
                    "pixel tolerances P, comma-separated (default 1; diagrams use the first)")
        ->check(listOf(positive()));
    sub->add_option("--fov", c->o.stats.fovDegrees,
                    "vertical field of view in degrees (default 60)")
        ->check(fovRange());
    sub->add_option("--height", c->o.stats.heightPixels, "viewport height in pixels (default 1080)")
        ->check(numberIn(1.0, 1e9));
    addMetricOption(*sub, c->metric);
    sub->add_option("--dem", c->o.demPath, "DEM for the river comparison (default: the build's)");
    sub->add_option("--rivers", c->o.riversPath,
                    "rivers for the river comparison (default: the build's)");
    sub->add_flag("--no-rivers", c->noRivers, "skip the BAI vs plain 3D_DP river comparison");
    sub->add_option("--threads", c->o.threads,
                    "blocks read (tables) and ranked (river comparison) at once (default 0: every "
                    "core, at most " +
                        std::to_string(engine::WorkerPool::kMaxThreads) +
                        "); the report is the same for any number")
        ->transform(integerIn(0, engine::WorkerPool::kMaxThreads));
    sub->add_option("--budget", c->budgets,
                    "river point budgets in percent of unlocked points, comma-separated "
                    "(default 5,10,20,40)")
        ->check(listOf(numberIn(0.0, 100.0)));
    sub->add_option("--image-size", c->o.imageSize, "grid diagram size in pixels (default 1024)")
        ->transform(integerIn(16, 16384));
    sub->add_flag("--annotate,!--no-annotate", c->o.annotate,
                  "grid diagrams get a scale bar and a north arrow (default on; the title with D, "
                  "P and the counts is always drawn)");
    sub->add_option("--bench-frames", c->o.benchFrames,
                    "frames of the frame-time plot along the camera path (default 60; 0: no plot, "
                    "no Vulkan device needed)")
        ->transform(integerIn(0, 100000));
    sub->add_option("--bench-path", c->o.benchPath,
                    "camera path JSON for the frame-time plot (default: a fly-over generated from "
                    "the data's extent)");
    sub->add_option_function<std::string>(
        "--bench-size",
        [c](const std::string& s) {
            if (!parseSize(s, c->o.benchWidth, c->o.benchHeight))
                throw CLI::ValidationError("--bench-size", "'" + s + "' is not WxH (1..16384)");
        },
        "image size WxH of the frame-time benchmark (default 640x360)");
    sub->add_flag("--validation", c->o.device.validation,
                  "Vulkan validation layer for the frame-time benchmark; any message fails");
    addQuietFlag(sub, c->quiet);
    sub->callback([c, &exitCode] { exitCode = run(*c); });
}

}  // namespace unilod::cli
