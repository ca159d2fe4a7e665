// Improved 3D Douglas-Peucker importance order (paper §2.1, §2.2.2 Eq. 2, §3.1).
//
// Origin O. The paper lets any point be the origin. We take the unlocked point nearest (in x, y)
// to the centre of the unlocked points' bounding box, ties to the lowest id: every base plane
// passes through O, and a central pivot keeps the planes close to the terrain's mean surface.
//
// Anchor A and floating point B: the pair of vectors u = P - O with the largest |u_a x u_b|.
// Found exactly without an O(n^2) scan by branch and bound: |u_a x u_b| <= |u_a| |u_b|. A first
// guess comes from the pairs among a dozen extreme points (in 8 horizontal directions, +-z and
// the farthest point); only points with |u| * max|u| above that guess can improve it. Those are
// sorted by |u| descending and scanned pairwise with the bound as the cut-off. With O central,
// only points near the far corners survive, so the search is O(n log n) on terrain; an
// adversarial set (every point at the same distance from O) degrades to quadratic in that
// candidate count. Ties: the lexicographically smallest (id, id) pair. A is the smaller id.
// If every cross product is zero (all points collinear with O), A is the point farthest from O
// and B the point farthest from A (ties: lowest id).
//
// Sequencing (§2.1): the nearest-neighbour chain from A over all unlocked points except O and B,
// in 3D Euclidean distance on the grid coordinates (ties: lowest id), then B. A kd-tree with
// alive counts answers each step in about O(log n), never an O(n^2) search.
//
// Selection (§2.1 with threshold 0): the chain [s, e] is split at the interior point with the
// largest (pseudo) distance to the plane through O, P_s, P_e (degenerate planes: see
// PlaneDistance); ties go to the point nearest the middle of [s, e] (so flat or collinear input
// still splits in halves, O(n log n)), then to the lower position. River points use
// D_k = d_k (C BAI + 1) (Eq. 2). Every interior point is selected exactly once; its own importance
// is that (pseudo) distance, its effective importance min(own, parent's effective), where the
// parent is the point whose selection created the sub-chain. A plain 3D_DP run with threshold t
// keeps a point iff it and all its ancestors have distance > t, i.e. iff effective > t.
//
// Locked points take no part in any of this (§3.1: they "do not participate").
#include "importance.h"

#include <algorithm>
#include <array>
#include <cassert>
#include <chrono>
#include <cmath>
#include <limits>

#include "kdtree.h"

namespace unilod {

Quantizer Quantizer::forPoints(const std::vector<Point>& points) {
    Quantizer q;
    if (points.empty()) return q;
    q.ox = q.oy = q.oz = std::numeric_limits<double>::infinity();
    for (const Point& p : points) {
        q.ox = std::min(q.ox, p.x);
        q.oy = std::min(q.oy, p.y);
        q.oz = std::min(q.oz, p.z);
    }
    return q;
}

bool Quantizer::fits(const Point& p) const {
    const double lim = double(kGridLimit) * kGridUnit;
    return std::fabs(p.x - ox) < lim && std::fabs(p.y - oy) < lim && std::fabs(p.z - oz) < lim;
}

namespace {

class Stopwatch {
public:
    double lap() {
        const auto now = std::chrono::steady_clock::now();
        const double s = std::chrono::duration<double>(now - last_).count();
        last_ = now;
        return s;
    }

private:
    std::chrono::steady_clock::time_point last_ = std::chrono::steady_clock::now();
};

struct Cross {
    Int128 x, y, z;
    bool zero() const { return x == 0 && y == 0 && z == 0; }
};

Cross cross(const GridPoint& o, const GridPoint& p, const GridPoint& q) {
    const Int128 ux = p.x - o.x, uy = p.y - o.y, uz = p.z - o.z;
    const Int128 vx = q.x - o.x, vy = q.y - o.y, vz = q.z - o.z;
    return {uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx};
}

double norm2(const Cross& c) {
    const double x = double(c.x), y = double(c.y), z = double(c.z);
    return x * x + y * y + z * z;
}

double dist2(const GridPoint& a, const GridPoint& b) {
    const double x = double(a.x - b.x), y = double(a.y - b.y), z = double(a.z - b.z);
    return x * x + y * y + z * z;
}

// Local index of O among the unlocked points (see the file comment).
std::uint32_t chooseOrigin(const std::vector<GridPoint>& g) {
    std::int64_t lo[2] = {g[0].x, g[0].y}, hi[2] = {g[0].x, g[0].y};
    for (const GridPoint& p : g) {
        lo[0] = std::min(lo[0], p.x);
        lo[1] = std::min(lo[1], p.y);
        hi[0] = std::max(hi[0], p.x);
        hi[1] = std::max(hi[1], p.y);
    }
    // Compare distances to the centre at twice the scale so the centre stays an integer.
    const Int128 cx = Int128(lo[0]) + hi[0], cy = Int128(lo[1]) + hi[1];
    std::uint32_t best = 0;
    Int128 bestD = -1;
    for (std::uint32_t i = 0; i < g.size(); ++i) {
        const Int128 dx = Int128(g[i].x) * 2 - cx, dy = Int128(g[i].y) * 2 - cy;
        const Int128 d = dx * dx + dy * dy;
        if (bestD < 0 || d < bestD) {
            bestD = d;
            best = i;
        }
    }
    return best;
}

// A and B as local indices (a < b), see the file comment.
std::array<std::uint32_t, 2> chooseBasePair(const std::vector<GridPoint>& g, std::uint32_t o,
                                            std::size_t& candidates) {
    const auto n = static_cast<std::uint32_t>(g.size());
    std::vector<double> r2(n);
    for (std::uint32_t i = 0; i < n; ++i)
        r2[i] = dist2(g[i], g[o]);

    double best = 0;  // best |cross|^2
    std::uint32_t ba = 0, bb = 0;
    bool found = false;
    auto consider = [&](std::uint32_t i, std::uint32_t j) {
        if (i == j || i == o || j == o) return;
        if (i > j) std::swap(i, j);
        const double v = norm2(cross(g[o], g[i], g[j]));
        if (v > best || (v == best && found && (i < ba || (i == ba && j < bb)))) {
            if (v == 0 && !found) return;
            best = v;
            ba = i;
            bb = j;
            found = true;
        }
    };

    // First guess from extreme points.
    constexpr int kDirs = 11;
    const double dir[kDirs][3] = {{1, 0, 0}, {-1, 0, 0},  {0, 1, 0},  {0, -1, 0},
                                  {1, 1, 0}, {-1, -1, 0}, {1, -1, 0}, {-1, 1, 0},
                                  {0, 0, 1}, {0, 0, -1},  {0, 0, 0}};
    std::array<std::uint32_t, kDirs> ext{};
    std::array<double, kDirs> extV{};
    extV.fill(-HUGE_VAL);
    for (std::uint32_t i = 0; i < n; ++i) {
        if (i == o) continue;
        const double ux = double(g[i].x - g[o].x), uy = double(g[i].y - g[o].y),
                     uz = double(g[i].z - g[o].z);
        for (int d = 0; d < kDirs; ++d) {
            const double v =
                d == kDirs - 1 ? r2[i] : dir[d][0] * ux + dir[d][1] * uy + dir[d][2] * uz;
            if (v > extV[d]) {
                extV[d] = v;
                ext[d] = i;
            }
        }
    }
    for (int a = 0; a < kDirs; ++a) {
        for (int b = a + 1; b < kDirs; ++b)
            consider(ext[a], ext[b]);
    }

    // Branch and bound over the points that can still beat the guess. The bound is relaxed by
    // a relative 1e-9 so that rounding in the floating-point norms never prunes a better pair.
    const double r2max = extV[kDirs - 1];
    constexpr double kSlack = 1 + 1e-9;
    std::vector<std::uint32_t> cand;
    for (std::uint32_t i = 0; i < n; ++i) {
        if (i != o && r2[i] * r2max * kSlack >= best) cand.push_back(i);
    }
    candidates = cand.size();
    std::sort(cand.begin(), cand.end(), [&](std::uint32_t a, std::uint32_t b) {
        return r2[a] > r2[b] || (r2[a] == r2[b] && a < b);
    });
    for (std::size_t a = 0; a + 1 < cand.size(); ++a) {
        if (r2[cand[a]] * r2[cand[a + 1]] * kSlack < best) break;
        for (std::size_t b = a + 1; b < cand.size(); ++b) {
            if (r2[cand[a]] * r2[cand[b]] * kSlack < best) break;
            consider(cand[a], cand[b]);
        }
    }
    if (found) return {ba, bb};

    // Everything collinear with O: farthest from O, then farthest from that.
    auto farthestFrom = [&](std::uint32_t from, std::uint32_t skip) {
        std::uint32_t f = std::numeric_limits<std::uint32_t>::max();
        double fd = -1;
        for (std::uint32_t i = 0; i < n; ++i) {
            if (i == o || i == skip) continue;
            const double d = dist2(g[i], g[from]);
            if (d > fd) {
                fd = d;
                f = i;
            }
        }
        return f;
    };
    const std::uint32_t a = farthestFrom(o, o);
    const std::uint32_t b = farthestFrom(a, a);
    return {std::min(a, b), std::max(a, b)};
}

}  // namespace

PlaneDistance::PlaneDistance(const GridPoint& o, const GridPoint& p, const GridPoint& q) {
    Cross n = cross(o, p, q);
    base_ = o;
    if (n.zero()) {
        GridPoint from = p, to = q;
        if (p == q) from = o;    // the "plane" through O and P: the line OP
        if (from == to) return;  // Kind::Point at O
        kind_ = Kind::Line;
        base_ = from;
        n = {to.x - from.x, to.y - from.y, to.z - from.z};
    } else {
        kind_ = Kind::Plane;
    }
    exactNx_ = n.x;
    exactNy_ = n.y;
    exactNz_ = n.z;
    nx_ = double(n.x);
    ny_ = double(n.y);
    nz_ = double(n.z);
    invLen_ = 1.0 / std::sqrt(nx_ * nx_ + ny_ * ny_ + nz_ * nz_);
}

// |w x d| / |d| with the cross product exact, so points on the line are exactly 0.
double PlaneDistance::lineDistance(std::int64_t ix, std::int64_t iy, std::int64_t iz) const {
    const Int128 cx = iy * exactNz_ - iz * exactNy_, cy = iz * exactNx_ - ix * exactNz_,
                 cz = ix * exactNy_ - iy * exactNx_;
    const double x = double(cx), y = double(cy), z = double(cz);
    return std::sqrt(x * x + y * y + z * z) * invLen_ * kGridUnit;
}

bool computeImportance(const PointSet& set, const ImportanceOptions& options,
                       ImportanceResult& result, std::string& error) {
    result = ImportanceResult{};
    const std::vector<Point>& pts = set.points;
    if (pts.size() >= std::numeric_limits<PointId>::max()) {
        error = "too many points (" + std::to_string(pts.size()) + ")";
        return false;
    }
    const auto n = static_cast<PointId>(pts.size());
    const Quantizer quantizer = Quantizer::forPoints(pts);
    for (PointId i = 0; i < n; ++i) {
        const Point& p = pts[i];
        if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) {
            error = "point " + std::to_string(i) + " has a non-finite coordinate";
            return false;
        }
        if (!quantizer.fits(p)) {
            error = "point " + std::to_string(i) + " is too far from the others (more than " +
                    std::to_string(double(kGridLimit) * kGridUnit / 1000) + " km)";
            return false;
        }
    }
    for (std::size_t r = 0; r < set.rivers.size(); ++r) {
        for (PointId id : set.rivers[r]) {
            if (id >= n) {
                error = "river " + std::to_string(r) + " refers to point " + std::to_string(id) +
                        " of " + std::to_string(n);
                return false;
            }
        }
    }

    Stopwatch watch;
    ImportanceStats& stats = result.stats;
    const double inf = std::numeric_limits<double>::infinity();
    const double nan = std::numeric_limits<double>::quiet_NaN();
    if (options.useBai) {
        const int row = options.baiTable.findRow(options.baiRow);
        if (row < 0) {
            error =
                "the BAI table has no row for threshold " + std::to_string(options.baiRow) + " m";
            return false;
        }
        result.baiFactor = baiFactors(set, options.baiTable, row);
    } else {
        result.baiFactor.assign(n, 1.0f);
    }
    stats.baiSeconds = watch.lap();

    // Unlocked points in id order; from here on "local" indices refer to this list.
    std::vector<PointId> ids;
    for (PointId i = 0; i < n; ++i) {
        if (!pts[i].locked) ids.push_back(i);
    }
    const auto m = static_cast<std::uint32_t>(ids.size());
    auto allocateResult = [&] {
        result.ownImportance.assign(n, nan);
        result.importance.assign(n, nan);
        result.depth.assign(n, 0);
    };
    if (m < 3) {
        allocateResult();
        // Too few to span a base plane: all are kept, in id order.
        for (PointId id : ids) {
            result.ownImportance[id] = result.importance[id] = inf;
            result.order.push_back(id);
        }
        if (m >= 1) result.origin = ids[0];
        if (m >= 2) {
            result.anchor = ids[1];
            result.chain = {ids[1]};
        }
        return true;
    }

    std::vector<GridPoint> g(m);
    for (std::uint32_t i = 0; i < m; ++i)
        g[i] = quantizer(pts[ids[i]]);
    const std::uint32_t o = chooseOrigin(g);
    const auto [a, b] = chooseBasePair(g, o, stats.basePairCandidates);
    result.origin = ids[o];
    result.anchor = ids[a];
    result.floating = ids[b];
    stats.basePlaneSeconds = watch.lap();

    // Nearest-neighbour chain A -> ... -> B over everything but O.
    std::vector<std::uint32_t> chain;  // local indices
    chain.reserve(m - 1);
    {
        KdTree tree(g);
        tree.remove(o);
        tree.remove(a);
        tree.remove(b);
        std::uint32_t cur = a;
        chain.push_back(a);
        while (tree.aliveCount() > 0) {
            const std::uint32_t next = tree.nearestTo(cur);
            tree.remove(next);
            chain.push_back(next);
            cur = next;
        }
        chain.push_back(b);
    }
    stats.chainSeconds = watch.lap();

    // Selection over the chain, with chain-ordered copies for linear scans.
    const auto c = static_cast<std::uint32_t>(chain.size());
    std::vector<GridPoint> cg(c);
    std::vector<float> cf(c);
    for (std::uint32_t k = 0; k < c; ++k) {
        cg[k] = g[chain[k]];
        cf[k] = result.baiFactor[ids[chain[k]]];
    }
    const GridPoint origin = g[o];
    std::vector<GridPoint>().swap(g);
    std::vector<double> own(c, inf), eff(c, inf);
    std::vector<std::uint32_t> depth(c, 0);
    struct Segment {
        std::uint32_t s, e;
        double parentEff;
        std::uint32_t depth;
    };
    std::vector<Segment> stack{{0, c - 1, inf, 1}};
    while (!stack.empty()) {
        const Segment seg = stack.back();
        stack.pop_back();
        if (seg.e - seg.s < 2) continue;
        const PlaneDistance dist(origin, cg[seg.s], cg[seg.e]);
        std::uint32_t best = seg.s + 1;
        double bestD = -1;
        for (std::uint32_t k = seg.s + 1; k < seg.e; ++k) {
            const double d = dist(cg[k]) * double(cf[k]);
            if (d > bestD || (d == bestD && preferSplit(k, best, seg.s, seg.e))) {
                bestD = d;
                best = k;
            }
        }
        own[best] = bestD;
        eff[best] = std::min(bestD, seg.parentEff);
        depth[best] = seg.depth;
        stack.push_back({best, seg.e, eff[best], seg.depth + 1});
        stack.push_back({seg.s, best, eff[best], seg.depth + 1});
    }

    stats.selectionSeconds = watch.lap();
    std::vector<GridPoint>().swap(cg);
    std::vector<float>().swap(cf);

    allocateResult();
    result.chain.resize(c);
    for (std::uint32_t k = 0; k < c; ++k) {
        const PointId id = ids[chain[k]];
        result.chain[k] = id;
        result.ownImportance[id] = own[k];
        result.importance[id] = eff[k];
        result.depth[id] = depth[k];
        stats.maxDepth = std::max(stats.maxDepth, depth[k]);
        stats.meanDepth += double(depth[k]);
    }
    stats.meanDepth /= double(c);
    result.ownImportance[ids[o]] = result.importance[ids[o]] = inf;

    // Deletion order: ascending effective importance, deeper first, then lower id.
    struct Key {
        double eff;
        std::uint32_t depthKey;  // larger depth sorts first
        PointId id;
    };
    std::vector<Key> keys;
    keys.reserve(m);
    for (PointId id : ids) {
        keys.push_back({result.importance[id], ~result.depth[id], id});
    }
    std::sort(keys.begin(), keys.end(), [](const Key& l, const Key& r) {
        if (l.eff != r.eff) return l.eff < r.eff;
        if (l.depthKey != r.depthKey) return l.depthKey < r.depthKey;
        return l.id < r.id;
    });
    result.order.resize(m);
    for (std::uint32_t i = 0; i < m; ++i)
        result.order[i] = keys[i].id;
    stats.orderSeconds = watch.lap();
    return true;
}

}  // namespace unilod
