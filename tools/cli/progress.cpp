#include "progress.h"

#include <unistd.h>

#include <cmath>
#include <utility>

namespace unilod::cli {

namespace {
constexpr double kTtyInterval = 0.25;  // seconds between terminal redraws
constexpr double kLogInterval = 5.0;   // seconds between log lines
}  // namespace

Progress::Progress(std::string label, bool enabled, const std::string& stage, std::size_t total)
    : label_(std::move(label)), enabled_(enabled) {
    tty_ = enabled_ && isatty(fileno(out_)) != 0;
    start_ = stageStart_ = printed_ = Clock::now();
    stage_ = stage;
    total_ = total;
    eta_.add(0, 0);
    print(true);
}

Progress::~Progress() {
    finish();
}

std::string Progress::formatSeconds(double s) {
    if (!(s >= 0) || !std::isfinite(s)) return "?";
    char buf[64];
    const long long t = std::llround(s);
    if (t < 60) {
        std::snprintf(buf, sizeof buf, "%lld s", t);
    } else if (t < 3600) {
        std::snprintf(buf, sizeof buf, "%lld min %02lld s", t / 60, t % 60);
    } else {
        std::snprintf(buf, sizeof buf, "%lld h %02lld min", t / 3600, t / 60 % 60);
    }
    return buf;
}

std::string Progress::formatLine(const std::string& label, const std::string& stage,
                                 std::size_t done, std::size_t total, double elapsed, double eta,
                                 double share) {
    std::string line = label + ":";
    if (!stage.empty()) line += " " + stage;
    if (total > 0) {
        if (share < 0) share = double(done) / double(total);
        char buf[96];
        std::snprintf(buf, sizeof buf, "  %zu/%zu  %3d %%", done, total,
                      int(100.0 * std::clamp(share, 0.0, 1.0)));
        line += buf;
    }
    line += "  elapsed " + formatSeconds(elapsed) + "  ETA " + formatSeconds(eta);
    return line;
}

void Progress::stage(const std::string& name, std::size_t total) {
    if (finished_) return;
    // The previous stage's final state stays on screen (its own line).
    if (enabled_ && (tty_ || done_ != printedDone_)) print(true);
    endLine();
    stage_ = name;
    done_ = printedDone_ = 0;
    share_ = -1;
    printedShare_ = 0;
    total_ = total;
    stageStart_ = Clock::now();
    eta_.reset();
    eta_.add(0, 0);
    print(true);
}

void Progress::update(std::size_t done, std::size_t total) {
    update(done, total, -1);
}

void Progress::update(std::size_t done, std::size_t total, double share) {
    if (finished_) return;
    done_ = done;
    total_ = total;
    share_ = share < 0 ? -1 : std::min(1.0, share);
    const double inStage = std::chrono::duration<double>(Clock::now() - stageStart_).count();
    if (total_ > 0) eta_.add(inStage, currentShare());
    print(total > 0 && done >= total);
}

double Progress::currentShare() const {
    if (total_ == 0) return 0;
    if (share_ >= 0) return share_;
    return std::min(1.0, double(done_) / double(total_));
}

void Progress::message(const std::string& line) {
    endLine();
    std::fprintf(out_, "%s\n", line.c_str());
    std::fflush(out_);
    if (!finished_ && tty_) print(true);
}

void Progress::finish() {
    if (finished_) return;
    finished_ = true;
    // A log gets a last line when it adds something: more done, or the time since the last.
    const double sincePrint = std::chrono::duration<double>(Clock::now() - printed_).count();
    if (tty_ || done_ != printedDone_ || sincePrint >= 1.0) print(true);
    endLine();
}

void Progress::endLine() {
    if (open_) std::fputc('\n', out_);
    open_ = false;
    width_ = 0;
    std::fflush(out_);
}

void Progress::print(bool force) {
    if (!enabled_) return;
    const Clock::time_point now = Clock::now();
    const double sincePrint = std::chrono::duration<double>(now - printed_).count();
    if (!force) {
        if (tty_) {
            if (sincePrint < kTtyInterval) return;
        } else {
            const bool tenth = total_ > 0 && currentShare() - printedShare_ >= 0.1;
            if (!tenth && sincePrint < kLogInterval) return;
        }
    }
    const double elapsed = std::chrono::duration<double>(now - start_).count();
    const double inStage = std::chrono::duration<double>(now - stageStart_).count();
    double eta = -1;
    if (finished_ || (total_ > 0 && done_ >= total_)) {
        eta = 0;
    } else if (total_ > 0) {
        eta = eta_.eta(inStage, currentShare());
    }
    const std::string line =
        formatLine(label_, stage_, done_, total_, elapsed, eta, total_ > 0 ? currentShare() : -1);
    if (tty_) {
        // Rewrite in place; spaces clear what a longer previous text left.
        const std::size_t pad = width_ > line.size() ? width_ - line.size() : 0;
        std::fprintf(out_, "\r%s%*s", line.c_str(), int(pad), "");
        width_ = line.size();
        open_ = true;
    } else {
        std::fprintf(out_, "%s\n", line.c_str());
    }
    std::fflush(out_);
    printed_ = now;
    printedDone_ = done_;
    printedShare_ = currentShare();
}

}  // namespace unilod::cli
