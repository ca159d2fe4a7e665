// `unilod check --errors` (issue "a bound that lies is a defect"): the TRUE `max` model error of a
// stored level, recomputed from the file's own data, so that a stored bound below it is caught.
//
// Definition (deletion.h, modelerror.h): the stored `max` error after step k is the running
// maximum over the steps <= k of max(vertical, river). Being non-decreasing, it must be at least
// the error of the CURRENT surface at every stored level, which is what is recomputed here:
//   vertical = max over the block's vertices (all of them, alive or deleted: the original points
//              as the file keeps them) of |z - S_k(x, y)|, S_k the level's triangulated surface,
//              linear on each triangle through its three vertices. Each vertex is located exactly
//              (integer orientation tests on its grid position, predicates.h; a point on an edge
//              may take either triangle, the surface is continuous there) in a uniform grid of
//              buckets over the level's triangles, about one triangle per bucket.
//   river    = for every river edge A-C alive at level k, the largest 3D distance (x, y from the
//              grid in metres, z) from the original chain vertices strictly between A and C to
//              the segment A-C. The chains are the full-resolution ones (checker.h
//              RiverReference); A and C are consecutive vertices alive after step k along a chain
//              (alive: vertex index < vertices.size() - k, ulod.h retention order).
//
// Tolerance. The build computes in double from the original heights; the file keeps z as float
// (round to nearest: |z_file - z| <= 2^-24 |z|) and stores errors rounded UP to float. A vertical
// value moves by at most 2 * 2^-24 * max|z| (z itself and S, a convex combination of three
// heights); a river distance is 1-Lipschitz in the point and in each segment end, so it moves by
// at most 2 * 2^-24 * max|z| too (x, y are the same exact grid values on both sides). The
// tolerance is twice that bound plus 1e-6 m for the double arithmetic (coordinates of tens of km,
// relative rounding ~1e-16):
//   stored >= recomputed - (4 * 2^-24 * max|z| of the block + 1e-6 m).
// That is 0.07 mm at 300 m of altitude and 0.5 mm at 2000 m: any real lie is far above it.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "cdt.h"
#include "checker.h"
#include "ulod.h"

namespace unilod {

// The stored-versus-recomputed slack above (metres).
double maxErrorTolerance(const format::Block& block);

struct LevelMaxError {
    // river: the largest river deviation, or horizontal distance of a vertex outside the level's
    // (simplified) domain to its outline (blocks.h "Domain").
    double vertical = 0, river = 0;
    std::uint32_t verticalVertex = 0;  // the vertex with the largest vertical distance
    std::uint32_t riverVertex = 0;     // the vertex with the largest river / outline distance
    double value() const { return vertical > river ? vertical : river; }
};

// The current `max` error of `block` after `step` deletions, whose triangles and river edges
// (vertex indices; the edges sorted) are given; `rivers`: the full-resolution chains. Returns
// false with a message when a vertex lies in no triangle or a chain's consecutive alive vertices
// are not a river edge (a file the topology check would reject).
bool levelMaxError(const format::Block& block, std::uint32_t step,
                   const std::vector<TriangleTriple>& triangles,
                   const std::vector<RiverEdge>& sortedEdges, const RiverReference& rivers,
                   LevelMaxError& result, std::string& error);

// Issue 18: a tree node's `max` error bounds the vertical error of every ORIGINAL point of its
// area (the vertices of the leaf blocks below it), not only of its own vertices (the build
// measures them as extra samples: modelerror.h ExtraSample), and the river deviation of every
// original river point (the build measures it against the points each river edge stands for:
// deletion.h RiverCover). This recomputes both per stored level of the node, leaf by leaf.
//
// Vertical. A leaf vertex is put on the node's grid from the file: q = (leaf origin + leaf grid *
// unit - node origin) / unit. The build placed the original point at round((p - node origin) /
// unit), and the leaf grid is round((p - leaf origin) / unit), so the build's integer position is
// within 1 unit of q on each axis (plus rounding of the double sums, far below). The error
// recomputed for a point is therefore the SMALLEST |z - S| over the integer positions within
// 1 + 1e-6 units of q on both axes (at most 3 x 3), 0 when one of them lies outside the level's
// domain (an extra sample outside the domain has no vertical error): a lower bound of what the
// build counted, exact up to the float tolerance of maxErrorTolerance (taken over the leaf's
// and the node's heights).
//
// River. The original river points are the vertices of the leaf's full-resolution river edges
// (level 0). The build measured each one against the river edge standing for it, A-C (3D
// distance to the segment, deletion.cpp spanDeviation, from the point's exact coordinates).
// Recomputed here: its SMALLEST 3D distance to any river edge alive at the level, at q (metres),
// less kNodeRiverSlack for the leaf grid's rounding of the point (half a unit per axis): a lower
// bound of what the build counted, whichever edge stood for the point. A level with no river
// edge while the leaves have river points has an infinite river error (rivers cannot vanish:
// chain ends are never deleted). Horizontal (outline) deviations of original points are not
// recomputed here.
inline constexpr double kNodeRiverSlack = 1e-3;  // metres: >= sqrt(2) / 2 grid units

class NodeOriginalError {
public:
    // `levels`: the node's triangles at each of its stored levels (vertex indices of `node`);
    // `riverLevels`: its river edges at the same levels (empty: rivers are not recomputed).
    NodeOriginalError(const format::Block& node, std::vector<std::vector<TriangleTriple>> levels,
                      std::vector<std::vector<RiverEdge>> riverLevels = {});
    ~NodeOriginalError();
    NodeOriginalError(const NodeOriginalError&) = delete;
    NodeOriginalError& operator=(const NodeOriginalError&) = delete;

    // Every vertex of `leaf` (a leaf block below the node) against every level.
    void add(const format::Block& leaf);

    struct Worst {
        double value = 0;  // the largest recomputed error of an original point (metres)
        std::uint32_t col = 0, row = 0, vertex = 0;  // the leaf block and its vertex
    };
    const std::vector<Worst>& worst() const { return worst_; }            // vertical, per level
    const std::vector<Worst>& riverWorst() const { return riverWorst_; }  // river, per level
    double tolerance() const { return tolerance_; }  // over the node and the leaves added

private:
    struct Impl;
    const format::Block& node_;
    std::vector<std::vector<TriangleTriple>> levels_;
    std::vector<std::vector<RiverEdge>> riverLevels_;
    std::vector<Impl*> buckets_;
    std::vector<Worst> worst_, riverWorst_;
    double tolerance_ = 0;
    bool checkRivers_ = false;
};

}  // namespace unilod
