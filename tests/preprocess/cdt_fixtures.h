// Fixed-seed blocks for the constrained Delaunay / deletion tests (paper §3.3): random or grid
// DEM points with meandering, non-crossing rivers and tributaries. Own PRNG (SplitMix64) so the
// inputs are identical on every platform.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numeric>
#include <vector>

#include "points.h"

namespace unilod::testing {

struct SplitMix64 {
    std::uint64_t state;
    explicit SplitMix64(std::uint64_t seed) : state(seed) {}
    std::uint64_t next() {
        std::uint64_t z = (state += 0x9E3779B97F4A7C15ull);
        z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
        z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
        return z ^ (z >> 31);
    }
    double uniform() { return double(next() >> 11) * (1.0 / 9007199254740992.0); }  // [0, 1)
    std::uint32_t below(std::uint32_t n) { return std::uint32_t(next() % n); }
};

inline double terrainZ(double x, double y) {
    return 200.0 + 40.0 * std::sin(x * 0.013) * std::cos(y * 0.011) + 0.02 * x +
           15.0 * std::sin(0.05 * (x + y));
}

struct BlockSpec {
    std::uint64_t seed = 1;
    std::uint32_t points = 2000;  // DEM points (approximately, for grids: side * side)
    std::uint32_t rivers = 3;     // main rivers (west to east), each with one tributary
    double size = 1000.0;         // square side, metres
    bool grid = false;            // exact grid (many cocircular points) instead of random
    bool lockBorder = true;       // lock the square's border points (hull)
};

// Points: the DEM points (random blocks: the four corners and the border points first), then the
// river vertices. River ends and junctions are locked; with lockBorder, the border points too.
inline PointSet makeBlock(const BlockSpec& spec) {
    SplitMix64 rng(spec.seed);
    PointSet set;
    const double s = spec.size;
    if (spec.grid) {
        const auto side = std::uint32_t(std::max(3.0, std::sqrt(double(spec.points))));
        const double step = s / (side - 1);
        for (std::uint32_t j = 0; j < side; ++j) {
            for (std::uint32_t i = 0; i < side; ++i) {
                Point p;
                p.x = i * step;
                p.y = j * step;
                p.z = terrainZ(p.x, p.y);
                p.locked = spec.lockBorder && (i == 0 || j == 0 || i + 1 == side || j + 1 == side);
                set.points.push_back(p);
            }
        }
    } else {
        for (double cx : {0.0, s}) {
            for (double cy : {0.0, s})
                set.points.push_back({cx, cy, terrainZ(cx, cy), PointKind::Dem, spec.lockBorder});
        }
        const std::uint32_t border = std::uint32_t(std::sqrt(double(spec.points)));
        for (std::uint32_t k = 1; k < border; ++k) {
            const double t = s * k / border;
            for (auto [x, y] : {std::pair{t, 0.0}, {t, s}, {0.0, t}, {s, t}}) {
                set.points.push_back({x, y, terrainZ(x, y), PointKind::Dem, spec.lockBorder});
            }
        }
        while (set.points.size() < spec.points) {
            const double x = s * (0.002 + 0.996 * rng.uniform());
            const double y = s * (0.002 + 0.996 * rng.uniform());
            set.points.push_back({x, y, terrainZ(x, y) + rng.uniform(), PointKind::Dem, false});
        }
    }
    auto addRiverPoint = [&](double x, double y, bool locked) {
        set.points.push_back({x, y, terrainZ(x, y) - 3.0, PointKind::River, locked});
        return PointId(set.points.size() - 1);
    };
    const double band = s / (spec.rivers + 1);
    const std::uint32_t verts =
        std::max<std::uint32_t>(8, std::uint32_t(std::sqrt(double(spec.points)) * 0.8));
    for (std::uint32_t r = 0; r < spec.rivers; ++r) {
        const double y0 = band * (r + 1), amp = band * 0.25, phase = rng.uniform() * 6.0;
        Polyline main;
        for (std::uint32_t k = 0; k < verts; ++k) {
            const double x = s * (0.05 + 0.9 * k / (verts - 1));
            const double y =
                y0 + amp * std::sin(phase + 9.0 * k / verts) + band * 0.03 * (rng.uniform() - 0.5);
            main.push_back(addRiverPoint(x, y, k == 0 || k + 1 == verts));
        }
        // A tributary from the north joining at the middle vertex (a junction, locked).
        const PointId junction = main[verts / 2];
        set.points[junction].locked = true;
        Polyline trib;
        const std::uint32_t tv = verts / 3;
        const double jx = set.points[junction].x, jy = set.points[junction].y;
        for (std::uint32_t k = tv; k-- > 1;) {
            const double x = jx - band * 0.3 * k / tv + band * 0.02 * (rng.uniform() - 0.5);
            const double y = jy + band * 0.1 + band * 0.35 * k / tv;
            trib.push_back(addRiverPoint(x, y, k + 1 == tv));
        }
        trib.push_back(junction);
        set.rivers.push_back(std::move(main));
        set.rivers.push_back(std::move(trib));
    }
    return set;
}

// A fixed-seed deletion order over the unlocked points (Fisher-Yates with SplitMix64).
inline std::vector<PointId> shuffledOrder(const PointSet& set, std::uint64_t seed) {
    std::vector<PointId> order;
    for (PointId i = 0; i < set.points.size(); ++i) {
        if (!set.points[i].locked) order.push_back(i);
    }
    SplitMix64 rng(seed);
    for (std::size_t i = order.size(); i > 1; --i)
        std::swap(order[i - 1], order[rng.below(std::uint32_t(i))]);
    return order;
}

}  // namespace unilod::testing
