// Points bucketed per triangle in one pool: triangle t's points are pool[rangeStart[t]] ..
// pool[rangeStart[t] + rangeCount[t] - 1]. Ranges of destroyed triangles become garbage and new
// ranges are appended, so the pool is compacted from time to time. Used by the greedy-insertion
// TIN (greedytin.h) and the model error (modelerror.h), after Garland & Heckbert's point lists.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "cdt.h"

namespace unilod {

// Pools of at most this many points compact by copying into a second buffer (no sort); larger
// ones (a tree root's holds every original point of the model) in place.
inline constexpr std::size_t kCopyCompactPoints = std::size_t(1) << 20;

// Drops the ranges of destroyed (or empty) triangles from `pool`, keeping each live range's
// points in their order. A small pool is copied range by range, in slot order, into `spare`
// (reserved to the pool's capacity), which then becomes the pool; a large one is compacted in
// place, ranges moved to the front by start. `scratch` is working memory; `copyLimit` (tests)
// the largest pool that is copied.
template <class PoolPoint>
void compactTrianglePool(const Cdt& cdt, std::vector<PoolPoint>& pool,
                         std::vector<std::uint32_t>& rangeStart,
                         const std::vector<std::uint32_t>& rangeCount,
                         std::vector<PoolPoint>& spare, std::vector<std::uint64_t>& scratch,
                         std::size_t copyLimit = kCopyCompactPoints) {
    if (pool.size() <= copyLimit) {
        spare.clear();
        spare.reserve(pool.capacity());
        for (std::uint32_t t = 0; t < cdt.triangleSlots(); ++t) {
            if (rangeCount[t] == 0 || !cdt.triangleAlive(t)) continue;
            const std::uint32_t start = rangeStart[t];
            rangeStart[t] = std::uint32_t(spare.size());
            spare.insert(spare.end(), pool.begin() + start, pool.begin() + start + rangeCount[t]);
        }
        pool.swap(spare);
        return;
    }
    // The live ranges by start (starts of non-empty ranges are distinct), as (start, slot)
    // pairs packed in one integer: sorted without indirection.
    std::vector<std::uint64_t>& live = scratch;
    live.clear();
    for (std::uint32_t t = 0; t < cdt.triangleSlots(); ++t) {
        if (rangeCount[t] > 0 && cdt.triangleAlive(t))
            live.push_back(std::uint64_t(rangeStart[t]) << 32 | t);
    }
    std::sort(live.begin(), live.end());
    std::uint32_t w = 0;
    for (std::uint64_t k : live) {
        const std::uint32_t t = std::uint32_t(k), start = std::uint32_t(k >> 32);
        if (start != w)
            std::copy(pool.begin() + start, pool.begin() + start + rangeCount[t], pool.begin() + w);
        rangeStart[t] = w;
        w += rangeCount[t];
    }
    pool.resize(w);
    std::vector<std::uint64_t>().swap(live);
}

}  // namespace unilod
