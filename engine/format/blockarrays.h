// THE table of a block's arrays, in raw-file order (README.md "Raw arrays"): the writer and the
// reader (ulod.cpp: byte layout, header counts, size check) and validation (validate.cpp) all walk
// it, so the order and the element sizes (the vectors' element types) are written once.
// Internal to the format library.
#pragma once

#include "ulod.h"

namespace unilod::format {

inline constexpr int kArrayCount = 17;

// f(vector, i) for the arrays i = 0 .. kArrayCount - 1 in file order.
template <typename B, typename F>
void forEachArray(B& b, F&& f) {
    f(b.vertices, 0);
    f(b.steps, 1);
    f(b.removedTriangleOffset, 2);
    f(b.addedTriangleOffset, 3);
    f(b.removedEdgeOffset, 4);
    f(b.addedEdgeOffset, 5);
    f(b.removedTriangles, 6);
    f(b.addedTriangles, 7);
    f(b.removedEdges, 8);
    f(b.addedEdges, 9);
    f(b.errorMax, 10);
    f(b.errorPaper, 11);
    f(b.errorRiver, 12);
    f(b.levels, 13);
    f(b.terrainIndices, 14);
    f(b.riverIndices, 15);
    f(b.grid, 16);
}

}  // namespace unilod::format
