// Exact geometric predicates on integer grid coordinates (paper §3.3: the river-constrained
// Delaunay triangulation; DESIGN.md "use exact predicates ... no epsilon-based orientation tests").
//
// Every block is quantised to a fixed grid (cdt.h) and every coordinate handed to these functions
// satisfies |c| <= kMaxGridCoordinate = 2^28 - 1. Then:
//   orient2d: coordinate differences < 2^29, products < 2^58, result < 2^59   -> exact in int64.
//   incircle: lifted terms dx^2 + dy^2 < 2^59 and 2x2 minors < 2^59 fit int64; their products are
//             < 2^118 and the sum of three < 2^120                              -> exact in int128.
// No floating point, no epsilon: the sign is always the true sign.
//
// The file lives with the .ulod format because the format owns the exact grid (GridXY, kGridUnit
// in ulod.h): the reader checks the orientation of every stored triangle with orient2d, and
// preprocess builds the triangulation with the same predicates (one definition of each).
#pragma once

#include <cstdint>

namespace unilod {

__extension__ typedef __int128 Int128;

inline constexpr std::int64_t kMaxGridCoordinate = (std::int64_t{1} << 28) - 1;

// Twice the signed area of (a, b, c): > 0 counter-clockwise, < 0 clockwise, 0 collinear.
inline std::int64_t orient2d(std::int64_t ax, std::int64_t ay, std::int64_t bx, std::int64_t by,
                             std::int64_t cx, std::int64_t cy) {
    return (bx - ax) * (cy - ay) - (by - ay) * (cx - ax);
}

// > 0 when d lies strictly inside the circle through the counter-clockwise triangle (a, b, c),
// 0 when the four points are cocircular, < 0 outside.
inline int incircle(std::int64_t ax, std::int64_t ay, std::int64_t bx, std::int64_t by,
                    std::int64_t cx, std::int64_t cy, std::int64_t dx, std::int64_t dy) {
    const std::int64_t adx = ax - dx, ady = ay - dy;
    const std::int64_t bdx = bx - dx, bdy = by - dy;
    const std::int64_t cdx = cx - dx, cdy = cy - dy;
    const std::int64_t alift = adx * adx + ady * ady;
    const std::int64_t blift = bdx * bdx + bdy * bdy;
    const std::int64_t clift = cdx * cdx + cdy * cdy;
    const Int128 det = Int128(alift) * (bdx * cdy - cdx * bdy) +
                       Int128(blift) * (cdx * ady - adx * cdy) +
                       Int128(clift) * (adx * bdy - bdx * ady);
    return det > 0 ? 1 : (det < 0 ? -1 : 0);
}

// The tie-break of incirclePerturbed (below): the sign of the coefficient of the (x, y)-smallest
// point whose coefficient is not zero. Out of line: about a third of the calls on grid data
// (cocircular cell corners), but longer than the determinant it follows.
[[gnu::noinline]] inline int incircleTieBreak(std::int64_t ax, std::int64_t ay, std::int64_t bx,
                                              std::int64_t by, std::int64_t cx, std::int64_t cy,
                                              std::int64_t dx, std::int64_t dy) {
    const std::int64_t x[4] = {ax, bx, cx, dx}, y[4] = {ay, by, cy, dy};
    const std::int64_t coefficient[4] = {orient2d(dx, dy, bx, by, cx, cy),
                                         orient2d(dx, dy, cx, cy, ax, ay),
                                         orient2d(dx, dy, ax, ay, bx, by),
                                         -orient2d(ax, ay, bx, by, cx, cy)};
    int first = -1;
    for (int i = 0; i < 4; ++i) {
        if (coefficient[i] == 0) continue;
        if (first < 0 || x[i] < x[first] || (x[i] == x[first] && y[i] < y[first])) first = i;
    }
    return first < 0 ? 0 : (coefficient[first] > 0 ? 1 : -1);
}

// incircle with ties broken by a symbolic perturbation, so that the Delaunay triangulation of
// any point set (with given constraints) is unique: each point's lifted height x^2 + y^2 is
// raised by an infinitesimal e_q, with e_q >> e_r whenever q precedes r in (x, y) lexicographic
// order (the idea of Devillers & Teillaud, "Perturbations and vertex removal in a 3D Delaunay
// triangulation", SODA 2003). A cocircular (a, b, c, d) then gets the sign of the first non-zero
// derivative of the determinant along that order: raising a, b or c adds orient2d of the other
// two with d (d, b, c / d, c, a / d, a, b), raising d subtracts orient2d(a, b, c). The order is
// translation invariant, so a block and a tree node break ties alike: the triangulation a node
// starts from is exactly the union of its children's (nodebuild.h). 0 only when all four points
// are collinear.
inline int incirclePerturbed(std::int64_t ax, std::int64_t ay, std::int64_t bx, std::int64_t by,
                             std::int64_t cx, std::int64_t cy, std::int64_t dx, std::int64_t dy) {
    const int s = incircle(ax, ay, bx, by, cx, cy, dx, dy);
    if (s != 0) [[likely]]
        return s;
    return incircleTieBreak(ax, ay, bx, by, cx, cy, dx, dy);
}

// Exact test whether p lies on the closed segment [a, b], given orient2d(a, b, p) == 0.
inline bool betweenCollinear(std::int64_t ax, std::int64_t ay, std::int64_t bx, std::int64_t by,
                             std::int64_t px, std::int64_t py) {
    const std::int64_t dot = (px - ax) * (bx - ax) + (py - ay) * (by - ay);
    const std::int64_t len = (bx - ax) * (bx - ax) + (by - ay) * (by - ay);
    return dot >= 0 && dot <= len;
}

}  // namespace unilod
