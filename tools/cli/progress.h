// The one progress printer of every `unilod` command (issue 20, item 4): build, order, check,
// report, capture, bench (and export). On stderr, one line per state:
//
//   build: blocks  12/42  29 %  elapsed 3 s  ETA 8 s
//   order: importance  elapsed 1 s  ETA ?
//
// - The first line is printed at once when the Progress is made (so that a command that first
//   reads its inputs for seconds says so within a second), the last by finish().
// - Elapsed is since the Progress was made; the ETA extrapolates the stage's recent rate
//   (EtaEstimator: the share of its work done over the last 10 s, or the last quarter of the
//   stage where that is longer), so that a stage that slows down is not extrapolated at its
//   early rate; "?" where nothing is counted yet or the stage has no total. The share is done /
//   total, or the caller's own estimate (update with `share`: `build` weighs its blocks and
//   tree nodes by their cost).
// - On a terminal the line is rewritten in place (\r) at most 4 times a second, and a new stage
//   starts a new line; elsewhere (logs, pipes) a line at most every 5 s or every 10 % of the
//   stage, plus one per stage and the last one.
// - Disabled (-q): prints nothing. message() prints a line (a warning) without breaking the bar.
// Call it from one thread (the libraries' progress callbacks do: build.h, ulodcheck.h).
#pragma once

#include <algorithm>
#include <chrono>
#include <cstddef>
#include <cstdio>
#include <deque>
#include <string>
#include <utility>

namespace unilod::cli {

// The time left in a stage from its recent progress: the rate of the share of work done over
// the last max(kMinWindow, kWindowShare * time in the stage) seconds. (A build's tree nodes at
// the end run on one core where its blocks ran on all: the whole stage's rate said "ETA 1 s"
// for the last 8 s of a 44 s build, MEASURED.md 2026-12-01.)
class EtaEstimator {
public:
    static constexpr double kMinWindow = 10.0, kWindowShare = 0.25, kSpacing = 0.25;

    void reset() { history_.clear(); }
    // A sample: `t` seconds into the stage, `share` (0 to 1) of its work done.
    void add(double t, double share) {
        if (history_.empty() || t - history_.back().first >= kSpacing)
            history_.emplace_back(t, share);
        // Keep the last sample at or before the window's start (the window only moves on).
        while (history_.size() >= 2 && history_[1].first <= t - window(t))
            history_.pop_front();
    }
    // Seconds left at `t` with `share` done; -1: unknown (nothing done yet). Where the share did
    // not move within the window, the whole stage's rate.
    double eta(double t, double share) const {
        if (share >= 1) return 0;
        if (!(share > 0) || !(t > 0)) return -1;
        const double whole = t * (1 - share) / share;
        if (history_.empty()) return whole;
        const auto& [t0, s0] = history_.front();
        if (!(t - t0 > 0) || !(share > s0)) return whole;
        return (1 - share) * (t - t0) / (share - s0);
    }
    static double window(double t) { return std::max(kMinWindow, kWindowShare * t); }

private:
    std::deque<std::pair<double, double>> history_;  // (seconds in the stage, share)
};

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
    // The same with the share of the stage's work done (0 to 1), where the units differ in cost:
    // the percentage and the ETA follow it.
    void update(std::size_t done, std::size_t total, double share);
    // A line of its own (a warning), printed even when disabled, then the bar again.
    void message(const std::string& line);
    // The last line (the state as it is), ending a terminal's line. Idempotent.
    void finish();

    bool enabled() const { return enabled_; }

    // The text of one line (no \r, no newline): "LABEL: STAGE  DONE/TOTAL  PCT %  elapsed E  ETA T".
    static std::string formatLine(const std::string& label, const std::string& stage,
                                  std::size_t done, std::size_t total, double elapsedSeconds,
                                  double etaSeconds, double share = -1);
    // "12 s", "3 min 05 s", "2 h 07 min"; negative: "?".
    static std::string formatSeconds(double seconds);

private:
    using Clock = std::chrono::steady_clock;
    void print(bool force);
    void endLine();
    double currentShare() const;  // of the stage's work done, 0 to 1

    std::string label_, stage_;
    bool enabled_ = true, tty_ = false, open_ = false, finished_ = false;
    std::size_t done_ = 0, total_ = 0, printedDone_ = 0, width_ = 0;
    double share_ = -1;  // the caller's share of the stage done; -1: done_ / total_
    double printedShare_ = 0;
    EtaEstimator eta_;
    Clock::time_point start_, stageStart_, printed_;
    std::FILE* out_ = stderr;
};

}  // namespace unilod::cli
