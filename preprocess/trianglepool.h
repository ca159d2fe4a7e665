// Points bucketed per triangle in one pool: triangle t's points are pool[rangeStart[t]] ..
// pool[rangeStart[t] + rangeCount[t] - 1]. Ranges of destroyed triangles become garbage and new
// ranges are appended, so the pool is compacted from time to time. Used by the greedy-insertion
// TIN (greedytin.h) and the model error (modelerror.h), after Garland & Heckbert's point lists.
#pragma once

#include <algorithm>
#include <cstdint>
#include <vector>

#include "cdt.h"

namespace unilod {

// Moves the ranges of the alive triangles that hold points to the front of `pool`, keeping their
// order, and drops everything else. `scratch` is working memory.
template <class PoolPoint>
void compactTrianglePool(const Cdt& cdt, std::vector<PoolPoint>& pool,
                         std::vector<std::uint32_t>& rangeStart,
                         const std::vector<std::uint32_t>& rangeCount,
                         std::vector<std::uint32_t>& scratch) {
    std::vector<std::uint32_t>& live = scratch;
    live.clear();
    for (std::uint32_t t = 0; t < cdt.triangleSlots(); ++t) {
        if (rangeCount[t] > 0 && cdt.triangleAlive(t)) live.push_back(t);
    }
    std::sort(live.begin(), live.end(),
              [&](std::uint32_t a, std::uint32_t b) { return rangeStart[a] < rangeStart[b]; });
    std::uint32_t w = 0;
    for (std::uint32_t t : live) {
        std::copy(pool.begin() + rangeStart[t], pool.begin() + rangeStart[t] + rangeCount[t],
                  pool.begin() + w);
        rangeStart[t] = w;
        w += rangeCount[t];
    }
    pool.resize(w);
}

}  // namespace unilod
