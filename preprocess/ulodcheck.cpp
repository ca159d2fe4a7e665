// .ulod file check (ulodcheck.h).
#include "ulodcheck.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <mutex>
#include <set>
#include <tuple>

#include "checker.h"
#include "errorcheck.h"
#include "meshimport.h"
#include "ulod.h"
#include "workers.h"

namespace unilod {

namespace {

TriangleTriple toTriple(const format::Triangle& t) {
    return canonicalTriangle(t.a, t.b, t.c);
}
RiverEdge toEdge(const format::Edge& e) {
    return makeRiverEdge(e.a, e.b);
}

std::string metres(double v) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.9g m", v);
    return buf;
}

// The stored `max` error of level `level` against the current error recomputed from the level's
// triangles and river edges (errorcheck.h); updates the summary's closest approach.
bool checkLevelError(const format::Block& b, std::size_t level,
                     const std::vector<TriangleTriple>& tris, const std::vector<RiverEdge>& edges,
                     const RiverReference& rivers, double tolerance, UlodCheckSummary& summary,
                     std::string& error) {
    const format::Level& l = b.levels[level];
    LevelMaxError e;
    if (!levelMaxError(b, l.step, tris, edges, rivers, e, error)) return false;
    const double stored = std::min(double(l.errorMax), double(b.errorMax[l.step]));
    const double recomputed = e.value();
    if (stored < recomputed - tolerance) {
        error = "max error lies: stored " + metres(double(l.errorMax)) + " (level) and " +
                metres(double(b.errorMax[l.step])) + " (errorMax[" + std::to_string(l.step) +
                "]), recomputed " + metres(recomputed) + " (vertical " + metres(e.vertical) +
                " at vertex " + std::to_string(e.verticalVertex) + ", river " + metres(e.river) +
                " at vertex " + std::to_string(e.riverVertex) + "), tolerance " + metres(tolerance);
        return false;
    }
    // The river part (format version 4) bounds the river and outline deviations on its own.
    const double storedRiver = std::min(double(l.errorRiver), double(b.errorRiver[l.step]));
    if (storedRiver < e.river - tolerance) {
        error = "max error's river part lies: stored " + metres(storedRiver) + " (errorRiver[" +
                std::to_string(l.step) + "]), recomputed river " + metres(e.river) +
                " at vertex " + std::to_string(e.riverVertex) + ", tolerance " + metres(tolerance);
        return false;
    }
    if (e.river > 0) summary.riverMargin = std::min(summary.riverMargin, storedRiver - e.river);
    const double margin = stored - recomputed;
    if (!summary.errorsChecked || margin < summary.smallestMargin) summary.smallestMargin = margin;
    summary.errorsChecked = true;
    if (stored > 0 && recomputed / stored > summary.worstRatio) {
        summary.worstRatio = recomputed / stored;
        summary.worstStored = stored;
        summary.worstRecomputed = recomputed;
        summary.worstCol = b.col;
        summary.worstRow = b.row;
        summary.worstTreeLevel = b.level;
        summary.worstLevel = static_cast<std::uint32_t>(level);
    }
    return true;
}

// A level of a block whose domain is not one convex region (blocks.h "Domain": holes, a
// concave or pinched outline), where the ghost-closed checks below do not apply: the triangles
// (counter-clockwise, no directed edge twice: validateLevelGeometry) must cover the plane at most
// once around every vertex (exact: the triangles of a vertex's fan that hold the direction +x,
// half-open, number exactly one at a vertex whose edges all have two triangles, at most one at
// an outline vertex), so the level is a locally injective triangulation of its domain, and
// river edges are edges of the level (validateLevelGeometry), so they cannot cross either.
bool checkDomainLevel(const std::vector<std::int32_t>& gx, const std::vector<std::int32_t>& gy,
                      const std::vector<TriangleTriple>& tris, std::string& error) {
    const std::size_t n = gx.size();
    std::vector<std::uint32_t> wraps(n, 0);
    for (const TriangleTriple& t : tris) {
        for (int k = 0; k < 3; ++k) {
            const PointId v = t.v[k], a = t.v[(k + 1) % 3], c = t.v[(k + 2) % 3];
            const std::int64_t ax = std::int64_t(gx[a]) - gx[v], ay = std::int64_t(gy[a]) - gy[v];
            const std::int64_t cy = std::int64_t(gy[c]) - gy[v];
            // +x lies in the angle [a, c) of a counter-clockwise triangle (less than pi):
            // a is at or below it (cross(a, x) >= 0, on the ray itself only pointing along +x)
            // and c strictly above it.
            const bool fromA = ay < 0 || (ay == 0 && ax > 0);
            const bool toC = cy > 0;
            if (fromA && toC) ++wraps[v];
        }
    }
    for (PointId v = 0; v < n; ++v) {
        // A closed fan turns k >= 1 times and counts k; an outline vertex's open fan counts at
        // most one unless it overlaps itself.
        if (wraps[v] > 1) {
            error = "the triangles around vertex " + std::to_string(v) + " overlap (they turn " +
                    std::to_string(wraps[v]) + " times around it)";
            return false;
        }
    }
    return true;
}

// `levelTriangles`, `levelRiverEdges` (not null): receive every stored level's triangles and
// river edges (sorted).
bool checkBlock(const format::Block& b, const UlodCheckOptions& options, UlodCheckSummary& summary,
                std::string& error, std::vector<std::vector<TriangleTriple>>* levelTriangles,
                std::vector<std::vector<RiverEdge>>* levelRiverEdges) {
    const std::size_t n = b.vertices.size();
    if (b.grid.size() != n) {
        error = "no exact grid coordinates stored: topology cannot be checked exactly";
        return false;
    }
    std::vector<std::int32_t> gx(n), gy(n);
    std::vector<std::uint8_t> locked(n);
    for (std::size_t i = 0; i < n; ++i) {
        gx[i] = b.grid[i].x;
        gy[i] = b.grid[i].y;
        locked[i] = (b.vertices[i].flags & format::kVertexLocked) != 0;
    }
    auto trianglesOf = [&](const format::Level& l) {
        std::vector<TriangleTriple> t;
        for (std::uint32_t i = 0; i < l.triangleCount; ++i) {
            t.push_back(toTriple(b.terrainIndices[l.triangleFirst + i]));
        }
        std::sort(t.begin(), t.end());
        return t;
    };
    auto levelEdges = [&](const format::Level& l) {
        std::vector<RiverEdge> e;
        for (std::uint32_t i = 0; i < l.riverCount; ++i)
            e.push_back(toEdge(b.riverIndices[l.riverFirst + i]));
        std::sort(e.begin(), e.end());
        return e;
    };

    // Full resolution: a valid convex constrained Delaunay triangulation, and the reference.
    const format::Level& l0 = b.levels.front();
    std::vector<TriangleTriple> tris = trianglesOf(l0);
    std::vector<RiverEdge> edges = levelEdges(l0);
    if (levelTriangles) levelTriangles->assign(1, tris);
    if (levelRiverEdges) levelRiverEdges->assign(1, edges);
    Cdt cdt;
    // A domain that is one convex region gets the full checks of checker.h on a ghost-closed
    // mesh; any other (holes, concave or pinched outline) the domain checks above.
    std::string why;
    // One region without holes: V - E + F = 1 over the triangles' vertices and edges.
    std::set<std::pair<PointId, PointId>> undirected;
    std::set<PointId> used;
    for (const TriangleTriple& t : tris) {
        for (int k = 0; k < 3; ++k) {
            used.insert(t.v[k]);
            undirected.insert(std::minmax(t.v[k], t.v[(k + 1) % 3]));
        }
    }
    const bool disk =
        std::int64_t(used.size()) - std::int64_t(undirected.size()) + std::int64_t(tris.size()) ==
        1;
    const bool convex = disk && cdtFromTriangles(gx, gy, locked, tris, edges, cdt, why) &&
                        boundaryIsConvex(cdt, why);
    CheckReference ref;
    if (convex) {
        ref = captureCheckReference(cdt);
        if (!checkCdt(cdt, ref, &edges, error)) {
            error = "level 0: " + error;
            return false;
        }
    } else {
        cdt = Cdt{};
        cdt.vertexTriangle.assign(n, Cdt::kNone);
        ref.rivers = captureRiverReference(cdt, edges);
        if (!checkDomainLevel(gx, gy, tris, error)) {
            error = "level 0: " + error;
            return false;
        }
    }
    const double tolerance = options.errors ? maxErrorTolerance(b) : 0.0;
    if (options.errors &&
        !checkLevelError(b, 0, tris, edges, ref.rivers, tolerance, summary, error)) {
        error = "level 0 (step 0): " + error;
        return false;
    }

    // Replay the records; at every stored level the replayed mesh must be the stored one and
    // satisfy every invariant against the full-resolution reference.
    std::set<TriangleTriple> alive(tris.begin(), tris.end());
    std::set<RiverEdge> aliveEdges(edges.begin(), edges.end());
    std::size_t level = 1;
    for (std::uint32_t s = 0; s < b.steps.size() && level < b.levels.size(); ++s) {
        const std::string stepName = "step " + std::to_string(s + 1);
        for (std::uint32_t i = b.removedTriangleOffset[s]; i < b.removedTriangleOffset[s + 1];
             ++i) {
            if (alive.erase(toTriple(b.removedTriangles[i])) != 1) {
                error = stepName + " removes a triangle that is not alive";
                return false;
            }
        }
        for (std::uint32_t i = b.addedTriangleOffset[s]; i < b.addedTriangleOffset[s + 1]; ++i) {
            if (!alive.insert(toTriple(b.addedTriangles[i])).second) {
                error = stepName + " adds a triangle that is alive";
                return false;
            }
        }
        for (std::uint32_t i = b.removedEdgeOffset[s]; i < b.removedEdgeOffset[s + 1]; ++i) {
            if (aliveEdges.erase(toEdge(b.removedEdges[i])) != 1) {
                error = stepName + " removes a river edge that is not alive";
                return false;
            }
        }
        for (std::uint32_t i = b.addedEdgeOffset[s]; i < b.addedEdgeOffset[s + 1]; ++i) {
            if (!aliveEdges.insert(toEdge(b.addedEdges[i])).second) {
                error = stepName + " adds a river edge that is alive";
                return false;
            }
        }
        if (alive.size() != b.steps[s].trianglesAlive ||
            aliveEdges.size() != b.steps[s].riverEdgesAlive) {
            error = stepName + ": the records leave " + std::to_string(alive.size()) +
                    " triangles and " + std::to_string(aliveEdges.size()) +
                    " river edges, the step says " + std::to_string(b.steps[s].trianglesAlive) +
                    " and " + std::to_string(b.steps[s].riverEdgesAlive);
            return false;
        }
        const format::Level& l = b.levels[level];
        if (l.step != s + 1) continue;
        const std::string name =
            "level " + std::to_string(level) + " (step " + std::to_string(l.step) + ")";
        tris = trianglesOf(l);
        edges = levelEdges(l);
        if (levelTriangles) levelTriangles->push_back(tris);
        if (levelRiverEdges) levelRiverEdges->push_back(edges);
        if (!std::equal(tris.begin(), tris.end(), alive.begin(), alive.end())) {
            error = name + ": stored triangles differ from the replayed records";
            return false;
        }
        if (!std::equal(edges.begin(), edges.end(), aliveEdges.begin(), aliveEdges.end())) {
            error = name + ": stored river edges differ from the replayed records";
            return false;
        }
        // The greedy order moves the outline (deletion.h: outline corners), so a coarser level
        // covers its own area: the ghost-closed checks take that area, and the winding test of
        // checkDomainLevel rules out overlaps, which the area no longer does.
        CheckReference levelRef = ref;
        levelRef.doubleHullArea = 0;
        for (const TriangleTriple& t : tris) {
            const PointId a = t.v[0], bb = t.v[1], c = t.v[2];
            levelRef.doubleHullArea +=
                Int128(std::int64_t(gx[bb]) - gx[a]) * (std::int64_t(gy[c]) - gy[a]) -
                Int128(std::int64_t(gy[bb]) - gy[a]) * (std::int64_t(gx[c]) - gx[a]);
        }
        const bool structure =
            checkDomainLevel(gx, gy, tris, error) &&
            (!convex || (cdtFromTriangles(gx, gy, locked, tris, edges, cdt, error) &&
                         checkCdt(cdt, levelRef, &edges, error)));
        if (!structure || (options.errors && !checkLevelError(b, level, tris, edges, ref.rivers,
                                                              tolerance, summary, error))) {
            error = name + ": " + error;
            return false;
        }
        ++level;
    }
    if (level != b.levels.size()) {
        error = "level " + std::to_string(level) + " was never reached by the records";
        return false;
    }
    return true;
}

// Issue 18: the stored `max` error of every level of tree node `b` (entry `index`) against the
// original points of its area, the vertices of the leaf blocks below it, vertical and river
// (errorcheck.h NodeOriginalError), read leaf by leaf.
bool checkNodeOriginals(const format::Reader& reader, std::size_t index, const format::Block& b,
                        std::vector<std::vector<TriangleTriple>> levels,
                        std::vector<std::vector<RiverEdge>> riverLevels, UlodCheckSummary& summary,
                        std::string& error) {
    NodeOriginalError originals(b, std::move(levels), std::move(riverLevels));
    const auto& infos = reader.blocks();
    std::vector<std::size_t> stack{index};
    format::Block leaf;
    while (!stack.empty()) {
        const format::BlockInfo& info = infos[stack.back()];
        const std::size_t at = stack.back();
        stack.pop_back();
        if (info.childCount > 0) {
            for (std::uint32_t c = 0; c < info.childCount; ++c)
                stack.push_back(info.firstChild + c);
            continue;
        }
        if (!reader.readBlock(at, leaf, error)) return false;
        originals.add(leaf);
    }
    const double tolerance = originals.tolerance();
    for (std::size_t level = 0; level < b.levels.size(); ++level) {
        const format::Level& l = b.levels[level];
        const NodeOriginalError::Worst& vertical = originals.worst()[level];
        const NodeOriginalError::Worst& river = originals.riverWorst()[level];
        const bool isRiver = river.value > vertical.value;
        const NodeOriginalError::Worst& w = isRiver ? river : vertical;
        const double stored = std::min(double(l.errorMax), double(b.errorMax[l.step]));
        if (stored < w.value - tolerance) {
            error = "level " + std::to_string(level) + " (step " + std::to_string(l.step) +
                    "): max error lies: stored " + metres(stored) + ", recomputed " +
                    metres(w.value) + (isRiver ? " (river, at vertex " : " (vertical, at vertex ") +
                    std::to_string(w.vertex) + " of block (" + std::to_string(w.col) + "," +
                    std::to_string(w.row) + ") below it: an original point), tolerance " +
                    metres(tolerance);
            return false;
        }
        const double storedRiver = std::min(double(l.errorRiver), double(b.errorRiver[l.step]));
        if (storedRiver < river.value - tolerance) {
            error = "level " + std::to_string(level) + " (step " + std::to_string(l.step) +
                    "): max error's river part lies: stored " + metres(storedRiver) +
                    ", recomputed " + metres(river.value) + " (at vertex " +
                    std::to_string(river.vertex) + " of block (" + std::to_string(river.col) +
                    "," + std::to_string(river.row) + ") below it: an original river point), " +
                    "tolerance " + metres(tolerance);
            return false;
        }
        if (river.value > 0 && std::isfinite(river.value))
            summary.riverMargin = std::min(summary.riverMargin, storedRiver - river.value);
        const double margin = stored - w.value;
        if (!summary.errorsChecked || margin < summary.smallestMargin)
            summary.smallestMargin = margin;
        summary.errorsChecked = true;
        if (stored > 0 && w.value / stored > summary.worstRatio) {
            summary.worstRatio = w.value / stored;
            summary.worstStored = stored;
            summary.worstRecomputed = w.value;
            summary.worstCol = b.col;
            summary.worstRow = b.row;
            summary.worstTreeLevel = b.level;
            summary.worstLevel = static_cast<std::uint32_t>(level);
        }
        summary.nodeRiverWorst = std::max(summary.nodeRiverWorst, river.value);
    }
    return true;
}

// Neighbouring blocks (and tree nodes of one tree level) must meet edge to edge: every outline
// edge of a block's full-resolution mesh on a border it shares with another block of its tree
// level is an outline edge of that block too, reversed, with the same heights at both ends and
// both ends locked (never deleted, so the edge stays at every level). What breaks this is a
// vertex on the border that one side holds and the other passes by (a T-junction: the two sides'
// outline edges overlap along the border line, a crack wherever the vertex's height differs
// from the edge's), or a border vertex that one side may delete. Positions are compared on the
// exact grid, in absolute grid units (a block's origin is a grid point, cdt.cpp).
class SharedBorders {
public:
    struct Edge {
        std::size_t entry = 0;
        std::uint32_t col = 0, row = 0, level = 0;
        std::int64_t x[2] = {0, 0}, y[2] = {0, 0};
        float z[2] = {0, 0};
        bool locked[2] = {false, false};
    };

    // The outline edges of entry `entry`'s full-resolution mesh (any thread), then append()ed in
    // entry order.
    static std::vector<Edge> outline(std::size_t entry, const format::Block& b) {
        std::vector<Edge> edges;
        const format::Level& l0 = b.levels.front();
        std::vector<std::pair<std::uint32_t, std::uint32_t>> directed;  // sorted, then searched
        directed.reserve(3 * std::size_t(l0.triangleCount));
        for (std::uint32_t i = 0; i < l0.triangleCount; ++i) {
            const format::Triangle& t = b.terrainIndices[l0.triangleFirst + i];
            directed.push_back({t.a, t.b});
            directed.push_back({t.b, t.c});
            directed.push_back({t.c, t.a});
        }
        std::sort(directed.begin(), directed.end());
        const std::int64_t ox = std::llround(b.originX / format::kGridUnit);
        const std::int64_t oy = std::llround(b.originY / format::kGridUnit);
        for (const auto& [u, w] : directed) {
            if (std::binary_search(directed.begin(), directed.end(), std::make_pair(w, u)))
                continue;
            Edge e;
            e.entry = entry;
            e.col = b.col;
            e.row = b.row;
            e.level = b.level;
            const std::uint32_t ends[2] = {u, w};
            for (int k = 0; k < 2; ++k) {
                e.x[k] = ox + b.grid[ends[k]].x;
                e.y[k] = oy + b.grid[ends[k]].y;
                e.z[k] = b.vertices[ends[k]].z;
                e.locked[k] = (b.vertices[ends[k]].flags & format::kVertexLocked) != 0;
            }
            edges.push_back(e);
        }
        return edges;
    }
    void append(const std::vector<Edge>& edges) {
        edges_.insert(edges_.end(), edges.begin(), edges.end());
    }

    bool check(std::string& error) {
        // Shared edges: the same two grid points in two entries of one tree level.
        auto key = [](const Edge& e) {
            const bool swap = std::make_pair(e.x[1], e.y[1]) < std::make_pair(e.x[0], e.y[0]);
            const int a = swap ? 1 : 0, c = 1 - a;
            return std::make_tuple(e.level, e.x[a], e.y[a], e.x[c], e.y[c]);
        };
        std::sort(edges_.begin(), edges_.end(), [&](const Edge& l, const Edge& r) {
            return std::make_pair(key(l), l.entry) < std::make_pair(key(r), r.entry);
        });
        std::vector<Edge> single;
        for (std::size_t i = 0; i < edges_.size();) {
            std::size_t j = i + 1;
            while (j < edges_.size() && key(edges_[j]) == key(edges_[i]))
                ++j;
            const Edge& e = edges_[i];
            if (j - i == 1) {
                single.push_back(e);
            } else {
                const Edge& f = edges_[i + 1];
                const bool reversed = e.x[0] == f.x[1] && e.y[0] == f.y[1];
                std::string why;
                if (j - i > 2)
                    why = "more than two blocks hold it";
                else if (!reversed)
                    why = "both blocks lie on the same side of it";
                else if (e.z[0] != f.z[1] || e.z[1] != f.z[0])
                    why = "its ends' heights differ";
                else if (!(e.locked[0] && e.locked[1] && f.locked[0] && f.locked[1]))
                    why = "an end is not locked, so a coarser level may delete it";
                if (!why.empty()) {
                    error = fail(e, f, e.x[0], e.y[0]) + ": the border edge to " +
                            at(e.x[1], e.y[1]) + ": " + why;
                    return false;
                }
            }
            i = j;
        }
        // Edges held by one block only (the domain's outline) must not overlap another block's
        // along a border line: that is a vertex one side holds and the other passes by.
        struct Span {
            std::int64_t lo, hi;
            const Edge* e;
        };
        std::map<std::tuple<std::uint32_t, int, std::int64_t>, std::vector<Span>> lines;
        for (const Edge& e : single) {
            if (e.x[0] == e.x[1])
                lines[{e.level, 0, e.x[0]}].push_back(
                    {std::min(e.y[0], e.y[1]), std::max(e.y[0], e.y[1]), &e});
            else if (e.y[0] == e.y[1])
                lines[{e.level, 1, e.y[0]}].push_back(
                    {std::min(e.x[0], e.x[1]), std::max(e.x[0], e.x[1]), &e});
        }
        for (auto& [line, spans] : lines) {
            std::sort(spans.begin(), spans.end(),
                      [](const Span& l, const Span& r) { return l.lo < r.lo; });
            const Span* reach = nullptr;  // the span reaching farthest so far
            for (const Span& sp : spans) {
                if (reach && sp.lo < reach->hi && sp.e->entry != reach->e->entry) {
                    const std::int64_t c = std::get<2>(line), p = std::max(sp.lo, reach->lo);
                    const bool vertical = std::get<1>(line) == 0;
                    error = fail(*reach->e, *sp.e, vertical ? c : p, vertical ? p : c) +
                            ": their outline edges overlap along the border (a vertex one of "
                            "them holds there, the other passes by: a crack)";
                    return false;
                }
                if (!reach || sp.hi > reach->hi) reach = &sp;
            }
        }
        return true;
    }

private:
    static std::string at(std::int64_t x, std::int64_t y) {
        char buf[64];
        std::snprintf(buf, sizeof buf, "(%.3f, %.3f)", double(x) * format::kGridUnit,
                      double(y) * format::kGridUnit);
        return buf;
    }
    static std::string fail(const Edge& a, const Edge& b, std::int64_t x, std::int64_t y) {
        return format::blockName(a.col, a.row, a.level) + " and " +
               format::blockName(b.col, b.row, b.level) + " do not meet at " + at(x, y);
    }
    std::vector<Edge> edges_;
};

// One entry's share of checkUlod: its summary (from a default one), error and outline edges.
struct EntryCheck {
    UlodCheckSummary summary;
    std::string error;  // empty: it holds
    std::vector<SharedBorders::Edge> outline;
};

EntryCheck checkEntry(const format::Reader& reader, std::size_t i,
                      const UlodCheckOptions& options) {
    EntryCheck r;
    format::Block b;
    if (!reader.readBlock(i, b, r.error)) return r;
    const bool node = options.errors && b.level > 0;
    std::vector<std::vector<TriangleTriple>> levels;
    std::vector<std::vector<RiverEdge>> riverLevels;
    if (!checkBlock(b, options, r.summary, r.error, node ? &levels : nullptr,
                    node ? &riverLevels : nullptr) ||
        (node && !checkNodeOriginals(reader, i, b, std::move(levels), std::move(riverLevels),
                                     r.summary, r.error))) {
        r.error = format::blockName(b.col, b.row, b.level) + ": " + r.error;
        return r;
    }
    r.outline = SharedBorders::outline(i, b);
    r.summary.blocks = 1;
    r.summary.levels = b.levels.size();
    r.summary.steps = b.steps.size();
    return r;
}

// Adds an entry's summary to the file's, as checking the entries one after another in file order
// would have (the closest approach: the first entry with the largest ratio).
void merge(UlodCheckSummary& into, const UlodCheckSummary& s) {
    into.blocks += s.blocks;
    into.levels += s.levels;
    into.steps += s.steps;
    if (s.errorsChecked) {
        if (!into.errorsChecked || s.smallestMargin < into.smallestMargin)
            into.smallestMargin = s.smallestMargin;
        into.errorsChecked = true;
    }
    if (s.worstRatio > into.worstRatio) {
        into.worstRatio = s.worstRatio;
        into.worstStored = s.worstStored;
        into.worstRecomputed = s.worstRecomputed;
        into.worstCol = s.worstCol;
        into.worstRow = s.worstRow;
        into.worstTreeLevel = s.worstTreeLevel;
        into.worstLevel = s.worstLevel;
    }
    into.nodeRiverWorst = std::max(into.nodeRiverWorst, s.nodeRiverWorst);
    into.riverMargin = std::min(into.riverMargin, s.riverMargin);
}

}  // namespace

bool checkUlod(const std::string& path, const UlodCheckOptions& options, UlodCheckSummary& summary,
               std::string& error, const std::function<void(std::size_t, std::size_t)>& progress) {
    summary = {};
    format::Reader reader;
    if (!reader.open(path, error)) return false;
    if (options.errors && (reader.header().metrics & format::kMetricMax) == 0) {
        error = path + ": the file stores no `max` error, so --errors has nothing to check";
        return false;
    }
    // Entries are independent (a node reads the leaves below it itself): one a task, the tree
    // nodes (stored after the leaves, the root last, each reading every leaf below it) handed
    // out first so that the largest tasks do not finish last. Results are combined in file
    // order, so the summary and the first failure named are those of a serial check.
    const std::size_t n = reader.blocks().size();
    std::vector<EntryCheck> results(n);
    std::mutex mutex;
    std::size_t done = 0;
    engine::WorkerPool pool(options.threads);
    pool.run(n, [&](std::size_t task) {
        const std::size_t i = n - 1 - task;
        results[i] = checkEntry(reader, i, options);
        std::lock_guard lock(mutex);
        ++done;
        if (progress) progress(done, n);
    });
    SharedBorders borders;
    for (std::size_t i = 0; i < n; ++i) {
        if (!results[i].error.empty()) {
            error = format::errorForFile(path, results[i].error);  // a block's read names it
            return false;
        }
        merge(summary, results[i].summary);
        borders.append(results[i].outline);
        results[i] = EntryCheck{};
    }
    if (!borders.check(error)) {
        error = path + ": " + error;
        return false;
    }
    return true;
}

}  // namespace unilod
