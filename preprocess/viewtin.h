// The best known method for one view (issues 15 and 18): a view-dependent greedy-insertion TIN of
// the whole model, the baseline the engine's cut is measured against, in triangles
// (`bench_order --view`) and in frame time (`unilod bench --runs tin`).
//
// Every point of the model (every leaf point once: mergedLeaves) that lies in the view frustum
// must be within its own tolerance: the engine's P-pixel bound h_lim (lod.h blockTolerance,
// nearest distance, Eq. 11 with the point's own S and view angles) for a box that is the point
// alone, the tightest bound a per-point method can use; points off screen need nothing. The TIN
// is greedytin.h's Garland-Heckbert insertion with weights 1 / h_lim (setWeights), refined until
// every weighted error is <= 1. Rivers are not constraints of this TIN (it is the terrain's
// baseline; run it on a model built without rivers for the like-for-like ratio).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "camera.h"
#include "cdt.h"
#include "pointset.h"
#include "ulod.h"

namespace unilod {

// The whole model at full resolution as ONE block: every leaf's vertices once (a border point
// held by several leaves is merged by its exact world position on the 1 mm grid), on one grid
// from the header's origin, and every leaf's full-resolution river edges (level 0 only). What a
// whole-DEM TIN sees. False with a message on a read error.
bool mergedLeaves(const format::Reader& reader, format::Block& out, std::string& error);

// A block's vertices as metres: origin + exact grid position (the float offsets without a grid).
PointSet blockPoints(const format::Block& b);

// The view of a TIN: camera, viewport and screen-space error P (pixels).
struct TinView {
    engine::Camera camera;
    double width = 1920, height = 1080;
    double pixels = 1;
};

// The weight of every point for `view`: 1 / h_lim of the point alone when it is in the view
// frustum, 0 otherwise. Returns the number of points on screen.
std::uint64_t viewWeights(const PointSet& set, const TinView& view, std::vector<double>& weights);

// The greedy TIN of `set` with `weights` refined until every weighted error is <= 1: its
// triangles (ids into set.points, counter-clockwise) and vertex count. False with a message
// (greedytin.h init).
bool weightedTin(const PointSet& set, const std::vector<double>& weights,
                 std::vector<TriangleTriple>& triangles, std::uint32_t& vertices,
                 std::string& error);

}  // namespace unilod
