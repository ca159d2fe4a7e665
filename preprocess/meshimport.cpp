// Cdt from a triangle list (meshimport.h). Half-edge conventions as in cdt.h: half-edge 3t + i
// is opposite vertex i and runs from tv[3t + (i+1)%3] to tv[3t + (i+2)%3]; the ghost triangle
// across boundary half-edge u -> v is (v, u, kGhost), whose half-edge 2 runs v -> u.
#include "meshimport.h"

#include <unordered_map>

namespace unilod {

namespace {
std::uint64_t key(PointId a, PointId b) {
    return std::uint64_t(a) << 32 | b;
}
}  // namespace

bool cdtFromTriangles(const std::vector<std::int32_t>& gx, const std::vector<std::int32_t>& gy,
                      const std::vector<std::uint8_t>& locked,
                      const std::vector<TriangleTriple>& triangles,
                      const std::vector<RiverEdge>& riverEdges, Cdt& cdt, std::string& error) {
    const auto n = static_cast<PointId>(gx.size());
    cdt = Cdt{};
    cdt.gx = gx;
    cdt.gy = gy;
    cdt.locked = locked;
    cdt.representative.resize(n);
    for (PointId v = 0; v < n; ++v)
        cdt.representative[v] = v;
    cdt.vertexTriangle.assign(n, Cdt::kNone);

    const auto real = static_cast<std::uint32_t>(triangles.size());
    cdt.tv.reserve(6 * std::size_t(real) + 6);
    for (const TriangleTriple& t : triangles) {
        for (PointId v : t.v) {
            if (v >= n) {
                error = "triangle uses vertex " + std::to_string(v) + " of " + std::to_string(n);
                return false;
            }
        }
        cdt.tv.insert(cdt.tv.end(), {t.v[0], t.v[1], t.v[2]});
    }
    std::unordered_map<std::uint64_t, std::uint32_t> half;  // directed edge -> half-edge
    half.reserve(3 * std::size_t(real) * 2);
    for (std::uint32_t h = 0; h < 3 * real; ++h) {
        const PointId a = cdt.tv[h - h % 3 + (h % 3 + 1) % 3],
                      b = cdt.tv[h - h % 3 + (h % 3 + 2) % 3];
        if (!half.emplace(key(a, b), h).second) {
            error = "edge " + std::to_string(a) + " -> " + std::to_string(b) +
                    " is used twice in the same direction (overlapping triangles)";
            return false;
        }
    }
    cdt.tn.assign(3 * std::size_t(real), Cdt::kNone);
    std::unordered_map<PointId, std::uint32_t> ghostFrom;  // boundary vertex -> its ghost
    for (std::uint32_t h = 0; h < 3 * real; ++h) {
        const PointId a = cdt.tv[h - h % 3 + (h % 3 + 1) % 3],
                      b = cdt.tv[h - h % 3 + (h % 3 + 2) % 3];
        const auto twin = half.find(key(b, a));
        if (twin != half.end()) {
            cdt.tn[h] = twin->second;
            continue;
        }
        const auto g = static_cast<std::uint32_t>(cdt.tv.size() / 3);
        cdt.tv.insert(cdt.tv.end(), {b, a, Cdt::kGhost});
        cdt.tn.insert(cdt.tn.end(), {Cdt::kNone, Cdt::kNone, h});
        cdt.tn[h] = 3 * g + 2;
        if (!ghostFrom.emplace(b, g).second) {
            error = "vertex " + std::to_string(b) + " starts two boundary edges (pinched boundary)";
            return false;
        }
    }
    // Ghost g = (v, u, G): half-edge 0 runs u -> G, its twin is half-edge 1 (G -> u) of the ghost
    // that starts at u.
    for (std::uint32_t g = real; g < cdt.tv.size() / 3; ++g) {
        const PointId u = cdt.tv[3 * g + 1];
        const auto next = ghostFrom.find(u);
        if (next == ghostFrom.end()) {
            error = "boundary is not closed at vertex " + std::to_string(u);
            return false;
        }
        cdt.tn[3 * g] = 3 * next->second + 1;
        cdt.tn[3 * next->second + 1] = 3 * g;
    }
    const auto slots = static_cast<std::uint32_t>(cdt.tv.size() / 3);
    cdt.tc.assign(slots, 0);
    cdt.stamp.assign(slots, 0);
    for (const RiverEdge& e : riverEdges) {
        const auto ab = half.find(key(e.a, e.b)), ba = half.find(key(e.b, e.a));
        if (ab == half.end() && ba == half.end()) {
            error = "river edge (" + std::to_string(e.a) + ", " + std::to_string(e.b) +
                    ") is not an edge of the triangulation";
            return false;
        }
        for (const auto& it : {ab, ba}) {
            if (it == half.end()) continue;
            const std::uint32_t h = it->second;
            cdt.tc[h / 3] |= std::uint8_t(1u << (h % 3));
            const std::uint32_t t = cdt.tn[h];
            cdt.tc[t / 3] |= std::uint8_t(1u << (t % 3));
        }
    }
    for (std::uint32_t t = 0; t < real; ++t) {
        for (int i = 0; i < 3; ++i) {
            if (cdt.vertexTriangle[cdt.tv[3 * t + i]] == Cdt::kNone) {
                cdt.vertexTriangle[cdt.tv[3 * t + i]] = t;
                ++cdt.vertexCount;
            }
        }
    }
    cdt.realTriangleCount = real;
    cdt.constraintEdgeCount = static_cast<std::uint32_t>(riverEdges.size());
    return true;
}

bool boundaryIsConvex(const Cdt& cdt, std::string& error) {
    for (std::uint32_t g = 0; g < cdt.triangleSlots(); ++g) {
        if (!cdt.triangleAlive(g) || cdt.tv[3 * g + 2] != Cdt::kGhost) continue;
        // Ghost (v, u, G): boundary edge u -> v. The ghost across half-edge 1 (G -> v) starts at
        // v: (w, v, G), the next boundary edge v -> w.
        const PointId v = cdt.tv[3 * g], u = cdt.tv[3 * g + 1];
        const std::uint32_t next = cdt.tn[3 * g + 1] / 3;
        const PointId w = cdt.tv[3 * next];
        if (cdt.orient(u, v, w) < 0) {
            error = "the boundary turns right at vertex " + std::to_string(v) +
                    " (the domain is not convex)";
            return false;
        }
    }
    return true;
}

}  // namespace unilod
