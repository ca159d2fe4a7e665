// Model error per deletion step (paper §3.2, Eq. 3-6): see modelerror.h.
#include "modelerror.h"

#include <algorithm>
#include <cassert>
#include <cmath>

namespace unilod {

namespace {
constexpr std::uint32_t kNil = 0xFFFFFFFFu;

bool containsPoint(const Cdt& cdt, std::uint32_t t, PointId m) {
    const PointId a = cdt.tv[3 * t], b = cdt.tv[3 * t + 1], c = cdt.tv[3 * t + 2];
    return cdt.orient(a, b, m) >= 0 && cdt.orient(b, c, m) >= 0 && cdt.orient(c, a, m) >= 0;
}
// A real (non-ghost) triangle at vertex v.
std::uint32_t realTriangleAt(const Cdt& cdt, PointId v) {
    std::uint32_t t = cdt.vertexTriangle[v];
    while (cdt.isGhost(t)) {
        std::uint32_t i = 0;
        while (cdt.tv[3 * t + i] != v)
            ++i;
        t = cdt.tn[3 * t + (i + 1) % 3] / 3;
    }
    return t;
}
}  // namespace

double surfaceHeight(const PointSet& set, const Cdt& cdt, std::uint32_t t, PointId m) {
    const PointId a = cdt.tv[3 * t], b = cdt.tv[3 * t + 1], c = cdt.tv[3 * t + 2];
    const double den = double(cdt.orient(a, b, c));
    const double wa = double(cdt.orient(b, c, m)), wb = double(cdt.orient(c, a, m));
    const double wc = double(cdt.orient(a, b, m));
    return (wa * set.points[a].z + wb * set.points[b].z + wc * set.points[c].z) / den;
}

double ModelError::heightAt(const Cdt& cdt, std::uint32_t t, PointId m) const {
    return surfaceHeight(*set_, cdt, t, m);
}

void ModelError::init(const PointSet& set, const Cdt& cdt, bool maxMetric, bool paperMetric) {
    set_ = &set;
    maxMetric_ = maxMetric;
    paperMetric_ = paperMetric;
    const std::size_t n = set.points.size();
    z_.resize(n);
    for (std::size_t i = 0; i < n; ++i)
        z_[i] = set.points[i].z;
    runningMax_ = 0;
    runningPaper_ = 0;
    if (maxMetric_) {
        bucketHead_.assign(cdt.triangleSlots(), kNil);
        bucketNext_.assign(n, kNil);
        for (PointId m = 0; m < n; ++m) {
            const std::uint32_t t = realTriangleAt(cdt, cdt.representative[m]);
            bucketNext_[m] = bucketHead_[t];
            bucketHead_[t] = m;
            if (cdt.representative[m] != m) {
                runningMax_ = std::max(runningMax_, std::fabs(z_[m] - heightAt(cdt, t, m)));
            }
        }
    }
    if (paperMetric_) {
        vertexAlive_.assign(n, 0);
        bx0_ = by0_ = INFINITY;
        bx1_ = by1_ = -INFINITY;
        for (PointId m = 0; m < n; ++m) {
            vertexAlive_[m] = cdt.isVertex(m) ? 1 : 0;
            bx0_ = std::min(bx0_, set.points[m].x), bx1_ = std::max(bx1_, set.points[m].x);
            by0_ = std::min(by0_, set.points[m].y), by1_ = std::max(by1_, set.points[m].y);
        }
        grid_.build(*this, bx0_, by0_, bx1_, by1_);
        nearest_.assign(n, kNil);
        nearHead_.assign(n, kNil);
        nearNext_.assign(n, kNil);
        paperSum_ = 0;
        for (PointId m = 0; m < n; ++m) {
            const Point& p = set.points[m];
            const PointId q = vertexAlive_[m] ? m : grid_.nearest(*this, p.x, p.y, p.z);
            nearest_[m] = q;
            nearNext_[m] = nearHead_[q];
            nearHead_[q] = m;
            paperSum_ += std::fabs(z_[m] - z_[q]);
        }
        runningPaper_ = currentPaper();
    }
}

void ModelError::updateMax(const Cdt& cdt, const std::vector<std::uint32_t>& removedSlots,
                           const std::vector<std::uint32_t>& addedSlots) {
    if (!maxMetric_) return;
    if (bucketHead_.size() < cdt.triangleSlots()) bucketHead_.resize(cdt.triangleSlots(), kNil);
    pending_.clear();
    for (std::uint32_t s : removedSlots) {
        for (std::uint32_t m = bucketHead_[s]; m != kNil; m = bucketNext_[m])
            pending_.push_back(m);
        bucketHead_[s] = kNil;
    }
    double stepMax = 0;
    for (PointId m : pending_) {
        std::uint32_t found = kNil;
        for (std::uint32_t t : addedSlots) {
            if (containsPoint(cdt, t, m)) {
                found = t;
                break;
            }
        }
        assert(found != kNil);
        bucketNext_[m] = bucketHead_[found];
        bucketHead_[found] = m;
        stepMax = std::max(stepMax, std::fabs(z_[m] - heightAt(cdt, found, m)));
    }
    runningMax_ = std::max(runningMax_, stepMax);
}

void ModelError::removeVertex(PointId v) {
    if (!paperMetric_) return;
    vertexAlive_[v] = 0;
    --grid_.alive;
    if (grid_.alive > 0 && grid_.alive * 4 < grid_.ids.size()) {
        grid_.build(*this, bx0_, by0_, bx1_, by1_);
    }
    std::uint32_t m = nearHead_[v];
    nearHead_[v] = kNil;
    while (m != kNil) {
        const std::uint32_t next = nearNext_[m];
        const Point& p = set_->points[m];
        const PointId q = grid_.nearest(*this, p.x, p.y, p.z);
        paperSum_ += std::fabs(z_[m] - z_[q]) - std::fabs(z_[m] - z_[v]);
        nearest_[m] = q;
        nearNext_[m] = nearHead_[q];
        nearHead_[q] = m;
        m = next;
    }
    runningPaper_ = std::max(runningPaper_, currentPaper());
}

std::size_t ModelError::memoryBytes() const {
    return z_.capacity() * 8 + (bucketHead_.capacity() + bucketNext_.capacity()) * 4 +
           pending_.capacity() * 4 + vertexAlive_.capacity() +
           (nearest_.capacity() + nearHead_.capacity() + nearNext_.capacity()) * 4 +
           (grid_.start.capacity() + grid_.ids.capacity()) * 4;
}

void ModelError::AliveGrid::build(const ModelError& me, double x0, double y0, double x1,
                                  double y1) {
    const std::size_t n = me.vertexAlive_.size();
    alive = 0;
    for (std::size_t v = 0; v < n; ++v)
        alive += me.vertexAlive_[v];
    const double w = std::max(x1 - x0, 1e-9), h = std::max(y1 - y0, 1e-9);
    // About two alive vertices per cell (at most 2^14 cells a side).
    cell = std::max(std::sqrt(w * h / std::max(1.0, alive / 2.0)), std::max(w, h) / 16384.0);
    nx = std::uint32_t(std::floor(w / cell)) + 1;
    ny = std::uint32_t(std::floor(h / cell)) + 1;
    minX = x0;
    minY = y0;
    start.assign(std::size_t(nx) * ny + 1, 0);
    auto cellOf = [&](PointId v) {
        const Point& p = me.set_->points[v];
        const auto cx = std::min(nx - 1, std::uint32_t((p.x - minX) / cell));
        const auto cy = std::min(ny - 1, std::uint32_t((p.y - minY) / cell));
        return std::size_t(cy) * nx + cx;
    };
    for (PointId v = 0; v < n; ++v) {
        if (me.vertexAlive_[v]) ++start[cellOf(v) + 1];
    }
    for (std::size_t c = 0; c + 1 < start.size(); ++c)
        start[c + 1] += start[c];
    ids.assign(alive, 0);
    std::vector<std::uint32_t> fill(start.begin(), start.end() - 1);
    for (PointId v = 0; v < n; ++v) {
        if (me.vertexAlive_[v]) ids[fill[cellOf(v)]++] = v;
    }
}

PointId ModelError::AliveGrid::nearest(const ModelError& me, double x, double y, double z) const {
    const auto cx = std::int64_t(std::min(nx - 1, std::uint32_t(std::max(0.0, (x - minX) / cell))));
    const auto cy = std::int64_t(std::min(ny - 1, std::uint32_t(std::max(0.0, (y - minY) / cell))));
    double best = INFINITY;
    PointId bestId = kNil;
    auto scanCell = [&](std::int64_t i, std::int64_t j) {
        if (i < 0 || j < 0 || i >= nx || j >= ny) return;
        const std::size_t c = std::size_t(j) * nx + std::size_t(i);
        for (std::uint32_t k = start[c]; k < start[c + 1]; ++k) {
            const PointId v = ids[k];
            if (!me.vertexAlive_[v]) continue;
            const Point& p = me.set_->points[v];
            const double dx = p.x - x, dy = p.y - y, dz = p.z - z;
            const double d2 = dx * dx + dy * dy + dz * dz;
            if (d2 < best || (d2 == best && v < bestId)) best = d2, bestId = v;
        }
    };
    const std::int64_t maxRing = std::max<std::int64_t>(nx, ny);
    for (std::int64_t r = 0; r <= maxRing; ++r) {
        if (r == 0) {
            scanCell(cx, cy);
        } else {
            for (std::int64_t i = cx - r; i <= cx + r; ++i)
                scanCell(i, cy - r), scanCell(i, cy + r);
            for (std::int64_t j = cy - r + 1; j <= cy + r - 1; ++j)
                scanCell(cx - r, j), scanCell(cx + r, j);
        }
        const double bound = double(r) * cell;
        if (bestId != kNil && best < bound * bound) break;
    }
    return bestId;
}

double bruteForceMaxError(const PointSet& set, const Cdt& cdt) {
    double worst = 0;
    for (PointId m = 0; m < set.points.size(); ++m) {
        std::uint32_t found = kNil;
        for (std::uint32_t t = 0; t < cdt.triangleSlots() && found == kNil; ++t) {
            if (cdt.triangleAlive(t) && !cdt.isGhost(t) && containsPoint(cdt, t, m)) found = t;
        }
        if (found == kNil) return INFINITY;  // outside the domain: cannot happen
        worst = std::max(worst, std::fabs(set.points[m].z - surfaceHeight(set, cdt, found, m)));
    }
    return worst;
}

double bruteForcePaperError(const PointSet& set, const Cdt& cdt) {
    long double sum = 0;
    for (const Point& p : set.points) {
        double best = INFINITY;
        PointId bestId = kNil;
        for (PointId v = 0; v < set.points.size(); ++v) {
            if (!cdt.isVertex(v)) continue;
            const Point& q = set.points[v];
            const double dx = q.x - p.x, dy = q.y - p.y, dz = q.z - p.z;
            const double d2 = dx * dx + dy * dy + dz * dz;
            if (d2 < best) best = d2, bestId = v;
        }
        sum += std::fabs(p.z - set.points[bestId].z);
    }
    return double(sum / (long double)(set.points.size()));
}

}  // namespace unilod
