// The `unilod` command: a thin main over the libraries, one subcommand per file (STYLE.md "CLI":
// subcommands like git / PDAL, options range-checked while parsing). Exit status: 0 success,
// 1 data error (a file, GDAL, the computation), 2 usage error.
#include <CLI/CLI.hpp>
#include <cstdio>
#include <exception>
#include <new>
#include <string>

#include "commands.h"

#ifndef UNILOD_VERSION
#define UNILOD_VERSION "unknown"
#endif

int main(int argc, char** argv) {
    CLI::App app{
        "unilod: unified level-of-detail model of a river network and a DEM "
        "(Dou et al. 2024, improved 3D_DP)"};
    app.set_version_flag("--version", std::string("unilod ") + UNILOD_VERSION);
    app.require_subcommand(1);
    int exitCode = 0;
    unilod::cli::addSynthCommand(app, exitCode);
    unilod::cli::addOrderCommand(app, exitCode);
    unilod::cli::addBuildCommand(app, exitCode);
    unilod::cli::addInfoCommand(app, exitCode);
    unilod::cli::addCheckCommand(app, exitCode);
    unilod::cli::addStatsCommand(app, exitCode);
    unilod::cli::addCaptureCommand(app, exitCode);
    unilod::cli::addBenchCommand(app, exitCode);
    unilod::cli::addViewCommand(app, exitCode);
    unilod::cli::addExportCommand(app, exitCode);
    unilod::cli::addReportCommand(app, exitCode);
    // The first word is the command (the program's own options take no value): name an unknown
    // one, and list the commands, instead of CLI11's "A subcommand is required".
    std::string commands;
    bool known = false;
    const std::string first = argc > 1 ? argv[1] : "";
    for (const CLI::App* sub : app.get_subcommands({})) {
        commands += (commands.empty() ? "" : ", ") + sub->get_name();
        known = known || sub->get_name() == first;
    }
    if (!known && (first.empty() || first[0] != '-')) {
        if (first.empty())
            std::fprintf(stderr, "unilod: no command given; commands: %s (unilod --help)\n",
                         commands.c_str());
        else
            std::fprintf(stderr, "unilod: unknown command '%s'; commands: %s (unilod --help)\n",
                         first.c_str(), commands.c_str());
        return 2;
    }
    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        // --help and --version arrive here too, with exit code 0.
        if (e.get_exit_code() == 0) return app.exit(e);
        // A usage error, in the form of every other error: the command, then what is wrong.
        const std::string command = known ? "unilod " + first : std::string("unilod");
        std::fprintf(stderr, "%s: error: %s\nRun '%s --help' for the usage.\n", command.c_str(),
                     e.what(), command.c_str());
        return 2;
    } catch (const std::bad_alloc&) {
        // Under a memory limit (ulimit -v, a container's limit with overcommit off) an allocation
        // fails anywhere: a clear message and exit 1 instead of an abort. Outputs are written
        // through temporaries removed on the way out (atomicfile.h), so none appears.
        std::fprintf(stderr,
                     "unilod %s: error: out of memory (the input needs more memory than this "
                     "process may use); no output was written\n",
                     first.c_str());
        return 1;
    } catch (const std::exception& e) {
        std::fprintf(stderr, "unilod %s: error: %s\n", first.c_str(), e.what());
        return 1;
    }
    return exitCode;
}
