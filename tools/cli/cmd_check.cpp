// `unilod check FILE [--errors]`: checksums and the topology invariants at every stored level of
// every block, and with --errors the `max` model error recomputed at every stored level
// (preprocess/ulodcheck.h, errorcheck.h). Exit 0 when everything holds, 1 with a precise message
// on the first failure.
#include <cmath>
#include <cstdio>
#include <string>

#include "commands.h"
#include "numbers.h"
#include "outputopts.h"
#include "progress.h"
#include "ulod.h"
#include "ulodcheck.h"
#include "workers.h"

namespace unilod::cli {

void addCheckCommand(CLI::App& app, int& exitCode) {
    auto path = std::make_shared<std::string>();
    auto quiet = std::make_shared<bool>(false);
    auto options = std::make_shared<UlodCheckOptions>();
    CLI::App* sub = app.add_subcommand(
        "check",
        "Verify checksums and the topology invariants at every stored level of a .ulod file");
    sub->add_option("FILE", *path, ".ulod file")->required();
    sub->add_flag("--errors", options->errors,
                  "also recompute the true `max` model error at every stored level from the "
                  "file's data; fail when a stored error is below it beyond the tolerance "
                  "(4 * 2^-24 * max|z| of the block + 1e-6 m); a tree node's against every "
                  "original point below it");
    sub->add_option("--threads", options->threads,
                    "entries checked at once (default 0: every core, at most " +
                        std::to_string(engine::WorkerPool::kMaxThreads) +
                        "); the result is the same for any number")
        ->transform(integerIn(0, engine::WorkerPool::kMaxThreads));
    addQuietFlag(sub, *quiet);
    sub->callback([path, quiet, options, &exitCode] {
        UlodCheckSummary s;
        std::string error;
        Progress bar("check", !*quiet, "blocks");
        auto progress = [&](std::size_t done, std::size_t total) { bar.update(done, total); };
        const bool ok = checkUlod(*path, *options, s, error, progress);
        bar.finish();
        if (!ok) {
            std::fprintf(stderr, "unilod check: FAILED: %s\n", error.c_str());
            exitCode = 1;
            return;
        }
        std::printf(
            "unilod check: OK: %s: %zu blocks, %zu stored levels, %zu deletion steps; "
            "checksums, records and topology invariants hold at every level",
            path->c_str(), s.blocks, s.levels, s.steps);
        if (s.errorsChecked) {
            std::printf(
                "; stored max errors bound the recomputed ones at every level (largest "
                "recomputed/stored %.9g: %.9g m of %.9g m at %s level %u; smallest "
                "margin %.3g m)",
                s.worstRatio, s.worstRecomputed, s.worstStored,
                format::blockName(s.worstCol, s.worstRow, s.worstTreeLevel).c_str(), s.worstLevel,
                s.smallestMargin);
            if (std::isfinite(s.riverMargin))
                std::printf(", and their river parts the recomputed river and outline deviations "
                            "(smallest margin %.3g m)",
                            s.riverMargin);
            if (s.nodeRiverWorst > 0)
                std::printf("; tree nodes: original river points within %.9g m of their river",
                            s.nodeRiverWorst);
        }
        std::printf("\n");
        exitCode = 0;
    });
}

}  // namespace unilod::cli
