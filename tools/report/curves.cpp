// Model error vs retention, aggregated over blocks (definition in report.h).
#include <algorithm>
#include <array>
#include <cmath>
#include <mutex>

#include "report.h"
#include "ulod.h"
#include "workers.h"

namespace unilod::report {

bool computeCurve(const std::string& path, std::vector<CurvePoint>& curve, bool& hasMax,
                  bool& hasPaper, std::string& error, const StatsReading& reading) {
    format::Reader reader;
    if (!reader.open(path, error)) return false;
    hasMax = (reader.header().metrics & format::kMetricMax) != 0;
    hasPaper = (reader.header().metrics & format::kMetricPaper) != 0;
    curve.assign(100, CurvePoint{});
    for (int i = 0; i < 100; ++i)
        curve[std::size_t(i)].retention = i + 1;
    const std::size_t n = reader.blocks().size();
    if (n == 0) {
        error = path + ": the file has no blocks";
        return false;
    }
    // Each block's errors at the 100 retentions, read one block a task (a 4M-point model's
    // blocks took 8 s on one thread until 2026-12-03), then summed in file order.
    struct BlockErrors {
        std::array<double, 100> max{}, paper{};
        std::string error;
    };
    std::vector<BlockErrors> blocks(n);
    std::size_t done = 0;
    std::mutex progressMutex;
    if (reading.progress) reading.progress(0, n);
    engine::WorkerPool pool(n <= 1 ? 1 : reading.threads);
    pool.run(n, [&](std::size_t b) {
        format::Block block;
        BlockErrors& out = blocks[b];
        if (reader.readBlock(b, block, out.error)) {
            const std::size_t steps = block.steps.size();
            const double vertices = double(block.vertices.size());
            for (std::size_t i = 0; i < curve.size(); ++i) {
                const double removable =
                    std::floor((1.0 - curve[i].retention / 100.0) * vertices + 1e-9);
                const std::size_t k = std::min(steps, std::size_t(std::max(0.0, removable)));
                if (hasMax) out.max[i] = block.errorMax[k];
                if (hasPaper) out.paper[i] = block.errorPaper[k];
            }
        }
        if (reading.progress) {  // counted under the lock: the counts rise one by one
            const std::lock_guard<std::mutex> lock(progressMutex);
            reading.progress(++done, n);
        }
    });
    for (const BlockErrors& b : blocks) {
        if (!b.error.empty()) {
            error = b.error;
            return false;
        }
        for (std::size_t i = 0; i < curve.size(); ++i) {
            CurvePoint& p = curve[i];
            if (hasMax) {
                p.maxOfMax = std::max(p.maxOfMax, b.max[i]);
                p.meanOfMax += b.max[i] / double(n);
            }
            if (hasPaper) {
                p.maxOfPaper = std::max(p.maxOfPaper, b.paper[i]);
                p.meanOfPaper += b.paper[i] / double(n);
            }
        }
    }
    return true;
}

}  // namespace unilod::report
