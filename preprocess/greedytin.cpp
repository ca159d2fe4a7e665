// Greedy-insertion TIN (Garland and Heckbert 1995, §4 algorithm III): see greedytin.h.
#include "greedytin.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <numeric>
#include <unordered_map>

#include "modelerror.h"
#include "trianglepool.h"

namespace unilod {

namespace {

constexpr std::uint32_t kNil = 0xFFFFFFFFu;

// A triangle's corners and heights for locating points and interpolating (the orientations are
// the barycentric weights: the same arithmetic as modelerror.cpp's heightGrid).
struct Corners {
    std::int64_t x[3], y[3];
    double z[3];
    double den;
};

Corners cornersOf(const PointSet& set, const Cdt& cdt, std::uint32_t t) {
    const PointId a = cdt.tv[3 * t], b = cdt.tv[3 * t + 1], c = cdt.tv[3 * t + 2];
    return {{cdt.gx[a], cdt.gx[b], cdt.gx[c]},
            {cdt.gy[a], cdt.gy[b], cdt.gy[c]},
            {set.points[a].z, set.points[b].z, set.points[c].z},
            double(cdt.orient(a, b, c))};
}

// Vertical error of (x, y, z) when the point lies in the closed triangle; -1 when it does not.
double errorIn(const Corners& q, std::int64_t x, std::int64_t y, double z) {
    const std::int64_t wc = orient2d(q.x[0], q.y[0], q.x[1], q.y[1], x, y);
    if (wc < 0) return -1;
    const std::int64_t wa = orient2d(q.x[1], q.y[1], q.x[2], q.y[2], x, y);
    if (wa < 0) return -1;
    const std::int64_t wb = orient2d(q.x[2], q.y[2], q.x[0], q.y[0], x, y);
    if (wb < 0) return -1;
    const double height = (double(wa) * q.z[0] + double(wb) * q.z[1] + double(wc) * q.z[2]) / q.den;
    return std::fabs(z - height);
}

}  // namespace

bool GreedyTin::init(const PointSet& set, std::string& error, const CdtOptions& options) {
    return init(set, {}, 0.0, error, options);
}

bool GreedyTin::placeRivers(const std::vector<Polyline>& rivers, double tolerance,
                            std::string& error) {
    const PointSet& set = *set_;
    for (const Polyline& chain : rivers) {
        for (PointId v : chain) {
            if (v >= set.points.size()) {
                error = "river point id " + std::to_string(v) + " out of range";
                return false;
            }
        }
    }
    // A placed segment: chain c, chain indices i < j, the vertices of its constraint edges.
    struct Placed {
        std::uint32_t c, i, j;
        std::vector<PointId> path;
    };
    std::vector<Placed> placed;
    std::unordered_map<std::uint64_t, std::uint32_t> owner;  // undirected edge -> placed index
    auto key = [](PointId u, PointId w) { return Cdt::edgeKey(std::min(u, w), std::max(u, w)); };
    auto rep = [&](PointId v) { return cdt_.representative[v]; };
    auto ensureVertex = [&](PointId v) {
        if (cdt_.isVertex(v)) return;
        const Cdt::SplitEdge s = cdt_.insertPoint(v);
        if (s.u == Cdt::kNone) return;
        // v lies on a placed segment's edge u-w: the segment now passes through v.
        const auto it = owner.find(key(s.u, s.w));
        assert(it != owner.end());
        const std::uint32_t k = it->second;
        owner.erase(it);
        std::vector<PointId>& path = placed[k].path;
        for (std::size_t m = 0; m + 1 < path.size(); ++m) {
            if (key(path[m], path[m + 1]) == key(s.u, s.w)) {
                path.insert(path.begin() + std::ptrdiff_t(m) + 1, v);
                break;
            }
        }
        owner[key(s.u, v)] = owner[key(v, s.w)] = k;
    };
    auto distance2 = [&](PointId a, PointId c, PointId m) {
        const Point &pa = set.points[a], &pc = set.points[c], &pm = set.points[m];
        const double da[3] = {pa.x, pa.y, pa.z}, dc[3] = {pc.x, pc.y, pc.z},
                     dm[3] = {pm.x, pm.y, pm.z};
        return segmentDistance2(da, dc, dm);
    };
    // The worst vertex strictly between chain indices i and j, and its squared distance.
    auto worst = [&](const Polyline& chain, std::uint32_t i, std::uint32_t j) {
        std::pair<std::uint32_t, double> w{i + 1, -1.0};
        for (std::uint32_t m = i + 1; m < j; ++m) {
            const double d2 = distance2(chain[i], chain[j], chain[m]);
            if (d2 > w.second) w = {m, d2};
        }
        return w;
    };
    // The placed segment a constraint edge on the way a -> b belongs to (crossed or run along),
    // or kNone: the segment can be inserted. Read-only (insertSegment's walk).
    auto blocker = [&](PointId a, PointId b) -> std::uint32_t {
        Cdt::Trace trace;
        for (PointId cur = a; cur != b;) {
            std::uint32_t h = cdt_.findEdge(cur, b);
            PointId end = b;
            if (h == Cdt::kNone) {
                cdt_.traceSegment(cur, b, trace);
                if (trace.end == Cdt::TraceEnd::Constraint) {
                    const std::uint32_t e = trace.edge;
                    return owner.at(key(cdt_.origin(e), cdt_.destination(e)));
                }
                if (trace.end == Cdt::TraceEnd::Vertex) end = trace.vertex;
                if (trace.crossed.empty()) h = cdt_.findEdge(cur, end);
            }
            if (h != Cdt::kNone && cdt_.isConstrained(h)) return owner.at(key(cur, end));
            cur = end;
        }
        return Cdt::kNone;
    };
    struct Range {
        std::uint32_t c, i, j;
    };
    std::vector<Range> pending;
    for (std::uint32_t c = rivers.size(); c-- > 0;) {
        if (rivers[c].size() >= 2) pending.push_back({c, 0, std::uint32_t(rivers[c].size() - 1)});
    }
    const double tol2 = tolerance * tolerance;
    auto split = [&](const Range& r) {
        const std::uint32_t m = worst(rivers[r.c], r.i, r.j).first;
        pending.push_back({r.c, m, r.j});
        pending.push_back({r.c, r.i, m});
    };
    std::vector<PointId> path;
    while (!pending.empty()) {
        const Range r = pending.back();
        pending.pop_back();
        const Polyline& chain = rivers[r.c];
        if (r.j > r.i + 1 && worst(chain, r.i, r.j).second > tol2) {
            split(r);
            continue;
        }
        const PointId a = rep(chain[r.i]), b = rep(chain[r.j]);
        ensureVertex(a);
        ensureVertex(b);
        if (a == b) continue;  // merged on the 1 mm grid
        const std::uint32_t k = blocker(a, b);
        if (k == Cdt::kNone) {
            if (!cdt_.insertSegment(a, b, path, error)) return false;  // blocker() said no
            for (std::size_t m = 0; m + 1 < path.size(); ++m)
                owner[key(path[m], path[m + 1])] = std::uint32_t(placed.size());
            placed.push_back({r.c, r.i, r.j, path});
            continue;
        }
        if (r.j > r.i + 1) {  // this one is a shortcut: split it
            split(r);
            continue;
        }
        Placed& other = placed[k];
        if (other.j == other.i + 1) {
            error = "river segments cross: " + std::to_string(chain[r.i]) + "-" +
                    std::to_string(chain[r.j]) + " and " + std::to_string(rivers[other.c][other.i]) +
                    "-" + std::to_string(rivers[other.c][other.j]);
            return false;
        }
        // An original segment meets a placed shortcut: take the shortcut out, split it, and try
        // this segment again after its halves.
        std::vector<std::uint32_t> freed;
        for (std::size_t m = 0; m + 1 < other.path.size(); ++m) {
            const std::uint32_t h = cdt_.findEdge(other.path[m], other.path[m + 1]);
            cdt_.setConstrained(h, false);
            --cdt_.constraintEdgeCount;
            owner.erase(key(other.path[m], other.path[m + 1]));
            freed.push_back(h);
        }
        other.path.clear();
        cdt_.legalize(freed);  // Delaunay again where the constraint was
        pending.push_back(r);
        split({other.c, other.i, other.j});
    }
    return true;
}

bool GreedyTin::init(const PointSet& set, const std::vector<Polyline>& rivers,
                     double riverTolerance, std::string& error, const CdtOptions& options) {
    set_ = &set;
    if (weights_ != nullptr) {
        if (weights_->size() != set.points.size()) {
            error = "greedy TIN: " + std::to_string(weights_->size()) + " weights for " +
                    std::to_string(set.points.size()) + " points";
            return false;
        }
        for (double w : *weights_) {
            if (!(w >= 0 && std::isfinite(w))) {
                error = "greedy TIN: point weights must be finite and >= 0";
                return false;
            }
        }
    }
    if (!buildHullCdt(set, options, cdt_, error)) return false;
    if (!(riverTolerance >= 0 && std::isfinite(riverTolerance))) {
        error = "the river tolerance must be finite and >= 0";
        return false;
    }
    if (!rivers.empty() && !placeRivers(rivers, riverTolerance, error)) return false;
    pool_.clear();
    heap_ = {};
    step_ = 0;
    garbage_ = 0;
    rangeStart_.assign(cdt_.triangleSlots(), 0);
    rangeCount_.assign(cdt_.triangleSlots(), 0);
    version_.assign(cdt_.triangleSlots(), 0);
    // Bucket every representative that is not a hull corner. Input order (raster rows, or any
    // spatially coherent order) keeps the walks from the previous hit short.
    pending_.clear();
    std::vector<std::uint32_t>& tri = destination_;
    tri.clear();
    std::uint32_t last = kNil;
    for (PointId m = 0; m < set.points.size(); ++m) {
        if (cdt_.representative[m] != m || cdt_.isVertex(m)) continue;
        if (last == kNil) {
            last = 0;
            while (!cdt_.triangleAlive(last) || cdt_.isGhost(last))
                ++last;
        }
        last = cdt_.locateFrom(m, last);
        assert(!cdt_.isGhost(last) && "a point outside the hull of all points");
        pending_.push_back({cdt_.gx[m], cdt_.gy[m], set.points[m].z, m, 0});
        tri.push_back(last);
        ++rangeCount_[last];
    }
    std::uint32_t offset = 0;
    for (std::uint32_t t = 0; t < rangeCount_.size(); ++t) {
        rangeStart_[t] = offset;
        offset += rangeCount_[t];
        rangeCount_[t] = 0;
    }
    pool_.resize(offset);
    for (std::size_t i = 0; i < pending_.size(); ++i)
        pool_[rangeStart_[tri[i]] + rangeCount_[tri[i]]++] = pending_[i];
    pending_.clear();
    for (std::uint32_t t = 0; t < cdt_.triangleSlots(); ++t) {
        if (rangeCount_[t] == 0) continue;
        const Corners q = cornersOf(set, cdt_, t);
        Candidate best{-1.0, kNil, t, version_[t]};
        for (std::uint32_t i = 0; i < rangeCount_[t]; ++i) {
            const PoolPoint& p = pool_[rangeStart_[t] + i];
            const Candidate c{weighted(p.id, std::max(0.0, errorIn(q, p.gx, p.gy, p.z))), p.id, t,
                              version_[t]};
            if (best < c) best = c;
        }
        heap_.push(best);
    }
    return true;
}

double GreedyTin::maxError() {
    while (!heap_.empty()) {
        const Candidate& top = heap_.top();
        if (top.version == version_[top.slot] && cdt_.triangleAlive(top.slot)) return top.error;
        heap_.pop();  // its triangle was destroyed or rebuilt since
    }
    return 0.0;
}

void GreedyTin::refineTo(double threshold) {
    while (maxError() > threshold) {
        const Candidate c = heap_.top();
        heap_.pop();
        insertWorst(c);
    }
}

void GreedyTin::growSlots() {
    const std::size_t slots = cdt_.triangleSlots();
    if (rangeStart_.size() < slots) {
        rangeStart_.resize(slots, 0);
        rangeCount_.resize(slots, 0);
        version_.resize(slots, 0);
    }
}

void GreedyTin::insertWorst(const Candidate& c) {
    cdt_.beginJournal(++step_);
    cdt_.insertPoint(c.id, c.slot);
    cdt_.endJournal();
    growSlots();
    // The points of the destroyed real triangles (the journal lists them: Bowyer-Watson only
    // destroys triangles that existed before the step) move to the created real ones; the
    // inserted point leaves the pool.
    pending_.clear();
    for (std::uint32_t t : cdt_.journalRemovedSlots) {
        const PoolPoint* begin = pool_.data() + rangeStart_[t];
        for (std::uint32_t i = 0; i < rangeCount_[t]; ++i) {
            if (begin[i].id != c.id) pending_.push_back(begin[i]);
        }
        garbage_ += rangeCount_[t];
        rangeCount_[t] = 0;
        ++version_[t];
    }
    created_.clear();
    for (std::uint32_t t : cdt_.journalCreated) {
        if (cdt_.triangleAlive(t) && !cdt_.isGhost(t)) created_.push_back(t);
    }
    std::sort(created_.begin(), created_.end());
    created_.erase(std::unique(created_.begin(), created_.end()), created_.end());
    for (std::uint32_t t : created_) {
        ++version_[t];
        rangeCount_[t] = 0;
    }
    distribute(created_);
}

void GreedyTin::distribute(const std::vector<std::uint32_t>& slots) {
    std::vector<Corners> tris;
    tris.reserve(slots.size());
    for (std::uint32_t t : slots)
        tris.push_back(cornersOf(*set_, cdt_, t));
    std::vector<Candidate> best(slots.size());
    for (std::size_t j = 0; j < slots.size(); ++j)
        best[j] = {-1.0, kNil, slots[j], version_[slots[j]]};
    destination_.resize(pending_.size());
    // Points arrive grouped by the destroyed triangle that held them, so consecutive points
    // usually fall in the same created triangle: try the previous hit first.
    std::size_t last = 0;
    for (std::size_t i = 0; i < pending_.size(); ++i) {
        const PoolPoint& p = pending_[i];
        std::size_t found = slots.size();
        for (std::size_t k = 0; k < slots.size(); ++k) {
            const std::size_t j = k == 0 ? last : (k <= last ? k - 1 : k);
            const double e = errorIn(tris[j], p.gx, p.gy, p.z);
            if (e < 0) continue;
            found = last = j;
            const Candidate cand{weighted(p.id, e), p.id, slots[j], best[j].version};
            if (best[j] < cand) best[j] = cand;
            break;
        }
        assert(found < slots.size() && "a point of the changed region lies in no new triangle");
        destination_[i] = std::uint32_t(found);
        ++rangeCount_[slots[found]];
    }
    // Append the created triangles' ranges at the end of the pool.
    std::uint32_t offset = std::uint32_t(pool_.size());
    for (std::uint32_t t : slots) {
        rangeStart_[t] = offset;
        offset += rangeCount_[t];
        rangeCount_[t] = 0;
    }
    pool_.resize(offset);
    for (std::size_t i = 0; i < pending_.size(); ++i) {
        const std::uint32_t t = slots[destination_[i]];
        pool_[rangeStart_[t] + rangeCount_[t]++] = pending_[i];
    }
    for (std::size_t j = 0; j < slots.size(); ++j) {
        if (rangeCount_[slots[j]] > 0) heap_.push(best[j]);
    }
    if (garbage_ > pool_.size() / 2 && pool_.size() > 1024) compact();
}

void GreedyTin::compact() {
    compactTrianglePool(cdt_, pool_, rangeStart_, rangeCount_, spare_, compactScratch_);
    garbage_ = 0;
}

bool greedyTinTriangles(const PointSet& set, const std::vector<double>& errors,
                        std::vector<std::uint64_t>& triangles, std::string& error) {
    triangles.assign(errors.size(), 0);
    for (double e : errors) {
        if (!(e >= 0 && std::isfinite(e))) {
            error = "error thresholds must be finite and >= 0";
            return false;
        }
    }
    GreedyTin tin;
    if (!tin.init(set, error)) return false;
    // One run, coarse to fine: the count at the first moment the error is within each threshold.
    std::vector<std::size_t> order(errors.size());
    std::iota(order.begin(), order.end(), std::size_t{0});
    std::stable_sort(order.begin(), order.end(),
                     [&](std::size_t a, std::size_t b) { return errors[a] > errors[b]; });
    for (std::size_t i : order) {
        tin.refineTo(errors[i]);
        triangles[i] = tin.triangleCount();
    }
    return true;
}

}  // namespace unilod
