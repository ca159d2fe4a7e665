// River-constrained Delaunay triangulation (paper §3.3). Construction: Bowyer-Watson insertion
// in Hilbert-curve order with a visibility walk from the last created triangle, ghost triangles
// closing the convex hull (the "vertex at infinity" idea of Shewchuk's Triangle and CGAL), then
// every river segment inserted by flipping away the edges it crosses (Sloan 1993). The hole of a
// deleted vertex is re-triangulated by ear clipping with exact predicates (planHole). Both are
// then made constrained Delaunay by Lawson flips (a non-locally-Delaunay, non-constraint edge
// is always flippable and every flip strictly improves the triangulation, so this terminates in
// the constrained Delaunay triangulation; Lawson 1977, Chew 1989).
#include "cdt.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <numeric>

namespace unilod {

namespace {

inline std::uint32_t nextIndex(std::uint32_t i) {
    return i == 2 ? 0 : i + 1;
}
inline std::uint32_t prevIndex(std::uint32_t i) {
    return i == 0 ? 2 : i - 1;
}

// Hilbert curve index of (x, y) on a 2^16 x 2^16 grid (the classic rotate-and-flip walk).
std::uint64_t hilbertIndex(std::uint32_t x, std::uint32_t y) {
    constexpr std::uint32_t kSide = 1u << 16;
    std::uint64_t d = 0;
    for (std::uint32_t s = kSide / 2; s > 0; s /= 2) {
        const std::uint32_t rx = (x & s) ? 1 : 0;
        const std::uint32_t ry = (y & s) ? 1 : 0;
        d += std::uint64_t(s) * s * ((3 * rx) ^ ry);
        if (ry == 0) {
            if (rx == 1) {
                x = kSide - 1 - x;
                y = kSide - 1 - y;
            }
            std::swap(x, y);
        }
    }
    return d;
}

}  // namespace

TriangleTriple canonicalTriangle(PointId a, PointId b, PointId c) {
    if (b < a && b < c) return {{b, c, a}};
    if (c < a && c < b) return {{c, a, b}};
    return {{a, b, c}};
}

// --- Journal ---------------------------------------------------------------------------------

void Cdt::beginJournal(std::uint32_t step) {
    journaling_ = true;
    step_ = step;
    journalRemovedSlots.clear();
    journalRemoved.clear();
    journalCreated.clear();
}

// --- Trial (undo log) ------------------------------------------------------------------------

void Cdt::beginTrial() {
    assert(!trial_);
    trial_ = true;
    if (++trialId_ == 0) {  // wrapped: forget every old mark
        std::fill(triangleMark_.begin(), triangleMark_.end(), 0);
        std::fill(vertexMark_.begin(), vertexMark_.end(), 0);
        trialId_ = 1;
    }
    trialSlots_ = triangleSlots();
    if (triangleMark_.size() < trialSlots_) triangleMark_.resize(trialSlots_ + trialSlots_ / 4, 0);
    if (vertexMark_.size() < vertexTriangle.size()) vertexMark_.resize(vertexTriangle.size(), 0);
    trialFreeLow_ = std::uint32_t(freeSlots.size());
    savedTriangles_.clear();
    savedVertices_.clear();
    savedFreePopped_.clear();
    savedCounts_[0] = vertexCount;
    savedCounts_[1] = realTriangleCount;
    savedCounts_[2] = constraintEdgeCount;
    savedCounts_[3] = mergedPoints;
    savedLastTriangle_ = lastTriangle_;
}

void Cdt::saveTriangleSlow(std::uint32_t t) {
    triangleMark_[t] = trialId_;
    SavedTriangle s;
    s.t = t;
    for (int i = 0; i < 3; ++i) {
        s.v[i] = tv[3 * t + i];
        s.n[i] = tn[3 * t + i];
    }
    s.stamp = stamp[t];
    s.c = tc[t];
    savedTriangles_.push_back(s);
}

void Cdt::rollbackTrial() {
    assert(trial_);
    trial_ = false;
    for (auto it = savedTriangles_.rbegin(); it != savedTriangles_.rend(); ++it) {
        const std::uint32_t t = it->t;
        for (int i = 0; i < 3; ++i) {
            tv[3 * t + i] = it->v[i];
            tn[3 * t + i] = it->n[i];
        }
        stamp[t] = it->stamp;
        tc[t] = it->c;
    }
    for (auto it = savedVertices_.rbegin(); it != savedVertices_.rend(); ++it)
        vertexTriangle[it->first] = it->second;
    tv.resize(3 * std::size_t(trialSlots_));
    tn.resize(3 * std::size_t(trialSlots_));
    tc.resize(trialSlots_);
    stamp.resize(trialSlots_);
    freeSlots.resize(trialFreeLow_);
    freeSlots.insert(freeSlots.end(), savedFreePopped_.rbegin(), savedFreePopped_.rend());
    vertexCount = savedCounts_[0];
    realTriangleCount = savedCounts_[1];
    constraintEdgeCount = savedCounts_[2];
    mergedPoints = savedCounts_[3];
    lastTriangle_ = savedLastTriangle_;
}

// --- Elementary operations -------------------------------------------------------------------

std::uint32_t Cdt::createTriangle(PointId a, PointId b, PointId c) {
    std::uint32_t t;
    if (!freeSlots.empty()) {
        t = freeSlots.back();
        if (trial_ && freeSlots.size() <= trialFreeLow_) {
            savedFreePopped_.push_back(t);
            trialFreeLow_ = std::uint32_t(freeSlots.size() - 1);
        }
        freeSlots.pop_back();
    } else {
        t = triangleSlots();
        tv.resize(tv.size() + 3);
        tn.resize(tn.size() + 3);
        tc.push_back(0);
        stamp.push_back(0);
    }
    if (trial_) saveTriangle(t);
    tv[3 * t] = a;
    tv[3 * t + 1] = b;
    tv[3 * t + 2] = c;
    tn[3 * t] = tn[3 * t + 1] = tn[3 * t + 2] = kNone;
    tc[t] = 0;
    stamp[t] = step_;
    bool ghost = false;
    for (PointId v : {a, b, c}) {
        if (v == kGhost) {
            ghost = true;
        } else {
            setVertexTriangle(v, t);
        }
    }
    if (!ghost) {
        ++realTriangleCount;
        lastTriangle_ = t;
    }
    if (journaling_) journalCreated.push_back(t);
    return t;
}

void Cdt::destroyTriangle(std::uint32_t t) {
    assert(triangleAlive(t));
    const bool ghost = isGhost(t);
    if (journaling_ && !ghost && stamp[t] != step_) {
        journalRemovedSlots.push_back(t);
        if (!exterior(t))
            journalRemoved.push_back(canonicalTriangle(tv[3 * t], tv[3 * t + 1], tv[3 * t + 2]));
    }
    if (!ghost) --realTriangleCount;
    if (trial_) saveTriangle(t);
    tv[3 * t] = tv[3 * t + 1] = tv[3 * t + 2] = kNone;
    freeSlots.push_back(t);
}

void Cdt::setConstrained(std::uint32_t h, bool on) {
    const std::uint32_t g = tn[h];
    if (trial_) {
        saveTriangle(h / 3);
        saveTriangle(g / 3);
    }
    if (on) {
        tc[h / 3] |= std::uint8_t(1u << (h % 3));
        tc[g / 3] |= std::uint8_t(1u << (g % 3));
    } else {
        tc[h / 3] &= std::uint8_t(~(1u << (h % 3)));
        tc[g / 3] &= std::uint8_t(~(1u << (g % 3)));
    }
}

std::uint32_t Cdt::findEdge(PointId a, PointId b) const {
    // Around a for the half-edge a -> b; past the first few triangles also around b for its
    // twin b -> a, one triangle of each in turn, so the cost is about the smaller degree: a frame
    // vertex or the apex of a fan in a 2-row DEM has thousands of triangles, its partner a few
    // (around a alone first: a typical degree is 6, and the second walk cost 8 % of a build).
    constexpr std::uint32_t kAloneSteps = 4;
    const std::uint32_t a0 = vertexTriangle[a];
    assert(a0 != kNone);
    const std::uint32_t b0 = b < vertexTriangle.size() ? vertexTriangle[b] : kNone;
    std::uint32_t ta = a0, tb = b0;
    for (std::uint32_t steps = 0;; ++steps) {
        std::uint32_t i = 0;
        while (tv[3 * ta + i] != a)
            ++i;
        if (tv[3 * ta + nextIndex(i)] == b) return 3 * ta + prevIndex(i);
        ta = tn[3 * ta + nextIndex(i)] / 3;
        if (ta == a0) return kNone;
        // b not a vertex (or the ghost): around a alone.
        if (tb == kNone || steps < kAloneSteps) continue;
        std::uint32_t j = 0;
        while (tv[3 * tb + j] != b)
            ++j;
        if (tv[3 * tb + nextIndex(j)] == a) return tn[3 * tb + prevIndex(j)];
        tb = tn[3 * tb + nextIndex(j)] / 3;
        if (tb == b0) return kNone;
    }
}

void Cdt::assignSides(const std::vector<std::uint32_t>& slots) {
    if (mark_.size() < triangleSlots()) mark_.resize(triangleSlots() + triangleSlots() / 2, 0);
    ++markStamp_;
    const std::uint32_t member = markStamp_;
    ++markStamp_;
    const std::uint32_t done = markStamp_;  // member whose side is set
    auto setSide = [&](std::uint32_t t, bool outside) {
        if (trial_) saveTriangle(t);
        tc[t] = std::uint8_t(outside ? (tc[t] | kExterior) : (tc[t] & ~kExterior));
        mark_[t] = done;
    };
    for (std::uint32_t t : slots) {
        if (triangleAlive(t)) mark_[t] = member;
    }
    std::vector<std::uint32_t>& queue = sideQueue_;
    queue.clear();
    for (std::uint32_t t : slots) {
        if (mark_[t] != member) continue;
        if (isGhost(t)) {
            setSide(t, true);
            queue.push_back(t);
            continue;
        }
        for (std::uint32_t i = 0; i < 3 && mark_[t] == member; ++i) {
            const std::uint32_t h = 3 * t + i;
            const PointId u = origin(h), w = destination(h);
            if (isConstrained(h) && boundaryDirected(u, w)) {
                setSide(t, false);
            } else if (isConstrained(h) && boundaryDirected(w, u)) {
                setSide(t, true);
            } else {
                const std::uint32_t g = tn[h] / 3;
                if (mark_[g] == member || mark_[g] == done) continue;
                setSide(t, isGhost(g) || exterior(g));
            }
        }
        if (mark_[t] == done) queue.push_back(t);
    }
    for (std::size_t q = 0; q < queue.size(); ++q) {
        const std::uint32_t t = queue[q];
        for (std::uint32_t i = 0; i < 3; ++i) {
            const std::uint32_t h = 3 * t + i;
            if (isConstrained(h) && isBoundaryEdge(origin(h), destination(h))) continue;
            const std::uint32_t g = tn[h] / 3;
            if (mark_[g] != member) continue;
            setSide(g, isGhost(g) || exterior(t));
            queue.push_back(g);
        }
    }
    for (std::uint32_t t : slots) {
        assert(!triangleAlive(t) || mark_[t] == done);
        (void)t;
    }
}

void Cdt::setSides(const std::vector<std::uint32_t>& slots, bool outside) {
    for (std::uint32_t t : slots) {
        if (!triangleAlive(t)) continue;
        if (trial_) saveTriangle(t);
        tc[t] = std::uint8_t(outside ? (tc[t] | kExterior) : (tc[t] & ~kExterior));
    }
}

void Cdt::flip(std::uint32_t h) {
    const std::uint32_t t = h / 3, i = h % 3;
    const std::uint32_t g = tn[h], n = g / 3, j = g % 3;
    const PointId a = tv[3 * t + i], b = tv[3 * t + nextIndex(i)], c = tv[3 * t + prevIndex(i)];
    const PointId d = tv[3 * n + j];
    assert(tv[3 * n + nextIndex(j)] == c && tv[3 * n + prevIndex(j)] == b);
    const std::uint32_t hca = tn[3 * t + nextIndex(i)], hab = tn[3 * t + prevIndex(i)];
    const std::uint32_t hbd = tn[3 * n + nextIndex(j)], hdc = tn[3 * n + prevIndex(j)];
    const bool cca = isConstrained(3 * t + nextIndex(i)), cab = isConstrained(3 * t + prevIndex(i));
    const bool cbd = isConstrained(3 * n + nextIndex(j)), cdc = isConstrained(3 * n + prevIndex(j));
    if (journaling_) {
        for (std::uint32_t s : {t, n}) {
            if (stamp[s] != step_) {
                journalRemovedSlots.push_back(s);
                if (!exterior(s))
                    journalRemoved.push_back(
                        canonicalTriangle(tv[3 * s], tv[3 * s + 1], tv[3 * s + 2]));
            }
            journalCreated.push_back(s);
        }
    }
    if (trial_) {
        saveTriangle(t);
        saveTriangle(n);
    }
    stamp[t] = stamp[n] = step_;
    // t becomes (a, b, d), n becomes (d, c, a).
    tv[3 * t] = a, tv[3 * t + 1] = b, tv[3 * t + 2] = d;
    tv[3 * n] = d, tv[3 * n + 1] = c, tv[3 * n + 2] = a;
    // Both triangles are on one side: only a ring edge (a constraint, never flipped) separates
    // the domain from the outside.
    const std::uint8_t side = tc[t] & kExterior;
    tc[t] = std::uint8_t((cbd ? 1u : 0u) | (cab ? 4u : 0u) | side);
    tc[n] = std::uint8_t((cca ? 1u : 0u) | (cdc ? 4u : 0u) | side);
    link(3 * t, hbd);
    link(3 * t + 2, hab);
    link(3 * n, hca);
    link(3 * n + 2, hdc);
    link(3 * t + 1, 3 * n + 1);
    setVertexTriangle(a, t);
    setVertexTriangle(b, t);
    setVertexTriangle(d, t);
    setVertexTriangle(c, n);
}

bool Cdt::takeHole(const std::vector<std::uint32_t>& triangles) {
    const std::size_t k = triangles.size();
    outer_.resize(k);
    cons_.resize(k);
    bool constraintAtV = false;
    for (std::size_t i = 0; i < k; ++i) {
        const std::uint32_t h = triangles[i];
        outer_[i] = tn[h];
        cons_[i] = isConstrained(h) ? 1 : 0;
        constraintAtV = constraintAtV || isConstrained(h - h % 3 + nextIndex(h % 3)) ||
                        isConstrained(h - h % 3 + prevIndex(h % 3));
    }
    return constraintAtV;
}

void Cdt::legalizeTriangles(const std::vector<std::uint32_t>& triangles) {
    legal_.clear();
    for (std::uint32_t t : triangles) {
        legal_.push_back(3 * t);
        legal_.push_back(3 * t + 1);
        legal_.push_back(3 * t + 2);
    }
    legalize(legal_);
}

void Cdt::legalize(std::vector<std::uint32_t>& stack) {
    while (!stack.empty()) {
        const std::uint32_t h = stack.back();
        stack.pop_back();
        const std::uint32_t t = h / 3;
        if (!triangleAlive(t) || isConstrained(h)) continue;
        const std::uint32_t g = tn[h], n = g / 3;
        if (isGhost(t) || isGhost(n)) continue;
        const std::uint32_t i = h % 3;
        const PointId a = tv[3 * t + i], b = tv[3 * t + nextIndex(i)], c = tv[3 * t + prevIndex(i)];
        const PointId d = tv[3 * n + g % 3];
        if (incirclePerturbed(gx[a], gy[a], gx[b], gy[b], gx[c], gy[c], gx[d], gy[d]) <= 0) continue;
        flip(h);
        stack.push_back(3 * t);
        stack.push_back(3 * t + 2);
        stack.push_back(3 * n);
        stack.push_back(3 * n + 2);
    }
}

void Cdt::planHole(const std::vector<PointId>& poly, std::vector<std::uint32_t>& triangles) {
    const std::uint32_t k = static_cast<std::uint32_t>(poly.size());
    assert(k >= 3);
    // Scratch of at least k entries, grown only (a plan is made several times per deletion).
    if (earPrev_.size() < k) {
        earPrev_.resize(k);
        earNext_.resize(k);
        across_.resize(k);
        holeX_.resize(k);
        holeY_.resize(k);
    }
    std::uint32_t* const prev = earPrev_.data();
    std::uint32_t* const next = earNext_.data();
    std::uint32_t* const across = across_.data();
    std::int64_t* const x = holeX_.data();
    std::int64_t* const y = holeY_.data();
    for (std::uint32_t i = 0; i < k; ++i) {
        prev[i] = i == 0 ? k - 1 : i - 1;
        next[i] = i + 1 == k ? 0 : i + 1;
        across[i] = kNone;
        x[i] = gx[poly[i]];
        y[i] = gy[poly[i]];
    }
    triangles.resize(3 * (k - 2));
    planNbr_.resize(triangles.size());
    std::uint32_t* const tri = triangles.data();
    std::uint32_t* const nbr = planNbr_.data();
    std::size_t stackSize = 0;
    auto push = [&](std::uint32_t h) {
        if (stackSize == planStack_.size()) planStack_.resize(2 * stackSize + 16);
        planStack_[stackSize++] = h;
    };
    auto orientAt = [&](std::uint32_t a, std::uint32_t b, std::uint32_t c) {
        return orient2d(x[a], y[a], x[b], y[b], x[c], y[c]);
    };
    auto isEar = [&](std::uint32_t p, std::uint32_t i, std::uint32_t n) {
        if (orientAt(p, i, n) <= 0) return false;
        for (std::uint32_t m = next[n]; m != p; m = next[m]) {
            if (orientAt(p, i, m) >= 0 && orientAt(i, n, m) >= 0 && orientAt(n, p, m) >= 0)
                return false;
        }
        return true;
    };
    // Ear clipping. across[j] is the plan half-edge on the far side of the current outline edge
    // j -> next[j] (kNone on an edge of the polygon), so each triangle is linked to the earlier
    // ones as it is made: planNbr_[3t + e] is the half-edge across edge e of triangle t
    // (opposite its corner e), kNone on the polygon. Every diagonal goes on the flip stack once,
    // as its earlier half-edge, in the order its later half-edge is made.
    auto link = [&](std::uint32_t h, std::uint32_t g) {
        nbr[h] = g;
        if (g == kNone) return;
        nbr[g] = h;
        push(g);
    };
    std::uint32_t remaining = k, i = 0, misses = 0, made = 0;
    while (remaining > 3) {
        const std::uint32_t p = prev[i], n = next[i];
        if (!isEar(p, i, n)) {
            i = n;
            ++misses;
            assert(misses <= remaining && "a star-shaped polygon always has an ear");
            continue;
        }
        const std::uint32_t h = 3 * made;
        tri[h] = p, tri[h + 1] = i, tri[h + 2] = n;
        link(h, across[i]);      // i -> n
        nbr[h + 1] = kNone;      // n -> p, the new diagonal: linked when its far side is made
        link(h + 2, across[p]);  // p -> i
        across[p] = h + 1;
        next[p] = n;
        prev[n] = p;
        --remaining;
        misses = 0;
        i = p;
        ++made;
    }
    const std::uint32_t p = prev[i], n = next[i], last = 3 * made;
    tri[last] = p, tri[last + 1] = i, tri[last + 2] = n;
    link(last, across[i]);
    link(last + 1, across[n]);
    link(last + 2, across[p]);
    // Lawson flips of the diagonals until none is illegal.
    auto setNbr = [&](std::uint32_t h, std::uint32_t g) {
        nbr[h] = g;
        if (g != kNone) nbr[g] = h;
    };
    while (stackSize != 0) {
        const std::uint32_t h = planStack_[--stackSize];
        const std::uint32_t g = nbr[h];
        if (g == kNone) continue;
        const std::uint32_t t = h / 3, e = h % 3, o = g / 3, f = g % 3;
        const std::uint32_t a = tri[3 * t + e], u = tri[3 * t + nextIndex(e)],
                            w = tri[3 * t + prevIndex(e)], d = tri[3 * o + f];
        if (incirclePerturbed(x[a], y[a], x[u], y[u], x[w], y[w], x[d], y[d]) <= 0) continue;
        // Quadrilateral a, u, d, w (counter-clockwise): u-w becomes a-d; t = (a, u, d),
        // o = (a, d, w).
        const std::uint32_t nWA = nbr[3 * t + nextIndex(e)], nAU = nbr[3 * t + prevIndex(e)];
        const std::uint32_t nUD = nbr[3 * o + nextIndex(f)], nDW = nbr[3 * o + prevIndex(f)];
        tri[3 * t] = a, tri[3 * t + 1] = u, tri[3 * t + 2] = d;
        tri[3 * o] = a, tri[3 * o + 1] = d, tri[3 * o + 2] = w;
        setNbr(3 * t, nUD);
        setNbr(3 * t + 2, nAU);
        setNbr(3 * o, nDW);
        setNbr(3 * o + 1, nWA);
        setNbr(3 * t + 1, 3 * o + 2);
        for (std::uint32_t q : {3 * t, 3 * t + 2, 3 * o, 3 * o + 1}) {
            if (nbr[q] != kNone) push(q);
        }
    }
}

// --- Segment walk and insertion --------------------------------------------------------------

void Cdt::traceSegment(PointId a, PointId b, Trace& trace) const {
    trace.crossed.clear();
    trace.vertex = kNone;
    trace.edge = kNone;
    const std::int64_t dx = gx[b] - gx[a], dy = gy[b] - gy[a];
    const std::uint32_t t0 = vertexTriangle[a];
    std::uint32_t t = t0, h = kNone;
    do {
        std::uint32_t i = 0;
        while (tv[3 * t + i] != a)
            ++i;
        const PointId p = tv[3 * t + nextIndex(i)], q = tv[3 * t + prevIndex(i)];
        // A vertex on the ray a -> b. Both corners are tested: for a on the hull, its hull
        // neighbour on one side is `p` only in a ghost triangle, so testing `p` alone misses a
        // segment running along the hull (a block border) in that direction.
        for (const PointId v : {p, q}) {
            if (v != kGhost && orient(a, b, v) == 0 &&
                (gx[v] - gx[a]) * dx + (gy[v] - gy[a]) * dy > 0) {
                trace.end = v == b ? TraceEnd::Reached : TraceEnd::Vertex;
                trace.vertex = v == b ? kNone : v;
                return;
            }
        }
        if (p != kGhost && q != kGhost) {
            const std::int64_t o1 = orient(a, b, p);
            if (o1 < 0 && orient(a, b, q) > 0) {
                h = 3 * t + i;
                break;
            }
        }
        t = tn[3 * t + nextIndex(i)] / 3;
    } while (t != t0);
    assert(h != kNone);
    for (;;) {
        if (isConstrained(h)) {
            trace.end = TraceEnd::Constraint;
            trace.edge = h;
            return;
        }
        trace.crossed.push_back(h);
        const std::uint32_t g = tn[h], n = g / 3, j = g % 3;
        const PointId r = tv[3 * n + j];
        assert(r != kGhost);
        if (r == b) {
            trace.end = TraceEnd::Reached;
            return;
        }
        const std::int64_t o = orient(a, b, r);
        if (o == 0) {
            trace.end = TraceEnd::Vertex;
            trace.vertex = r;
            return;
        }
        h = o > 0 ? 3 * n + nextIndex(j) : 3 * n + prevIndex(j);
    }
}

bool Cdt::insertSegment(PointId a, PointId b, std::vector<PointId>& path, std::string& error,
                        bool river) {
    assert(a != b);
    path.clear();
    path.push_back(a);
    PointId cur = a;
    while (cur != b) {
        std::uint32_t h = findEdge(cur, b);
        PointId end = b;
        if (h == kNone) {
            traceSegment(cur, b, trace_);
            if (trace_.end == TraceEnd::Constraint) {
                const std::uint32_t e = trace_.edge;
                error = "river segments cross: " + std::to_string(a) + "-" + std::to_string(b) +
                        " crosses " + std::to_string(origin(e)) + "-" +
                        std::to_string(destination(e));
                return false;
            }
            if (trace_.end == TraceEnd::Vertex) end = trace_.vertex;
            if (trace_.crossed.empty()) h = findEdge(cur, end);
        }
        if (h != kNone) {
            if (isConstrained(h) && river && isBoundaryEdge(cur, end)) {
                // A river along a ring edge: the edge is both (locked ends: never removed).
                riverOnBoundary.insert(edgeKey(std::min(cur, end), std::max(cur, end)));
                locked[cur] = 1;
                locked[end] = 1;
                path.push_back(end);
                cur = end;
                continue;
            }
            if (isConstrained(h)) {
                error = "river segments overlap: " + std::to_string(a) + "-" + std::to_string(b) +
                        " runs along the river edge " + std::to_string(cur) + "-" +
                        std::to_string(end);
                return false;
            }
            setConstrained(h, true);
            ++constraintEdgeCount;
            path.push_back(end);
            cur = end;
            continue;
        }
        // Flip the crossed edges away (Sloan 1993): an edge whose quadrilateral is strictly
        // convex is flipped, and its new diagonal goes back to the queue while it still crosses
        // cur-end; a non-convex one waits at the back of the queue. This terminates with cur-end
        // an edge. (Re-triangulating the crossed region as two pseudo-polygons is not enough on
        // its own: a vertex beside the segment can have its whole star crossed.)
        queue_.clear();
        for (std::uint32_t e : trace_.crossed)
            queue_.push_back({origin(e), destination(e)});
        touched_.clear();
        for (std::size_t head = 0; head < queue_.size(); ++head) {
            const auto [u, w] = queue_[head];
            const std::uint32_t e = findEdge(u, w);
            assert(e != kNone);
            const PointId p = tv[e], q = tv[tn[e]];
            const std::int64_t su = orient(p, q, u), sw = orient(p, q, w);
            if (!((su > 0 && sw < 0) || (su < 0 && sw > 0))) {
                queue_.push_back({u, w});
                continue;
            }
            touched_.push_back(e / 3);
            touched_.push_back(tn[e] / 3);
            flip(e);
            const std::int64_t sp = orient(cur, end, p), sq = orient(cur, end, q);
            if ((sp > 0 && sq < 0) || (sp < 0 && sq > 0)) queue_.push_back({p, q});
            if (queue_.size() > 4096 && head > queue_.size() / 2) {
                queue_.erase(queue_.begin(), queue_.begin() + std::ptrdiff_t(head) + 1);
                head = std::size_t(-1);
            }
        }
        const std::uint32_t e = findEdge(cur, end);
        assert(e != kNone);
        setConstrained(e, true);
        ++constraintEdgeCount;
        legalizeTriangles(touched_);
        path.push_back(end);
        cur = end;
    }
    return true;
}

// --- Vertex removal --------------------------------------------------------------------------

bool Cdt::star(PointId v, std::vector<PointId>& link, std::vector<std::uint32_t>& triangles) const {
    link.clear();
    triangles.clear();
    const std::uint32_t t0 = vertexTriangle[v];
    assert(t0 != kNone);
    std::uint32_t t = t0;
    do {
        if (isGhost(t)) return false;
        std::uint32_t i = 0;
        while (tv[3 * t + i] != v)
            ++i;
        link.push_back(tv[3 * t + nextIndex(i)]);
        triangles.push_back(3 * t + i);
        t = tn[3 * t + nextIndex(i)] / 3;
    } while (t != t0);
    return true;
}

void Cdt::createPlanned(const std::vector<PointId>& ring) {
    created_.clear();
    for (std::size_t j = 0; j < plan_.size(); j += 3) {
        const std::uint32_t t =
            createTriangle(ring[plan_[j]], ring[plan_[j + 1]], ring[plan_[j + 2]]);
        created_.push_back(t);
    }
}

void Cdt::linkPlanned() {
    for (std::uint32_t q = 0; q < plan_.size(); ++q) {
        const std::uint32_t h = 3 * created_[q / 3] + q % 3;
        const std::uint32_t g = planNbr_[q];
        if (g != kNone) {
            if (g > q) link(h, 3 * created_[g / 3] + g % 3);
            continue;
        }
        const std::uint32_t u = plan_[q - q % 3 + nextIndex(q % 3)];
        link(h, outer_[u]);
        if (cons_[u]) tc[h / 3] |= std::uint8_t(1u << (h % 3));
    }
}

bool Cdt::straightHullStar(PointId v, std::vector<PointId>& link,
                           std::vector<std::uint32_t>& triangles) const {
    link.clear();
    triangles.clear();
    // Walk counter-clockwise round v from the ghost triangle (v, g, C) (the one after (v, A, g)).
    const std::uint32_t t0 = vertexTriangle[v];
    std::uint32_t t = t0, start = kNone;
    do {
        std::uint32_t i = 0;
        while (tv[3 * t + i] != v)
            ++i;
        if (tv[3 * t + nextIndex(i)] == kGhost) {
            start = t;
            break;
        }
        t = tn[3 * t + nextIndex(i)] / 3;
    } while (t != t0);
    if (start == kNone) return false;  // interior
    t = tn[3 * start + nextIndex([&] {
             std::uint32_t i = 0;
             while (tv[3 * start + i] != v)
                 ++i;
             return i;
         }())] /
        3;
    for (;;) {
        std::uint32_t i = 0;
        while (tv[3 * t + i] != v)
            ++i;
        const PointId next = tv[3 * t + nextIndex(i)];
        if (next == kGhost) return false;  // v on the hull twice cannot be; be safe
        link.push_back(next);
        if (tv[3 * t + prevIndex(i)] == kGhost) break;  // (v, A, g): A is the last
        triangles.push_back(3 * t + i);
        // No river edge at v (nor along the hull at v).
        if (isConstrained(3 * t + nextIndex(i)) || isConstrained(3 * t + prevIndex(i)))
            return false;
        t = tn[3 * t + nextIndex(i)] / 3;
    }
    // link = C, L1, ..., A; triangles = the real ones (v, link[k], link[k + 1]).
    if (link.size() < 2 || triangles.size() + 1 != link.size()) return false;
    const PointId c = link.front(), a = link.back();
    if (orient(a, v, c) != 0) return false;
    return betweenCollinear(gx[a], gy[a], gx[c], gy[c], gx[v], gy[v]) && a != c;
}

void Cdt::removeHullVertex(PointId v, const std::vector<PointId>& ring,
                           const std::vector<std::uint32_t>& triangles) {
    const std::uint32_t k = std::uint32_t(ring.size());  // polygon C, ..., A; edge k-1: A -> C
    const std::uint32_t m = k - 1;                        // real triangles
    assert(triangles.size() == m);
    outer_.resize(k);
    cons_.assign(k, 0);
    for (std::size_t i = 0; i < m; ++i) {
        outer_[i] = tn[triangles[i]];
        cons_[i] = isConstrained(triangles[i]) ? 1 : 0;
    }
    // The ghost triangles (v, A, g) and (v, g, C), and the ghost half-edges beyond them.
    const std::uint32_t hA = triangles[m - 1], tA = hA / 3;  // (v, L, A)
    const std::uint32_t gA = tn[tA * 3 + nextIndex(hA % 3)] / 3;  // across A -> v: (v, A, g)
    const std::uint32_t hC = triangles[0], tC = hC / 3;              // (v, C, L1)
    const std::uint32_t gC = tn[tC * 3 + prevIndex(hC % 3)] / 3;  // across v -> C: (C, v, g)
    auto edgeOf = [&](std::uint32_t t, PointId from, PointId to) {
        for (std::uint32_t e = 0; e < 3; ++e) {
            if (tv[3 * t + nextIndex(e)] == from && tv[3 * t + prevIndex(e)] == to) return 3 * t + e;
        }
        assert(false);
        return kNone;
    };
    const PointId a = ring[m], c = ring[0];
    const std::uint32_t beyondA = tn[edgeOf(gA, a, kGhost)];  // twin of A -> g
    const std::uint32_t beyondC = tn[edgeOf(gC, kGhost, c)];  // twin of g -> C
    planHole(ring, plan_);
    // Ghosts first, then the real triangles in star order: the plan's triangles take the real
    // triangles' slots back last-in first-out, as for an interior vertex (deletion.cpp relies on
    // it to evaluate the plan in the deletion's order).
    destroyTriangle(gA);
    destroyTriangle(gC);
    for (std::uint32_t h : triangles)
        destroyTriangle(h / 3);
    setVertexTriangle(v, kNone);
    --vertexCount;
    createPlanned(ring);
    const std::uint32_t ghost = createTriangle(c, a, kGhost);
    link(edgeOf(ghost, a, kGhost), beyondA);
    link(edgeOf(ghost, kGhost, c), beyondC);
    outer_[m] = edgeOf(ghost, c, a);
    linkPlanned();
}

void Cdt::removeVertex(PointId v) {
    const bool interior = star(v, poly_, starTris_);
    assert(interior);
    (void)interior;
    removeVertex(v, poly_, starTris_);
}

void Cdt::replaceStar(PointId v, const std::vector<PointId>& ring,
                      const std::vector<std::uint32_t>& triangles) {
    for (std::uint32_t h : triangles)
        destroyTriangle(h / 3);
    setVertexTriangle(v, kNone);
    --vertexCount;
    createPlanned(ring);
    linkPlanned();
}

void Cdt::removeVertex(PointId v, const std::vector<PointId>& ring,
                       const std::vector<std::uint32_t>& triangles) {
    assert(ring.size() == triangles.size());
    const bool riverAtV = takeHole(triangles);
    planHole(ring, plan_);
    replaceStar(v, ring, triangles);
    // A river edge at v is gone with it: a link vertex it hid may now be visible from a
    // triangle beyond the hole and inside its circumcircle, so those edges are checked too.
    if (!riverAtV) return;
    legalizeTriangles(created_);
}

void Cdt::removeVertexWithDiagonal(PointId v, const std::vector<PointId>& ring,
                                   const std::vector<std::uint32_t>& triangles, std::uint32_t ia,
                                   std::uint32_t ic) {
    const std::uint32_t k = std::uint32_t(ring.size());
    assert(ia < k && ic < k && ia != ic);
    const bool riverAtV = takeHole(triangles);
    // Sides: ring[ia .. ic] and ring[ic .. ia] (cyclic), each closed by the new edge.
    const std::uint32_t n1 = (ic + k - ia) % k + 1, n2 = (ia + k - ic) % k + 1;
    std::uint32_t chord[2] = {kNone, kNone};
    if (n1 < 3 || n2 < 3) {
        // The diagonal is a link edge already (ring[ia] -> ring[ic] or back): one polygon.
        planHole(ring, plan_);
    } else {
        // Both plans in ring indices, one after the other; the closing edge of each side (from
        // its last vertex to its first) is linked to the other's.
        std::vector<PointId>& side = splitSide_;
        std::vector<std::uint32_t>& sub = splitPlan_;
        plan_.clear();
        splitNbr_.clear();
        for (int s = 0; s < 2; ++s) {
            const std::uint32_t first = s == 0 ? ia : ic, count = s == 0 ? n1 : n2;
            side.resize(count);
            for (std::uint32_t j = 0; j < count; ++j)
                side[j] = ring[(first + j) % k];
            planHole(side, sub);
            const std::uint32_t offset = std::uint32_t(plan_.size());
            for (std::uint32_t q = 0; q < sub.size(); ++q) {
                plan_.push_back((first + sub[q]) % k);
                const std::uint32_t g = planNbr_[q];
                splitNbr_.push_back(g == kNone ? kNone : g + offset);
                // The half-edge opposite corner q % 3 runs from the next corner to the one after.
                const std::uint32_t from = sub[q - q % 3 + nextIndex(q % 3)];
                const std::uint32_t to = sub[q - q % 3 + prevIndex(q % 3)];
                if (g == kNone && from == count - 1 && to == 0) chord[s] = offset + q;
            }
        }
        assert(chord[0] != kNone && chord[1] != kNone);
        splitNbr_[chord[0]] = chord[1];
        splitNbr_[chord[1]] = chord[0];
        planNbr_.swap(splitNbr_);
    }
    replaceStar(v, ring, triangles);
    // The new edge, constrained before the flips below, which may not cross it.
    const std::uint32_t e = chord[0] != kNone ? 3 * created_[chord[0] / 3] + chord[0] % 3
                            : n2 < 3          ? tn[outer_[ic]]  // ring[ic] -> ring[ia]
                                              : tn[outer_[ia]];          // ring[ia] -> ring[ic]
    assert((origin(e) == ring[ic] && destination(e) == ring[ia]) ||
           (origin(e) == ring[ia] && destination(e) == ring[ic]));
    setConstrained(e, true);
    ++constraintEdgeCount;
    if (riverAtV) {
        // As removeVertex: a constraint at v no longer hides the link from beyond the hole.
        legalizeTriangles(created_);
    }
}

// --- Point insertion (Bowyer-Watson) ---------------------------------------------------------

std::uint32_t Cdt::locateGridFrom(std::int64_t x, std::int64_t y, std::uint32_t start) const {
    std::uint32_t t = start;
    std::uint32_t rot = 0;
    for (;;) {
        if (isGhost(t)) return t;
        bool inside = true;
        for (std::uint32_t k = 0; k < 3; ++k) {
            const std::uint32_t e = (k + rot) % 3;
            const PointId u = tv[3 * t + nextIndex(e)], w = tv[3 * t + prevIndex(e)];
            if (orient2d(gx[u], gy[u], gx[w], gy[w], x, y) < 0) {
                t = tn[3 * t + e] / 3;
                inside = false;
                break;
            }
        }
        if (inside) return t;
        rot = rot == 2 ? 0 : rot + 1;
    }
}

Cdt::SplitEdge Cdt::insertPoint(PointId p, std::uint32_t hint) {
    const std::uint32_t start =
        hint != kNone && triangleAlive(hint) ? locateFrom(p, hint) : locate(p);
    // On a constraint edge of the (closed) triangle holding p: the edge stops being one while
    // the cavity crosses it, its two halves become constraints after.
    SplitEdge split;
    if (!isGhost(start)) {
        for (std::uint32_t i = 0; i < 3; ++i) {
            const std::uint32_t h = 3 * start + i;
            if (isConstrained(h) && orient(origin(h), destination(h), p) == 0) {
                split = {origin(h), destination(h)};
                setConstrained(h, false);
                break;
            }
        }
    }
    auto inCircle = [&](std::uint32_t t) {
        const PointId* v = &tv[3 * t];
        if (v[0] == kGhost || v[1] == kGhost || v[2] == kGhost) {
            std::uint32_t g = 0;
            while (v[g] != kGhost)
                ++g;
            const PointId u = v[nextIndex(g)], w = v[prevIndex(g)];
            const std::int64_t o = orient(u, w, p);
            if (o != 0) return o > 0;
            // On the hull line: inside the open segment u-w only.
            const std::int64_t dot = (gx[p] - gx[u]) * std::int64_t(gx[w] - gx[u]) +
                                     (gy[p] - gy[u]) * std::int64_t(gy[w] - gy[u]);
            const std::int64_t len = std::int64_t(gx[w] - gx[u]) * (gx[w] - gx[u]) +
                                     std::int64_t(gy[w] - gy[u]) * (gy[w] - gy[u]);
            return dot > 0 && dot < len;
        }
        return incirclePerturbed(gx[v[0]], gy[v[0]], gx[v[1]], gy[v[1]], gx[v[2]], gy[v[2]], gx[p],
                                 gy[p]) > 0;
    };
    if (mark_.size() < triangleSlots()) mark_.resize(triangleSlots() + triangleSlots() / 2, 0);
    ++markStamp_;
    cavity_.clear();
    cavity_.push_back(start);
    mark_[start] = markStamp_;
    boundary_.clear();
    for (std::size_t k = 0; k < cavity_.size(); ++k) {
        const std::uint32_t t = cavity_[k];
        for (std::uint32_t i = 0; i < 3; ++i) {
            const std::uint32_t n = tn[3 * t + i] / 3;
            // Constrained Delaunay: the cavity is what p sees, so a constraint edge is never
            // inside it (both of its triangles reached around an end of it).
            assert(!(mark_[n] == markStamp_ && isConstrained(3 * t + i)));
            if (mark_[n] == markStamp_) continue;
            if (!isConstrained(3 * t + i) && inCircle(n)) {
                mark_[n] = markStamp_;
                cavity_.push_back(n);
            } else {
                boundary_.push_back(3 * t + i);
            }
        }
    }
    // Boundary edges (u, w) with their outer half-edges, saved before the cavity dies.
    std::vector<FanEdge>& edges = fan_;
    edges.clear();
    for (std::uint32_t h : boundary_) {
        edges.push_back({origin(h), destination(h), tn[h], isConstrained(h), kNone});
    }
    for (std::uint32_t t : cavity_)
        destroyTriangle(t);
    for (FanEdge& e : edges) {
        e.t = createTriangle(e.u, e.w, p);
        link(3 * e.t + 2, e.outer);
        if (e.cons) tc[e.t] |= 4;
    }
    std::sort(edges.begin(), edges.end(),
              [](const FanEdge& x, const FanEdge& y) { return x.u < y.u; });
    for (const FanEdge& e : edges) {
        auto it = std::lower_bound(edges.begin(), edges.end(), e.w,
                                   [](const FanEdge& x, PointId key) { return x.u < key; });
        assert(it != edges.end() && it->u == e.w);
        link(3 * e.t, 3 * it->t + 1);
    }
    ++vertexCount;
    if (split.u != kNone) {
        setConstrained(findEdge(split.u, p), true);
        setConstrained(findEdge(p, split.w), true);
        ++constraintEdgeCount;
    }
    return split;
}

// --- Construction ----------------------------------------------------------------------------

namespace {

// buildCdt's first stage: the grid frame, every point quantised, points on the same grid point
// merged (the lowest id wins). `vertices` receives the representatives sorted by (gx, gy).
bool quantisePoints(const PointSet& set, const CdtOptions& options, Cdt& cdt,
                    std::vector<PointId>& vertices, std::string& error) {
    cdt = Cdt();
    const std::size_t n = set.points.size();
    if (n >= Cdt::kGhost) {
        error = "too many points in one block: " + std::to_string(n);
        return false;
    }
    if (!(options.gridUnit > 0)) {
        error = "grid unit must be positive";
        return false;
    }
    double minX = INFINITY, minY = INFINITY, maxX = -INFINITY, maxY = -INFINITY;
    for (std::size_t i = 0; i < n; ++i) {
        const Point& p = set.points[i];
        if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) {
            error = "point " + std::to_string(i) + " has a non-finite coordinate";
            return false;
        }
        minX = std::min(minX, p.x), maxX = std::max(maxX, p.x);
        minY = std::min(minY, p.y), maxY = std::max(maxY, p.y);
    }
    // Positions are rounded to the grid in absolute coordinates and the origin is a grid point
    // (the one nearest the bounding box centre): a point gets the same grid position, up to one
    // integer translation, in every block and tree node that holds it, so the exact predicates
    // (and incirclePerturbed's tie breaks) decide alike everywhere (nodebuild.h).
    cdt.gridUnit = options.gridUnit;
    const double ox = n ? std::round(0.5 * (minX + maxX) / cdt.gridUnit) : 0.0;
    const double oy = n ? std::round(0.5 * (minY + maxY) / cdt.gridUnit) : 0.0;
    cdt.originX = ox * cdt.gridUnit;
    cdt.originY = oy * cdt.gridUnit;
    cdt.gx.resize(n);
    cdt.gy.resize(n);
    const double limit = double(kMaxGridCoordinate);
    for (std::size_t i = 0; i < n; ++i) {
        const double fx = std::round(set.points[i].x / cdt.gridUnit) - ox;
        const double fy = std::round(set.points[i].y / cdt.gridUnit) - oy;
        if (std::fabs(fx) > limit || std::fabs(fy) > limit) {
            error = "block too large for the exact grid: point " + std::to_string(i) +
                    " lies more than 2^28-1 grid units (" + std::to_string(limit * cdt.gridUnit) +
                    " m) from the block centre";
            return false;
        }
        cdt.gx[i] = static_cast<std::int32_t>(fx);
        cdt.gy[i] = static_cast<std::int32_t>(fy);
    }
    // Merge points on the same grid point: the lowest id wins.
    std::vector<PointId> ids(n);
    std::iota(ids.begin(), ids.end(), PointId{0});
    std::sort(ids.begin(), ids.end(), [&](PointId a, PointId b) {
        if (cdt.gx[a] != cdt.gx[b]) return cdt.gx[a] < cdt.gx[b];
        if (cdt.gy[a] != cdt.gy[b]) return cdt.gy[a] < cdt.gy[b];
        return a < b;
    });
    cdt.representative.assign(n, 0);
    cdt.locked.assign(n, 0);
    vertices.clear();
    vertices.reserve(n);
    for (std::size_t k = 0; k < n; ++k) {
        const PointId id = ids[k];
        if (k > 0 && cdt.gx[id] == cdt.gx[ids[k - 1]] && cdt.gy[id] == cdt.gy[ids[k - 1]]) {
            cdt.representative[id] = cdt.representative[ids[k - 1]];
            ++cdt.mergedPoints;
        } else {
            cdt.representative[id] = id;
            vertices.push_back(id);
        }
        if (set.points[id].locked) cdt.locked[cdt.representative[id]] = 1;
    }
    ids = std::vector<PointId>();
    if (vertices.size() < 3) {
        error = "fewer than 3 distinct points in the block";
        return false;
    }
    return true;
}

// buildCdt's second stage: the Delaunay triangulation of `vertices` (Bowyer-Watson, Hilbert
// order). `n` = the number of point ids.
bool triangulateVertices(Cdt& cdt, std::size_t n, std::vector<PointId>& vertices,
                         std::string& error) {
    // Insertion order: Hilbert curve over the bounding box, ties by id.
    {
        std::int64_t lo = kMaxGridCoordinate, hi = -kMaxGridCoordinate;
        for (PointId v : vertices) {
            lo = std::min<std::int64_t>({lo, cdt.gx[v], cdt.gy[v]});
            hi = std::max<std::int64_t>({hi, cdt.gx[v], cdt.gy[v]});
        }
        const double scale = hi > lo ? 65535.0 / double(hi - lo) : 0.0;
        std::vector<std::pair<std::uint64_t, PointId>> keys(vertices.size());
        for (std::size_t k = 0; k < vertices.size(); ++k) {
            const PointId v = vertices[k];
            const auto hx = static_cast<std::uint32_t>(double(cdt.gx[v] - lo) * scale);
            const auto hy = static_cast<std::uint32_t>(double(cdt.gy[v] - lo) * scale);
            keys[k] = {hilbertIndex(hx, hy), v};
        }
        std::sort(keys.begin(), keys.end());
        for (std::size_t k = 0; k < keys.size(); ++k)
            vertices[k] = keys[k].second;
    }
    // First triangle: the first two points and the first point not collinear with them.
    const PointId a = vertices[0];
    PointId b = vertices[1];
    std::size_t third = 2;
    while (third < vertices.size() && cdt.orient(a, b, vertices[third]) == 0)
        ++third;
    if (third == vertices.size()) {
        error = "all points of the block are collinear";
        return false;
    }
    PointId c = vertices[third];
    if (cdt.orient(a, b, c) < 0) std::swap(b, c);
    cdt.vertexTriangle.assign(n, Cdt::kNone);
    cdt.tv.reserve(3 * (2 * vertices.size() + 8));
    cdt.tn.reserve(3 * (2 * vertices.size() + 8));
    cdt.tc.reserve(2 * vertices.size() + 8);
    cdt.stamp.reserve(2 * vertices.size() + 8);
    {
        const PointId g = Cdt::kGhost;
        const std::uint32_t r = cdt.createTriangle(a, b, c);
        const std::uint32_t gab = cdt.createTriangle(b, a, g);
        const std::uint32_t gbc = cdt.createTriangle(c, b, g);
        const std::uint32_t gca = cdt.createTriangle(a, c, g);
        cdt.link(3 * r + 2, 3 * gab + 2);
        cdt.link(3 * r + 0, 3 * gbc + 2);
        cdt.link(3 * r + 1, 3 * gca + 2);
        cdt.link(3 * gab + 0, 3 * gca + 1);
        cdt.link(3 * gab + 1, 3 * gbc + 0);
        cdt.link(3 * gbc + 1, 3 * gca + 0);
        cdt.vertexCount = 3;
    }
    for (std::size_t k = 1; k < vertices.size(); ++k) {
        if (k == 1 || k == third) continue;
        cdt.insertPoint(vertices[k]);
    }
    return true;
}

}  // namespace

bool buildCdt(const PointSet& set, const CdtOptions& options, Cdt& cdt, std::string& error) {
    std::vector<PointId> vertices;
    if (!quantisePoints(set, options, cdt, vertices, error)) return false;
    const std::size_t n = set.points.size();
    const bool domain = !set.boundaries.empty();
    if (domain) {
        // The frame: a square around every point, twice the points' half extent (at least 1 m
        // of grid units beyond them), inside the exact grid.
        std::int64_t half = 0;
        for (PointId v : vertices)
            half = std::max<std::int64_t>({half, std::abs(std::int64_t(cdt.gx[v])),
                                           std::abs(std::int64_t(cdt.gy[v]))});
        const std::int64_t f = std::min<std::int64_t>(kMaxGridCoordinate, 2 * half + 1000);
        if (f <= half) {
            error = "block too large for the exact grid with a domain frame";
            return false;
        }
        cdt.frameFirst = PointId(n);
        const std::int32_t fx[4] = {-std::int32_t(f), std::int32_t(f), std::int32_t(f),
                                    -std::int32_t(f)};
        const std::int32_t fy[4] = {-std::int32_t(f), -std::int32_t(f), std::int32_t(f),
                                    std::int32_t(f)};
        for (int k = 0; k < 4; ++k) {
            const PointId id = PointId(n + std::size_t(k));
            cdt.gx.push_back(fx[k]);
            cdt.gy.push_back(fy[k]);
            cdt.representative.push_back(id);
            cdt.locked.push_back(1);
            vertices.push_back(id);
        }
    }
    if (!triangulateVertices(cdt, cdt.gx.size(), vertices, error)) return false;
    std::vector<PointId> path;
    // Boundary rings first: their edges are constraints with a direction.
    for (std::size_t r = 0; r < set.boundaries.size(); ++r) {
        const Polyline& ring = set.boundaries[r];
        Polyline corners;
        for (std::size_t s = 0; s < ring.size(); ++s) {
            if (ring[s] >= n) {
                error = "boundary ring " + std::to_string(r) + " vertex " + std::to_string(s) +
                        ": point id " + std::to_string(ring[s]) + " out of range";
                return false;
            }
            const PointId v = cdt.representative[ring[s]];
            if (corners.empty() || corners.back() != v) corners.push_back(v);
        }
        while (corners.size() > 1 && corners.back() == corners.front())
            corners.pop_back();
        if (corners.size() < 3) {
            error = "boundary ring " + std::to_string(r) + " has fewer than 3 distinct vertices";
            return false;
        }
        Polyline out;
        for (std::size_t s = 0; s < corners.size(); ++s) {
            const PointId u = corners[s], w = corners[(s + 1) % corners.size()];
            std::string why;
            if (!cdt.insertSegment(u, w, path, why)) {
                error = "boundary ring " + std::to_string(r) + " edge " + std::to_string(s) +
                        ": " + why;
                return false;
            }
            for (std::size_t k = 0; k + 1 < path.size(); ++k) {
                cdt.boundary.insert(Cdt::edgeKey(path[k], path[k + 1]));
                out.push_back(path[k]);
            }
        }
        cdt.boundaryRings.push_back(std::move(out));
    }
    // River constraints.
    for (std::size_t r = 0; r < set.rivers.size(); ++r) {
        const Polyline& line = set.rivers[r];
        Polyline out;
        for (std::size_t s = 0; s < line.size(); ++s) {
            if (line[s] >= n) {
                error = "river " + std::to_string(r) + " vertex " + std::to_string(s) +
                        ": point id " + std::to_string(line[s]) + " out of range";
                return false;
            }
            const PointId v = cdt.representative[line[s]];
            if (!out.empty() && out.back() == v) continue;
            if (out.empty()) {
                out.push_back(v);
                continue;
            }
            std::string why;
            if (!cdt.insertSegment(out.back(), v, path, why, true)) {
                error =
                    "river " + std::to_string(r) + " segment " + std::to_string(s - 1) + ": " + why;
                return false;
            }
            out.insert(out.end(), path.begin() + 1, path.end());
        }
        if (out.size() >= 2) cdt.rivers.push_back(std::move(out));
    }
    if (domain) {
        std::vector<std::uint32_t> all;
        for (std::uint32_t t = 0; t < cdt.triangleSlots(); ++t)
            if (cdt.triangleAlive(t)) all.push_back(t);
        cdt.assignSides(all);
    }
    return true;
}

bool buildHullCdt(const PointSet& set, const CdtOptions& options, Cdt& cdt, std::string& error) {
    std::vector<PointId> vertices;
    if (!quantisePoints(set, options, cdt, vertices, error)) return false;
    // Andrew's monotone chain on the exact grid over the (gx, gy)-sorted representatives;
    // collinear points are popped (orient <= 0), so only the corners remain.
    std::vector<PointId> hull(2 * vertices.size());
    std::size_t k = 0;
    for (std::size_t i = 0; i < vertices.size(); ++i) {
        while (k >= 2 && cdt.orient(hull[k - 2], hull[k - 1], vertices[i]) <= 0)
            --k;
        hull[k++] = vertices[i];
    }
    for (std::size_t i = vertices.size() - 1, lower = k + 1; i-- > 0;) {
        while (k >= lower && cdt.orient(hull[k - 2], hull[k - 1], vertices[i]) <= 0)
            --k;
        hull[k++] = vertices[i];
    }
    hull.resize(k - 1);  // the last point repeats the first
    if (hull.size() < 3) {
        error = "all points of the block are collinear";
        return false;
    }
    return triangulateVertices(cdt, set.points.size(), hull, error);
}

std::vector<TriangleTriple> collectTriangles(const Cdt& cdt) {
    std::vector<TriangleTriple> out;
    out.reserve(cdt.realTriangleCount);
    for (std::uint32_t t = 0; t < cdt.triangleSlots(); ++t) {
        if (!cdt.inDomain(t)) continue;
        out.push_back(canonicalTriangle(cdt.tv[3 * t], cdt.tv[3 * t + 1], cdt.tv[3 * t + 2]));
    }
    std::sort(out.begin(), out.end());
    return out;
}

std::vector<RiverEdge> collectRiverEdges(const Cdt& cdt) {
    std::vector<RiverEdge> out;
    for (std::uint32_t h = 0; h < cdt.tv.size(); ++h) {
        if (!cdt.triangleAlive(h / 3) || !cdt.isConstrained(h)) continue;
        const PointId u = cdt.origin(h), w = cdt.destination(h);
        if (u < w && (!cdt.isBoundaryEdge(u, w) || cdt.isRiverOnBoundary(u, w)))
            out.push_back({u, w});
    }
    std::sort(out.begin(), out.end());
    return out;
}

}  // namespace unilod
