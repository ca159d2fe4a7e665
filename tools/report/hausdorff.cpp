// 2D Hausdorff distance between polylines (report.h): exact point-to-segment distances, the
// supremum over a polyline sampled densely (error bound in report.h).
#include <algorithm>
#include <cassert>
#include <cmath>
#include <limits>

#include "report.h"

namespace unilod::report {

double pointSegmentDistance(const XY& p, const XY& a, const XY& b) {
    const double dx = b.x - a.x, dy = b.y - a.y;
    const double len2 = dx * dx + dy * dy;
    double t = 0;
    if (len2 > 0) t = std::clamp(((p.x - a.x) * dx + (p.y - a.y) * dy) / len2, 0.0, 1.0);
    const double qx = a.x + t * dx - p.x, qy = a.y + t * dy - p.y;
    return std::sqrt(qx * qx + qy * qy);
}

namespace {

double distanceTo(const XY& p, const std::vector<XY>& b) {
    if (b.size() == 1) return pointSegmentDistance(p, b[0], b[0]);
    double best = std::numeric_limits<double>::infinity();
    for (std::size_t i = 0; i + 1 < b.size(); ++i)
        best = std::min(best, pointSegmentDistance(p, b[i], b[i + 1]));
    return best;
}

}  // namespace

double directedHausdorff(const std::vector<XY>& a, const std::vector<XY>& b, int samples) {
    assert(!a.empty() && !b.empty() && samples >= 1);
    double worst = 0;
    for (std::size_t i = 0; i < a.size(); ++i) {
        worst = std::max(worst, distanceTo(a[i], b));
        if (i + 1 == a.size()) break;
        for (int s = 1; s < samples; ++s) {
            const double t = double(s) / samples;
            const XY p{a[i].x + t * (a[i + 1].x - a[i].x), a[i].y + t * (a[i + 1].y - a[i].y)};
            worst = std::max(worst, distanceTo(p, b));
        }
    }
    return worst;
}

double hausdorff2D(const std::vector<XY>& a, const std::vector<XY>& b, int samples) {
    return std::max(directedHausdorff(a, b, samples), directedHausdorff(b, a, samples));
}

}  // namespace unilod::report
