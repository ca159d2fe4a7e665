// Paper §3.4 Eq. 11 and the level choice of DESIGN.md "Screen-space error".
#include "lod.h"

#include <algorithm>
#include <cassert>
#include <cmath>

namespace unilod::engine {

double nearestBoxDistance(const double eye[3], const double boxMin[3], const double boxMax[3]) {
    double sum = 0;
    for (int i = 0; i < 3; ++i) {
        const double d = std::max({boxMin[i] - eye[i], 0.0, eye[i] - boxMax[i]});
        sum += d * d;
    }
    return std::sqrt(sum);
}

double toleranceFor(double pixels, double distance, double fovRadians, double viewportHeight) {
    assert(viewportHeight > 0);
    return 2.0 * pixels * distance * std::tan(fovRadians / 2.0) / viewportHeight;
}

double blockDistance(DistanceMode mode, const double eye[3], const double boxMin[3],
                     const double boxMax[3]) {
    if (mode == DistanceMode::Nearest) return nearestBoxDistance(eye, boxMin, boxMax);
    double sum = 0;
    for (int i = 0; i < 3; ++i) {
        const double d = (boxMin[i] + boxMax[i]) / 2.0 - eye[i];
        sum += d * d;
    }
    return std::sqrt(sum);
}

double frustumEdgeFactor(double fovRadians, double aspect) {
    const double t = std::tan(fovRadians / 2.0);
    const double tan2 = t * t * (1.0 + aspect * aspect);  // tan^2 of the corner ray's angle
    return 1.0 / (1.0 + tan2);                              // cos^2 = 1 / (1 + tan^2)
}

double effectiveDistance(const ViewTolerance& view, double distance, const BoxView& box) {
    if (view.mode == DistanceMode::Centre) return distance;
    const double cornerCos =
        std::sqrt(frustumEdgeFactor(view.fovRadians, view.width / view.height));
    const double axisCos = std::max(cornerCos, box.axisCos);
    // A box seen straight along world up (verticalSin 0) hides every vertical error; the floor
    // keeps S' finite (h_lim then allows any level).
    const double verticalSin = box.horizontal ? 1.0 : std::max(box.verticalSin, 1e-9);
    return axisCos * std::max(box.minDepth, distance * cornerCos) / verticalSin;
}

double blockTolerance(const ViewTolerance& view, double distance, const BoxView& box) {
    return toleranceFor(view.pixels, effectiveDistance(view, distance, box), view.fovRadians,
                        view.height);
}

std::size_t exactStep(const std::vector<float>& errors, double hLim) {
    // Number of steps k with errors[k] <= hLim; k* is one less (or none: full resolution).
    const auto qualifying = std::upper_bound(errors.begin(), errors.end(), hLim,
                                             [](double h, float e) { return h < double(e); });
    return qualifying == errors.begin() ? 0 : std::size_t(qualifying - errors.begin()) - 1;
}

std::size_t exactStep(const std::vector<float>& errors, double hLim,
                      const std::vector<float>& riverErrors, double hRiver) {
    const std::size_t k = exactStep(errors, hLim);
    return riverErrors.empty() ? k : std::min(k, exactStep(riverErrors, hRiver));
}

LevelChoice chooseLevel(const std::vector<format::Level>& levels, const std::vector<float>& errors,
                        double hLim) {
    assert(!levels.empty() && !errors.empty());
    const std::size_t kStar = exactStep(errors, hLim);
    LevelChoice c;
    for (std::size_t i = 0; i < levels.size(); ++i)
        if (levels[i].step <= kStar) c.level = i;
    c.step = levels[c.level].step;
    c.error = errors[c.step];
    if (c.level + 1 < levels.size()) c.nextError = errors[levels[c.level + 1].step];
    return c;
}

LevelChoice chooseStoredLevel(const std::vector<format::Level>& levels, std::uint32_t metric,
                              double hLim, double hRiver) {
    assert(!levels.empty());
    auto error = [metric](const format::Level& l) {
        return double(metric == format::kMetricPaper ? l.errorPaper : l.errorMax);
    };
    LevelChoice c;
    c.level = format::storedLevelFor(levels, metric, hLim, hRiver);
    c.step = levels[c.level].step;
    c.error = error(levels[c.level]);
    if (metric != format::kMetricPaper) c.riverError = levels[c.level].errorRiver;
    if (c.level + 1 < levels.size()) c.nextError = error(levels[c.level + 1]);
    return c;
}

}  // namespace unilod::engine
