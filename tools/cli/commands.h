// The `unilod` subcommands: each cmd_*.cpp registers one CLI11 subcommand whose callback stores
// the exit status (0 ok, 1 data error) in `exitCode`. main.cpp maps usage errors to 2.
#pragma once

#include <CLI/CLI.hpp>

namespace unilod::cli {

void addSynthCommand(CLI::App& app, int& exitCode);
void addOrderCommand(CLI::App& app, int& exitCode);
void addBuildCommand(CLI::App& app, int& exitCode);
void addInfoCommand(CLI::App& app, int& exitCode);
void addCheckCommand(CLI::App& app, int& exitCode);
void addStatsCommand(CLI::App& app, int& exitCode);
void addCaptureCommand(CLI::App& app, int& exitCode);
void addBenchCommand(CLI::App& app, int& exitCode);
void addViewCommand(CLI::App& app, int& exitCode);
void addExportCommand(CLI::App& app, int& exitCode);
void addReportCommand(CLI::App& app, int& exitCode);

}  // namespace unilod::cli
