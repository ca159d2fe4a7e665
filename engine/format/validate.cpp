// Validation of one block (ulod.h validateBlock, validateLevelGeometry) and the small rules every
// reader path shares (storedLevelFor, blockName). The checks are listed in README.md ("Structural
// rules"); the file's bytes are ulod.cpp's concern, the compact encoding blockcodec.cpp's.
#include <algorithm>
#include <cassert>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <string>
#include <utility>
#include <vector>

#include "blockarrays.h"
#include "directededges.h"
#include "predicates.h"
#include "ulod.h"

namespace unilod::format {

namespace {

// ---- validation -----------------------------------------------------------------------------

bool checkOffsets(const std::vector<std::uint32_t>& offsets, std::size_t steps,
                  std::size_t arraySize, const char* name, std::string& error) {
    if (offsets.size() != steps + 1) {
        error = std::string(name) + " has " + std::to_string(offsets.size()) +
                " entries, expected steps + 1 = " + std::to_string(steps + 1);
        return false;
    }
    if (offsets[0] != 0) {
        error = std::string(name) + "[0] is " + std::to_string(offsets[0]) + ", expected 0";
        return false;
    }
    for (std::size_t s = 1; s < offsets.size(); ++s) {
        if (offsets[s] < offsets[s - 1]) {
            error = std::string(name) + " decreases at " + std::to_string(s) + " (" +
                    std::to_string(offsets[s - 1]) + " -> " + std::to_string(offsets[s]) + ")";
            return false;
        }
    }
    if (offsets.back() != arraySize) {
        error = std::string(name) + " ends at " + std::to_string(offsets.back()) +
                " but its array has " + std::to_string(arraySize) + " entries";
        return false;
    }
    return true;
}

// `where` names the element's place, built only on failure.
template <class Where>
bool checkTriangle(const Triangle& t, std::uint64_t limit, const Where& where,
                   std::string& error) {
    if (t.a >= limit || t.b >= limit || t.c >= limit) {
        error = where() + ": triangle (" + std::to_string(t.a) + "," + std::to_string(t.b) + "," +
                std::to_string(t.c) + ") has an index >= " + std::to_string(limit);
        return false;
    }
    return true;
}

template <class Where>
bool checkEdge(const Edge& e, std::uint64_t limit, const Where& where, std::string& error) {
    if (e.a >= e.b || e.b >= limit) {
        error = where() + ": edge (" + std::to_string(e.a) + "," + std::to_string(e.b) +
                ") is not a < b < " + std::to_string(limit);
        return false;
    }
    return true;
}

bool checkErrors(const std::vector<float>& errors, bool present, std::size_t steps,
                 const char* name, std::string& error) {
    if (!present) {
        if (!errors.empty()) {
            error = std::string(name) + " has " + std::to_string(errors.size()) +
                    " entries but the metric is not in the file";
            return false;
        }
        return true;
    }
    if (errors.size() != steps + 1) {
        error = std::string(name) + " has " + std::to_string(errors.size()) +
                " entries, expected steps + 1 = " + std::to_string(steps + 1);
        return false;
    }
    for (std::size_t s = 0; s < errors.size(); ++s) {
        if (!std::isfinite(errors[s]) || errors[s] < 0) {
            error = std::string(name) + "[" + std::to_string(s) + "] is not a finite value >= 0";
            return false;
        }
        if (s > 0 && errors[s] < errors[s - 1]) {
            error = std::string(name) + " decreases at step " + std::to_string(s) + " (" +
                    std::to_string(errors[s - 1]) + " -> " + std::to_string(errors[s]) + ")";
            return false;
        }
    }
    return true;
}

// The block's bounding box finite and ordered, its origin finite and inside it (the builder puts
// the origin at the centre of the box of the block's points): vertices are drawn relative to the
// origin, so a far-away origin would place them anywhere.
bool boxAndOriginValid(const Block& b, std::string& error) {
    const double lo[3] = {b.minX, b.minY, b.minZ}, hi[3] = {b.maxX, b.maxY, b.maxZ};
    for (int a = 0; a < 3; ++a) {
        if (!std::isfinite(lo[a]) || !std::isfinite(hi[a]) || lo[a] > hi[a]) {
            error = "bounding box is not finite or inverted";
            return false;
        }
    }
    if (!(b.originX >= b.minX && b.originX <= b.maxX && b.originY >= b.minY &&
          b.originY <= b.maxY)) {
        error = "origin (" + std::to_string(b.originX) + ", " + std::to_string(b.originY) +
                ") is not finite or lies outside the bounding box";
        return false;
    }
    return true;
}

// True when float coordinate `c`, at double position `at` (origin + c, or c itself for z), lies
// in [lo, hi] up to the float rounding the format allows (kFloatSlack, kAbsoluteSlack).
bool insideWithSlack(double at, float c, double lo, double hi) {
    const double slack = kFloatSlack * std::fabs(double(c)) + kAbsoluteSlack;
    return at >= lo - slack && at <= hi + slack;
}

// Vertex i: finite, known flags, inside the block's box; its grid position (if stored) bounded so
// that orient2d is exact and within a grid unit of its float position, so the orientation proved
// on the grid is the one drawn (up to slivers thinner than a millimetre).
bool vertexValid(const Block& b, std::uint64_t i, std::string& error) {
    const Vertex& v = b.vertices[i];
    const std::string name = "vertex " + std::to_string(i);
    if (!std::isfinite(v.x) || !std::isfinite(v.y) || !std::isfinite(v.z)) {
        error = name + " has a non-finite coordinate";
        return false;
    }
    if ((v.flags & ~(kVertexRiver | kVertexLocked)) != 0) {
        error = name + " has unknown flags " + std::to_string(v.flags);
        return false;
    }
    // x, y also up to a grid unit outside: a built vertex's x, y are its grid position (the exact
    // position rounded to kGridUnit, blockcodec.h), the box the exact positions'.
    if (!insideWithSlack(b.originX + double(v.x), v.x, b.minX - kGridUnit, b.maxX + kGridUnit) ||
        !insideWithSlack(b.originY + double(v.y), v.y, b.minY - kGridUnit, b.maxY + kGridUnit) ||
        !insideWithSlack(double(v.z), v.z, b.minZ, b.maxZ)) {
        error = name + " (" + std::to_string(v.x) + ", " + std::to_string(v.y) + ", " +
                std::to_string(v.z) + ") lies outside the block's bounding box";
        return false;
    }
    if (b.grid.empty()) return true;
    const GridXY g = b.grid[i];
    if (std::abs(std::int64_t(g.x)) > kMaxGridCoordinate ||
        std::abs(std::int64_t(g.y)) > kMaxGridCoordinate) {
        error = name + ": grid position (" + std::to_string(g.x) + ", " + std::to_string(g.y) +
                ") is beyond +-(2^28 - 1)";
        return false;
    }
    const double dx = std::fabs(double(v.x) - double(g.x) * kGridUnit);
    const double dy = std::fabs(double(v.y) - double(g.y) * kGridUnit);
    if (dx > kGridUnit + kFloatSlack * std::fabs(double(v.x)) ||
        dy > kGridUnit + kFloatSlack * std::fabs(double(v.y))) {
        error = name + ": float position (" + std::to_string(v.x) + ", " + std::to_string(v.y) +
                ") and grid position (" + std::to_string(g.x) + ", " + std::to_string(g.y) +
                ") differ by more than a grid unit";
        return false;
    }
    return true;
}

std::string triangleText(const Triangle& t) {
    // Appended piece by piece: GCC 12 at -O3 reports a false -Wrestrict on "(" + std::string.
    std::string text = "(";
    text += std::to_string(t.a);
    text += ',';
    text += std::to_string(t.b);
    text += ',';
    text += std::to_string(t.c);
    text += ')';
    return text;
}

constexpr std::uint64_t edgeKey(std::uint32_t a, std::uint32_t b) {
    return std::uint64_t(a) << 32 | b;
}

bool validateLevelGeometryImpl(const Block& b, std::size_t level, std::string& error) {
    const std::string where = "level " + std::to_string(level);
    if (level >= b.levels.size()) {
        error = where + " does not exist";
        return false;
    }
    const Level& l = b.levels[level];
    if (l.vertexCount > b.vertices.size() ||
        std::uint64_t(l.triangleFirst) + l.triangleCount > b.terrainIndices.size() ||
        std::uint64_t(l.riverFirst) + l.riverCount > b.riverIndices.size()) {
        error = where + ": its vertices or index ranges lie outside the block's arrays";
        return false;
    }
    const std::uint64_t n = l.vertexCount;
    const bool exact = !b.grid.empty() && b.grid.size() == b.vertices.size();
    auto gridOk = [&](std::uint32_t v) {
        return std::abs(std::int64_t(b.grid[v].x)) <= kMaxGridCoordinate &&
               std::abs(std::int64_t(b.grid[v].y)) <= kMaxGridCoordinate;
    };
    for (std::uint32_t i = 0; i < l.triangleCount; ++i) {
        const Triangle& t = b.terrainIndices[l.triangleFirst + i];
        if (!checkTriangle(t, n, [&] { return where + " terrain"; }, error)) return false;
        if (t.a == t.b || t.b == t.c || t.c == t.a) {
            error = where + ": triangle " + triangleText(t) + " repeats a vertex";
            return false;
        }
        if (exact) {
            if (!gridOk(t.a) || !gridOk(t.b) || !gridOk(t.c)) {
                error = where + ": triangle " + triangleText(t) +
                        " has a grid position beyond +-(2^28 - 1)";
                return false;
            }
            const GridXY &p = b.grid[t.a], &q = b.grid[t.b], &r = b.grid[t.c];
            if (orient2d(p.x, p.y, q.x, q.y, r.x, r.y) <= 0) {
                error = where + ": triangle " + triangleText(t) +
                        " is not counter-clockwise on the exact grid (flipped or degenerate)";
                return false;
            }
        }
    }
    // In a valid triangulation no directed edge occurs twice (directededges.h: the edges bucketed
    // by their first vertex).
    const DirectedEdges edges(b.terrainIndices.data() + l.triangleFirst,
                              b.terrainIndices.data() + l.triangleFirst + l.triangleCount, n);
    for (std::uint64_t v = 0; v < n; ++v) {
        const std::uint64_t twice = edges.repeat(std::uint32_t(v));
        if (twice != DirectedEdges::kNoRepeat) {
            error = where + ": edge " + std::to_string(v) + "->" + std::to_string(twice) +
                    " is used by two triangles in the same direction (a duplicated or flipped "
                    "triangle, or more than two triangles on one edge)";
            return false;
        }
    }
    std::vector<std::uint64_t> rivers;
    rivers.reserve(l.riverCount);
    for (std::uint32_t i = 0; i < l.riverCount; ++i) {
        const Edge& e = b.riverIndices[l.riverFirst + i];
        if (!checkEdge(e, n, [&] { return where + " river"; }, error)) return false;
        if (!edges.has(e.a, e.b) && !edges.has(e.b, e.a)) {
            error = where + ": river edge (" + std::to_string(e.a) + "," + std::to_string(e.b) +
                    ") is not an edge of the level's triangles";
            return false;
        }
        rivers.push_back(edgeKey(e.a, e.b));
    }
    std::sort(rivers.begin(), rivers.end());
    const auto dup = std::adjacent_find(rivers.begin(), rivers.end());
    if (dup != rivers.end()) {
        error = where + ": river edge (" + std::to_string(*dup >> 32) + "," +
                std::to_string(*dup & 0xffffffffu) + ") appears twice";
        return false;
    }
    return true;
}

// Ulod.h validateLevelTable (messages without the block's name).
bool levelTableValid(const std::vector<Level>& levels, std::uint64_t vertexCount,
                     std::uint64_t stepCount, std::uint32_t fullTriangles, std::uint32_t metrics,
                     std::string& error) {
    if (levels.empty()) {
        error = "no levels (levels[0] must be the full resolution)";
        return false;
    }
    if (levels[0].step != 0) {
        error = "levels[0].step is " + std::to_string(levels[0].step) + ", expected 0";
        return false;
    }
    if (levels[0].triangleCount != fullTriangles) {
        error = "levels[0] has " + std::to_string(levels[0].triangleCount) +
                " triangles, the directory " + std::to_string(fullTriangles);
        return false;
    }
    for (std::size_t l = 0; l < levels.size(); ++l) {
        const Level& level = levels[l];
        const std::string where = "level " + std::to_string(l);
        if (l > 0 && level.step <= levels[l - 1].step) {
            error = where + ": step " + std::to_string(level.step) + " is not above level " +
                    std::to_string(l - 1) + "'s step " + std::to_string(levels[l - 1].step);
            return false;
        }
        if (level.step > stepCount || stepCount > vertexCount) {
            error = where + ": step " + std::to_string(level.step) + " > step count " +
                    std::to_string(stepCount) + " or more steps than vertices";
            return false;
        }
        if (level.vertexCount != vertexCount - level.step) {
            error = where + ": vertexCount " + std::to_string(level.vertexCount) +
                    ", expected vertices - step = " + std::to_string(vertexCount - level.step);
            return false;
        }
        // Errors of the metrics present: finite, >= 0, non-decreasing (the river part within
        // the `max` error).
        const float values[3] = {level.errorMax, level.errorPaper, level.errorRiver};
        const bool present[3] = {(metrics & kMetricMax) != 0, (metrics & kMetricPaper) != 0,
                                 (metrics & kMetricMax) != 0};
        for (int k = 0; k < 3; ++k) {
            const float before = l == 0 ? 0.0f
                                 : k == 0 ? levels[l - 1].errorMax
                                 : k == 1 ? levels[l - 1].errorPaper
                                          : levels[l - 1].errorRiver;
            const bool ok = !present[k] || (std::isfinite(values[k]) && values[k] >= before);
            if (!ok) {
                error = where + ": an error is not finite, negative or below the level before";
                return false;
            }
        }
        if (present[0] && level.errorRiver > level.errorMax) {
            error = where + ": errorRiver exceeds errorMax";
            return false;
        }
    }
    return true;
}

bool validateBlockImpl(const Block& b, std::uint32_t metrics, std::string& error) {
    constexpr std::uint64_t kMax32 = std::numeric_limits<std::uint32_t>::max();
    bool tooBig = false;
    forEachArray(b, [&](const auto& v, int) { tooBig = tooBig || v.size() > kMax32; });
    if (tooBig) {
        error = "an array has more than 2^32 - 1 entries";
        return false;
    }

    const std::uint64_t n = b.vertices.size();
    const std::uint64_t stepCount = b.steps.size();
    if (!b.grid.empty() && b.grid.size() != n) {
        error = "grid has " + std::to_string(b.grid.size()) + " entries for " + std::to_string(n) +
                " vertices";
        return false;
    }
    if (!boxAndOriginValid(b, error)) return false;
    for (std::uint64_t i = 0; i < n; ++i) {
        if (!vertexValid(b, i, error)) return false;
    }

    // Retention order: the vertices alive before step s are [0, n - s), so step s deletes
    // vertex n - 1 - s. Anything else would break the engine's prefix rule.
    if (stepCount > n) {
        error = std::to_string(stepCount) + " steps but only " + std::to_string(n) + " vertices";
        return false;
    }
    for (std::uint64_t s = 0; s < stepCount; ++s) {
        if (b.steps[s].vertex != n - 1 - s) {
            error = "step " + std::to_string(s) + " deletes vertex " +
                    std::to_string(b.steps[s].vertex) + ", retention order requires " +
                    std::to_string(n - 1 - s);
            return false;
        }
        if ((b.vertices[n - 1 - s].flags & kVertexLocked) != 0) {
            error =
                "step " + std::to_string(s) + " deletes locked vertex " + std::to_string(n - 1 - s);
            return false;
        }
    }

    if (!checkOffsets(b.removedTriangleOffset, stepCount, b.removedTriangles.size(),
                      "removedTriangleOffset", error) ||
        !checkOffsets(b.addedTriangleOffset, stepCount, b.addedTriangles.size(),
                      "addedTriangleOffset", error) ||
        !checkOffsets(b.removedEdgeOffset, stepCount, b.removedEdges.size(), "removedEdgeOffset",
                      error) ||
        !checkOffsets(b.addedEdgeOffset, stepCount, b.addedEdges.size(), "addedEdgeOffset",
                      error)) {
        return false;
    }

    // Records of step s: removed elements existed before it (indices < n - s), added ones exist
    // after it (indices < n - s - 1, the deleted vertex is gone).
    for (std::uint64_t s = 0; s < stepCount; ++s) {
        auto where = [&] { return "step " + std::to_string(s); };
        for (auto i = b.removedTriangleOffset[s]; i < b.removedTriangleOffset[s + 1]; ++i) {
            if (!checkTriangle(b.removedTriangles[i], n - s, [&] { return where() + " removed"; }, error)) {
                return false;
            }
        }
        for (auto i = b.addedTriangleOffset[s]; i < b.addedTriangleOffset[s + 1]; ++i) {
            if (!checkTriangle(b.addedTriangles[i], n - s - 1, [&] { return where() + " added"; }, error)) {
                return false;
            }
        }
        for (auto i = b.removedEdgeOffset[s]; i < b.removedEdgeOffset[s + 1]; ++i) {
            if (!checkEdge(b.removedEdges[i], n - s, [&] { return where() + " removed"; }, error)) return false;
        }
        for (auto i = b.addedEdgeOffset[s]; i < b.addedEdgeOffset[s + 1]; ++i) {
            if (!checkEdge(b.addedEdges[i], n - s - 1, [&] { return where() + " added"; }, error)) return false;
        }
    }

    if (!checkErrors(b.errorMax, (metrics & kMetricMax) != 0, stepCount, "errorMax", error) ||
        !checkErrors(b.errorPaper, (metrics & kMetricPaper) != 0, stepCount, "errorPaper", error) ||
        !checkErrors(b.errorRiver, (metrics & kMetricMax) != 0, stepCount, "errorRiver", error)) {
        return false;
    }
    // The river part of the `max` error is part of it.
    for (std::size_t s = 0; s < b.errorRiver.size(); ++s) {
        if (b.errorRiver[s] > b.errorMax[s]) {
            error = "errorRiver[" + std::to_string(s) + "] exceeds errorMax[" + std::to_string(s) +
                    "]";
            return false;
        }
    }

    if (!levelTableValid(b.levels, n, stepCount, b.levels.empty() ? 0 : b.levels[0].triangleCount,
                         metrics, error))
        return false;

    // Alive counts replayed from the full resolution (levels[0]) through the records.
    std::vector<std::uint64_t> trianglesAlive(stepCount + 1), edgesAlive(stepCount + 1);
    trianglesAlive[0] = b.levels[0].triangleCount;
    edgesAlive[0] = b.levels[0].riverCount;
    for (std::uint64_t s = 0; s < stepCount; ++s) {
        const std::uint64_t removedT = b.removedTriangleOffset[s + 1] - b.removedTriangleOffset[s];
        const std::uint64_t addedT = b.addedTriangleOffset[s + 1] - b.addedTriangleOffset[s];
        const std::uint64_t removedE = b.removedEdgeOffset[s + 1] - b.removedEdgeOffset[s];
        const std::uint64_t addedE = b.addedEdgeOffset[s + 1] - b.addedEdgeOffset[s];
        const auto where = [&] { return "step " + std::to_string(s); };
        if (removedT > trianglesAlive[s] || removedE > edgesAlive[s]) {
            error = where() + " removes more triangles or river edges than are alive";
            return false;
        }
        trianglesAlive[s + 1] = trianglesAlive[s] - removedT + addedT;
        edgesAlive[s + 1] = edgesAlive[s] - removedE + addedE;
        if (b.steps[s].trianglesAlive != trianglesAlive[s + 1]) {
            error = where() + ": trianglesAlive is " + std::to_string(b.steps[s].trianglesAlive) +
                    " but the records give " + std::to_string(trianglesAlive[s + 1]);
            return false;
        }
        if (b.steps[s].riverEdgesAlive != edgesAlive[s + 1]) {
            error = where() + ": riverEdgesAlive is " + std::to_string(b.steps[s].riverEdgesAlive) +
                    " but the records give " + std::to_string(edgesAlive[s + 1]);
            return false;
        }
    }

    for (std::size_t l = 0; l < b.levels.size(); ++l) {
        const Level& level = b.levels[l];
        const std::string where = "level " + std::to_string(l);
        if (level.triangleCount != trianglesAlive[level.step] ||
            level.riverCount != edgesAlive[level.step]) {
            error = where + ": " + std::to_string(level.triangleCount) + " triangles and " +
                    std::to_string(level.riverCount) + " river edges, the records give " +
                    std::to_string(trianglesAlive[level.step]) + " and " +
                    std::to_string(edgesAlive[level.step]);
            return false;
        }
        if (std::uint64_t(level.triangleFirst) + level.triangleCount > b.terrainIndices.size()) {
            error = where + ": terrain range [" + std::to_string(level.triangleFirst) + ", +" +
                    std::to_string(level.triangleCount) + ") outside the " +
                    std::to_string(b.terrainIndices.size()) + " terrain triangles";
            return false;
        }
        if (std::uint64_t(level.riverFirst) + level.riverCount > b.riverIndices.size()) {
            error = where + ": river range [" + std::to_string(level.riverFirst) + ", +" +
                    std::to_string(level.riverCount) + ") outside the " +
                    std::to_string(b.riverIndices.size()) + " river edges";
            return false;
        }
        if (!validateLevelGeometryImpl(b, l, error)) return false;
        // The level's errors are the error table's at its step (what the engine's h_s is).
        const bool maxOk = (metrics & kMetricMax) == 0
                               ? level.errorRiver == 0
                               : level.errorMax == b.errorMax[level.step] &&
                                     level.errorRiver == b.errorRiver[level.step];
        const bool paperOk =
            (metrics & kMetricPaper) == 0 || level.errorPaper == b.errorPaper[level.step];
        if (!maxOk || !paperOk) {
            error = where + ": errors differ from the error table at step " +
                    std::to_string(level.step);
            return false;
        }
    }
    return true;
}

}  // namespace

bool validateBlock(const Block& block, std::uint32_t metrics, std::string& error) {
    if (!validateBlockImpl(block, metrics, error)) {
        error = blockName(block.col, block.row, block.level) + ": " + error;
        return false;
    }
    return true;
}

bool validateLevelGeometry(const Block& block, std::size_t level, std::string& error) {
    return validateLevelGeometryImpl(block, level, error);
}

bool validateLevelTable(const std::vector<Level>& levels, std::uint32_t vertexCount,
                        std::uint32_t stepCount, std::uint32_t fullTriangles,
                        std::uint32_t metrics, std::string& error) {
    return levelTableValid(levels, vertexCount, stepCount, fullTriangles, metrics, error);
}

bool outlineMoves(const Block& b) {
    if (b.levels.empty()) return false;
    const Level& last = b.levels.back();
    assert(std::size_t(last.triangleFirst) + last.triangleCount <= b.terrainIndices.size());
    // The directed edges of the coarsest level's triangles that no other triangle has reversed:
    // the outline.
    std::vector<std::pair<std::uint32_t, std::uint32_t>> directed;
    directed.reserve(3 * std::size_t(last.triangleCount));
    for (std::uint32_t i = 0; i < last.triangleCount; ++i) {
        const Triangle& t = b.terrainIndices[last.triangleFirst + i];
        directed.push_back({t.a, t.b}), directed.push_back({t.b, t.c}), directed.push_back({t.c, t.a});
    }
    std::sort(directed.begin(), directed.end());
    // Float vertices relative to the origin; the box in doubles: the reader's tolerance.
    auto on = [](double v, double side) {
        return std::fabs(v - side) <= kFloatSlack * std::fabs(side) + 2e-3;
    };
    const double x0 = b.minX - b.originX, x1 = b.maxX - b.originX;
    const double y0 = b.minY - b.originY, y1 = b.maxY - b.originY;
    for (const auto& [u, w] : directed) {
        if (std::binary_search(directed.begin(), directed.end(), std::make_pair(w, u))) continue;
        const Vertex &p = b.vertices[u], &q = b.vertices[w];
        const bool side = (on(p.x, x0) && on(q.x, x0)) || (on(p.x, x1) && on(q.x, x1)) ||
                          (on(p.y, y0) && on(q.y, y0)) || (on(p.y, y1) && on(q.y, y1));
        if (!side) return true;
    }
    return false;
}

bool levelFits(const Level& level, std::uint32_t metric, double hLim, double hRiver) {
    if (metric == kMetricPaper) return double(level.errorPaper) <= hLim;
    return double(level.errorMax) <= hLim && double(level.errorRiver) <= hRiver;
}

std::size_t storedLevelFor(const std::vector<Level>& levels, std::uint32_t metric, double hLim,
                           double hRiver) {
    assert(!levels.empty());
    std::size_t chosen = 0;
    for (std::size_t i = 0; i < levels.size(); ++i)
        if (levelFits(levels[i], metric, hLim, hRiver)) chosen = i;  // errors non-decreasing
    return chosen;
}

std::string blockName(std::uint32_t col, std::uint32_t row, std::uint32_t level) {
    if (level > 0) {
        return "node (" + std::to_string(col) + "," + std::to_string(row) + ") of tree level " +
               std::to_string(level);
    }
    return "block (" + std::to_string(col) + "," + std::to_string(row) + ")";
}

}  // namespace unilod::format
