// The stored levels' index data of a block, derived from its full-resolution mesh and its
// topology-change records (issue 4, paper §3.4). One implementation for the builder
// (preprocess/lodindex.cpp) and the compact block decoder (blockcodec.cpp), which stores no index
// data and derives it again.
//
// Layout. Levels are stored in pairs (fine F, coarse C) as [F \ C | F n C | C \ F], each part
// sorted by (a, b, c): F is the first two parts, C the last two, and the triangles the two share
// are stored once. River edges are laid out the same way.
#pragma once

#include <string>
#include <vector>

#include "ulod.h"

namespace unilod::format {

// A triangle rotated so that its smallest vertex index comes first (the cyclic order, hence the
// orientation, is kept). Every triangle of a built block is stored this way.
inline Triangle canonicalTriangle(Triangle t) {
    if (t.b < t.a && t.b < t.c) return {t.b, t.c, t.a};
    if (t.c < t.a && t.c < t.b) return {t.c, t.a, t.b};
    return t;
}
inline bool lessIndex(const Triangle& l, const Triangle& r) {
    return l.a != r.a ? l.a < r.a : (l.b != r.b ? l.b < r.b : l.c < r.c);
}
inline bool lessIndex(const Edge& l, const Edge& r) {
    return l.a != r.a ? l.a < r.a : l.b < r.b;
}
// The same element: every index equal, in order.
inline bool sameIndex(const Triangle& l, const Triangle& r) {
    return l.a == r.a && l.b == r.b && l.c == r.c;
}
inline bool sameIndex(const Edge& l, const Edge& r) {
    return l.a == r.a && l.b == r.b;
}

// An element's life: alive after k deletion steps iff birth <= k < death (kAliveToTheEnd: never
// removed).
inline constexpr std::uint32_t kAliveToTheEnd = 0xFFFFFFFFu;
template <class T>
struct Life {
    T item;
    std::uint32_t birth, death;
    bool aliveAt(std::uint32_t k) const { return birth <= k && k < death; }
};

// Fills block.terrainIndices, block.riverIndices and every level's ranges from the lives of every
// triangle and river edge (the decoder's replay knows them) and the level steps in block.levels.
void layOutLevels(Block& block, std::vector<Life<Triangle>>& triangles,
                  std::vector<Life<Edge>>& edges);

// The same from the records: fills block.terrainIndices, block.riverIndices and every level's
// triangleFirst/Count and riverFirst/Count from the level steps already in block.levels, the
// records (removed/added triangles and edges with their offsets) and the mesh before the first
// step. Returns false with `error` when a step removes an element that is not alive or adds one
// that is.
bool layOutLevels(Block& block, const std::vector<Triangle>& initialTriangles,
                  const std::vector<Edge>& initialEdges, std::string& error);

}  // namespace unilod::format
