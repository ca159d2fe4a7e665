// Rebuilds a Cdt (cdt.h) from a plain triangle list, so that the invariant checker (checker.h)
// can verify a triangulation read back from a .ulod file at any stored level.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "cdt.h"

namespace unilod {

// `gx`, `gy`: exact grid coordinates per vertex id; `locked`: per vertex id; `triangles`:
// counter-clockwise vertex triples; `riverEdges`: the constraint edges. Ghost triangles close the
// boundary. Returns false with `error` when the list is not a manifold triangulation with a
// single boundary loop per boundary vertex (an edge used twice in one direction, a vertex where
// two boundary edges start) or a river edge is not an edge of the triangles.
bool cdtFromTriangles(const std::vector<std::int32_t>& gx, const std::vector<std::int32_t>& gy,
                      const std::vector<std::uint8_t>& locked,
                      const std::vector<TriangleTriple>& triangles,
                      const std::vector<RiverEdge>& riverEdges, Cdt& cdt, std::string& error);

// Convexity of the boundary (the domain is the convex hull of the block's points): false with a
// message naming the first reflex boundary vertex.
bool boundaryIsConvex(const Cdt& cdt, std::string& error);

}  // namespace unilod
