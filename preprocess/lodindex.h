// LOD index data of one block (issue 4, paper §3.4): from the full triangulation and the deletion
// records, the vertices in retention order, the stored levels and their index ranges, so that the
// engine draws ONE contiguous index range for the terrain (and one for the river lines) per block.
//
// Levels. T(k), the triangles alive after k deletions, falls by exactly 2 per step (every deleted
// vertex is interior and the domain never changes). Level 0 is step 0; level j + 1 is the first
// step k with T(k_j) > ratio * T(k), so for every step k the finest stored level k_j <= k draws
// T(k_j) <= ratio * T(k) triangles; the last step is always a level (the coarsest model). Given
// h_lim, the engine takes k* (the last step with h_s <= h_lim) and the level k_j <= k*: its error
// is <= h_s(k*) <= h_lim (errors are non-decreasing) and it draws at most ratio x the triangles of
// the exact step.
//
// Layout: format/lodlayout.h (paired levels, [F \ C | F n C | C \ F]), with geometric levels
// 2.5-3.6x the full-resolution list instead of the 1 / (1 - 1/ratio) = 4.3x of one list per level.
// Every triangle is stored with its smallest vertex index first and each step's removals sorted,
// the canonical form the compact encoding (format/blockcodec.h) reproduces.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "cdt.h"
#include "deletion.h"
#include "ulod.h"

namespace unilod {

inline constexpr double kLodTriangleRatio = 1.3;

struct LodIndexInput {
    const Cdt* cdt = nullptr;                      // after the deletion (vertex ids, locked flags)
    const PointSet* points = nullptr;              // the block's points (coordinates, kinds)
    std::vector<TriangleTriple> initialTriangles;  // collectTriangles before the deletion
    std::vector<RiverEdge> initialEdges;           // collectRiverEdges before the deletion
    const DeletionRecords* records = nullptr;
    double originX = 0, originY = 0;  // block origin for vertex coordinates (the CDT grid origin)
    double ratio = kLodTriangleRatio;
    // Which metrics the deletion computed (a block without any deletion step still has its
    // step-0 error for each of them).
    bool maxError = true, paperError = true;
    // The height quantum of the points' z (blocks.cpp quantises them): added to every stored
    // error, which is then rounded up to a multiple of it (format::quantizeError).
    double zQuantum = format::kDefaultZQuantum;
};

// Fills vertices (retention order), the records (renumbered to vertex indices), errors, levels
// and index arrays of `block`. Returns false with `error` on inconsistent input.
bool buildLodIndex(const LodIndexInput& input, format::Block& block, std::string& error);

}  // namespace unilod
