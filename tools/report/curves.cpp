// Model error vs retention, aggregated over blocks (definition in report.h).
#include <algorithm>
#include <cmath>

#include "report.h"
#include "ulod.h"

namespace unilod::report {

bool computeCurve(const std::string& path, std::vector<CurvePoint>& curve, bool& hasMax,
                  bool& hasPaper, std::string& error) {
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
    format::Block block;
    for (std::size_t b = 0; b < n; ++b) {
        if (!reader.readBlock(b, block, error)) return false;
        const std::size_t steps = block.steps.size();
        const double vertices = double(block.vertices.size());
        for (CurvePoint& p : curve) {
            const double removable = std::floor((1.0 - p.retention / 100.0) * vertices + 1e-9);
            const std::size_t k = std::min(steps, std::size_t(std::max(0.0, removable)));
            if (hasMax) {
                const double e = block.errorMax[k];
                p.maxOfMax = std::max(p.maxOfMax, e);
                p.meanOfMax += e / double(n);
            }
            if (hasPaper) {
                const double e = block.errorPaper[k];
                p.maxOfPaper = std::max(p.maxOfPaper, e);
                p.meanOfPaper += e / double(n);
            }
        }
    }
    return true;
}

}  // namespace unilod::report
