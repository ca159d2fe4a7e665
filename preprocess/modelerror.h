// Model error of the simplified block after every deletion step (paper §3.2, Eq. 3-6;
// DESIGN.md "Model error"). M = every original point of the block (merged duplicates included),
// N = the vertices still in the triangulation.
//
// `max`: max over m in M of |z_m - S(x_m, y_m)|, S the current triangulated surface (linear on
//   each triangle, heights of the vertices' own points). Maintained incrementally: every original
//   point sits in the bucket of one triangle that covers it (exact integer point-in-triangle
//   test); after a step only the points of the destroyed triangles are re-located among the
//   created triangles and re-evaluated. Points outside the step's region keep their value, so the
//   running maximum over steps is max(previous running maximum, the re-evaluated values).
// `paper`: mean over m in M of |H_m - H_n(m)|, n(m) the retained point nearest to m in 3D (Eq. 3,
//   4; ties: lowest id), Eq. 5-6. Each point keeps its nearest retained vertex; deleting v only
//   re-assigns the points whose nearest was v (a deletion never brings another point closer).
//   Nearest queries use a uniform grid over the alive vertices, rebuilt with a coarser cell
//   whenever the alive count drops to a quarter, so a query scans O(1) cells at every level.
// Both are reported as running maxima (non-decreasing along the order, so "h_s <= h_lim" selects
// a prefix of the deletion order).
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "cdt.h"

namespace unilod {

class ModelError {
public:
    // `cdt`: the full triangulation of `set` (before any deletion).
    void init(const PointSet& set, const Cdt& cdt, bool maxMetric, bool paperMetric);
    // After a step: the destroyed pre-existing triangle slots and the created alive real slots.
    void updateMax(const Cdt& cdt, const std::vector<std::uint32_t>& removedSlots,
                   const std::vector<std::uint32_t>& addedSlots);
    // After vertex v left the triangulation.
    void removeVertex(PointId v);

    double runningMax() const { return runningMax_; }
    double runningPaper() const { return runningPaper_; }
    double currentPaper() const { return double(paperSum_ / (long double)(z_.size())); }
    std::size_t memoryBytes() const;

private:
    struct AliveGrid {
        double minX = 0, minY = 0, cell = 1;
        std::uint32_t nx = 1, ny = 1;
        std::vector<std::uint32_t> start;  // CSR over cells
        std::vector<PointId> ids;
        std::uint32_t alive = 0;
        void build(const ModelError& me, double x0, double y0, double x1, double y1);
        PointId nearest(const ModelError& me, double x, double y, double z) const;
    };
    double heightAt(const Cdt& cdt, std::uint32_t t, PointId m) const;

    const PointSet* set_ = nullptr;
    bool maxMetric_ = false, paperMetric_ = false;
    std::vector<double> z_;
    // max metric
    std::vector<std::uint32_t> bucketHead_;  // per triangle slot
    std::vector<std::uint32_t> bucketNext_;  // per point
    std::vector<PointId> pending_;
    double runningMax_ = 0;
    // paper metric
    std::vector<std::uint8_t> vertexAlive_;
    std::vector<PointId> nearest_;  // per point
    std::vector<std::uint32_t> nearHead_, nearNext_;
    long double paperSum_ = 0;
    double runningPaper_ = 0;
    double bx0_ = 0, by0_ = 0, bx1_ = 0, by1_ = 0;
    AliveGrid grid_;
};

// From-scratch recomputations (tests): the current `max` value (no running maximum): every
// original point located by scanning all triangles; the current `paper` value: nearest vertex by
// scanning all vertices.
double bruteForceMaxError(const PointSet& set, const Cdt& cdt);
double bruteForcePaperError(const PointSet& set, const Cdt& cdt);

// Height of the surface of triangle t at original point m's grid position (shared formula).
double surfaceHeight(const PointSet& set, const Cdt& cdt, std::uint32_t t, PointId m);

}  // namespace unilod
