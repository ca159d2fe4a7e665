// Tree nodes of the block hierarchy (nodebuild.h).
#include "nodebuild.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <map>
#include <unordered_map>
#include <unordered_set>

namespace unilod {

namespace {

std::uint64_t directedKey(PointId u, PointId w) {
    return (std::uint64_t(u) << 32) | w;
}

struct XYHash {
    std::size_t operator()(const std::pair<double, double>& p) const {
        const std::uint64_t a = std::bit_cast<std::uint64_t>(p.first);
        const std::uint64_t b = std::bit_cast<std::uint64_t>(p.second);
        return std::size_t(a * 0x9E3779B97F4A7C15ull ^ (b + 0x632BE59BD9B4E019ull + (a << 6)));
    }
};

}  // namespace

std::uint32_t nodeHandoffTriangles(std::uint64_t width, std::uint64_t height,
                                   std::uint64_t lockedCells, std::uint32_t level) {
    const std::uint64_t w = std::min<std::uint64_t>(width, 1u << 30),
                        h = std::min<std::uint64_t>(height, 1u << 30);
    const std::uint64_t border =
        2 * std::max(std::min<std::uint64_t>(lockedCells, 1ull << 40), 4 * std::min(w, h));
    const std::uint64_t area = w * h / 8;
    const std::uint64_t count = level == 0 ? std::max(area, border) : border;
    return std::uint32_t(std::clamp<std::uint64_t>(count, 64, 1u << 30));
}

double nodeHandoffError(double blockExtent, double modelExtent, std::uint32_t level,
                        double pixels) {
    return std::min(std::ldexp(blockExtent, int(std::min<std::uint32_t>(level, 60))) / pixels,
                    modelExtent / kRootPixels);
}

PointSet nodePointSet(const std::vector<const CoarseState*>& children, const NodeBorder& border,
                      std::unordered_map<std::uint64_t, RiverCover>* riverCover) {
    PointSet set;
    std::unordered_map<std::pair<double, double>, PointId, XYHash> ids;
    std::vector<TriangleTriple> triangles;
    std::vector<RiverEdge> rivers;
    for (const CoarseState* child : children) {
        std::vector<PointId> map(child->points.size());
        for (std::size_t i = 0; i < child->points.size(); ++i) {
            const Point& p = child->points[i];
            auto [it, fresh] = ids.try_emplace({p.x, p.y}, PointId(set.points.size()));
            if (fresh) {
                Point q = p;
                q.locked = false;
                set.points.push_back(q);
            } else if (p.kind == PointKind::River) {
                set.points[it->second].kind = PointKind::River;
            }
            map[i] = it->second;
        }
        for (const TriangleTriple& t : child->triangles)
            triangles.push_back({{map[t.v[0]], map[t.v[1]], map[t.v[2]]}});
        for (std::size_t k = 0; k < child->rivers.size(); ++k) {
            const RiverEdge& e = child->rivers[k];
            const PointId a = map[e.a], b = map[e.b];
            rivers.push_back({std::min(a, b), std::max(a, b)});
            if (riverCover != nullptr && k < child->riverCover.size()) {
                // (An edge two children share lies on their locked border: nothing deleted.)
                const auto [it, fresh] = riverCover->try_emplace(
                    directedKey(std::min(a, b), std::max(a, b)), child->riverCover[k]);
                if (!fresh && child->riverCover[k].points.size() > it->second.points.size())
                    it->second = child->riverCover[k];
            }
        }
    }
    const std::size_t n = set.points.size();
    // The node's outer border lines.
    for (Point& p : set.points) {
        if ((border.lockX0 && p.x == border.x0) || (border.lockX1 && p.x == border.x1) ||
            (border.lockY0 && p.y == border.y0) || (border.lockY1 && p.y == border.y1))
            p.locked = true;
    }

    // Outline: directed triangle edges whose reverse no triangle has (the domain on the left of
    // a counter-clockwise triangle's edges), chained into rings.
    std::unordered_set<std::uint64_t> directed;
    directed.reserve(triangles.size() * 3);
    for (const TriangleTriple& t : triangles)
        for (int i = 0; i < 3; ++i)
            directed.insert(directedKey(t.v[i], t.v[(i + 1) % 3]));
    std::vector<std::pair<PointId, PointId>> outline;
    for (const TriangleTriple& t : triangles) {
        for (int i = 0; i < 3; ++i) {
            const PointId u = t.v[i], w = t.v[(i + 1) % 3];
            if (!directed.count(directedKey(w, u))) outline.push_back({u, w});
        }
    }
    std::sort(outline.begin(), outline.end());  // deterministic chaining
    std::vector<std::uint32_t> firstOut(n + 1, 0);
    for (const auto& e : outline)
        ++firstOut[e.first + 1];
    for (std::size_t v = 0; v < n; ++v)
        firstOut[v + 1] += firstOut[v];
    for (std::size_t v = 0; v < n; ++v) {
        if (firstOut[v + 1] - firstOut[v] > 1) set.points[v].locked = true;  // a pinch point
    }
    std::vector<std::uint8_t> used(outline.size(), 0);
    for (std::size_t e0 = 0; e0 < outline.size(); ++e0) {
        if (used[e0]) continue;
        Polyline ring;
        std::size_t e = e0;
        for (;;) {
            used[e] = 1;
            ring.push_back(outline[e].first);
            const PointId to = outline[e].second;
            std::size_t next = firstOut[to];
            while (next < firstOut[to + 1] && used[next])
                ++next;
            if (next == firstOut[to + 1]) break;
            e = next;
        }
        set.boundaries.push_back(std::move(ring));
    }

    // Rivers: the coarsest river edges chained into polylines between vertices of degree != 2
    // (ends and junctions, locked); a closed loop starts at its lowest vertex (locked).
    std::sort(rivers.begin(), rivers.end());
    rivers.erase(std::unique(rivers.begin(), rivers.end()), rivers.end());
    std::vector<std::uint32_t> degree(n, 0);
    for (const RiverEdge& e : rivers) {
        ++degree[e.a];
        ++degree[e.b];
    }
    std::vector<std::uint32_t> firstEdge(n + 1, 0);
    for (std::size_t v = 0; v < n; ++v)
        firstEdge[v + 1] = firstEdge[v] + degree[v];
    std::vector<std::uint32_t> incident(firstEdge[n]), fill(firstEdge.begin(), firstEdge.end() - 1);
    for (std::uint32_t i = 0; i < rivers.size(); ++i) {
        incident[fill[rivers[i].a]++] = i;
        incident[fill[rivers[i].b]++] = i;
    }
    std::vector<std::uint8_t> walked(rivers.size(), 0);
    auto walk = [&](PointId start, std::uint32_t edge) {
        Polyline line{start};
        PointId v = start;
        for (;;) {
            walked[edge] = 1;
            v = rivers[edge].a == v ? rivers[edge].b : rivers[edge].a;
            line.push_back(v);
            if (degree[v] != 2 || v == start) break;
            const std::uint32_t* inc = &incident[firstEdge[v]];
            edge = walked[inc[0]] ? inc[1] : inc[0];
            if (walked[edge]) break;
        }
        set.rivers.push_back(std::move(line));
    };
    for (PointId v = 0; v < n; ++v) {
        if (degree[v] == 0) continue;
        set.points[v].kind = PointKind::River;
        if (degree[v] == 2) continue;
        set.points[v].locked = true;
        for (std::uint32_t k = firstEdge[v]; k < firstEdge[v + 1]; ++k)
            if (!walked[incident[k]]) walk(v, incident[k]);
    }
    for (std::uint32_t i = 0; i < rivers.size(); ++i) {
        if (walked[i]) continue;
        set.points[rivers[i].a].locked = true;
        walk(rivers[i].a, i);
    }
    return set;
}

bool buildNode(const std::vector<const CoarseState*>& children, const NodeBorder& border,
               std::uint32_t col, std::uint32_t row, const BlockBuildOptions& options,
               const std::function<void(const std::function<void(const Point&)>&)>& originals,
               std::size_t originalCount, format::Block& block, BlockBuildStats& stats,
               CoarseState& coarse, std::string& error, const OriginalGrid* grid) {
    NodeErrorInput input;
    input.originals = originals;
    input.originalCount = originalCount;
    input.grid = grid;
    for (const CoarseState* child : children) {
        input.errorFloor = std::max(input.errorFloor, child->errorMax);
        input.riverFloor = std::max(input.riverFloor, child->errorRiver);
    }
    const PointSet set = nodePointSet(children, border, &input.riverCover);
    return buildBlock(set, col, row, options, block, stats, error, &input, &coarse);
}

}  // namespace unilod
