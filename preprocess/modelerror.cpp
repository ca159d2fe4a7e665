// Model error per deletion step (paper §3.2, Eq. 3-6): see modelerror.h.
#include "modelerror.h"

#include <algorithm>
#include <cassert>
#include <cmath>

#include "trianglepool.h"

namespace unilod {

namespace {
constexpr std::uint32_t kNil = 0xFFFFFFFFu;

bool containsGrid(const Cdt& cdt, std::uint32_t t, std::int64_t x, std::int64_t y) {
    const PointId a = cdt.tv[3 * t], b = cdt.tv[3 * t + 1], c = cdt.tv[3 * t + 2];
    return orient2d(cdt.gx[a], cdt.gy[a], cdt.gx[b], cdt.gy[b], x, y) >= 0 &&
           orient2d(cdt.gx[b], cdt.gy[b], cdt.gx[c], cdt.gy[c], x, y) >= 0 &&
           orient2d(cdt.gx[c], cdt.gy[c], cdt.gx[a], cdt.gy[a], x, y) >= 0;
}

double heightGrid(const PointSet& set, const Cdt& cdt, std::uint32_t t, std::int64_t x,
                  std::int64_t y) {
    const PointId a = cdt.tv[3 * t], b = cdt.tv[3 * t + 1], c = cdt.tv[3 * t + 2];
    const double den = double(cdt.orient(a, b, c));
    const double wa = double(orient2d(cdt.gx[b], cdt.gy[b], cdt.gx[c], cdt.gy[c], x, y));
    const double wb = double(orient2d(cdt.gx[c], cdt.gy[c], cdt.gx[a], cdt.gy[a], x, y));
    const double wc = double(orient2d(cdt.gx[a], cdt.gy[a], cdt.gx[b], cdt.gy[b], x, y));
    return (wa * set.points[a].z + wb * set.points[b].z + wc * set.points[c].z) / den;
}

// Squared 3D distance of Eq. 4: horizontal on the grid, vertical in metres.
inline double distance2Of(std::int64_t dgx, std::int64_t dgy, double dz, double unit) {
    const double dx = double(dgx) * unit, dy = double(dgy) * unit;
    return dx * dx + dy * dy + dz * dz;
}

// A triangle of the domain at vertex v (cdt.h inDomain; every vertex of the full
// triangulation has one).
std::uint32_t realTriangleAt(const Cdt& cdt, PointId v) {
    const std::uint32_t t0 = cdt.vertexTriangle[v];
    std::uint32_t t = t0;
    do {
        if (cdt.inDomain(t)) return t;
        std::uint32_t i = 0;
        while (cdt.tv[3 * t + i] != v)
            ++i;
        t = cdt.tn[3 * t + (i + 1) % 3] / 3;
    } while (t != t0);
    assert(false && "a vertex without a triangle of the domain");
    return t0;
}

std::uint64_t mortonKey(std::uint32_t x, std::uint32_t y) {
    auto spread = [](std::uint64_t v) {
        v &= 0xFFFF;
        v = (v | (v << 8)) & 0x00FF00FFull;
        v = (v | (v << 4)) & 0x0F0F0F0Full;
        v = (v | (v << 2)) & 0x33333333ull;
        v = (v | (v << 1)) & 0x55555555ull;
        return v;
    };
    return spread(x) | (spread(y) << 1);
}
}  // namespace

double surfaceHeight(const PointSet& set, const Cdt& cdt, std::uint32_t t, PointId m) {
    return heightGrid(set, cdt, t, cdt.gx[m], cdt.gy[m]);
}

void ModelError::init(const PointSet& set, const Cdt& cdt, bool maxMetric, bool paperMetric,
                      ExtraSamples* extra, bool release) {
    set_ = &set;
    cdt_ = &cdt;
    maxMetric_ = maxMetric;
    paperMetric_ = paperMetric;
    unit_ = cdt.gridUnit;
    const std::size_t n = set.points.size();
    runningMax_ = 0;
    runningPaper_ = 0;
    paperSum_ = 0;
    // Samples in Morton order of the grid position (ties by id).
    std::vector<std::pair<std::uint64_t, PointId>> keys(n);
    {
        std::int64_t x0 = kMaxGridCoordinate, y0 = kMaxGridCoordinate;
        std::int64_t x1 = -kMaxGridCoordinate, y1 = -kMaxGridCoordinate;
        for (PointId m = 0; m < n; ++m) {
            x0 = std::min<std::int64_t>(x0, cdt.gx[m]), x1 = std::max<std::int64_t>(x1, cdt.gx[m]);
            y0 = std::min<std::int64_t>(y0, cdt.gy[m]), y1 = std::max<std::int64_t>(y1, cdt.gy[m]);
        }
        gridX0_ = x0, gridY0_ = y0, gridX1_ = x1, gridY1_ = y1;
        const double sx = 65535.0 / double(std::max<std::int64_t>(1, x1 - x0));
        const double sy = 65535.0 / double(std::max<std::int64_t>(1, y1 - y0));
        for (PointId m = 0; m < n; ++m) {
            keys[m] = {mortonKey(std::uint32_t(double(cdt.gx[m] - x0) * sx),
                                 std::uint32_t(double(cdt.gy[m] - y0) * sy)),
                       m};
        }
        std::sort(keys.begin(), keys.end());
    }
    samples_.resize(n);
    for (std::size_t s = 0; s < n; ++s) {
        const PointId m = keys[s].second;
        samples_[s] = {cdt.gx[m], cdt.gy[m], set.points[m].z, kNil, kNil};
    }
    if (maxMetric_) {
        // Each original point goes to a real triangle at its vertex; the pool holds every
        // triangle's points contiguously.
        std::vector<std::uint32_t> tri(n);
        rangeStart_.assign(cdt.triangleSlots(), 0);
        rangeCount_.assign(cdt.triangleSlots(), 0);
        for (std::uint32_t s = 0; s < n; ++s) {
            const PointId m = keys[s].second;
            tri[s] = realTriangleAt(cdt, cdt.representative[m]);
            ++rangeCount_[tri[s]];
            if (cdt.representative[m] != m) {
                runningMax_ =
                    std::max(runningMax_,
                             std::fabs(samples_[s].z - heightGrid(set, cdt, tri[s], samples_[s].gx,
                                                                  samples_[s].gy)));
            }
        }
        // Extra samples: located by a walk from the previous one's triangle (callers pass them
        // in spatial order for short walks). Outside the hull they are left out (the hull only
        // shrinks); in an exterior triangle (outside the domain, inside the hull) they have no
        // vertical error yet but are kept like the set's points: when the outline moves out over
        // them (an outline vertex deleted), a domain triangle takes them (locateError).
        // Only each extra sample's triangle is kept here (kNil: left out); the pool is filled
        // from `extra` itself, which a tree root's caller then frees (it holds every original
        // point of the model: one copy at a time, not two).
        std::vector<std::uint32_t> extraTri;
        const std::size_t extraCount = extra != nullptr ? extra->size() : 0;
        if (extraCount > 0 && n > 0) {
            extraTri.reserve(extraCount);
            std::uint32_t at = realTriangleAt(cdt, cdt.representative[keys[0].second]);
            for (std::size_t i = 0; i < extraCount; ++i) {
                const ExtraSample e = extra->at(i);
                std::uint32_t t = cdt.locateGridFrom(e.gx, e.gy, at);
                if (cdt.isGhost(t)) {
                    extraTri.push_back(kNil);
                    continue;
                }
                if (!cdt.inDomain(t)) {
                    // On the outline the point is in the domain (closed, as locateError decides
                    // later): the domain triangle across the edge it lies on holds it.
                    for (std::uint32_t h = 3 * t; h < 3 * t + 3; ++h) {
                        const PointId u = cdt.origin(h), w = cdt.destination(h);
                        if (orient2d(cdt.gx[u], cdt.gy[u], cdt.gx[w], cdt.gy[w], e.gx, e.gy) == 0 &&
                            cdt.inDomain(cdt.tn[h] / 3)) {
                            t = cdt.tn[h] / 3;
                            break;
                        }
                    }
                }
                at = t;
                extraTri.push_back(t);
                ++rangeCount_[t];
                if (cdt.inDomain(t))
                    runningMax_ =
                        std::max(runningMax_, std::fabs(e.z - heightGrid(set, cdt, t, e.gx, e.gy)));
            }
        }
        std::uint32_t offset = 0;
        for (std::uint32_t t = 0; t < rangeCount_.size(); ++t) {
            rangeStart_[t] = offset;
            offset += rangeCount_[t];
            rangeCount_[t] = 0;
        }
        const std::size_t total = offset;
        // Room for the points re-appended by the deletions before a compaction (updateMax
        // compacts rather than grow the pool past its capacity).
        const std::size_t room = total + total / 4 + 1024;
        // Each point's place: per triangle the set's points, then the extra samples in order.
        std::vector<std::uint32_t> setPlace(n);
        for (std::uint32_t s = 0; s < n; ++s)
            setPlace[s] = rangeStart_[tri[s]] + rangeCount_[tri[s]]++;
        for (std::uint32_t& t : extraTri)
            if (t != kNil) t = rangeStart_[t] + rangeCount_[t]++;  // now the sample's place
        // The references (at()): the set's points by id, the extra ones after them, the grid's
        // cells first.
        setCount_ = std::uint32_t(n);
        explicit_.clear();
        grid_ = SampleGrid{};
        if (extra != nullptr) {
            if (release) {
                explicit_.swap(extra->points);
                std::vector<ExtraSample>().swap(extra->points);
                grid_ = std::move(extra->grid);
            } else {
                explicit_ = extra->points;
                grid_ = extra->grid;
            }
        }
        gridCells_ = grid_.cells();
        gridShift_ = grid_.shift();
        gridMask_ = (std::size_t(1) << gridShift_) - 1;
        assert(n + gridCells_ + explicit_.size() < kNil);
        const auto ref = [&](std::size_t i) {
            if (extra->refs.empty()) return PoolPoint{std::uint32_t(n + gridCells_ + i), 0.0f};
            return PoolPoint{std::uint32_t(n + extra->refs[i].ref), extra->refs[i].z};
        };
        if (release && extra != nullptr && !extra->refs.empty() && !extraTri.empty()) {
            // The released references' buffer becomes the pool: every reference moved to its
            // place along the cycles of the permutation (a place below extraTri.size() holds the
            // reference of that index until it moves on; kNil marks a moved or left-out one),
            // then the set's points written into the places left.
            pool_.swap(extra->refs);
            std::vector<SampleRef>().swap(extra->refs);
            if (pool_.capacity() < room) pool_.reserve(room);
            for (PoolPoint& r : pool_)
                r.ref = std::uint32_t(n + r.ref);
            pool_.resize(std::max(total, extraTri.size()));
            for (std::size_t i = 0; i < extraTri.size(); ++i) {
                if (extraTri[i] == kNil || extraTri[i] == i) continue;
                PoolPoint carried = pool_[i];
                std::uint32_t to = extraTri[i];
                extraTri[i] = kNil;
                for (;;) {
                    if (to < extraTri.size() && extraTri[to] != kNil) {
                        // `to` holds a reference still to move: take its place, carry it on.
                        std::swap(carried, pool_[to]);
                        const std::uint32_t next = extraTri[to];
                        extraTri[to] = kNil;
                        assert(next != to);  // `to` was the place of the reference carried
                        to = next;
                    } else {
                        pool_[to] = carried;
                        break;
                    }
                }
            }
            pool_.resize(total);
        } else {
            pool_.reserve(room);
            pool_.resize(total);
            for (std::size_t i = 0; i < extraTri.size(); ++i)
                if (extraTri[i] != kNil) pool_[extraTri[i]] = ref(i);
            if (release && extra != nullptr) std::vector<SampleRef>().swap(extra->refs);
        }
        for (std::uint32_t s = 0; s < n; ++s)
            pool_[setPlace[s]] = {keys[s].second, 0.0f};
        garbage_ = 0;
    }
    if (paperMetric_) {
        entryOf_.assign(n, kNil);
        entries_.clear();
        for (std::uint32_t s = 0; s < n; ++s) {
            const PointId m = keys[s].second;
            if (!cdt.isVertex(m)) continue;
            entryOf_[m] = std::uint32_t(entries_.size());
            entries_.push_back({samples_[s].gx, samples_[s].gy, samples_[s].z, m, 0});
        }
        buildGrid();
        nearHead_.assign(n, kNil);
        for (std::uint32_t s = 0; s < n; ++s) {
            const PointId m = keys[s].second;
            Sample& p = samples_[s];
            const PointId q = cdt.isVertex(m) ? m : nearest(p.gx, p.gy, p.z);
            p.nearest = q;
            p.nearNext = nearHead_[q];
            nearHead_[q] = s;
            paperSum_ += std::fabs(p.z - entries_[entryOf_[q]].z);
        }
        runningPaper_ = currentPaper();
    }
}

void ModelError::loadAddedTriangles(const Cdt& cdt, const std::vector<std::uint32_t>& addedSlots) {
    // The created triangles' corners and heights, once per step; the point-in-triangle
    // orientations are the barycentric weights of the height (same arithmetic as heightGrid).
    addedTris_.clear();
    for (std::uint32_t t : addedSlots)
        loadTriangle(cdt, cdt.tv[3 * t], cdt.tv[3 * t + 1], cdt.tv[3 * t + 2], t, cdt.exterior(t));
}

void ModelError::loadTriangle(const Cdt& cdt, PointId a, PointId b, PointId c, std::uint32_t slot,
                              bool exterior) {
    // An exterior triangle (cdt.h "Domain") may have frame corners, which have no height.
    auto z = [&](PointId v) { return exterior ? 0.0 : set_->points[v].z; };
    const std::int64_t x[3] = {cdt.gx[a], cdt.gx[b], cdt.gx[c]};
    const std::int64_t y[3] = {cdt.gy[a], cdt.gy[b], cdt.gy[c]};
    AddedTri q;
    for (int e = 0; e < 3; ++e) {
        // orient2d(u, w, p) = (wx - ux)(py - uy) - (wy - uy)(px - ux) for the edge u -> w
        // opposite corner e.
        const int u = (e + 1) % 3, w = (e + 2) % 3;
        q.a[e] = -(y[w] - y[u]);
        q.b[e] = x[w] - x[u];
        q.c[e] = (y[w] - y[u]) * x[u] - (x[w] - x[u]) * y[u];
    }
    q.z[0] = z(a), q.z[1] = z(b), q.z[2] = z(c);
    q.den = double(cdt.orient(a, b, c));
    q.slot = slot;
    q.exterior = exterior;
    q.v[0] = a, q.v[1] = b, q.v[2] = c;
    addedTris_.push_back(q);
}

bool ModelError::linkAdded() {
    const std::size_t count = addedTris_.size();
    if (count < walkFrom || count < 2) return false;
    // Directed edges (from, to) -> triangle * 3 + edge, sorted; the triangle across edge (u, w)
    // holds (w, u) (every triangle counter-clockwise).
    edgeScratch_.clear();
    for (std::size_t j = 0; j < count; ++j)
        for (int e = 0; e < 3; ++e) {
            const AddedTri& q = addedTris_[j];
            const std::uint64_t from = q.v[(e + 1) % 3], to = q.v[(e + 2) % 3];
            edgeScratch_.push_back({from << 32 | to, std::uint32_t(3 * j + e)});
        }
    std::sort(edgeScratch_.begin(), edgeScratch_.end());
    addedNext_.assign(3 * count, Cdt::kNone);
    std::fill(recent_, recent_ + kRecent, Cdt::kNone);
    for (const auto& [key, at] : edgeScratch_) {
        const std::uint64_t twin = (key & 0xFFFFFFFFu) << 32 | key >> 32;
        const auto it = std::lower_bound(edgeScratch_.begin(), edgeScratch_.end(),
                                         std::pair<std::uint64_t, std::uint32_t>{twin, 0});
        if (it != edgeScratch_.end() && it->first == twin) addedNext_[at] = it->second / 3;
    }
    return true;
}

double ModelError::walkError(const Pos& p, std::size_t& last, std::uint32_t& slot) {
    const std::size_t count = addedTris_.size();
    const std::int64_t px = p.gx, py = p.gy;
    std::int64_t w[3];
    auto weights = [&](std::size_t j) {
        const AddedTri& q = addedTris_[j];
        for (int e = 0; e < 3; ++e)
            w[e] = q.a[e] * px + q.b[e] * py + q.c[e];
    };
    // How far p lies outside triangle j (0: inside, closed): the largest squared distance from p
    // to the line of an edge that has p on its outer side; its edge in `out` (-1: none). Exact
    // only in its sign; it steers the walk, which the exact weights end.
    auto outside = [&](std::size_t j, int& out) {
        weights(j);
        const AddedTri& q = addedTris_[j];
        double worst = 0;
        out = -1;
        for (int e = 0; e < 3; ++e) {
            if (w[e] >= 0) continue;
            const double d = double(w[e]) * double(w[e]) /
                             (double(q.a[e]) * double(q.a[e]) + double(q.b[e]) * double(q.b[e]));
            if (out < 0 || d > worst) worst = d, out = e;
        }
        return worst;
    };
    // Start from the nearest of the last triangles found (points of one step alternate between
    // a few places: two rows of a strip), then walk towards p across the edge it is farthest
    // outside of, until a triangle holds it.
    std::size_t j = last < count ? last : 0;
    int out = -1;
    double best = outside(j, out);
    for (std::uint32_t h : recent_) {
        if (out < 0) break;
        if (h >= count || h == j) continue;
        int o = -1;
        const double d = outside(h, o);
        if (d < best) best = d, j = h, out = o;
    }
    for (std::size_t steps = 0; out >= 0; ++steps) {
        const std::uint32_t next = addedNext_[3 * j + std::size_t(out)];
        if (next == Cdt::kNone || steps > count) return locateError(p, last, slot);
        j = next;
        outside(j, out);
    }
    weights(j);
    if (recent_[0] != j) {
        std::copy_backward(recent_, recent_ + kRecent - 1, recent_ + kRecent);
        recent_[0] = std::uint32_t(j);
    }
    // The added triangles holding p (closed): j alone when p is inside it; j and the triangle
    // across the edge p lies on; on a corner (p at a vertex's position: a tree node's extra
    // samples include its own vertices) every added triangle around that corner.
    held_.assign(1, std::uint32_t(j));
    int zeros = 0, corner = -1;
    for (int e = 0; e < 3; ++e)
        if (w[e] == 0) ++zeros;
    if (zeros == 1) {
        for (int e = 0; e < 3; ++e)
            if (w[e] == 0 && addedNext_[3 * j + std::size_t(e)] != Cdt::kNone)
                held_.push_back(addedNext_[3 * j + std::size_t(e)]);
    } else if (zeros == 2) {
        for (int c = 0; c < 3; ++c)
            if (w[c] != 0) corner = c;
        // Round the corner both ways across the edges at it (edge e is opposite corner e).
        const PointId v = addedTris_[j].v[corner];
        for (int turn = 1; turn <= 2; ++turn) {
            std::size_t t = j;
            int edge = (corner + turn) % 3;
            for (std::size_t guard = 0; guard < count; ++guard) {
                const std::uint32_t next = addedNext_[3 * t + std::size_t(edge)];
                if (next == Cdt::kNone || next == j) break;
                const AddedTri& n = addedTris_[next];
                const int c = n.v[0] == v ? 0 : n.v[1] == v ? 1 : 2;
                // Of the two edges at the corner, the one not shared with t.
                const int e1 = (c + 1) % 3, e2 = (c + 2) % 3;
                edge = addedNext_[3 * std::size_t(next) + std::size_t(e1)] == t ? e2 : e1;
                t = next;
                if (std::find(held_.begin(), held_.end(), next) == held_.end())
                    held_.push_back(next);
            }
        }
    } else if (zeros > 2) {
        return locateError(p, last, slot);  // not a triangle (cannot happen: den > 0)
    }
    // As the scan (order last, 0, 1, ...): the first domain triangle, else the first exterior one.
    auto before = [&](std::size_t x, std::size_t y) {
        if (x == last || y == last) return x == last;
        return x < y;
    };
    std::size_t domain = count, exterior = count;
    for (std::uint32_t k : held_) {
        std::size_t& pick = addedTris_[k].exterior ? exterior : domain;
        if (pick == count || before(k, pick)) pick = k;
    }
    if (domain != count) {
        const AddedTri& q = addedTris_[domain];
        weights(domain);
        slot = q.slot;
        last = domain;
        const double height =
            (double(w[0]) * q.z[0] + double(w[1]) * q.z[1] + double(w[2]) * q.z[2]) / q.den;
        return std::fabs(p.z - height);
    }
    slot = addedTris_[exterior].slot;
    return 0.0;
}

double ModelError::locateError(const Pos& p, std::size_t& last, std::uint32_t& slot) const {
    // Points arrive grouped by the removed triangle that held them, so consecutive points
    // usually fall in the same created triangle: try the previous hit first. Points on a shared
    // edge may be claimed by either triangle; the height there is the same (exact weights).
    const std::size_t count = addedTris_.size();
    std::size_t outside = count;  // an exterior triangle holding p (closed)
    for (std::size_t k = 0; k < count; ++k) {
        const std::size_t j = k == 0 ? last : (k <= last ? k - 1 : k);
        const AddedTri& q = addedTris_[j];
        const std::int64_t px = p.gx, py = p.gy;
        const std::int64_t wc = q.a[2] * px + q.b[2] * py + q.c[2];
        if (wc < 0) continue;
        const std::int64_t wa = q.a[0] * px + q.b[0] * py + q.c[0];
        if (wa < 0) continue;
        const std::int64_t wb = q.a[1] * px + q.b[1] * py + q.c[1];
        if (wb < 0) continue;
        // A point on the outline lies in the closure of a triangle on either side: it belongs to
        // the domain's. Only a point outside the domain (no domain triangle holds it) goes to an
        // exterior triangle, with no vertical error: its distance to the domain is the outline's
        // planimetric deviation, which the deletion sequence bounds (deletion.h).
        if (q.exterior) {
            if (outside == count) outside = j;
            continue;
        }
        slot = q.slot;
        last = j;
        const double height =
            (double(wa) * q.z[0] + double(wb) * q.z[1] + double(wc) * q.z[2]) / q.den;
        return std::fabs(p.z - height);
    }
    if (outside != count) {
        slot = addedTris_[outside].slot;
        return 0.0;
    }
    slot = kNil;
    assert(false && "a point of the changed region lies in no new triangle");
    return INFINITY;
}

double ModelError::evaluateMax(const Cdt& cdt, const std::vector<std::uint32_t>& removedSlots,
                               const std::vector<std::uint32_t>& addedSlots) {
    if (!maxMetric_) return 0;
    loadAddedTriangles(cdt, addedSlots);
    return evaluateLoaded(removedSlots);
}

double ModelError::evaluatePlannedMax(const Cdt& cdt,
                                      const std::vector<std::uint32_t>& removedSlots,
                                      const std::vector<PointId>& corners, bool exterior) {
    if (!maxMetric_) return 0;
    addedTris_.clear();
    for (std::size_t j = 0; j + 2 < corners.size(); j += 3)
        loadTriangle(cdt, corners[j], corners[j + 1], corners[j + 2], kNil, exterior);
    return evaluateLoaded(removedSlots);
}

double ModelError::evaluateLoaded(const std::vector<std::uint32_t>& removedSlots) {
    double stepMax = 0;
    std::size_t last = 0;
    std::uint32_t slot = kNil;
    const bool walk = linkAdded();
    for (std::uint32_t t : removedSlots) {
        if (t >= rangeStart_.size()) continue;
        const PoolPoint* begin = pool_.data() + rangeStart_[t];
        for (std::uint32_t i = 0; i < rangeCount_[t]; ++i)
            stepMax = std::max(stepMax, locate(begin[i], last, slot, walk));
    }
    return stepMax;
}

double ModelError::updateMax(const Cdt& cdt, const std::vector<std::uint32_t>& removedSlots,
                             const std::vector<std::uint32_t>& addedSlots) {
    if (!maxMetric_) return 0;
    if (rangeStart_.size() < cdt.triangleSlots()) {
        rangeStart_.resize(cdt.triangleSlots(), 0);
        rangeCount_.resize(cdt.triangleSlots(), 0);
    }
    pending_.clear();
    for (std::uint32_t t : removedSlots) {
        const PoolPoint* begin = pool_.data() + rangeStart_[t];
        pending_.insert(pending_.end(), begin, begin + rangeCount_[t]);
        garbage_ += rangeCount_[t];
        rangeCount_[t] = 0;
    }
    for (std::uint32_t t : addedSlots)
        rangeCount_[t] = 0;
    // Compact in place once the garbage outweighs the live points, or before the pending points
    // would make the pool outgrow its capacity (a reallocation would hold the old and the new
    // pool at once: a tree root's pool holds every original point of the model).
    if ((garbage_ > pool_.size() / 2 && pool_.size() > 1024) ||
        (garbage_ > 0 && pool_.size() + pending_.size() > pool_.capacity()))
        compact(cdt);
    // Locate every pending point among the created triangles (exact, closed triangles).
    destination_.resize(pending_.size());
    loadAddedTriangles(cdt, addedSlots);
    const bool walk = linkAdded();
    double stepMax = 0;
    std::size_t last = 0;
    for (std::size_t i = 0; i < pending_.size(); ++i) {
        std::uint32_t found = kNil;
        stepMax = std::max(stepMax, locate(pending_[i], last, found, walk));
        destination_[i] = found;
        ++rangeCount_[found];
    }
    runningMax_ = std::max(runningMax_, stepMax);
    // Append the created triangles' ranges at the end of the pool.
    std::uint32_t offset = std::uint32_t(pool_.size());
    for (std::uint32_t t : addedSlots) {
        rangeStart_[t] = offset;
        offset += rangeCount_[t];
        rangeCount_[t] = 0;
    }
    pool_.resize(offset);
    for (std::size_t i = 0; i < pending_.size(); ++i) {
        const std::uint32_t t = destination_[i];
        pool_[rangeStart_[t] + rangeCount_[t]++] = pending_[i];
    }
    return stepMax;
}

void ModelError::compact(const Cdt& cdt) {
    compactTrianglePool(cdt, pool_, rangeStart_, rangeCount_, spare_, compactScratch_);
    garbage_ = 0;
}

void ModelError::removeVertex(PointId v) {
    if (!paperMetric_) return;
    const std::uint32_t e = entryOf_[v];
    const double zv = entries_[e].z;
    const std::int32_t vx = entries_[e].gx, vy = entries_[e].gy;
    entries_[e].id = kNil;
    entryOf_[v] = kNil;
    --alive_;
    {
        const std::int64_t i = std::clamp<std::int64_t>((vx - gridX0_) / cell_, 0, nx_ - 1);
        const std::int64_t j = std::clamp<std::int64_t>((vy - gridY0_) / cell_, 0, ny_ - 1);
        --coarseAlive_[std::size_t((j / kCoarse) * coarseX_ + i / kCoarse)];
    }
    if (alive_ > 0 && std::size_t(alive_) * 2 < entries_.size()) buildGrid();
    std::uint32_t s = nearHead_[v];
    nearHead_[v] = kNil;
    if (s == kNil) {
        runningPaper_ = std::max(runningPaper_, currentPaper());
        return;
    }
    // The orphans of v lie around v: gather the alive vertices of the 3x3 (then 5x5) cells around
    // v's cell once, take each orphan's nearest among them, and accept it when it is closer than
    // the gathered square's border (otherwise a full ring search decides). Same result as the
    // ring search, ties included.
    const std::int64_t cx = std::clamp<std::int64_t>((vx - gridX0_) / cell_, 0, nx_ - 1);
    const std::int64_t cy = std::clamp<std::int64_t>((vy - gridY0_) / cell_, 0, ny_ - 1);
    // Square of radius r cells around v's cell: its alive vertices and its border.
    struct Square {
        std::int64_t xlo, xhi, ylo, yhi;
        bool gathered = false;
    } squares[2];
    auto gather = [&](int level) {
        const std::int64_t r = level + 1;
        const std::int64_t i0 = std::max<std::int64_t>(0, cx - r),
                           i1 = std::min<std::int64_t>(nx_ - 1, cx + r);
        const std::int64_t j0 = std::max<std::int64_t>(0, cy - r),
                           j1 = std::min<std::int64_t>(ny_ - 1, cy + r);
        std::vector<Entry>& out = candidates_[level];
        out.clear();
        for (std::int64_t j = j0; j <= j1; ++j) {
            const std::size_t row = std::size_t(j) * nx_;
            for (std::uint32_t k = cellStart_[row + std::size_t(i0)];
                 k < cellStart_[row + std::size_t(i1) + 1]; ++k) {
                if (entries_[k].id != kNil) out.push_back(entries_[k]);
            }
        }
        constexpr std::int64_t kFar = std::int64_t(1) << 40;
        Square& sq = squares[level];
        sq.xlo = i0 > 0 ? gridX0_ + i0 * cell_ : -kFar;
        sq.xhi = i1 < nx_ - 1 ? gridX0_ + (i1 + 1) * cell_ : kFar;
        sq.ylo = j0 > 0 ? gridY0_ + j0 * cell_ : -kFar;
        sq.yhi = j1 < ny_ - 1 ? gridY0_ + (j1 + 1) * cell_ : kFar;
        sq.gathered = true;
    };
    while (s != kNil) {
        Sample& p = samples_[s];
        const std::uint32_t next = p.nearNext;
        if (next != kNil) __builtin_prefetch(&samples_[next]);  // overlap the list walk's miss
        PointId q = kNil;
        double zq = 0;
        for (int level = 0; level < 2 && q == kNil; ++level) {
            if (!squares[level].gathered) gather(level);
            double best = INFINITY;
            PointId bestId = kNil;
            for (const Entry& c : candidates_[level]) {
                const double d2 = distance2Of(c.gx - p.gx, c.gy - p.gy, c.z - p.z, unit_);
                if (d2 < best || (d2 == best && c.id < bestId)) best = d2, bestId = c.id, zq = c.z;
            }
            const Square& sq = squares[level];
            const std::int64_t gap =
                std::min({p.gx - sq.xlo, sq.xhi - p.gx, p.gy - sq.ylo, sq.yhi - p.gy});
            const double bound = double(gap) * unit_;
            if (bestId != kNil && gap > 0 && best < bound * bound) q = bestId;
        }
        if (q == kNil) {
            q = nearest(p.gx, p.gy, p.z);
            zq = entries_[entryOf_[q]].z;
        }
        paperSum_ += std::fabs(p.z - zq) - std::fabs(p.z - zv);
        p.nearest = q;
        p.nearNext = nearHead_[q];
        nearHead_[q] = s;
        s = next;
    }
    runningPaper_ = std::max(runningPaper_, currentPaper());
}

std::size_t ModelError::memoryBytes() const {
    return samples_.capacity() * sizeof(Sample) + pool_.capacity() * sizeof(PoolPoint) +
           explicit_.capacity() * sizeof(ExtraSample) +
           (grid_.gx.capacity() + grid_.gy.capacity()) * sizeof(std::int32_t) +
           (rangeStart_.capacity() + rangeCount_.capacity() + destination_.capacity()) * 4 +
           compactScratch_.capacity() * 8 +
           (pending_.capacity() + spare_.capacity()) * sizeof(PoolPoint) +
           (nearHead_.capacity() + entryOf_.capacity()) * 4 + entries_.capacity() * sizeof(Entry) +
           cellStart_.capacity() * 4;
}

void ModelError::buildGrid() {
    // Keep the alive entries (in their current, spatially coherent order).
    std::size_t k = 0;
    for (const Entry& e : entries_) {
        if (e.id != kNil) entries_[k++] = e;
    }
    entries_.resize(k);
    alive_ = std::uint32_t(k);
    const std::int64_t w = gridX1_ - gridX0_ + 1, h = gridY1_ - gridY0_ + 1;
    // About two alive vertices per cell, at most 2^14 cells a side.
    cell_ = std::int64_t(std::ceil(std::sqrt(double(w) * double(h) / std::max(1.0, k / 2.0))));
    cell_ = std::max<std::int64_t>({cell_, 1, (std::max(w, h) + 16383) / 16384});
    nx_ = std::uint32_t(w / cell_ + 1);
    ny_ = std::uint32_t(h / cell_ + 1);
    cellStart_.assign(std::size_t(nx_) * ny_ + 1, 0);
    auto cellOf = [&](const Entry& e) {
        return std::size_t((e.gy - gridY0_) / cell_) * nx_ + std::size_t((e.gx - gridX0_) / cell_);
    };
    for (const Entry& e : entries_)
        ++cellStart_[cellOf(e) + 1];
    for (std::size_t c = 0; c + 1 < cellStart_.size(); ++c)
        cellStart_[c + 1] += cellStart_[c];
    std::vector<Entry> sorted(k);
    std::vector<std::uint32_t> fill(cellStart_.begin(), cellStart_.end() - 1);
    for (const Entry& e : entries_) {
        const std::uint32_t slot = fill[cellOf(e)]++;
        sorted[slot] = e;
        entryOf_[e.id] = slot;
    }
    entries_.swap(sorted);
    coarseX_ = (std::int64_t(nx_) + kCoarse - 1) / kCoarse;
    coarseY_ = (std::int64_t(ny_) + kCoarse - 1) / kCoarse;
    coarseAlive_.assign(std::size_t(coarseX_ * coarseY_), 0);
    for (const Entry& e : entries_) {
        const std::int64_t i = (e.gx - gridX0_) / cell_, j = (e.gy - gridY0_) / cell_;
        ++coarseAlive_[std::size_t((j / kCoarse) * coarseX_ + i / kCoarse)];
    }
}

PointId ModelError::nearest(std::int32_t gx, std::int32_t gy, double z) const {
    const std::int64_t cx = std::clamp<std::int64_t>((gx - gridX0_) / cell_, 0, nx_ - 1);
    const std::int64_t cy = std::clamp<std::int64_t>((gy - gridY0_) / cell_, 0, ny_ - 1);
    double best = INFINITY;
    PointId bestId = kNil;
    auto scanCell = [&](std::int64_t i, std::int64_t j) {
        if (i < 0 || j < 0 || i >= nx_ || j >= ny_) return;
        const std::size_t c = std::size_t(j) * nx_ + std::size_t(i);
        for (std::uint32_t k = cellStart_[c]; k < cellStart_[c + 1]; ++k) {
            const Entry& e = entries_[k];
            if (e.id == kNil) continue;
            const double d2 = distance2Of(e.gx - gx, e.gy - gy, e.z - z, unit_);
            if (d2 < best || (d2 == best && e.id < bestId)) best = d2, bestId = e.id;
        }
    };
    constexpr std::int64_t kFar = std::int64_t(1) << 40;
    for (std::int64_t r = 0;; ++r) {
        if (r == kFineRings) {
            // Far from any alive vertex (the greedy order empties whole flat regions): go on
            // in rings of coarse blocks, skipping the empty ones by their alive counts.
            const std::int64_t bx = cx / kCoarse, by = cy / kCoarse;
            const std::int64_t bnx = coarseX_, bny = coarseY_;
            for (std::int64_t R = 0;; ++R) {
                auto scanBlock = [&](std::int64_t bi, std::int64_t bj) {
                    if (bi < 0 || bj < 0 || bi >= bnx || bj >= bny) return;
                    if (coarseAlive_[std::size_t(bj * bnx + bi)] == 0) return;
                    for (std::int64_t j = bj * kCoarse; j < (bj + 1) * kCoarse; ++j) {
                        for (std::int64_t i = bi * kCoarse; i < (bi + 1) * kCoarse; ++i)
                            scanCell(i, j);
                    }
                };
                if (R == 0) {
                    scanBlock(bx, by);
                } else {
                    for (std::int64_t i = bx - R; i <= bx + R; ++i)
                        scanBlock(i, by - R), scanBlock(i, by + R);
                    for (std::int64_t j = by - R + 1; j <= by + R - 1; ++j)
                        scanBlock(bx - R, j), scanBlock(bx + R, j);
                }
                const std::int64_t side = kCoarse * cell_;
                const std::int64_t left = bx - R > 0 ? gx - (gridX0_ + (bx - R) * side) : kFar;
                const std::int64_t right =
                    bx + R < bnx - 1 ? gridX0_ + (bx + R + 1) * side - gx : kFar;
                const std::int64_t down = by - R > 0 ? gy - (gridY0_ + (by - R) * side) : kFar;
                const std::int64_t up =
                    by + R < bny - 1 ? gridY0_ + (by + R + 1) * side - gy : kFar;
                const std::int64_t gap = std::min({left, right, down, up});
                if (gap == kFar) break;
                const double bound = double(gap) * unit_;
                if (bestId != kNil && best < bound * bound) break;
            }
            break;
        }
        if (r == 0) {
            scanCell(cx, cy);
        } else {
            for (std::int64_t i = cx - r; i <= cx + r; ++i)
                scanCell(i, cy - r), scanCell(i, cy + r);
            for (std::int64_t j = cy - r + 1; j <= cy + r - 1; ++j) {
                scanCell(cx - r, j), scanCell(cx + r, j);
            }
        }
        // Every unscanned cell lies outside the square of rings 0..r: at least this far away.
        const std::int64_t left = cx - r > 0 ? gx - (gridX0_ + (cx - r) * cell_) : kFar;
        const std::int64_t right = cx + r < nx_ - 1 ? gridX0_ + (cx + r + 1) * cell_ - gx : kFar;
        const std::int64_t down = cy - r > 0 ? gy - (gridY0_ + (cy - r) * cell_) : kFar;
        const std::int64_t up = cy + r < ny_ - 1 ? gridY0_ + (cy + r + 1) * cell_ - gy : kFar;
        const std::int64_t gap = std::min({left, right, down, up});
        if (gap == kFar) break;
        const double bound = double(gap) * unit_;
        if (bestId != kNil && best < bound * bound) break;
    }
    return bestId;
}

namespace {
// The vertical error at grid position (x, y) of height z, by scanning every triangle; -1 outside
// the domain, INFINITY outside the frame or the hull (cannot happen for the set's points).
double bruteForceAt(const PointSet& set, const Cdt& cdt, std::int64_t x, std::int64_t y, double z) {
    std::uint32_t found = kNil;
    for (std::uint32_t t = 0; t < cdt.triangleSlots(); ++t) {
        if (cdt.triangleAlive(t) && !cdt.isGhost(t) && containsGrid(cdt, t, x, y)) {
            if (found == kNil || cdt.exterior(found)) found = t;
            if (!cdt.exterior(found)) break;
        }
    }
    if (found == kNil) return INFINITY;
    if (cdt.exterior(found)) return -1;  // outside the domain: the outline's deviation
    return std::fabs(z - heightGrid(set, cdt, found, x, y));
}
}  // namespace

double bruteForceMaxError(const PointSet& set, const Cdt& cdt) {
    double worst = 0;
    for (PointId m = 0; m < set.points.size(); ++m)
        worst = std::max(worst, bruteForceAt(set, cdt, cdt.gx[m], cdt.gy[m], set.points[m].z));
    return worst;
}

double bruteForceExtraError(const PointSet& set, const Cdt& cdt,
                            const std::vector<ExtraSample>& extra) {
    double worst = 0;
    for (const ExtraSample& e : extra) {
        const double v = bruteForceAt(set, cdt, e.gx, e.gy, e.z);
        if (v != INFINITY) worst = std::max(worst, v);  // outside the hull: left out (init)
    }
    return worst;
}

double segmentDistance2(const double a[3], const double c[3], const double m[3]) {
    double d[3], w[3];
    double len2 = 0, dot = 0;
    for (int k = 0; k < 3; ++k) {
        d[k] = c[k] - a[k];
        w[k] = m[k] - a[k];
        len2 += d[k] * d[k];
        dot += w[k] * d[k];
    }
    const double t = len2 > 0 ? std::clamp(dot / len2, 0.0, 1.0) : 0.0;
    double e2 = 0;
    for (int k = 0; k < 3; ++k)
        e2 += (w[k] - t * d[k]) * (w[k] - t * d[k]);
    return e2;
}

double bruteForceRiverDeviation(const PointSet& set, const Cdt& cdt) {
    const double u = cdt.gridUnit;
    auto at = [&](PointId v, int axis) {
        return axis == 0 ? double(cdt.gx[v]) * u
                         : (axis == 1 ? double(cdt.gy[v]) * u : set.points[v].z);
    };
    double worst = 0;
    for (const Polyline& line : cdt.rivers) {
        std::size_t prev = 0;
        for (std::size_t i = 1; i < line.size(); ++i) {
            if (!cdt.isVertex(line[i])) continue;
            const PointId a = line[prev], c = line[i];
            for (std::size_t j = prev + 1; j < i; ++j) {
                const PointId m = line[j];
                const double pa[3] = {at(a, 0), at(a, 1), at(a, 2)};
                const double pc[3] = {at(c, 0), at(c, 1), at(c, 2)};
                const double pm[3] = {at(m, 0), at(m, 1), at(m, 2)};
                worst = std::max(worst, std::sqrt(segmentDistance2(pa, pc, pm)));
            }
            prev = i;
        }
    }
    return worst;
}

double bruteForcePaperError(const PointSet& set, const Cdt& cdt) {
    long double sum = 0;
    for (PointId m = 0; m < set.points.size(); ++m) {
        const Point& p = set.points[m];
        double best = INFINITY;
        PointId bestId = kNil;
        for (PointId v = 0; v < set.points.size(); ++v) {
            if (!cdt.isVertex(v)) continue;
            const double d2 = distance2Of(std::int64_t(cdt.gx[v]) - cdt.gx[m],
                                          std::int64_t(cdt.gy[v]) - cdt.gy[m],
                                          set.points[v].z - p.z, cdt.gridUnit);
            if (d2 < best) best = d2, bestId = v;
        }
        sum += std::fabs(p.z - set.points[bestId].z);
    }
    return double(sum / (long double)(set.points.size()));
}

}  // namespace unilod
