#include "selection.h"

#include <cassert>
#include <cmath>

#include "camera.h"

namespace unilod::exporter {

namespace {
constexpr double kDegree = 3.14159265358979323846 / 180.0;

engine::Camera cameraOf(const SelectionOptions& options) {
    engine::Camera camera;
    for (int k = 0; k < 3; ++k) camera.eye[k] = options.eye[k];
    camera.yawDegrees = options.yawDegrees;
    camera.pitchDegrees = options.pitchDegrees;
    camera.fovDegrees = options.fovDegrees;
    return camera;
}
}  // namespace

double blockTolerance(const format::BlockInfo& info, const SelectionOptions& options,
                      bool rivers, double* distance, engine::BoxView* box) {
    if (distance != nullptr) *distance = 0;
    if (box != nullptr) *box = engine::BoxView{};
    if (!options.useCamera) return options.hLim;
    const double boxMin[3] = {info.minX, info.minY, info.minZ};
    const double boxMax[3] = {info.maxX, info.maxY, info.maxZ};
    const double s = engine::blockDistance(options.distance, options.eye, boxMin, boxMax);
    engine::BoxView view =
        options.hasDirection ? engine::boxView(cameraOf(options), boxMin, boxMax) : engine::BoxView{};
    view.horizontal = rivers;
    if (distance != nullptr) *distance = s;
    if (box != nullptr) *box = view;
    const engine::ViewTolerance tolerance{options.pixels, options.fovDegrees * kDegree,
                                          options.widthPixels, options.heightPixels,
                                          options.distance};
    return engine::blockTolerance(tolerance, s, view);
}

bool blockVisible(const format::BlockInfo& info, const SelectionOptions& options) {
    if (!options.useCamera || !options.hasDirection || !options.cull) return true;
    const engine::Camera camera = cameraOf(options);
    const double boxMin[3] = {info.minX, info.minY, info.minZ};
    const double boxMax[3] = {info.maxX, info.maxY, info.maxZ};
    return engine::boxInFrustum(camera, options.widthPixels / options.heightPixels, boxMin, boxMax);
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
    s.hLim = blockTolerance(info, options, block.levels.front().riverCount > 0, &s.distance,
                            &s.box);
    s.choice = engine::chooseStoredLevel(block.levels, metric, s.hLim);
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
            !(options.widthPixels >= 1) || !(options.heightPixels >= 1) ||
            !(options.pixels > 0) || !std::isfinite(options.yawDegrees) ||
            !std::isfinite(options.pitchDegrees) || std::abs(options.pitchDegrees) > 90) {
            error = "invalid camera options (fov in (0, 180), size >= 1x1, pixels > 0, pitch in "
                    "[-90, 90])";
            return false;
        }
    } else if (!(options.hLim >= 0) || !std::isfinite(options.hLim)) {
        error = "h_lim must be a finite number >= 0";
        return false;
    }
    return true;
}

}  // namespace unilod::exporter
