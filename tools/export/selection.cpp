#include "selection.h"

#include <cassert>
#include <cmath>


namespace unilod::exporter {

engine::ViewSpec viewSpec(const SelectionOptions& options) {
    engine::ViewSpec v;
    if (!options.useCamera) {
        v.kind = engine::ViewSpec::Kind::Uniform;
        v.hLim = options.hLim;
        return v;
    }
    v.kind = engine::ViewSpec::Kind::Camera;
    for (int k = 0; k < 3; ++k) v.camera.eye[k] = options.eye[k];
    v.camera.yawDegrees = options.yawDegrees;
    v.camera.pitchDegrees = options.pitchDegrees;
    v.camera.fovDegrees = options.fovDegrees;
    v.direction = options.hasDirection;
    v.cull = options.cull;
    v.widthPixels = options.widthPixels;
    v.heightPixels = options.heightPixels;
    v.pixels = options.pixels;
    v.distance = options.distance;
    return v;
}

ExportedBlock selectLevel(const format::Block& block, std::size_t index,
                          const SelectionOptions& options, std::uint32_t metric) {
    assert(!block.levels.empty());
    ExportedBlock s;
    static_cast<engine::NodeChoice&>(s) = engine::chooseNode(
        viewSpec(options), engine::lodNode(block), std::uint32_t(index), metric);
    const format::Level& level = block.levels[s.wanted.level];
    s.vertexCount = level.vertexCount;
    s.triangles = level.triangleCount;
    s.riverEdges = level.riverCount;
    return s;
}

bool resolveMetric(const format::Reader& reader, const SelectionOptions& options,
                   std::uint32_t& metric, std::string& error) {
    if (!format::resolveMetric(reader.header(), reader.path(), options.metric, metric, error))
        return false;
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
