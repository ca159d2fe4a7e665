// `unilod check FILE`: checksums and the topology invariants at every stored level of every block
// (preprocess/ulodcheck.h). Exit 0 when everything holds, 1 with a precise message on the first
// failure.
#include <cstdio>
#include <string>

#include "commands.h"
#include "ulodcheck.h"

namespace unilod::cli {

void addCheckCommand(CLI::App& app, int& exitCode) {
    auto path = std::make_shared<std::string>();
    auto quiet = std::make_shared<bool>(false);
    CLI::App* sub = app.add_subcommand(
        "check",
        "Verify checksums and the topology invariants at every stored level of a .ulod file");
    sub->add_option("FILE", *path, ".ulod file")->required();
    sub->add_flag("-q,--quiet", *quiet, "no progress output");
    sub->callback([path, quiet, &exitCode] {
        UlodCheckSummary s;
        std::string error;
        auto progress = [&](std::size_t done, std::size_t total) {
            if (!*quiet) std::fprintf(stderr, "  checked block %zu/%zu\n", done, total);
        };
        if (!checkUlod(*path, s, error, progress)) {
            std::fprintf(stderr, "unilod check: FAILED: %s\n", error.c_str());
            exitCode = 1;
            return;
        }
        std::printf(
            "unilod check: OK: %s: %zu blocks, %zu stored levels, %zu deletion steps; "
            "checksums, records and topology invariants hold at every level\n",
            path->c_str(), s.blocks, s.levels, s.steps);
        exitCode = 0;
    });
}

}  // namespace unilod::cli
