// bench_importance: time and peak memory of the improved 3D_DP importance order (issue 2) on
// synthetic terrain with rivers (tools/synthetic.h, fixed seed). Prints JSON; no thresholds here:
// the goals (10^6 points <= 3 s single-threaded, <= 200 bytes per point) are read off the output.
//
// Each size runs in its own child process so that the peak resident set size is per size. Heap
// use is counted by replacing global operator new/delete (malloc_usable_size per block).
#include <malloc.h>
#include <sys/resource.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <new>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>

#include "atomicfile.h"
#include "benchutil.h"
#include "importance.h"
#include "jsontext.h"
#include "synthetic.h"

namespace {
std::atomic<std::size_t> gHeapNow{0}, gHeapPeak{0};

void noteAlloc(void* p) {
    const std::size_t now = gHeapNow += malloc_usable_size(p);
    std::size_t peak = gHeapPeak.load();
    while (now > peak && !gHeapPeak.compare_exchange_weak(peak, now)) {
    }
}
}  // namespace

void* operator new(std::size_t n) {
    void* p = std::malloc(n ? n : 1);
    if (!p) throw std::bad_alloc();
    noteAlloc(p);
    return p;
}
void* operator new[](std::size_t n) {
    return operator new(n);
}
void operator delete(void* p) noexcept {
    if (!p) return;
    gHeapNow -= malloc_usable_size(p);
    std::free(p);
}
void operator delete[](void* p) noexcept {
    operator delete(p);
}
void operator delete(void* p, std::size_t) noexcept {
    operator delete(p);
}
void operator delete[](void* p, std::size_t) noexcept {
    operator delete(p);
}

namespace {

using nlohmann::json;

json runOne(std::size_t points, std::uint64_t seed, bool bai) {
    using Clock = std::chrono::steady_clock;
    unilod::SyntheticOptions synth;
    synth.targetPoints = points;
    synth.seed = seed;
    const auto g0 = Clock::now();
    const unilod::PointSet set = unilod::generateSyntheticTerrain(synth);
    const double genSeconds = std::chrono::duration<double>(Clock::now() - g0).count();
    std::size_t riverPoints = 0, locked = 0;
    for (const auto& p : set.points) {
        riverPoints += p.kind == unilod::PointKind::River;
        locked += p.locked;
    }

    const std::size_t heapBefore = gHeapNow.load();
    gHeapPeak = heapBefore;
    unilod::ImportanceOptions opt;
    opt.useBai = bai;
    unilod::ImportanceResult r;
    std::string err;
    const auto t0 = Clock::now();
    if (!unilod::computeImportance(set, opt, r, err)) {
        std::fprintf(stderr, "bench_importance: %s\n", err.c_str());
        std::exit(1);
    }
    const double seconds = std::chrono::duration<double>(Clock::now() - t0).count();
    const std::size_t peak = gHeapPeak.load();
    rusage ru{};
    getrusage(RUSAGE_SELF, &ru);
    const double n = double(set.points.size());
    const auto& s = r.stats;
    return {
        {"points", set.points.size()},
        {"river_points", riverPoints},
        {"rivers", set.rivers.size()},
        {"locked_points", locked},
        {"ranked_points", r.order.size()},
        {"bai", bai},
        {"threads", 1},
        {"seconds", seconds},
        {"phases_seconds",
         {{"bai", s.baiSeconds},
          {"base_plane", s.basePlaneSeconds},
          {"chain", s.chainSeconds},
          {"selection", s.selectionSeconds},
          {"order", s.orderSeconds}}},
        {"base_pair_candidates", s.basePairCandidates},
        {"split_tree_depth", {{"max", s.maxDepth}, {"mean", s.meanDepth}}},
        {"input_heap_bytes", heapBefore},
        {"peak_heap_bytes", peak},
        {"peak_heap_bytes_per_point", double(peak) / n},
        {"ordering_extra_bytes_per_point", double(peak - heapBefore) / n},
        {"max_rss_bytes", std::size_t(ru.ru_maxrss) * 1024},
        {"generation_seconds", genSeconds},
    };
}

}  // namespace

int main(int argc, char** argv) {
    CLI::App app{"Time and peak memory of the improved 3D_DP importance order (prints JSON)"};
    std::vector<std::size_t> sizes{100000, 1000000, 4000000};
    std::uint64_t seed = 1;
    bool noBai = false;
    std::string out;
    app.add_option("--sizes", sizes, "point counts (comma separated)")->delimiter(',');
    app.add_option("--seed", seed, "generator seed");
    app.add_flag("--no-bai", noBai, "plain 3D_DP");
    app.add_option("--json", out, "also write the JSON to this file");
    CLI11_PARSE(app, argc, argv);

    json runs = json::array();
    for (std::size_t size : sizes) {
        std::fprintf(stderr, "bench_importance: %zu points...\n", size);
        runs.push_back(unilod::bench::runInChild([&] { return runOne(size, seed, !noBai); }));
    }
    const json result = {
        {"benchmark", "importance"},
        {"goal", {{"points", 1000000}, {"seconds_max", 3.0}, {"bytes_per_point_max", 200}}},
        {"hardware_threads", std::thread::hardware_concurrency()},
        {"runs", runs},
    };
    const std::string text = unilod::jsonText(result, 2);
    std::printf("%s\n", text.c_str());
    if (!out.empty()) {
        std::string error;
        if (!unilod::format::writeFileAtomically(
                out, text + "\n", {.replace = true, .inputs = {}, .inputParts = {}}, error)) {
            std::fprintf(stderr, "bench_importance: error: %s\n", error.c_str());
            return 1;
        }
    }
    return 0;
}
