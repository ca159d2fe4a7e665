// Invariant checker (paper §3.3; see checker.h for the list). Deliberately independent of the
// mesh operations in cdt.cpp: it recomputes everything from the raw arrays.
#include "checker.h"

#include <algorithm>
#include <map>
#include <numeric>

namespace unilod {

namespace {

std::string edgeName(PointId a, PointId b) {
    return std::to_string(a) + "-" + std::to_string(b);
}

std::string int128ToString(Int128 v) {
    if (v == 0) return "0";
    const bool neg = v < 0;
    if (neg) v = -v;
    std::string s;
    while (v > 0) {
        s.push_back(char('0' + int(v % 10)));
        v /= 10;
    }
    if (neg) s.push_back('-');
    std::reverse(s.begin(), s.end());
    return s;
}

Int128 doubleHullAreaOf(const Cdt& cdt) {
    std::vector<PointId> v;
    for (PointId i = 0; i < cdt.vertexTriangle.size(); ++i) {
        if (cdt.isVertex(i)) v.push_back(i);
    }
    std::sort(v.begin(), v.end(), [&](PointId a, PointId b) {
        return cdt.gx[a] != cdt.gx[b] ? cdt.gx[a] < cdt.gx[b] : cdt.gy[a] < cdt.gy[b];
    });
    if (v.size() < 3) return 0;
    std::vector<PointId> hull(2 * v.size());
    std::size_t k = 0;
    for (std::size_t i = 0; i < v.size(); ++i) {  // Andrew's monotone chain
        while (k >= 2 && cdt.orient(hull[k - 2], hull[k - 1], v[i]) <= 0)
            --k;
        hull[k++] = v[i];
    }
    for (std::size_t i = v.size() - 1, lower = k + 1; i-- > 0;) {
        while (k >= lower && cdt.orient(hull[k - 2], hull[k - 1], v[i]) <= 0)
            --k;
        hull[k++] = v[i];
    }
    Int128 area = 0;
    for (std::size_t i = 0; i + 1 < k; ++i) {
        const PointId a = hull[i], b = hull[i + 1];
        area += Int128(cdt.gx[a]) * cdt.gy[b] - Int128(cdt.gx[b]) * cdt.gy[a];
    }
    return area;
}

// Builds the adjacency of a river edge list (CSR) over vertex ids.
struct RiverGraph {
    std::vector<std::uint32_t> start;
    std::vector<PointId> next;
    void build(std::size_t n, const std::vector<RiverEdge>& edges) {
        start.assign(n + 1, 0);
        for (const RiverEdge& e : edges)
            ++start[e.a + 1], ++start[e.b + 1];
        for (std::size_t i = 0; i < n; ++i)
            start[i + 1] += start[i];
        next.resize(2 * edges.size());
        std::vector<std::uint32_t> fill(start.begin(), start.end() - 1);
        for (const RiverEdge& e : edges)
            next[fill[e.a]++] = e.b, next[fill[e.b]++] = e.a;
    }
    std::uint32_t degree(PointId v) const { return start[v + 1] - start[v]; }
};

// Chains of the river graph from junction to junction, then closed loops.
std::vector<std::vector<PointId>> chainsOf(const RiverGraph& g, std::size_t n,
                                           const std::vector<RiverEdge>& edges) {
    std::vector<std::vector<PointId>> chains;
    std::vector<std::uint8_t> used(g.next.size(), 0);  // per CSR slot
    auto slotOf = [&](PointId a, PointId b) {
        for (std::uint32_t s = g.start[a]; s < g.start[a + 1]; ++s) {
            if (g.next[s] == b) return s;
        }
        return std::uint32_t(0xFFFFFFFFu);
    };
    auto walk = [&](PointId first, std::uint32_t slot, bool stopAtFirst) {
        std::vector<PointId> chain{first};
        PointId prev = first, cur = g.next[slot];
        used[slot] = 1;
        used[slotOf(cur, prev)] = 1;
        for (;;) {
            chain.push_back(cur);
            if (g.degree(cur) != 2 || (stopAtFirst && cur == first)) break;
            const std::uint32_t s0 = g.start[cur];
            const std::uint32_t s = used[s0] ? s0 + 1 : s0;
            if (used[s]) break;
            used[s] = 1;
            used[slotOf(g.next[s], cur)] = 1;
            prev = cur;
            cur = g.next[s];
        }
        return chain;
    };
    for (PointId v = 0; v < n; ++v) {
        const std::uint32_t d = g.degree(v);
        if (d == 0 || d == 2) continue;
        for (std::uint32_t s = g.start[v]; s < g.start[v + 1]; ++s) {
            if (!used[s]) chains.push_back(walk(v, s, false));
        }
    }
    for (const RiverEdge& e : edges) {
        const std::uint32_t s = slotOf(e.a, e.b);
        if (!used[s]) chains.push_back(walk(e.a, s, true));
    }
    return chains;
}

bool segmentsConflict(const Cdt& cdt, const RiverEdge& e, const RiverEdge& f) {
    const PointId p = e.a, q = e.b, r = f.a, s = f.b;
    auto onSegment = [&](PointId a, PointId b, PointId x) {
        return betweenCollinear(cdt.gx[a], cdt.gy[a], cdt.gx[b], cdt.gy[b], cdt.gx[x], cdt.gy[x]);
    };
    const std::int64_t o1 = cdt.orient(p, q, r), o2 = cdt.orient(p, q, s);
    const std::int64_t o3 = cdt.orient(r, s, p), o4 = cdt.orient(r, s, q);
    // Sharing an endpoint: a conflict only when the two edges overlap along a line.
    PointId shared = Cdt::kNone, x = 0, y = 0;
    if (p == r) shared = p, x = q, y = s;
    if (p == s) shared = p, x = q, y = r;
    if (q == r) shared = q, x = p, y = s;
    if (q == s) shared = q, x = p, y = r;
    if (shared != Cdt::kNone) {
        if (cdt.orient(shared, x, y) != 0) return false;
        const std::int64_t dot =
            std::int64_t(cdt.gx[x] - cdt.gx[shared]) * (cdt.gx[y] - cdt.gx[shared]) +
            std::int64_t(cdt.gy[x] - cdt.gy[shared]) * (cdt.gy[y] - cdt.gy[shared]);
        return dot > 0;
    }
    if (((o1 > 0 && o2 < 0) || (o1 < 0 && o2 > 0)) && ((o3 > 0 && o4 < 0) || (o3 < 0 && o4 > 0)))
        return true;
    if (o1 == 0 && onSegment(p, q, r)) return true;
    if (o2 == 0 && onSegment(p, q, s)) return true;
    if (o3 == 0 && onSegment(r, s, p)) return true;
    if (o4 == 0 && onSegment(r, s, q)) return true;
    return false;
}

}  // namespace

RiverReference captureRiverReference(const Cdt& cdt, const std::vector<RiverEdge>& edges) {
    RiverReference ref;
    const std::size_t n = cdt.vertexTriangle.size();
    RiverGraph g;
    g.build(n, edges);
    for (PointId v = 0; v < n; ++v) {
        if (g.degree(v) != 0 && g.degree(v) != 2) ref.junctions.push_back(v);
    }
    ref.chains = chainsOf(g, n, edges);
    return ref;
}

CheckReference captureCheckReference(const Cdt& cdt) {
    CheckReference ref;
    ref.rivers = captureRiverReference(cdt, collectRiverEdges(cdt));
    for (PointId v = 0; v < cdt.locked.size(); ++v) {
        if (cdt.locked[v] && cdt.isVertex(v)) ref.lockedVertices.push_back(v);
    }
    ref.doubleHullArea = doubleHullAreaOf(cdt);
    return ref;
}

bool checkCdt(const Cdt& cdt, const CheckReference& ref, const std::vector<RiverEdge>* riverEdges,
              std::string& message) {
    const std::size_t n = cdt.vertexTriangle.size();
    auto fail = [&](std::string m) {
        message = std::move(m);
        return false;
    };
    auto triName = [&](std::uint32_t t) {
        auto name = [&](PointId v) {
            return v == Cdt::kGhost ? std::string("inf") : std::to_string(v);
        };
        return "triangle " + std::to_string(t) + " (" + name(cdt.tv[3 * t]) + ", " +
               name(cdt.tv[3 * t + 1]) + ", " + name(cdt.tv[3 * t + 2]) + ")";
    };
    // 1. Triangles and adjacency.
    std::uint32_t alive = 0, real = 0;
    Int128 area = 0;
    for (std::uint32_t t = 0; t < cdt.triangleSlots(); ++t) {
        if (!cdt.triangleAlive(t)) continue;
        ++alive;
        const PointId* v = &cdt.tv[3 * t];
        int ghosts = 0;
        for (int i = 0; i < 3; ++i) {
            if (v[i] == Cdt::kGhost) {
                ++ghosts;
            } else if (v[i] >= n || !cdt.isVertex(v[i])) {
                return fail(triName(t) + " uses " + std::to_string(v[i]) +
                            ", which is not a vertex");
            }
        }
        if (ghosts > 1 || v[0] == v[1] || v[1] == v[2] || v[0] == v[2]) {
            return fail(triName(t) + " repeats a vertex");
        }
        for (std::uint32_t i = 0; i < 3; ++i) {
            const std::uint32_t h = 3 * t + i, g = cdt.tn[h];
            if (g == Cdt::kNone || g / 3 >= cdt.triangleSlots() || !cdt.triangleAlive(g / 3)) {
                return fail(triName(t) + " edge " + std::to_string(i) + " has no live neighbour");
            }
            if (cdt.tn[g] != h || cdt.origin(g) != cdt.destination(h) ||
                cdt.destination(g) != cdt.origin(h)) {
                return fail(triName(t) + " edge " + std::to_string(i) +
                            ": inconsistent adjacency with " + triName(g / 3));
            }
            if (cdt.isConstrained(g) != cdt.isConstrained(h)) {
                return fail(triName(t) + " edge " + std::to_string(i) +
                            ": constraint flag differs between the two sides");
            }
        }
        if (ghosts == 0) {
            ++real;
            const std::int64_t o = cdt.orient(v[0], v[1], v[2]);
            if (o <= 0) {
                return fail(triName(t) + " is not counter-clockwise (twice its area is " +
                            std::to_string(o) + ")");
            }
            area += o;
        }
    }
    if (real != cdt.realTriangleCount) {
        return fail("realTriangleCount is " + std::to_string(cdt.realTriangleCount) + " but " +
                    std::to_string(real) + " real triangles are alive");
    }
    // 1b. Vertices.
    std::uint32_t vertices = 0;
    for (PointId v = 0; v < n; ++v) {
        const std::uint32_t t = cdt.vertexTriangle[v];
        if (t == Cdt::kNone) continue;
        ++vertices;
        if (t >= cdt.triangleSlots() || !cdt.triangleAlive(t) ||
            (cdt.tv[3 * t] != v && cdt.tv[3 * t + 1] != v && cdt.tv[3 * t + 2] != v)) {
            return fail("vertex " + std::to_string(v) + " points to a triangle without it");
        }
    }
    if (vertices != cdt.vertexCount) {
        return fail("vertexCount is " + std::to_string(cdt.vertexCount) + " but " +
                    std::to_string(vertices) + " vertices are alive");
    }
    // Closed surface of V + 1 vertices (with infinity), F faces, 3F/2 edges: V + 1 - F/2 = 2.
    if (std::int64_t(vertices) + 1 - std::int64_t(alive) / 2 != 2 || alive % 2 != 0) {
        return fail("Euler characteristic is wrong: " + std::to_string(vertices) +
                    " vertices and " + std::to_string(alive) + " triangles with ghosts");
    }
    if (area != ref.doubleHullArea) {
        return fail("triangle areas sum to " + int128ToString(area) + "/2 but the domain has " +
                    int128ToString(ref.doubleHullArea) + "/2 (gap or overlap)");
    }
    // 2. Locked points.
    for (PointId v : ref.lockedVertices) {
        if (!cdt.isVertex(v)) return fail("locked point " + std::to_string(v) + " was deleted");
    }
    // 3. River edges.
    std::vector<RiverEdge> fromMesh;
    if (riverEdges == nullptr) {
        fromMesh = collectRiverEdges(cdt);
        riverEdges = &fromMesh;
    }
    const std::vector<RiverEdge>& edges = *riverEdges;
    for (const RiverEdge& e : edges) {
        if (e.a >= n || e.b >= n || !cdt.isVertex(e.a) || !cdt.isVertex(e.b) || e.a == e.b) {
            return fail("river edge " + edgeName(e.a, e.b) +
                        " has an endpoint that is not a vertex");
        }
    }
    {
        std::vector<std::uint32_t> order(edges.size());
        std::iota(order.begin(), order.end(), 0u);
        auto minX = [&](const RiverEdge& e) { return std::min(cdt.gx[e.a], cdt.gx[e.b]); };
        auto maxX = [&](const RiverEdge& e) { return std::max(cdt.gx[e.a], cdt.gx[e.b]); };
        std::sort(order.begin(), order.end(), [&](std::uint32_t a, std::uint32_t b) {
            return minX(edges[a]) < minX(edges[b]);
        });
        for (std::size_t i = 0; i < order.size(); ++i) {
            const RiverEdge& e = edges[order[i]];
            const std::int32_t ylo = std::min(cdt.gy[e.a], cdt.gy[e.b]);
            const std::int32_t yhi = std::max(cdt.gy[e.a], cdt.gy[e.b]);
            for (std::size_t j = i + 1; j < order.size() && minX(edges[order[j]]) <= maxX(e); ++j) {
                const RiverEdge& f = edges[order[j]];
                if (std::max(cdt.gy[f.a], cdt.gy[f.b]) < ylo ||
                    std::min(cdt.gy[f.a], cdt.gy[f.b]) > yhi)
                    continue;
                if (e == f) return fail("river edge " + edgeName(e.a, e.b) + " is listed twice");
                if (segmentsConflict(cdt, e, f)) {
                    return fail("river edges " + edgeName(e.a, e.b) + " and " + edgeName(f.a, f.b) +
                                " cross");
                }
            }
        }
    }
    for (const RiverEdge& e : edges) {
        const std::uint32_t h = cdt.findEdge(e.a, e.b);
        if (h == Cdt::kNone) {
            return fail("river edge " + edgeName(e.a, e.b) +
                        " is not an edge of the triangulation");
        }
        if (!cdt.isConstrained(h)) {
            return fail("river edge " + edgeName(e.a, e.b) + " is not marked as a constraint");
        }
    }
    std::uint32_t constrained = 0, ringEdges = 0;
    for (std::uint32_t h = 0; h < cdt.tv.size(); ++h) {
        if (!cdt.triangleAlive(h / 3)) continue;
        const PointId u = cdt.origin(h), w = cdt.destination(h);
        if (cdt.isConstrained(h) && u < w) {
            ++constrained;
            ringEdges += cdt.isBoundaryEdge(u, w);
        }
    }
    std::uint32_t shared = 0;  // river edges along ring edges (Cdt::riverOnBoundary)
    for (const RiverEdge& e : edges)
        shared += cdt.isBoundaryEdge(e.a, e.b);
    if (constrained + shared != edges.size() + ringEdges) {
        return fail("the mesh has " + std::to_string(constrained) + " constraint edges but " +
                    std::to_string(edges.size()) + " river edges and " +
                    std::to_string(ringEdges) + " boundary edges are expected");
    }
    // The domain (cdt.h "Domain"): every recorded ring edge is a constraint edge, and the side
    // bits agree with the outline: a triangle left of a ring edge is inside, right of it outside,
    // the two triangles of any other edge are on the same side, ghost neighbours are outside.
    if (ringEdges != cdt.boundary.size()) {
        return fail(std::to_string(cdt.boundary.size()) + " ring edges recorded but " +
                    std::to_string(ringEdges) + " in the mesh");
    }
    for (std::uint32_t h = 0; h < cdt.tv.size(); ++h) {
        const std::uint32_t t = h / 3;
        if (!cdt.triangleAlive(t) || cdt.isGhost(t)) continue;
        const PointId u = cdt.origin(h), w = cdt.destination(h);
        const std::uint32_t g = cdt.tn[h] / 3;
        bool wantExterior;
        if (cdt.isConstrained(h) && cdt.boundaryDirected(u, w)) {
            wantExterior = false;
        } else if (cdt.isConstrained(h) && cdt.boundaryDirected(w, u)) {
            wantExterior = true;
        } else if (cdt.isGhost(g)) {
            wantExterior = cdt.frameFirst != Cdt::kGhost;
        } else {
            wantExterior = cdt.exterior(g);
        }
        if (cdt.exterior(t) != wantExterior) {
            return fail("triangle " + std::to_string(t) + " is marked " +
                        (cdt.exterior(t) ? "outside" : "inside") + " the domain across edge " +
                        edgeName(u, w));
        }
    }
    if (constrained != cdt.constraintEdgeCount) {
        return fail("constraintEdgeCount is " + std::to_string(cdt.constraintEdgeCount) +
                    " but the mesh has " + std::to_string(constrained) + " constraint edges");
    }
    // 4. River structure.
    RiverGraph graph;
    graph.build(n, edges);
    std::vector<PointId> junctions;
    for (PointId v = 0; v < n; ++v) {
        if (graph.degree(v) != 0 && graph.degree(v) != 2) junctions.push_back(v);
    }
    if (junctions != ref.rivers.junctions) {
        std::vector<PointId> diff;
        std::set_symmetric_difference(junctions.begin(), junctions.end(),
                                      ref.rivers.junctions.begin(), ref.rivers.junctions.end(),
                                      std::back_inserter(diff));
        return fail("river junctions / ends changed at vertex " +
                    std::to_string(diff.empty() ? 0 : diff[0]));
    }
    const auto& refChains = ref.rivers.chains;
    std::vector<std::uint32_t> chainOf(n, Cdt::kNone), posOf(n, 0);
    std::map<std::pair<PointId, PointId>, std::vector<std::uint32_t>> byEnds;
    for (std::uint32_t c = 0; c < refChains.size(); ++c) {
        const auto& ch = refChains[c];
        for (std::uint32_t k = 1; k + 1 < ch.size(); ++k)
            chainOf[ch[k]] = c, posOf[ch[k]] = k;
        if (ch.front() == ch.back()) chainOf[ch.front()] = c, posOf[ch.front()] = 0;
        byEnds[{std::min(ch.front(), ch.back()), std::max(ch.front(), ch.back())}].push_back(c);
    }
    std::vector<std::uint8_t> matched(refChains.size(), 0);
    for (const auto& ch : chainsOf(graph, n, edges)) {
        const bool loop = ch.front() == ch.back() && graph.degree(ch.front()) == 2;
        std::uint32_t c = Cdt::kNone;
        if (ch.size() > 2 || loop) {
            c = chainOf[ch[1]];
            bool ok = c != Cdt::kNone;
            if (ok && !loop) {
                const auto& r = refChains[c];
                const bool up =
                    ch.size() > 3 ? posOf[ch[1]] < posOf[ch[2]] : ch.front() == r.front();
                for (std::size_t k = 1; ok && k + 1 < ch.size(); ++k) {
                    ok = chainOf[ch[k]] == c;
                    if (ok && k >= 2)
                        ok = up ? posOf[ch[k]] > posOf[ch[k - 1]] : posOf[ch[k]] < posOf[ch[k - 1]];
                }
                ok = ok && (up ? (ch.front() == r.front() && ch.back() == r.back())
                               : (ch.front() == r.back() && ch.back() == r.front()));
            } else {
                for (std::size_t k = 0; ok && k < ch.size(); ++k)
                    ok = chainOf[ch[k]] == c;
            }
            if (!ok) {
                return fail("river chain " + edgeName(ch.front(), ch.back()) + " through " +
                            std::to_string(ch[1]) + " does not follow one original river chain");
            }
        } else {
            auto it =
                byEnds.find({std::min(ch.front(), ch.back()), std::max(ch.front(), ch.back())});
            if (it != byEnds.end()) {
                for (std::uint32_t cand : it->second) {
                    if (matched[cand]) continue;
                    const auto& r = refChains[cand];
                    bool allGone = true;
                    for (std::size_t k = 1; k + 1 < r.size(); ++k)
                        allGone &= !cdt.isVertex(r[k]);
                    if (allGone) {
                        c = cand;
                        break;
                    }
                }
            }
            if (c == Cdt::kNone) {
                return fail("river edge " + edgeName(ch.front(), ch.back()) +
                            " joins two junctions that no original river chain joined");
            }
        }
        if (matched[c]) {
            return fail("original river chain " +
                        edgeName(refChains[c].front(), refChains[c].back()) +
                        " is split into several chains");
        }
        matched[c] = 1;
    }
    for (std::uint32_t c = 0; c < refChains.size(); ++c) {
        if (!matched[c]) {
            return fail("original river chain " +
                        edgeName(refChains[c].front(), refChains[c].back()) + " is broken");
        }
    }
    // 5. Constrained Delaunay.
    for (std::uint32_t h = 0; h < cdt.tv.size(); ++h) {
        const std::uint32_t t = h / 3;
        if (!cdt.triangleAlive(t) || cdt.isConstrained(h) || cdt.isGhost(t)) continue;
        const std::uint32_t g = cdt.tn[h];
        if (cdt.isGhost(g / 3) || cdt.origin(h) > cdt.destination(h)) continue;
        const PointId a = cdt.tv[h], b = cdt.origin(h), c = cdt.destination(h), d = cdt.tv[g];
        if (incircle(cdt.gx[a], cdt.gy[a], cdt.gx[b], cdt.gy[b], cdt.gx[c], cdt.gy[c], cdt.gx[d],
                     cdt.gy[d]) > 0) {
            return fail("edge " + edgeName(b, c) + " is not locally Delaunay: vertex " +
                        std::to_string(d) + " lies inside the circumcircle of " + triName(t));
        }
    }
    return true;
}

}  // namespace unilod
