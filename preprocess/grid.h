// Fixed-grid integer coordinates for exact geometric predicates (DESIGN.md: "exact predicates, no
// epsilon orientation tests"). Points are rounded once to a grid of kGridUnit metres relative to a
// common origin; orientation / collinearity are then decided exactly with 64/128-bit integers.
#pragma once

#include <cmath>
#include <cstdint>
#include <vector>

#include "points.h"

namespace unilod {

__extension__ typedef __int128 Int128;

inline constexpr double kGridUnit = 1e-3;  // 1 mm
// Largest accepted |grid coordinate| (about 1100 km from the origin at 1 mm): keeps every cross
// product of coordinate differences exact in 128 bits.
inline constexpr std::int64_t kGridLimit = std::int64_t{1} << 40;

struct GridPoint {
    std::int64_t x = 0, y = 0, z = 0;
    bool operator==(const GridPoint&) const = default;
};

struct Quantizer {
    double ox = 0, oy = 0, oz = 0;  // grid origin (metres): the bounding box minimum
    // Origin at the bounding-box minimum of the points (zero for an empty set).
    static Quantizer forPoints(const std::vector<Point>& points);
    GridPoint operator()(const Point& p) const {
        return {std::llround((p.x - ox) / kGridUnit), std::llround((p.y - oy) / kGridUnit),
                std::llround((p.z - oz) / kGridUnit)};
    }
    // True when p quantises inside kGridLimit.
    bool fits(const Point& p) const;
};

// Sign of the 2D orientation of (a, b, c) in the xy plane: +1 counter-clockwise (left turn),
// -1 clockwise, 0 collinear. Exact.
inline int orient2d(const GridPoint& a, const GridPoint& b, const GridPoint& c) {
    const Int128 det =
        Int128(b.x - a.x) * Int128(c.y - a.y) - Int128(b.y - a.y) * Int128(c.x - a.x);
    return det > 0 ? 1 : (det < 0 ? -1 : 0);
}

}  // namespace unilod
