// Improved 3D Douglas-Peucker importance order (paper §2.1, §3.1; DESIGN.md "Improved 3D_DP").
//
// 1. Base plane: origin O, anchor A, floating point B (the pair of vectors from O with the
//    largest cross product).
// 2. Sequencing: nearest-neighbour chain over all unlocked points but O, from A, ending at B.
// 3. Selection with threshold 0: recursive split of the chain at the point farthest from the
//    current base plane (through O and the sub-chain's two end points). River points use the
//    BAI pseudo distance (Eq. 2). Every point receives its own importance = its (pseudo) distance
//    when it was selected, and the effective importance = min(own, parent's effective), so that
//    the points with effective importance > t are exactly those plain 3D_DP with threshold t keeps.
// Locked points take no part (paper §3.1). Details and degenerate cases: importance.cpp.
#pragma once

#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "bai.h"
#include "grid.h"
#include "points.h"

namespace unilod {

struct ImportanceOptions {
    bool useBai = true;  // false: plain 3D_DP (--no-bai)
    BaiTable baiTable = BaiTable::paperDefault();
    double baiRow = kDefaultBaiRow;  // simplification-threshold row of Table 1
    // The greedy order only (blockbuild.h): C of Table 1 at the threshold a key stands for
    // (bai.h BaiKeys::byThreshold) instead of row `baiRow` at every threshold.
    bool baiByThreshold = false;
};

// Where the time went and how the search behaved (for benchmarks and summaries).
struct ImportanceStats {
    double baiSeconds = 0, basePlaneSeconds = 0, chainSeconds = 0, selectionSeconds = 0,
           orderSeconds = 0;
    std::size_t basePairCandidates = 0;  // points left for the exact base-pair search
    std::uint32_t maxDepth = 0;          // depth of the split tree
    double meanDepth = 0;
};

struct ImportanceResult {
    PointId origin = kNoPoint, anchor = kNoPoint, floating = kNoPoint;  // O, A, B
    // Nearest-neighbour chain (point ids): A first, B last, every unlocked point but O once.
    std::vector<PointId> chain;
    // Per point id. Locked points: NaN. O, A, B: +infinity (always kept).
    std::vector<double> ownImportance;
    std::vector<double> importance;    // effective importance
    std::vector<std::uint32_t> depth;  // depth in the split tree (O, A, B, locked: 0)
    std::vector<float> baiFactor;      // C * BAI + 1 per point (1 with BAI off, and DEM points)
    // Deletion order: every unlocked point once, ascending effective importance; ties: deeper
    // split-tree depth first (descendants before ancestors), then lower id. O, A, B come last.
    std::vector<PointId> order;
    ImportanceStats stats;
};

// Returns false with `error` set when the options are invalid (unknown BAI row).
bool computeImportance(const PointSet& set, const ImportanceOptions& options,
                       ImportanceResult& result, std::string& error);

// --- Building blocks, exposed for tests and reference implementations -----------------------

// Distance from a point to the base plane through O, P (sub-chain start) and Q (end), in metres.
// Degenerate cases: O, P, Q collinear with P != Q -> distance to line PQ; P == Q != O -> distance
// to line OP; P == Q == O -> distance to O. Degeneracy is decided exactly on grid coordinates, and
// a point exactly on the plane (or line) gets exactly 0: the floating-point value is used unless
// it is within its rounding error bound of 0, where an exact 128-bit test decides.
class PlaneDistance {
public:
    enum class Kind { Plane, Line, Point };
    PlaneDistance(const GridPoint& o, const GridPoint& p, const GridPoint& q);
    Kind kind() const { return kind_; }

    double operator()(const GridPoint& x) const {
        const std::int64_t ix = x.x - base_.x, iy = x.y - base_.y, iz = x.z - base_.z;
        const double wx = double(ix), wy = double(iy), wz = double(iz);
        if (kind_ == Kind::Plane) {
            const double tx = nx_ * wx, ty = ny_ * wy, tz = nz_ * wz;
            const double dot = tx + ty + tz;
            // |error| <= 4 eps (|tx| + |ty| + |tz|): conversion of n, three products, two sums.
            constexpr double kErr = 4 * 0x1.0p-53;
            if (std::fabs(dot) <= kErr * (std::fabs(tx) + std::fabs(ty) + std::fabs(tz)) &&
                exactNx_ * ix + exactNy_ * iy + exactNz_ * iz == 0) {
                return 0.0;
            }
            return std::fabs(dot) * invLen_ * kGridUnit;
        }
        if (kind_ == Kind::Line) return lineDistance(ix, iy, iz);
        return std::sqrt(wx * wx + wy * wy + wz * wz) * kGridUnit;
    }

private:
    double lineDistance(std::int64_t ix, std::int64_t iy, std::int64_t iz) const;

    Kind kind_ = Kind::Point;
    GridPoint base_;                   // O for a plane or a point; the line's first point
    double nx_ = 0, ny_ = 0, nz_ = 0;  // plane normal (OP x OQ) or line direction, unnormalised
    double invLen_ = 0;                // 1 / |(nx, ny, nz)|
    Int128 exactNx_ = 0, exactNy_ = 0, exactNz_ = 0;
};

// Selection tie-break shared by the implementation and reference checks: among interior chain
// positions with equal (pseudo) distance, the one closest to the middle of [s, e], then the lower.
inline bool preferSplit(std::int64_t k, std::int64_t best, std::int64_t s, std::int64_t e) {
    const std::int64_t dk = k * 2 - (s + e), db = best * 2 - (s + e);
    const std::int64_t ak = dk < 0 ? -dk : dk, ab = db < 0 ? -db : db;
    return ak < ab || (ak == ab && k < best);
}

}  // namespace unilod
