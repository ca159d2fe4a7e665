// `unilod build DEM [RIVERS] -o OUT.ulod`: the unified LOD model file (issue 4; pipeline in
// preprocess/build.h). Progress on stderr (progress.h), a summary on stdout; errors name the file
// and the problem, exit 1, and leave no output file. An existing OUT needs --overwrite
// (outputopts.h).
#include <cstdio>
#include <string>

#include "build.h"
#include "commands.h"
#include "ingestopts.h"
#include "numbers.h"
#include "outputopts.h"
#include "progress.h"

namespace unilod::cli {

namespace {

struct BuildCli {
    BuildOptions o;
    OutputFlags output;
    std::string metric = "max";
    std::string encoding = "compact";
    std::string order = "greedy";
    bool noBai = false;
    bool quiet = false;
    MemoryFlags memory;
};

std::string megabytes(std::uint64_t bytes) {
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.2f MB", double(bytes) / 1e6);
    return buf;
}

int run(BuildCli& c) {
    c.o.useBai = !c.noBai;
    c.o.order = c.order == "3ddp" ? DeletionOrderKind::ThreeDdp : DeletionOrderKind::Greedy;
    c.o.defaultMetric = c.metric == "paper" ? format::kMetricPaper : format::kMetricMax;
    c.o.rawBlocks = c.encoding == "raw";
    c.o.memoryLimitBytes = c.memory.limitBytes();
    c.o.memoryCheck = c.memory.check;
    c.o.outPath = c.output.path;
    c.o.force = c.output.overwrite;
    if (!c.quiet) {
        std::fprintf(stderr, "unilod build: %s%s%s -> %s\n", c.o.demPath.c_str(),
                     c.o.riversPath.empty() ? "" : " + ", c.o.riversPath.c_str(),
                     c.o.outPath.c_str());
    }
    // The first line at once: reading and splitting the inputs takes seconds on large DEMs.
    Progress progress(
        "build", !c.quiet,
        c.o.riversPath.empty() ? "reading the DEM" : "reading the DEM and the rivers");
    c.o.stage = [&progress](const std::string& stage, std::size_t total) {
        progress.stage(stage, total);
    };
    c.o.progress = [&progress](std::size_t done, std::size_t total, double work) {
        progress.update(done, total, work);
    };
    c.o.warn = [&progress](const std::string& w) {
        progress.message("unilod build: warning: " + w);
    };
    BuildSummary s;
    std::string error;
    const bool ok = runBuild(c.o, s, error);
    progress.finish();
    if (!ok) {
        std::fprintf(stderr, "unilod build: error: %s\n", error.c_str());
        return 1;
    }
    std::printf("unilod build summary\n");
    std::printf("  DEM              %s (%d x %d cells, %s)\n", c.o.demPath.c_str(), s.demWidth,
                s.demHeight, s.crsName.c_str());
    for (const std::string& conversion : s.demConversions)
        std::printf("  DEM conversion   %s\n", conversion.c_str());
    if (s.nodataCells > 0)
        std::printf(
            "  DEM nodata       %zu cells (nodata value, mask, NaN or infinite): %zu filled in "
            "small interior holes, the rest outside the domain\n",
            s.nodataCells, s.filledNodataCells);
    if (c.o.riversPath.empty()) {
        std::printf("  rivers           none (terrain-only model)\n");
    } else {
        std::printf("  rivers           %s (%zu lines after cleaning)\n", c.o.riversPath.c_str(),
                    s.riverLines);
        std::printf("  river cleaning   %s\n", s.cleaning.c_str());
    }
    std::printf(
        "  points           %zu DEM + %zu river (%zu locked, %zu border crossings, "
        "%zu DEM points dropped next to rivers",
        s.demPoints, s.riverPoints, s.lockedPoints, s.crossings, s.droppedDemPoints);
    if (s.droppedDemPoints > 0)
        std::printf(
            ", %zu river vertices added where rivers pass them; the dropped points at most "
            "%.3g m off the full-resolution surface, in the error",
            s.droppedCellVertices, s.droppedDeviation);
    std::printf(")\n");
    std::printf("  blocks           %zu (block size %d cells, stride %d)\n", s.blocks, s.blockSize,
                c.o.stride);
    if (s.nodes > 0)
        std::printf("  tree             %zu nodes above the blocks in %zu levels; the root's "
                    "coarsest state %zu triangles\n",
                    s.nodes, s.treeLevels, s.rootTriangles);
    else
        std::printf("  tree             none (--no-tree, or an order / metric without it)\n");
    std::printf("  deletion steps   %zu (%zu ranked points kept, %zu deferred deletions)\n",
                s.steps, s.kept, s.deferrals);
    std::printf("  triangles        %zu full resolution, %zu coarsest; index data %.2fx full\n",
                s.fullTriangles, s.coarsestTriangles,
                s.fullTriangles ? double(s.indexTriangles) / double(s.fullTriangles) : 0.0);
    std::printf("  order            %s\n", deletionOrderName(c.o.order));
    if (!c.o.useBai)
        std::printf("  BAI              off\n");
    else if (c.o.order == DeletionOrderKind::Greedy && !c.o.baiRow)
        std::printf("  BAI              on (C of Table 1 at each deletion's threshold)\n");
    else
        std::printf("  BAI              on (row %g m of Table 1)\n",
                    c.o.baiRow.value_or(kDefaultBaiRow));
    std::printf("  metrics          %s (default %s)\n",
                recordsPaperMetric(c.o) ? "max, paper" : "max", c.metric.c_str());
    std::printf("  output           %s (%s)\n", c.o.outPath.c_str(),
                megabytes(s.outputBytes).c_str());
    std::printf("  seconds          %.2f (%u thread%s)\n", s.seconds, s.threads,
                s.threads == 1 ? "" : "s");
    if (s.peakMemory > 0)
        std::printf(
            "  memory           %.2f GB peak resident (estimated %.2f GB before the work, "
            "README \"Large DEMs\")\n",
            s.peakMemory / 1e9, s.memoryEstimate / 1e9);
    return 0;
}

}  // namespace

void addBuildCommand(CLI::App& app, int& exitCode) {
    auto c = std::make_shared<BuildCli>();
    CLI::App* sub = app.add_subcommand(
        "build",
        "Build the unified LOD model (.ulod) of a DEM and a river network (or the DEM alone)");
    addIngestOptions(*sub, c->o);
    addOutputOptions(sub, c->output, "output .ulod file");
    sub->add_option("--block-size", c->o.blockSize,
                    "block side in DEM cells (default " + std::to_string(kDefaultBlockSize) +
                        "; clamped to the DEM: one block where it is larger)")
        ->transform(integerIn(1, 1 << 24));
    sub->add_option("--threads", c->o.threads, "worker threads (default: all cores)")
        ->transform(integerIn(0, 1024));
    sub->add_option("--order", c->order,
                    "deletion order: greedy (default; smallest model error first) or 3ddp (the "
                    "paper's improved 3D_DP)")
        ->check(CLI::IsMember({"greedy", "3ddp"}));
    sub->add_flag("--no-bai", c->noBai, "no Bending Adjustment Index (3ddp: plain 3D_DP)");
    sub->add_option("--bai-table", c->o.baiTablePath, "BAI constants table file (see README)");
    sub->add_option("--bai-row", c->o.baiRow,
                    "simplification-threshold row of the BAI table (m); default: greedy takes "
                    "C at each deletion's threshold (README \"BAI\"), 3ddp the 500 m row")
        ->check(nonNegative());  // a table's thresholds are >= 0 (bai.h)
    sub->add_option("--metric", c->metric, "default error metric recorded in the file")
        ->check(CLI::IsMember({"max", "paper"}));
    sub->add_flag("--paper-metric", c->o.paperMetric,
                  "also record the paper's metric (mean nearest-point error) with the greedy "
                  "order (3ddp and --metric paper always record it; about 20 % more build time)");
    sub->add_flag("--tree,!--no-tree", c->o.tree,
                  "build the block hierarchy (default; greedy order, max metric only): tree "
                  "nodes above the blocks whose shared borders simplify, so far views draw a few "
                  "nodes; --no-tree: the flat block grid");
    sub->add_option("--handoff-pixels", c->o.handoffPixels,
                    "tree hand-over: a block or node stops simplifying before an error of its "
                    "extent / this (default " +
                        std::to_string(int(kDefaultHandoffPixels)) +
                        ": the parent takes over once the node spans fewer pixels at P = 1); "
                        "larger: coarser nodes drawn sooner")
        ->check(numberIn(1.0, 1e6));
    addMemoryOptions(*sub, c->memory, "build");
    sub->add_option("--temp-dir", c->o.tempDir,
                    "folder of the temporary file that holds a raster larger than the memory "
                    "while it is read at --stride > 1 (4 bytes a cell, deleted once read; "
                    "default: the output's folder)");
    sub->add_option("--encoding", c->encoding,
                    "block encoding: compact (default; about 7 bytes per point) or raw (plain "
                    "arrays, about 35-40 times larger, for tools that read the layout directly)")
        ->check(CLI::IsMember({"compact", "raw"}));
    addQuietFlag(sub, c->quiet);
    sub->callback([c, &exitCode] { exitCode = run(*c); });
}

}  // namespace unilod::cli
