// The one progress printer of every `unilod` command (issue 20, item 4): build, order, check,
// report, capture, bench (and export). On stderr, one line per state:
//
//   build: blocks  12/42  29 %  elapsed 3 s  ETA 8 s
//   order: importance  elapsed 1 s  ETA ?
//
// - The first line is printed at once when the Progress is made (so that a command that first
//   reads its inputs for seconds says so within a second), the last by finish().
// - Elapsed is since the Progress was made; the ETA extrapolates the current stage's rate
//   (elapsed in the stage * (total - done) / done); "?" where nothing is counted yet or the stage
//   has no total.
// - On a terminal the line is rewritten in place (\r) at most 4 times a second, and a new stage
//   starts a new line; elsewhere (logs, pipes) a line at most every 5 s or every 10 % of the
//   stage, plus one per stage and the last one.
// - Disabled (-q): prints nothing. message() prints a line (a warning) without breaking the bar.
// Call it from one thread (the libraries' progress callbacks do: build.h, ulodcheck.h).
#pragma once

#include <chrono>
#include <cstddef>
#include <cstdio>
#include <string>

namespace unilod::cli {

class Progress {
public:
    // `label`: the command ("build"); `stage`: what it does first ("reading the DEM").
    Progress(std::string label, bool enabled, const std::string& stage = "",
             std::size_t total = 0);
    ~Progress();  // finish()
    Progress(const Progress&) = delete;
    Progress& operator=(const Progress&) = delete;

    // A new stage, `total` units of work (0: not counted). Always printed.
    void stage(const std::string& name, std::size_t total = 0);
    // `done` of `total` units of the current stage (total replaces the stage's).
    void update(std::size_t done, std::size_t total);
    // A line of its own (a warning), printed even when disabled, then the bar again.
    void message(const std::string& line);
    // The last line (the state as it is), ending a terminal's line. Idempotent.
    void finish();

    bool enabled() const { return enabled_; }

    // The text of one line (no \r, no newline): "LABEL: STAGE  DONE/TOTAL  PCT %  elapsed E  ETA T".
    static std::string formatLine(const std::string& label, const std::string& stage,
                                  std::size_t done, std::size_t total, double elapsedSeconds,
                                  double etaSeconds);
    // "12 s", "3 min 05 s", "2 h 07 min"; negative: "?".
    static std::string formatSeconds(double seconds);

private:
    using Clock = std::chrono::steady_clock;
    void print(bool force);
    void endLine();

    std::string label_, stage_;
    bool enabled_ = true, tty_ = false, open_ = false, finished_ = false;
    std::size_t done_ = 0, total_ = 0, printedDone_ = 0, width_ = 0;
    Clock::time_point start_, stageStart_, printed_;
    std::FILE* out_ = stderr;
};

}  // namespace unilod::cli
