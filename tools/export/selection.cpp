#include "selection.h"

#include <cassert>
#include <cmath>

namespace unilod::exporter {

namespace {
constexpr double kDegree = 3.14159265358979323846 / 180.0;
}

double blockTolerance(const format::BlockInfo& info, const SelectionOptions& options,
                      double* distance) {
    if (!options.useCamera) {
        if (distance != nullptr) *distance = 0;
        return options.hLim;
    }
    const double boxMin[3] = {info.minX, info.minY, info.minZ};
    const double boxMax[3] = {info.maxX, info.maxY, info.maxZ};
    const double s = engine::nearestBoxDistance(options.eye, boxMin, boxMax);
    if (distance != nullptr) *distance = s;
    return engine::toleranceFor(options.pixels, s, options.fovDegrees * kDegree,
                                options.heightPixels);
}

BlockSelection selectLevel(const format::Block& block, std::size_t index,
                           const SelectionOptions& options, std::uint32_t metric) {
    assert(!block.levels.empty());
    format::BlockInfo info;
    info.minX = block.minX;
    info.minY = block.minY;
    info.minZ = block.minZ;
    info.maxX = block.maxX;
    info.maxY = block.maxY;
    info.maxZ = block.maxZ;
    BlockSelection s;
    s.index = index;
    s.col = block.col;
    s.row = block.row;
    s.hLim = blockTolerance(info, options, &s.distance);
    const std::vector<float>& errors =
        metric == format::kMetricPaper ? block.errorPaper : block.errorMax;
    s.choice = engine::chooseLevel(block.levels, errors, s.hLim);
    const format::Level& level = block.levels[s.choice.level];
    s.vertexCount = level.vertexCount;
    s.triangles = level.triangleCount;
    s.riverEdges = level.riverCount;
    return s;
}

bool resolveMetric(const format::Reader& reader, const SelectionOptions& options,
                   std::uint32_t& metric, std::string& error) {
    metric = options.metric == 0 ? reader.header().defaultMetric : options.metric;
    if (metric != format::kMetricMax && metric != format::kMetricPaper) {
        error = "unknown error metric";
        return false;
    }
    if (!(reader.header().metrics & metric)) {
        error = reader.path() + ": the file has no '" +
                (metric == format::kMetricPaper ? "paper" : "max") + "' error metric";
        return false;
    }
    if (options.useCamera) {
        for (double v : options.eye) {
            if (!std::isfinite(v)) {
                error = "camera position must be finite";
                return false;
            }
        }
        if (!(options.fovDegrees > 0 && options.fovDegrees < 180) ||
            !(options.heightPixels >= 1) || !(options.pixels > 0)) {
            error = "invalid camera options (fov in (0, 180), height >= 1, pixels > 0)";
            return false;
        }
    } else if (!(options.hLim >= 0) || !std::isfinite(options.hLim)) {
        error = "h_lim must be a finite number >= 0";
        return false;
    }
    return true;
}

}  // namespace unilod::exporter
