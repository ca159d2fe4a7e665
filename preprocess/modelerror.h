// Model error of the simplified block after every deletion step (paper §3.2, Eq. 3-6;
// DESIGN.md "Model error"). M = every original point of the block (merged duplicates included),
// N = the vertices still in the triangulation.
//
// `max`: max over m in M of |z_m - S(x_m, y_m)|, S the current triangulated surface (linear on
//   each triangle, heights of the vertices' own points). Maintained incrementally: every original
//   point sits in the bucket of one triangle that covers it (exact integer point-in-triangle
//   test; a point on the outline in a domain triangle's: the domain is closed, and a ring step
//   hands the triangle across its new outline edge over as changed, deletion.cpp apply); after
//   a step only the points of the destroyed triangles are re-located among the
//   created triangles and re-evaluated (a scan of the created triangles; from walkFrom of them
//   on, a walk across their shared edges from the nearest recent hit, with the scan's answers:
//   a star of hundreds of triangles, as a 2-row DEM makes, made the scan cubic overall). Points
//   outside the step's region keep their value, so the running maximum over steps is max(previous
//   running maximum, the re-evaluated values). Each triangle's points are one contiguous range of a
//   pool (the step appends the created triangles' ranges; the pool is compacted in place when half
//   of it is garbage), so the re-evaluation streams through memory.
// `paper`: mean over m in M of |H_m - H_n(m)|, n(m) the retained point nearest to m in 3D (Eq. 3,
//   4; ties: lowest id), Eq. 5-6. Horizontal distances are taken on the block's exact grid
//   (cdt.h, 1 mm), heights in metres. Each point keeps its nearest retained vertex; deleting v
//   only re-assigns the points whose nearest was v (a deletion never brings another point
//   closer). That is about N ln N re-assignments over the whole order (14 million at 10^6
//   points), so each must be cheap: the orphans of v are matched against the alive vertices of
//   the 3x3 (then 5x5) grid cells around v, gathered once per deletion, and a match is accepted
//   only when it is closer than the gathered square's border; otherwise a ring search over a
//   uniform grid of the alive vertices decides (about two per cell, rebuilt with a coarser cell
//   whenever the alive count halves; coordinates stored in the cells). Both give exactly the
//   brute-force answer, ties included. (The kd-tree of kdtree.h answers the same query; measured
//   here at 2-3 us per query on a 10^6-point tree with 90 % removed, 14 million queries would
//   exceed the 10 s budget alone.)
// Both are reported as running maxima (non-decreasing along the order, so "h_s <= h_lim" selects
// a prefix of the deletion order). Per-point data is packed and stored in Morton order of the
// grid position, so that the points of one triangle or one Voronoi cell sit close in memory.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "cdt.h"

namespace unilod {

// An original point that is not a point of the triangulated set (issue 18: a tree node starts
// from its children's coarsest vertices, but its error is measured against every original point
// of its area): a position on the Cdt's grid and a height.
struct ExtraSample {
    std::int32_t gx = 0, gy = 0;
    double z = 0;
};

// A reference to an original point and, for a grid cell, its height (a float: the heights of a
// block's points lie on the 1/128 m quantum, blocks.cpp, and such a height below 131 072 m is a
// float exactly). 8 bytes in the error pool instead of a position and a double height, 16 (a tree
// root measures its error against every original point of the model: 16 of the build's 30
// bytes per point at 64M points, MEASURED.md).
struct SampleRef {
    std::uint32_t ref = 0;
    float z = 0;
};

// Original points on the sampled DEM grid, known by their cell: sampled cell (k, j), reference
// j * 2^shift() + k (a power-of-two row pitch: decoded by a shift and a mask), lies at grid
// position (gx[k], gy[j]).
struct SampleGrid {
    std::vector<std::int32_t> gx, gy;  // per sampled column / row
    int shift() const {
        int b = 0;
        while ((std::size_t(1) << b) < gx.size())
            ++b;
        return b;
    }
    // The references' range: rows times the pitch (0 without cells).
    std::size_t cells() const { return gx.empty() ? 0 : gy.size() << shift(); }
};

// Original points beyond the triangulated set's, in their order: `refs[i].ref` below
// grid.cells() is a cell of `grid` with height refs[i].z, from there on the explicit point
// points[refs[i].ref - grid.cells()]. Empty `refs`: the points of `points` in order. The grid's
// references plus the explicit points and the set's points must stay below 2^32.
struct ExtraSamples {
    std::vector<SampleRef> refs;
    std::vector<ExtraSample> points;
    SampleGrid grid;
    std::size_t size() const { return refs.empty() ? points.size() : refs.size(); }
    // The i-th point's position and height.
    ExtraSample at(std::size_t i) const {
        if (refs.empty()) return points[i];
        const std::size_t r = refs[i].ref;
        if (r >= grid.cells()) return points[r - grid.cells()];
        const int b = grid.shift();
        return {grid.gx[r & ((std::size_t(1) << b) - 1)], grid.gy[r >> b], double(refs[i].z)};
    }
};

class ModelError {
public:
    // `cdt`: the full triangulation of `set` (before any deletion); both must outlive this
    // object's use (the pool refers to their points). `extra`: more original points, counted in M
    // like the set's (the paper metric, Eq. 3-6, is over the set's points only); each is located
    // in the triangulation (exact, closed), and one outside the domain has no vertical error.
    // `release`: the caller no longer needs them (a tree root holds every original point of the
    // model): `extra->refs`' buffer becomes the pool, permuted in place, and the explicit points
    // and the grid are moved here, so that nothing is held twice; reserve `refs` to about 1.25 x
    // its size plus the set's points (the pool's room for re-appended points; less costs a
    // reallocation).
    void init(const PointSet& set, const Cdt& cdt, bool maxMetric, bool paperMetric,
              ExtraSamples* extra = nullptr, bool release = false);
    // After a step: the destroyed pre-existing triangle slots and the created alive real slots.
    // Returns the step's own vertical error: the largest re-evaluated value (before the running
    // maximum).
    double updateMax(const Cdt& cdt, const std::vector<std::uint32_t>& removedSlots,
                     const std::vector<std::uint32_t>& addedSlots);
    // The value updateMax would return for this change, without recording anything (the greedy
    // order's key, evaluated on a trial step: cdt.h beginTrial).
    double evaluateMax(const Cdt& cdt, const std::vector<std::uint32_t>& removedSlots,
                       const std::vector<std::uint32_t>& addedSlots);
    // The same for triangles not in the mesh: `corners` holds 3 vertex ids per triangle
    // (counter-clockwise), e.g. Cdt::planHole's plan for the hole of `removedSlots`.
    // `exterior`: the planned triangles lie outside the domain (cdt.h "Domain").
    double evaluatePlannedMax(const Cdt& cdt, const std::vector<std::uint32_t>& removedSlots,
                              const std::vector<PointId>& corners, bool exterior = false);
    // After vertex v left the triangulation.
    void removeVertex(PointId v);

    double runningMax() const { return runningMax_; }
    double runningPaper() const { return runningPaper_; }
    double currentPaper() const {
        return samples_.empty() ? 0.0 : double(paperSum_ / (long double)(samples_.size()));
    }
    std::size_t memoryBytes() const;
    // Asks the cache for triangle t's range of the max metric's pool (a hint: read next by the
    // evaluation of a hole that removes t).
    void prefetchRange(std::uint32_t t) const {
        if (t < rangeStart_.size()) {
            __builtin_prefetch(&rangeStart_[t]);
            __builtin_prefetch(&rangeCount_[t]);
        }
    }

private:
    // One original point, packed (paper metric).
    struct Sample {
        std::int32_t gx, gy;
        double z;
        PointId nearest;         // nearest retained vertex
        std::uint32_t nearNext;  // next sample with the same nearest vertex
    };
    static_assert(sizeof(Sample) == 24);
    // One original point in the max metric's pool (at()): below the set's point count a point
    // of the set by id, then a cell of grid_ (its height inline), then explicit_[ref - set
    // points - cells].
    using PoolPoint = SampleRef;
    static_assert(sizeof(PoolPoint) == 8);
    struct Pos {
        std::int64_t gx, gy;
        double z;
    };
    Pos at(PoolPoint p) const {
        std::size_t r = p.ref;
        if (r < setCount_) return {cdt_->gx[r], cdt_->gy[r], set_->points[r].z};
        r -= setCount_;
        if (r < gridCells_)
            return {grid_.gx[r & gridMask_], grid_.gy[r >> gridShift_], double(p.z)};
        const ExtraSample& e = explicit_[r - gridCells_];
        return {e.gx, e.gy, e.z};
    }
    // Alive vertices in grid cells, coordinates inline; a dead entry has id == kNone.
    struct Entry {
        std::int32_t gx, gy;
        double z;
        PointId id;
        std::uint32_t pad;
    };
    static_assert(sizeof(Entry) == 24);
    void buildGrid();
    // Moves the live ranges to the front of the pool (drops the garbage).
    void compact(const Cdt& cdt);
    void loadAddedTriangles(const Cdt& cdt, const std::vector<std::uint32_t>& addedSlots);
    void loadTriangle(const Cdt& cdt, PointId a, PointId b, PointId c, std::uint32_t slot,
                      bool exterior);
    double evaluateLoaded(const std::vector<std::uint32_t>& removedSlots);
    // Locates p among the added triangles (exact, closed; `last`: the previous hit, tried first)
    // and returns its vertical error; `slot` receives the triangle. Scans them in the order
    // last, 0, 1, ...: the first domain triangle holding p, else the first exterior one.
    double locateError(const Pos& p, std::size_t& last, std::uint32_t& slot) const;
    // The same answer, found by walking from `last` across the added triangles' shared edges
    // (a star of very high degree: the scan made a 2-row DEM build in cubic time), starting from
    // the nearest of the last few hits; the tie of a point on an edge or at a corner is decided
    // among the triangles there as the scan's order would. Falls back to locateError where the
    // walk leaves the added triangles or goes round too long. Needs linkAdded().
    double walkError(const Pos& p, std::size_t& last, std::uint32_t& slot);
    // Links the added triangles across their shared edges (addedNext_) when there are at least
    // walkFrom of them (else the scan is as fast); returns whether it did.
    bool linkAdded();
    double locate(PoolPoint r, std::size_t& last, std::uint32_t& slot, bool walk) {
        const Pos p = at(r);
        return walk ? walkError(p, last, slot) : locateError(p, last, slot);
    }
    PointId nearest(std::int32_t gx, std::int32_t gy, double z) const;

    const PointSet* set_ = nullptr;
    const Cdt* cdt_ = nullptr;
    // What the pool's references point to (at()).
    std::uint32_t setCount_ = 0;
    std::size_t gridCells_ = 0, gridMask_ = 0;
    int gridShift_ = 0;
    SampleGrid grid_;
    std::vector<ExtraSample> explicit_;
    bool maxMetric_ = false, paperMetric_ = false;
    double unit_ = 1e-3;
    std::vector<Sample> samples_;
    // max metric: the points covered by triangle t are pool_[rangeStart_[t] + 0 .. count - 1]
    std::vector<PoolPoint> pool_, pending_;
    std::vector<std::uint32_t> rangeStart_, rangeCount_, destination_;
    std::vector<std::uint64_t> compactScratch_;  // compactTrianglePool's
    std::vector<PoolPoint> spare_;                 // compactTrianglePool's second buffer
    std::size_t garbage_ = 0;
    // Edge e (opposite corner e) as an exact linear function of the point: orient2d of the
    // edge's ends and (px, py) is a[e] px + b[e] py + c[e] (grid coordinates are at most
    // kMaxGridCoordinate < 2^28 in size: every term and sum stays below 2^60).
    struct AddedTri {
        std::int64_t a[3], b[3], c[3];
        double z[3];
        double den;
        std::uint32_t slot;
        bool exterior;  // a triangle outside the domain: points in it have no vertical error
        PointId v[3];   // the corners (edge e runs from v[e + 1] to v[e + 2], mod 3)
    };
    std::vector<AddedTri> addedTris_;
    // linkAdded: per added triangle and edge e, the added triangle across it (kNone: none).
    std::vector<std::uint32_t> addedNext_;
    std::vector<std::pair<std::uint64_t, std::uint32_t>> edgeScratch_;
    // walkError: the last triangles it found, most recent first (kNone: none yet).
    static constexpr int kRecent = 4;
    std::uint32_t recent_[kRecent] = {Cdt::kNone, Cdt::kNone, Cdt::kNone, Cdt::kNone};
    std::vector<std::uint32_t> held_;  // walkError: the added triangles holding the point

public:
    // The star size from which points are located by walking (walkError) instead of scanning;
    // the answers are the same (tests build with 0 and with SIZE_MAX and compare).
    static inline std::size_t walkFrom = 32;

private:
    double runningMax_ = 0;
    // paper metric
    std::vector<std::uint32_t> nearHead_;  // per vertex id: first sample
    std::vector<std::uint32_t> entryOf_;   // per vertex id: its grid entry
    std::vector<Entry> entries_, candidates_[2];
    std::vector<std::uint32_t> cellStart_;
    std::int64_t gridX0_ = 0, gridY0_ = 0, gridX1_ = 0, gridY1_ = 0;
    std::int64_t cell_ = 1;
    std::uint32_t nx_ = 1, ny_ = 1, alive_ = 0;
    // Alive vertices per block of kCoarse x kCoarse cells: the ring search leaves the cells for
    // these blocks after kFineRings rings.
    static constexpr std::int64_t kCoarse = 8, kFineRings = 3;
    std::vector<std::uint32_t> coarseAlive_;
    std::int64_t coarseX_ = 1, coarseY_ = 1;
    long double paperSum_ = 0;
    double runningPaper_ = 0;
};

// From-scratch recomputations (tests): the current `max` value (no running maximum): every
// original point located by scanning all triangles; the current `paper` value: nearest vertex by
// scanning all vertices (same distance formula: grid horizontal, metres vertical).
double bruteForceMaxError(const PointSet& set, const Cdt& cdt);
// The same over extra original points (ModelError::init `extra`; those outside the domain or the
// hull have none).
double bruteForceExtraError(const PointSet& set, const Cdt& cdt,
                            const std::vector<ExtraSample>& extra);
// The river part of the `max` error (deletion.h): along every river as built (Cdt::rivers), the
// largest 3D distance from an original vertex to the segment between the alive vertices before
// and after it; 0 when every river vertex is alive.
double bruteForceRiverDeviation(const PointSet& set, const Cdt& cdt);
// Squared 3D distance from m to the segment a-c (a point when a == c); plain doubles, used by
// bruteForceRiverDeviation and the benchmark's river baselines (tools/bench_order.cpp).
double segmentDistance2(const double a[3], const double c[3], const double m[3]);
double bruteForcePaperError(const PointSet& set, const Cdt& cdt);

// Height of the surface of triangle t at original point m's grid position (shared formula).
double surfaceHeight(const PointSet& set, const Cdt& cdt, std::uint32_t t, PointId m);

}  // namespace unilod
