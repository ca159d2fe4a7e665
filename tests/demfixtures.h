// DEM fixtures shared by tests of different areas.
#pragma once

#include <cmath>
#include <cstddef>

#include "dem.h"

namespace unilod::test {

// A 36 x 36 DEM of 30 m cells with relief (a plane plus 20 m waves) whose valid data is a disc
// with a bite out of its side and a hole: a concave outline and an inner ring, whose corners
// the greedy order cuts when the outer edge is not locked.
inline DemGrid discWithBiteAndHole() {
    DemGrid d;
    d.width = d.height = 36;
    d.originX = 500000;
    d.originY = 4000000;
    d.cellX = 30;
    d.cellY = -30;
    for (int r = 0; r < d.height; ++r) {
        for (int c = 0; c < d.width; ++c) {
            const double x = c - 17.5, y = r - 17.5;
            const bool disc = x * x + y * y < 16.5 * 16.5;
            const bool bite = (x - 8) * (x - 8) + y * y < 8.0 * 8.0;
            const bool hole = (x + 7) * (x + 7) + (y - 2) * (y - 2) < 3.2 * 3.2;
            d.z.push_back(!disc || bite || hole
                              ? NAN
                              : float(100 + 2 * c + 3 * r) +
                                    float(20.0 * std::sin(c / 4.0) * std::cos(r / 5.0)));
        }
    }
    return d;
}

}  // namespace unilod::test
