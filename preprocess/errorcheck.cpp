// The true `max` model error of a stored level, recomputed from a .ulod block (errorcheck.h).
#include "errorcheck.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <set>

#include "modelerror.h"
#include "predicates.h"

namespace unilod {

namespace {

constexpr std::uint32_t kNotFound = 0xFFFFFFFFu;

// Uniform buckets in compressed rows: bucket c lists list[start[c] .. start[c + 1]), the items
// i whose forCells(i, f) calls f(c).
template <typename ForCells>
void fillBuckets(std::size_t items, std::size_t cells, ForCells&& forCells,
                 std::vector<std::uint32_t>& start, std::vector<std::uint32_t>& list) {
    start.assign(cells + 1, 0);
    for (std::size_t i = 0; i < items; ++i)
        forCells(i, [&](std::size_t c) { ++start[c + 1]; });
    for (std::size_t c = 1; c < start.size(); ++c)
        start[c] += start[c - 1];
    list.resize(start.back());
    std::vector<std::uint32_t> fill(start.begin(), start.end() - 1);
    for (std::size_t i = 0; i < items; ++i)
        forCells(i, [&](std::size_t c) { list[fill[c]++] = std::uint32_t(i); });
}

// A level's triangles in a uniform grid of buckets: every triangle is listed in each bucket its
// bounding box touches (compressed rows). About one triangle per bucket, so a point is located
// with a handful of exact orientation tests; the triangles' areas sum to the domain's, so the
// lists stay near linear in the triangle count.
class TriangleBuckets {
public:
    TriangleBuckets(const format::Block& b, const std::vector<TriangleTriple>& triangles)
        : b_(b), tris_(triangles) {
        x0_ = y0_ = INT64_MAX;
        std::int64_t x1 = INT64_MIN, y1 = INT64_MIN;
        for (const format::GridXY& g : b.grid) {
            x0_ = std::min<std::int64_t>(x0_, g.x);
            y0_ = std::min<std::int64_t>(y0_, g.y);
            x1 = std::max<std::int64_t>(x1, g.x);
            y1 = std::max<std::int64_t>(y1, g.y);
        }
        const double w = double(x1 - x0_ + 1), h = double(y1 - y0_ + 1);
        const double target = double(std::max<std::size_t>(triangles.size(), 1));
        cell_ = std::max<std::int64_t>(1, std::int64_t(std::ceil(std::sqrt(w * h / target))));
        nx_ = (x1 - x0_) / cell_ + 1;
        ny_ = (y1 - y0_) / cell_ + 1;
        auto forCells = [&](std::size_t i, auto&& f) {
            std::int64_t lx = INT64_MAX, ly = INT64_MAX, hx = INT64_MIN, hy = INT64_MIN;
            for (PointId v : triangles[i].v) {
                lx = std::min<std::int64_t>(lx, b.grid[v].x);
                ly = std::min<std::int64_t>(ly, b.grid[v].y);
                hx = std::max<std::int64_t>(hx, b.grid[v].x);
                hy = std::max<std::int64_t>(hy, b.grid[v].y);
            }
            for (std::int64_t cy = (ly - y0_) / cell_; cy <= (hy - y0_) / cell_; ++cy) {
                for (std::int64_t cx = (lx - x0_) / cell_; cx <= (hx - x0_) / cell_; ++cx)
                    f(std::size_t(cy * nx_ + cx));
            }
        };
        fillBuckets(triangles.size(), std::size_t(nx_ * ny_), forCells, start_, list_);
    }

    // A triangle whose closed interior holds grid point (x, y), or kNotFound.
    std::uint32_t locate(std::int64_t x, std::int64_t y) const {
        if (x < x0_ || y < y0_) return kNotFound;
        const std::int64_t cx = (x - x0_) / cell_, cy = (y - y0_) / cell_;
        if (cx >= nx_ || cy >= ny_) return kNotFound;
        const std::size_t c = std::size_t(cy * nx_ + cx);
        for (std::uint32_t k = start_[c]; k < start_[c + 1]; ++k) {
            if (contains(tris_[list_[k]], x, y)) return list_[k];
        }
        return kNotFound;
    }

private:
    bool contains(const TriangleTriple& t, std::int64_t x, std::int64_t y) const {
        const format::GridXY a = b_.grid[t.v[0]], b = b_.grid[t.v[1]], c = b_.grid[t.v[2]];
        const std::int64_t o0 = orient2d(a.x, a.y, b.x, b.y, x, y);
        const std::int64_t o1 = orient2d(b.x, b.y, c.x, c.y, x, y);
        const std::int64_t o2 = orient2d(c.x, c.y, a.x, a.y, x, y);
        // Either orientation (the file promises counter-clockwise; the checker verifies it).
        return (o0 >= 0 && o1 >= 0 && o2 >= 0) || (o0 <= 0 && o1 <= 0 && o2 <= 0);
    }

    const format::Block& b_;
    const std::vector<TriangleTriple>& tris_;
    std::int64_t x0_ = 0, y0_ = 0, cell_ = 1, nx_ = 1, ny_ = 1;
    std::vector<std::uint32_t> start_, list_;
};

// Height at grid point (x, y) of the plane through triangle t's vertices: the build's formula
// (modelerror.cpp), exact barycentric weights from orient2d, heights from the file.
double surfaceHeight(const format::Block& b, const TriangleTriple& t, std::int64_t x,
                     std::int64_t y) {
    const format::GridXY p = b.grid[t.v[0]], q = b.grid[t.v[1]], r = b.grid[t.v[2]];
    const double den = double(orient2d(p.x, p.y, q.x, q.y, r.x, r.y));
    const double wa = double(orient2d(q.x, q.y, r.x, r.y, x, y));
    const double wb = double(orient2d(r.x, r.y, p.x, p.y, x, y));
    const double wc = double(orient2d(p.x, p.y, q.x, q.y, x, y));
    return (wa * double(b.vertices[t.v[0]].z) + wb * double(b.vertices[t.v[1]].z) +
            wc * double(b.vertices[t.v[2]].z)) /
           den;
}

// 3D distance from vertex m to the segment a-c: the build's formula (deletion.cpp).
double segmentDistance(const format::Block& b, std::uint32_t a, std::uint32_t c, std::uint32_t m) {
    const double u = format::kGridUnit;
    const double ax = double(b.grid[a].x) * u, ay = double(b.grid[a].y) * u,
                 az = double(b.vertices[a].z);
    const double dx = double(b.grid[c].x) * u - ax, dy = double(b.grid[c].y) * u - ay,
                 dz = double(b.vertices[c].z) - az;
    const double len2 = dx * dx + dy * dy + dz * dz;
    const double mx = double(b.grid[m].x) * u - ax, my = double(b.grid[m].y) * u - ay,
                 mz = double(b.vertices[m].z) - az;
    double t = len2 > 0 ? (mx * dx + my * dy + mz * dz) / len2 : 0.0;
    t = std::clamp(t, 0.0, 1.0);
    const double ex = mx - t * dx, ey = my - t * dy, ez = mz - t * dz;
    return std::sqrt(ex * ex + ey * ey + ez * ez);
}

bool verticalError(const format::Block& b, const std::vector<TriangleTriple>& triangles,
                   LevelMaxError& result, std::string& error) {
    const TriangleBuckets buckets(b, triangles);
    // The level's outline (edges of one triangle only), built when a vertex lies outside.
    std::vector<std::pair<std::uint32_t, std::uint32_t>> outline;
    for (std::uint32_t i = 0; i < b.vertices.size(); ++i) {
        const std::int64_t x = b.grid[i].x, y = b.grid[i].y;
        const std::uint32_t t = buckets.locate(x, y);
        if (t == kNotFound) {
            // Outside the simplified domain (an outline vertex deleted, deletion.h): its
            // horizontal distance to the level's outline is the outline's deviation there.
            if (outline.empty()) {
                std::set<std::pair<std::uint32_t, std::uint32_t>> directed;
                for (const TriangleTriple& tri : triangles)
                    for (int k = 0; k < 3; ++k)
                        directed.insert({tri.v[k], tri.v[(k + 1) % 3]});
                for (const auto& [u, w] : directed)
                    if (!directed.count({w, u})) outline.push_back({u, w});
            }
            const double u = format::kGridUnit;
            double best = INFINITY;
            for (const auto& [ea, ec] : outline) {
                const double a[3] = {double(b.grid[ea].x) * u, double(b.grid[ea].y) * u, 0.0};
                const double c[3] = {double(b.grid[ec].x) * u, double(b.grid[ec].y) * u, 0.0};
                const double m[3] = {double(x) * u, double(y) * u, 0.0};
                best = std::min(best, segmentDistance2(a, c, m));
            }
            if (outline.empty()) {
                error = "vertex " + std::to_string(i) + " lies in no triangle";
                return false;
            }
            const double e = std::sqrt(best);
            if (e > result.river) {
                result.river = e;
                result.riverVertex = i;
            }
            continue;
        }
        const double e = std::fabs(double(b.vertices[i].z) - surfaceHeight(b, triangles[t], x, y));
        if (e > result.vertical) {
            result.vertical = e;
            result.verticalVertex = i;
        }
    }
    return true;
}

bool riverError(const format::Block& b, std::uint32_t step, const std::vector<RiverEdge>& edges,
                const RiverReference& rivers, LevelMaxError& result, std::string& error) {
    const std::size_t aliveCount = b.vertices.size() - step;
    auto alive = [&](PointId v) { return v < aliveCount; };
    // The chain's vertices strictly between positions i and j (cyclic for a loop) against the
    // segment chain[i]-chain[j], which must be an alive river edge.
    auto span = [&](const std::vector<PointId>& chain, std::size_t i, std::size_t j,
                    std::size_t period) {
        const PointId a = chain[i], c = chain[j];
        if (!std::binary_search(edges.begin(), edges.end(), makeRiverEdge(a, c))) {
            error = "river vertices " + std::to_string(a) + " and " + std::to_string(c) +
                    " are consecutive alive vertices of an original chain but no river edge";
            return false;
        }
        for (std::size_t k = (i + 1) % period; k != j; k = (k + 1) % period) {
            const double e = segmentDistance(b, a, c, chain[k]);
            if (e > result.river) {
                result.river = e;
                result.riverVertex = chain[k];
            }
        }
        return true;
    };
    for (const std::vector<PointId>& chain : rivers.chains) {
        if (chain.size() < 2) continue;
        const bool loop = chain.front() == chain.back();
        // A loop's positions are cyclic over its distinct vertices; an open chain's ends are
        // junctions or river ends, never deleted.
        const std::size_t period = loop ? chain.size() - 1 : chain.size();
        std::vector<std::size_t> at;
        for (std::size_t k = 0; k < period; ++k) {
            if (alive(chain[k])) at.push_back(k);
        }
        if (!loop && (!alive(chain.front()) || !alive(chain.back()))) {
            error = "the river chain from vertex " + std::to_string(chain.front()) + " to " +
                    std::to_string(chain.back()) + " lost an end vertex";
            return false;
        }
        if (loop && at.size() < 2) {
            error = "the river loop through vertex " + std::to_string(chain.front()) +
                    " keeps fewer than two vertices";
            return false;
        }
        const std::size_t spans = loop ? at.size() : at.size() - 1;
        for (std::size_t s = 0; s < spans; ++s) {
            if (!span(chain, at[s], at[(s + 1) % at.size()], period)) return false;
        }
    }
    return true;
}

// A level's river edges in a uniform grid of buckets over the node's grid (each edge listed in
// every bucket its bounding box touches), for the smallest 3D distance of a point to them.
class SegmentBuckets {
public:
    SegmentBuckets(const format::Block& b, const std::vector<RiverEdge>& edges)
        : b_(b), edges_(edges) {
        if (edges.empty()) return;
        const double u = format::kGridUnit;
        double x0 = INFINITY, y0 = INFINITY, x1 = -INFINITY, y1 = -INFINITY;
        for (const format::GridXY& g : b.grid) {
            x0 = std::min(x0, double(g.x) * u);
            y0 = std::min(y0, double(g.y) * u);
            x1 = std::max(x1, double(g.x) * u);
            y1 = std::max(y1, double(g.y) * u);
        }
        x0_ = x0, y0_ = y0;
        cell_ = std::max(1e-3, std::sqrt((x1 - x0 + u) * (y1 - y0 + u) / double(edges.size())));
        nx_ = std::int64_t((x1 - x0) / cell_) + 1;
        ny_ = std::int64_t((y1 - y0) / cell_) + 1;
        auto forCells = [&](std::size_t i, auto&& f) {
            const format::GridXY p = b.grid[edges[i].a], q = b.grid[edges[i].b];
            const std::int64_t cx0 = column(double(std::min(p.x, q.x)) * u),
                               cx1 = column(double(std::max(p.x, q.x)) * u);
            const std::int64_t cy0 = row(double(std::min(p.y, q.y)) * u),
                               cy1 = row(double(std::max(p.y, q.y)) * u);
            for (std::int64_t cy = cy0; cy <= cy1; ++cy)
                for (std::int64_t cx = cx0; cx <= cx1; ++cx)
                    f(std::size_t(cy * nx_ + cx));
        };
        fillBuckets(edges.size(), std::size_t(nx_ * ny_), forCells, start_, list_);
    }

    // The smallest 3D distance from m (metres: x, y relative to the node origin, z absolute) to
    // the edges when it exceeds `floor`; otherwise some value <= floor (the search stops at the
    // first edge within it). Infinity without edges.
    double nearestAbove(const double m[3], double floor) const {
        if (edges_.empty()) return INFINITY;
        double best = INFINITY;
        // Every edge within distance r of m (3D, hence also in plan) lies in a bucket of the
        // square of half-side r around m: grow r until it covers the best distance found.
        for (double r = std::max(floor, 0.5 * cell_);; r *= 2) {
            const std::int64_t cx0 = column(m[0] - r), cx1 = column(m[0] + r);
            const std::int64_t cy0 = row(m[1] - r), cy1 = row(m[1] + r);
            for (std::int64_t cy = cy0; cy <= cy1; ++cy) {
                for (std::int64_t cx = cx0; cx <= cx1; ++cx) {
                    const std::size_t c = std::size_t(cy * nx_ + cx);
                    for (std::uint32_t k = start_[c]; k < start_[c + 1]; ++k) {
                        best = std::min(best, distance(edges_[list_[k]], m));
                        if (best <= floor) return best;
                    }
                }
            }
            const bool whole = cx0 == 0 && cy0 == 0 && cx1 == nx_ - 1 && cy1 == ny_ - 1;
            if (best <= r || whole) return best;
        }
    }

private:
    std::int64_t column(double x) const {
        return std::clamp<std::int64_t>(std::int64_t(std::floor((x - x0_) / cell_)), 0, nx_ - 1);
    }
    std::int64_t row(double y) const {
        return std::clamp<std::int64_t>(std::int64_t(std::floor((y - y0_) / cell_)), 0, ny_ - 1);
    }
    double distance(const RiverEdge& e, const double m[3]) const {
        const double u = format::kGridUnit;
        const double a[3] = {double(b_.grid[e.a].x) * u, double(b_.grid[e.a].y) * u,
                             double(b_.vertices[e.a].z)};
        const double c[3] = {double(b_.grid[e.b].x) * u, double(b_.grid[e.b].y) * u,
                             double(b_.vertices[e.b].z)};
        return std::sqrt(segmentDistance2(a, c, m));
    }

    const format::Block& b_;
    const std::vector<RiverEdge>& edges_;
    double x0_ = 0, y0_ = 0, cell_ = 1;
    std::int64_t nx_ = 1, ny_ = 1;
    std::vector<std::uint32_t> start_, list_;
};

}  // namespace

struct NodeOriginalError::Impl {
    TriangleBuckets buckets;
    SegmentBuckets rivers;
};

NodeOriginalError::NodeOriginalError(const format::Block& node,
                                     std::vector<std::vector<TriangleTriple>> levels,
                                     std::vector<std::vector<RiverEdge>> riverLevels)
    : node_(node),
      levels_(std::move(levels)),
      riverLevels_(std::move(riverLevels)),
      worst_(levels_.size()),
      riverWorst_(levels_.size()),
      tolerance_(maxErrorTolerance(node)),
      checkRivers_(!riverLevels_.empty()) {
    riverLevels_.resize(levels_.size());
    for (std::size_t l = 0; l < levels_.size(); ++l)
        buckets_.push_back(
            new Impl{TriangleBuckets(node_, levels_[l]), SegmentBuckets(node_, riverLevels_[l])});
}

NodeOriginalError::~NodeOriginalError() {
    for (Impl* b : buckets_)
        delete b;
}

void NodeOriginalError::add(const format::Block& leaf) {
    tolerance_ = std::max(tolerance_, maxErrorTolerance(leaf));
    const double u = format::kGridUnit;
    // The leaf's original river points: the vertices of its full-resolution river edges.
    std::vector<std::uint8_t> riverPoint(leaf.vertices.size(), 0);
    if (!leaf.levels.empty()) {
        const format::Level& l0 = leaf.levels.front();
        for (std::uint32_t i = 0; i < l0.riverCount; ++i) {
            const format::Edge& e = leaf.riverIndices[l0.riverFirst + i];
            if (e.a < riverPoint.size()) riverPoint[e.a] = 1;
            if (e.b < riverPoint.size()) riverPoint[e.b] = 1;
        }
    }
    // The leaf's vertices in the node's grid (those that can lie in its triangles), then one
    // level at a time over all of them: a level's buckets and triangles stay in cache (the
    // vertex-major order missed them at nearly every lookup). Per level the vertices are visited
    // in the same order either way, so the worst found (and its tie-break) is the same.
    struct LeafPoint {
        double m[3];
        std::int64_t x0, x1, y0, y1, rx, ry;
        std::uint32_t v;
    };
    std::vector<LeafPoint> points;
    points.reserve(leaf.vertices.size());
    for (std::uint32_t v = 0; v < leaf.vertices.size() && v < leaf.grid.size(); ++v) {
        const double qx = (leaf.originX + double(leaf.grid[v].x) * u - node_.originX) / u;
        const double qy = (leaf.originY + double(leaf.grid[v].y) * u - node_.originY) / u;
        // Far outside the node's grid (|coordinate| < 2^28: ulod.h): in none of its triangles.
        if (!(std::fabs(qx) < 0x1p40 && std::fabs(qy) < 0x1p40)) continue;
        points.push_back({{qx * u, qy * u, double(leaf.vertices[v].z)},
                          std::int64_t(std::ceil(qx - 1 - 1e-6)),
                          std::int64_t(std::floor(qx + 1 + 1e-6)),
                          std::int64_t(std::ceil(qy - 1 - 1e-6)),
                          std::int64_t(std::floor(qy + 1 + 1e-6)),
                          std::llround(qx),
                          std::llround(qy),
                          v});
    }
    for (std::size_t l = 0; l < levels_.size(); ++l) {
        const TriangleBuckets& b = buckets_[l]->buckets;
        const std::vector<TriangleTriple>& tris = levels_[l];
        for (const LeafPoint& p : points) {
            const double z = p.m[2];
            if (checkRivers_ && riverPoint[p.v]) {
                // Above the level's worst plus the slack: the point raises it.
                const double d =
                    buckets_[l]->rivers.nearestAbove(p.m, riverWorst_[l].value + kNodeRiverSlack);
                if (d - kNodeRiverSlack > riverWorst_[l].value)
                    riverWorst_[l] = {d - kNodeRiverSlack, leaf.col, leaf.row, p.v};
            }
            auto error = [&](std::int64_t x, std::int64_t y) {
                const std::uint32_t t = b.locate(x, y);
                return t == kNotFound ? 0.0 : std::fabs(z - surfaceHeight(node_, tris[t], x, y));
            };
            // The nearest position first: when it does not beat the level's worst, the smallest
            // over the positions cannot either.
            double e = error(p.rx, p.ry);
            if (e <= worst_[l].value) continue;
            for (std::int64_t y = p.y0; y <= p.y1 && e > 0; ++y)
                for (std::int64_t x = p.x0; x <= p.x1 && e > 0; ++x)
                    if (x != p.rx || y != p.ry) e = std::min(e, error(x, y));
            if (e > worst_[l].value) worst_[l] = {e, leaf.col, leaf.row, p.v};
        }
    }
}

double maxErrorTolerance(const format::Block& block) {
    double zMax = 0;
    for (const format::Vertex& v : block.vertices)
        zMax = std::max(zMax, std::fabs(double(v.z)));
    return 4.0 * std::ldexp(zMax, -24) + 1e-6;
}

bool levelMaxError(const format::Block& block, std::uint32_t step,
                   const std::vector<TriangleTriple>& triangles,
                   const std::vector<RiverEdge>& sortedEdges, const RiverReference& rivers,
                   LevelMaxError& result, std::string& error) {
    result = {};
    if (block.grid.size() != block.vertices.size() || step > block.vertices.size()) {
        error = "no exact grid coordinates stored or step out of range";
        return false;
    }
    return verticalError(block, triangles, result, error) &&
           riverError(block, step, sortedEdges, rivers, result, error);
}

}  // namespace unilod
