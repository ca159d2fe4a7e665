// The directed edges a -> b of a set of triangles, bucketed by a: a counting sort over the
// vertices (O(n + t)), each bucket holding the other ends of a vertex's edges (its degree: a few
// entries). One implementation for the level validation (validate.cpp: no directed edge twice,
// every river edge an edge of the level) and the engine's refinement tables (engine/lod/
// refine.cpp: the outline, the edges whose reverse is absent).
#pragma once

#include <algorithm>
#include <cstdint>
#include <vector>

#include "ulod.h"

namespace unilod::format {

class DirectedEdges {
public:
    // The edges of the triangles [first, last), whose vertex indices are below `vertexCount`
    // (the caller's check). A bucket larger than kSmallBucket is sorted (searched by halves); the
    // others keep the triangles' order (checked and searched entry by entry).
    DirectedEdges(const Triangle* first, const Triangle* last, std::size_t vertexCount)
        : start_(vertexCount + 1, 0) {
        const auto each = [&](auto&& f) {
            for (const Triangle* t = first; t != last; ++t) {
                f(t->a, t->b);
                f(t->b, t->c);
                f(t->c, t->a);
            }
        };
        each([&](std::uint32_t from, std::uint32_t) { ++start_[from + 1]; });
        for (std::size_t v = 0; v < vertexCount; ++v)
            start_[v + 1] += start_[v];
        to_.resize(start_[vertexCount]);
        std::vector<std::uint64_t> fill(start_.begin(), start_.end() - 1);
        each([&](std::uint32_t from, std::uint32_t to) { to_[fill[from]++] = to; });
        for (std::size_t v = 0; v < vertexCount; ++v)
            if (start_[v + 1] - start_[v] > kSmallBucket)
                std::sort(to_.begin() + std::ptrdiff_t(start_[v]),
                          to_.begin() + std::ptrdiff_t(start_[v + 1]));
    }

    // Whether the edge from -> to is one of them.
    bool has(std::uint32_t from, std::uint32_t to) const {
        const auto first = to_.begin() + std::ptrdiff_t(start_[from]);
        const auto last = to_.begin() + std::ptrdiff_t(start_[from + 1]);
        if (std::uint64_t(last - first) <= kSmallBucket) return std::find(first, last, to) != last;
        return std::binary_search(first, last, to);
    }

    // The smallest `to` with from -> to twice among them; kNoRepeat when none.
    static constexpr std::uint64_t kNoRepeat = ~std::uint64_t(0);
    std::uint64_t repeat(std::uint32_t from) const {
        const auto first = to_.begin() + std::ptrdiff_t(start_[from]);
        const auto last = to_.begin() + std::ptrdiff_t(start_[from + 1]);
        std::uint64_t twice = kNoRepeat;
        if (std::uint64_t(last - first) <= kSmallBucket) {
            for (auto i = first; i != last; ++i)
                for (auto j = i + 1; j != last; ++j)
                    if (*i == *j) twice = std::min<std::uint64_t>(twice, *i);
        } else {
            const auto at = std::adjacent_find(first, last);
            if (at != last) twice = *at;
        }
        return twice;
    }

private:
    static constexpr std::uint64_t kSmallBucket = 16;
    std::vector<std::uint64_t> start_;
    std::vector<std::uint32_t> to_;
};

}  // namespace unilod::format
