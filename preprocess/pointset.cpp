// Assembly of the unified point set (paper §3, DESIGN.md "Point set"): DEM cell centres plus river
// vertices with bilinear DEM altitudes, junctions merged into shared ids by exact coordinate
// equality, locked endpoints and junctions (paper §3.1).
#include "pointset.h"

#include <algorithm>
#include <bit>
#include <cassert>
#include <cmath>
#include <cstdint>
#include <unordered_map>

namespace unilod {

namespace {

// Exact coordinate key: the bit patterns of x and y (+0.0 folds -0.0 into 0.0, so that the two
// zeros, which compare equal, also merge).
struct CoordKey {
    std::uint64_t x, y;
    bool operator==(const CoordKey&) const = default;
};
struct CoordKeyHash {
    std::size_t operator()(const CoordKey& k) const {
        std::uint64_t h = k.x * 0x9E3779B97F4A7C15ull;
        h ^= (k.y + 0x632BE59BD9B4E019ull + (h << 6) + (h >> 2));
        return static_cast<std::size_t>(h ^ (h >> 29));
    }
};
CoordKey keyOf(double x, double y) {
    return {std::bit_cast<std::uint64_t>(x + 0.0), std::bit_cast<std::uint64_t>(y + 0.0)};
}

double distanceSquaredToSegment(double px, double py, const RiverVertex& a, const RiverVertex& b) {
    const double dx = b.x - a.x, dy = b.y - a.y;
    const double len2 = dx * dx + dy * dy;
    double t = len2 > 0 ? ((px - a.x) * dx + (py - a.y) * dy) / len2 : 0.0;
    t = std::clamp(t, 0.0, 1.0);
    const double ex = a.x + t * dx - px, ey = a.y + t * dy - py;
    return ex * ex + ey * ey;
}

// Index range [lo, hi] of grid lines i (coordinate origin + i * step) whose coordinate lies in
// [from, to], clamped to [0, n - 1]; lo > hi when empty.
void indexRange(double from, double to, double origin, double step, int n, int& lo, int& hi) {
    double a = (from - origin) / step, b = (to - origin) / step;
    if (a > b) std::swap(a, b);
    // Clamped in double before the conversion, which would overflow for far-away ranges.
    lo = static_cast<int>(std::clamp(std::ceil(a), 0.0, static_cast<double>(n)));
    hi = static_cast<int>(std::clamp(std::floor(b), -1.0, static_cast<double>(n - 1)));
}

// Calls f(col, row) for the cells whose centre is closer than `c` to segment ab. Walks only the
// rows the segment passes within c of, and in each row only the columns near its crossing, so
// that a long diagonal segment costs its length in cells, not its bounding box.
template <typename F>
void forCellsNearSegment(const DemGrid& dem, const RiverVertex& a, const RiverVertex& b, double c,
                         F&& f) {
    const double c2 = c * c;
    int r0, r1;
    indexRange(std::min(a.y, b.y) - c, std::max(a.y, b.y) + c, dem.originY, dem.cellY, dem.height,
               r0, r1);
    const double dy = b.y - a.y;
    for (int r = r0; r <= r1; ++r) {
        const double yr = dem.centreY(r);
        // Parameter interval where the segment is within c of the row's line, in y.
        double t0 = 0, t1 = 1;
        if (dy != 0) {
            t0 = (yr - c - a.y) / dy;
            t1 = (yr + c - a.y) / dy;
            if (t0 > t1) std::swap(t0, t1);
            t0 = std::max(t0, 0.0);
            t1 = std::min(t1, 1.0);
            if (t0 > t1) continue;
        } else if (std::abs(a.y - yr) > c) {
            continue;
        }
        const double xa = a.x + (b.x - a.x) * t0, xb = a.x + (b.x - a.x) * t1;
        int c0, c1;
        indexRange(std::min(xa, xb) - c, std::max(xa, xb) + c, dem.originX, dem.cellX, dem.width,
                   c0, c1);
        for (int col = c0; col <= c1; ++col) {
            if (distanceSquaredToSegment(dem.centreX(col), yr, a, b) < c2) f(col, r);
        }
    }
}

}  // namespace

std::vector<RiverPiece> sampleRiverPieces(const DemGrid& dem, const RiverLines& rivers) {
    // Runs of vertices with a finite DEM altitude, consecutive duplicates removed.
    std::vector<RiverPiece> pieces;
    RiverPiece current;
    auto flush = [&] {
        if (current.size() >= 2) pieces.push_back(std::move(current));
        current.clear();
    };
    for (const RiverLine& line : rivers) {
        for (const XY& v : line) {
            const double z = dem.sample(v.x, v.y);
            if (!std::isfinite(z)) {
                flush();
                continue;
            }
            if (!current.empty() && current.back().x == v.x && current.back().y == v.y) continue;
            current.push_back({v.x, v.y, z});
        }
        flush();
    }
    return pieces;
}

std::vector<std::uint8_t> riverClearanceMask(const DemGrid& dem,
                                             const std::vector<RiverPiece>& pieces,
                                             double clearance, int stride) {
    std::vector<std::uint8_t> drop;
    if (clearance <= 0 || pieces.empty()) return drop;
    const std::size_t w = std::size_t((dem.width - 1) / stride + 1);
    drop.assign(w * std::size_t((dem.height - 1) / stride + 1), 0);
    for (const auto& piece : pieces) {
        for (std::size_t i = 0; i + 1 < piece.size(); ++i) {
            forCellsNearSegment(dem, piece[i], piece[i + 1], clearance, [&](int col, int row) {
                if (col % stride == 0 && row % stride == 0)
                    drop[std::size_t(row / stride) * w + std::size_t(col / stride)] = 1;
            });
        }
    }
    return drop;
}

std::size_t addVerticesAtDroppedCells(const DemGrid& dem, double clearance, int stride,
                                      std::vector<RiverPiece>& pieces) {
    if (clearance <= 0) return 0;
    // New vertices closer than the clearance to a vertex of the segment (or to each other) are
    // left out: the river already passes within about the clearance of the cell there, and no
    // vertices crowd (a near-duplicate vertex makes slivers of its own).
    const double kApart = clearance;
    auto onLattice = [&](int col, int row) {
        return col % stride == 0 && row % stride == 0 &&
               std::isfinite(dem.z[static_cast<std::size_t>(row) * dem.width + col]);
    };
    // Also left out: a new vertex closer than kRiverSeparation to another segment. Rounded to the
    // exact grid it could land on that segment or beyond it: where two rivers meet at a very
    // small angle (a hairpin bend, a tributary alongside), both got a vertex for the same cell
    // and the two rounded to one grid point, so the block's triangulation found a river edge
    // twice and the build failed. The segments near each lattice cell, sorted by cell:
    struct Near {
        std::size_t cell;
        std::uint32_t piece, segment;
        auto operator<=>(const Near&) const = default;
    };
    std::vector<Near> near;
    for (std::uint32_t p = 0; p < pieces.size(); ++p) {
        for (std::uint32_t i = 0; i + 1 < pieces[p].size(); ++i) {
            forCellsNearSegment(
                dem, pieces[p][i], pieces[p][i + 1], clearance + kRiverSeparation,
                [&](int col, int row) {
                    if (onLattice(col, row))
                        near.push_back({static_cast<std::size_t>(row) * dem.width + col, p, i});
                });
        }
    }
    std::sort(near.begin(), near.end());
    auto apart = [&](std::size_t cell, std::uint32_t p, std::uint32_t i, double x, double y) {
        const auto lo = std::lower_bound(near.begin(), near.end(), Near{cell, 0, 0});
        for (auto it = lo; it != near.end() && it->cell == cell; ++it) {
            if (it->piece == p && it->segment == i) continue;
            const RiverPiece& q = pieces[it->piece];
            if (distanceSquaredToSegment(x, y, q[it->segment], q[it->segment + 1]) <
                kRiverSeparation * kRiverSeparation)
                return false;
        }
        return true;
    };
    std::size_t added = 0;
    std::vector<std::pair<double, RiverVertex>> along;
    std::vector<RiverPiece> result(pieces.size());
    for (std::uint32_t p = 0; p < pieces.size(); ++p) {
        const RiverPiece& piece = pieces[p];
        RiverPiece& out = result[p];
        out.reserve(piece.size());
        for (std::uint32_t i = 0; i + 1 < piece.size(); ++i) {
            const RiverVertex a = piece[i], b = piece[i + 1];
            out.push_back(a);
            const double dx = b.x - a.x, dy = b.y - a.y;
            const double len = std::hypot(dx, dy);
            if (!(len > 2 * kApart)) continue;
            along.clear();
            forCellsNearSegment(dem, a, b, clearance, [&](int col, int row) {
                if (!onLattice(col, row)) return;
                const double t =
                    ((dem.centreX(col) - a.x) * dx + (dem.centreY(row) - a.y) * dy) / (len * len);
                if (t * len < kApart || (1 - t) * len < kApart) return;
                const double x = a.x + t * dx, y = a.y + t * dy;
                if (!apart(static_cast<std::size_t>(row) * dem.width + col, p, i, x, y)) return;
                const double z = dem.sample(x, y);
                along.push_back({t, {x, y, std::isfinite(z) ? z : a.z + t * (b.z - a.z)}});
            });
            std::sort(along.begin(), along.end(),
                      [](const auto& l, const auto& r) { return l.first < r.first; });
            double last = 0;
            for (const auto& [t, v] : along) {
                if ((t - last) * len < kApart || (1 - t) * len < kApart) continue;
                out.push_back(v);
                last = t;
                ++added;
            }
        }
        out.push_back(piece.back());
    }
    pieces = std::move(result);
    return added;
}

void appendRiverPieces(const std::vector<RiverPiece>& pieces, PointSet& set) {
    // River points, one id per distinct (x, y).
    std::unordered_map<CoordKey, PointId, CoordKeyHash> ids;
    std::vector<std::uint32_t> uses;  // per river point (offset by the first river id)
    const std::size_t firstRiver = set.points.size();
    set.rivers.reserve(set.rivers.size() + pieces.size());
    for (const auto& piece : pieces) {
        Polyline& line = set.rivers.emplace_back();
        line.reserve(piece.size());
        for (const RiverVertex& v : piece) {
            auto [it, inserted] = ids.try_emplace(keyOf(v.x, v.y), kNoPoint);
            if (inserted) {
                assert(set.points.size() < kNoPoint);
                it->second = static_cast<PointId>(set.points.size());
                Point p;
                p.x = v.x;
                p.y = v.y;
                p.z = v.z;
                p.kind = PointKind::River;
                set.points.push_back(p);
                uses.push_back(0);
            }
            line.push_back(it->second);
            ++uses[it->second - firstRiver];
        }
        set.points[line.front()].locked = true;
        set.points[line.back()].locked = true;
    }
    for (std::size_t i = 0; i < uses.size(); ++i) {
        if (uses[i] > 1) set.points[firstRiver + i].locked = true;
    }
}

PointSet buildPointSet(const DemGrid& dem, const RiverLines& rivers,
                       const PointSetOptions& options) {
    assert(options.stride >= 1);
    assert(options.riverClearance >= 0);
    assert(dem.z.size() == static_cast<std::size_t>(dem.width) * dem.height);

    std::vector<RiverPiece> pieces = sampleRiverPieces(dem, rivers);
    const std::vector<std::uint8_t> drop =
        riverClearanceMask(dem, pieces, options.riverClearance, options.stride);
    addVerticesAtDroppedCells(dem, options.riverClearance, options.stride, pieces);

    PointSet set;
    const int stride = options.stride;
    const int lastRow = (dem.height - 1) / stride * stride;
    const int lastCol = (dem.width - 1) / stride * stride;
    for (int r = 0; r < dem.height; r += stride) {
        for (int c = 0; c < dem.width; c += stride) {
            const std::size_t cell = static_cast<std::size_t>(r) * dem.width + c;
            if (std::isnan(dem.z[cell])) continue;
            Point p;
            p.x = dem.centreX(c);
            p.y = dem.centreY(r);
            p.z = dem.z[cell];
            p.kind = PointKind::Dem;
            if (!drop.empty() &&
                drop[std::size_t(r / stride) * std::size_t((dem.width - 1) / stride + 1) +
                     std::size_t(c / stride)]) {
                set.dropped.push_back(p);
                continue;
            }
            p.locked = options.lockBorder && (r == 0 || r == lastRow || c == 0 || c == lastCol);
            set.points.push_back(p);
        }
    }

    appendRiverPieces(pieces, set);
    return set;
}

}  // namespace unilod
