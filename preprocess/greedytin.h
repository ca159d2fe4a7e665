// Greedy-insertion TIN: the baseline the deletion order is measured against (Garland and
// Heckbert 1995, "Fast polygonal approximation of terrains and height fields", CMU-CS-95-181,
// §4 algorithm III: Delaunay greedy insertion with per-triangle candidates in a heap).
//
// Start from the Delaunay triangulation of the corners of the convex hull of the points
// (cdt.h buildHullCdt), then repeatedly insert the point with the largest vertical error
// |z - S(x, y)| (S linear on each triangle) by Delaunay insertion (Cdt::insertPoint, exact
// integer predicates on the block grid), until the largest error is <= the threshold.
//
// Bookkeeping (as modelerror.h's `max` metric): every point not in the triangulation sits in
// the bucket of one real triangle covering it (exact closed point-in-triangle test); each
// triangle's points are one contiguous range of a pool. An insertion re-locates only the points
// of the triangles it destroyed (Cdt journal) among the triangles it created, and each created
// triangle's worst point goes into a max-heap keyed (error, lower id first). Entries of
// destroyed or rebuilt triangles are skipped when they reach the top (a version per slot: lazy
// invalidation), so the valid top is always the global maximum error.
//
// Points on the same grid point (1 mm) are merged as in buildCdt (the lowest id is the vertex;
// the others are not measured). Heights use the same barycentric formula as modelerror.cpp.
// Deterministic: no threads, ties broken by point id.
//
// With rivers (the baseline for a model that must hold its rivers, issue 15): each river chain
// (point ids from one end or junction to the next) is simplified to a river tolerance by 3D
// Douglas-Peucker (every dropped river vertex within the tolerance, as a 3D distance, of the
// segment that replaces it: the model's river error, modelerror.h) and the kept segments are
// inserted as constraint edges before any other point; the greedy insertion then runs as above,
// constrained Delaunay (Cdt::insertPoint never crosses a constraint), over every other point
// (the dropped river vertices included: their vertical error counts as any point's). Where a
// kept segment would cross or overlap one already placed, the one that is a shortcut (spans
// dropped vertices) is split at its worst vertex and both halves are simplified again, so the
// placed rivers never cross; two original segments crossing is an error.
#pragma once

#include <cstddef>
#include <cstdint>
#include <queue>
#include <string>
#include <vector>

#include "cdt.h"
#include "points.h"

namespace unilod {

class GreedyTin {
public:
    // Triangulates the hull corners of `set` (its rivers are ignored) and buckets the other
    // points. `set` must outlive this object. False with `error` on too few distinct points,
    // collinear points or a non-finite coordinate (buildHullCdt's errors).
    bool init(const PointSet& set, std::string& error, const CdtOptions& options = {});
    // The same with `rivers` (chains of point ids of `set`, see above) simplified to
    // `riverTolerance` metres and placed as constraints first. False with `error` also when
    // two original river segments cross.
    bool init(const PointSet& set, const std::vector<Polyline>& rivers, double riverTolerance,
              std::string& error, const CdtOptions& options = {});
    // Placed river segments: constraint edges of the triangulation (sub-edges where a segment
    // passes through a vertex count once each).
    std::uint32_t riverEdgeCount() const { return cdt_.constraintEdgeCount; }
    // Per-point weights (the view-dependent baseline of bench_order --view): point m's key is
    // w[m] * |z - S| instead of |z - S|, so refineTo(1) inserts until every point is within
    // 1 / w[m] of the surface (w = 0: the point never needs inserting). Set before init; one
    // weight per point of the set, each finite and >= 0; the vector must outlive this object.
    // Null (the default): every weight 1.
    void setWeights(const std::vector<double>* weights) { weights_ = weights; }
    // Inserts worst points until the largest vertical error is <= `threshold` (metres; with
    // weights, the largest weighted error).
    void refineTo(double threshold);
    // The largest vertical (with weights: weighted) error over all (representative) points now;
    // 0 when all are vertices.
    double maxError();
    std::uint32_t triangleCount() const { return cdt_.realTriangleCount; }
    std::uint32_t vertexCount() const { return cdt_.vertexCount; }
    const Cdt& cdt() const { return cdt_; }

private:
    struct PoolPoint {
        std::int32_t gx, gy;
        double z;
        PointId id;
        std::uint32_t pad;
    };
    static_assert(sizeof(PoolPoint) == 24);
    struct Candidate {
        double error;
        PointId id;
        std::uint32_t slot, version;
        bool operator<(const Candidate& o) const {  // max-heap: larger error, then lower id
            return error != o.error ? error < o.error : id > o.id;
        }
    };
    void insertWorst(const Candidate& c);
    bool placeRivers(const std::vector<Polyline>& rivers, double tolerance, std::string& error);
    // Appends the points of `pending` to the ranges of the triangles `slots` (each point lies in
    // one of them) and pushes each triangle's worst point.
    void distribute(const std::vector<std::uint32_t>& slots);
    void growSlots();
    void compact();

    double weighted(PointId id, double e) const { return weights_ ? e * (*weights_)[id] : e; }

    const PointSet* set_ = nullptr;
    const std::vector<double>* weights_ = nullptr;
    Cdt cdt_;
    std::vector<PoolPoint> pool_, pending_;
    std::vector<std::uint32_t> rangeStart_, rangeCount_, version_, destination_, created_;
    std::vector<std::uint64_t> compactScratch_;  // compactTrianglePool's
    std::vector<PoolPoint> spare_;                 // compactTrianglePool's second buffer
    std::size_t garbage_ = 0;
    std::priority_queue<Candidate> heap_;
    std::uint32_t step_ = 0;
};

// Runs one greedy insertion down to the smallest of `errors` (metres, each >= 0) and returns,
// for each threshold in the given order, the real triangle count at the first moment the
// largest vertical error is <= it. False with `error` as GreedyTin::init, or for a negative or
// non-finite threshold.
bool greedyTinTriangles(const PointSet& set, const std::vector<double>& errors,
                        std::vector<std::uint64_t>& triangles, std::string& error);

}  // namespace unilod
