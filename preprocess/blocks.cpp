// Block partition (blocks.h).
#include "blocks.h"

#include <algorithm>
#include <cassert>
#include <cmath>

#include "grid.h"

namespace unilod {

namespace {

// Border lines of one axis: cell indices 0, B, 2B, ..., and the last sampled cell, where B is the
// block size rounded down to a multiple of the stride (the sampled grid must hit every border).
std::vector<int> borderLines(int cells, int stride, int blockSize) {
    const int last = (cells - 1) / stride * stride;
    const int step = std::max(stride, blockSize / stride * stride);
    std::vector<int> lines;
    for (int c = 0; c < last; c += step)
        lines.push_back(c);
    lines.push_back(last);
    return lines;
}

// Index i of the interval [lines[i], lines[i+1]] holding v (cell coordinate), clamped.
std::size_t intervalOf(const std::vector<int>& lines, double v) {
    const auto it = std::upper_bound(lines.begin(), lines.end(), v,
                                     [](double x, int line) { return x < double(line); });
    const auto i = static_cast<std::ptrdiff_t>(it - lines.begin()) - 1;
    return static_cast<std::size_t>(
        std::clamp<std::ptrdiff_t>(i, 0, static_cast<std::ptrdiff_t>(lines.size()) - 2));
}

}  // namespace

bool BlockSource::init(const DemGrid& dem, const RiverLines& rivers, const BlockOptions& options,
                       std::string& error) {
    dem_ = &dem;
    options_ = options;
    if (options.stride < 1) {
        error = "stride must be at least 1 (got " + std::to_string(options.stride) + ")";
        return false;
    }
    if (options.blockSize < 1) {
        error = "block size must be positive (got " + std::to_string(options.blockSize) + ")";
        return false;
    }
    const int largest = std::max(dem.width, dem.height) - 1;
    if (options.blockSize > largest) {
        error = "block size " + std::to_string(options.blockSize) +
                " cells is larger than the DEM (" + std::to_string(dem.width) + " x " +
                std::to_string(dem.height) + " cells)";
        return false;
    }
    if (options.blockSize < 2 * options.stride) {
        error = "block size " + std::to_string(options.blockSize) +
                " cells must be at least twice the stride (" + std::to_string(options.stride) + ")";
        return false;
    }
    if ((dem.width - 1) / options.stride < 1 || (dem.height - 1) / options.stride < 1) {
        error = "the DEM (" + std::to_string(dem.width) + " x " + std::to_string(dem.height) +
                " cells) is too small to triangulate at stride " + std::to_string(options.stride);
        return false;
    }
    borderCols_ = borderLines(dem.width, options.stride, options.blockSize);
    borderRows_ = borderLines(dem.height, options.stride, options.blockSize);
    blocksX_ = static_cast<std::uint32_t>(borderCols_.size() - 1);
    blocksY_ = static_cast<std::uint32_t>(borderRows_.size() - 1);
    rects_.clear();
    for (std::uint32_t by = 0; by < blocksY_; ++by) {
        for (std::uint32_t bx = 0; bx < blocksX_; ++bx) {
            rects_.push_back({bx, by, borderCols_[bx], borderCols_[bx + 1], borderRows_[by],
                              borderRows_[by + 1]});
        }
    }

    // Rivers: pieces on the DEM, then a crossing vertex wherever a segment crosses a border line.
    const std::vector<RiverPiece> raw = sampleRiverPieces(dem, rivers);
    stats_ = {};
    stats_.riverPieces = raw.size();
    drop_ = riverClearanceMask(dem, raw, options.riverClearance);
    pieces_.clear();
    for (const RiverPiece& piece : raw) {
        RiverPiece out{piece.front()};
        for (std::size_t i = 0; i + 1 < piece.size(); ++i) {
            const RiverVertex a = piece[i], b = piece[i + 1];
            struct Cross {
                double t, x, y;
                bool vertical;  // crossing of a vertical border line (x exact)
            };
            std::vector<Cross> cross;
            // Interior border lines only: the outer ones bound the DEM, no segment crosses them.
            for (std::size_t k = 1; k + 1 < borderCols_.size(); ++k) {
                const double x = dem.centreX(borderCols_[k]);
                if ((a.x - x) * (b.x - x) < 0) {
                    const double t = (x - a.x) / (b.x - a.x);
                    cross.push_back({t, x, a.y + t * (b.y - a.y), true});
                }
            }
            for (std::size_t k = 1; k + 1 < borderRows_.size(); ++k) {
                const double y = dem.centreY(borderRows_[k]);
                if ((a.y - y) * (b.y - y) < 0) {
                    const double t = (y - a.y) / (b.y - a.y);
                    cross.push_back({t, a.x + t * (b.x - a.x), y, false});
                }
            }
            std::sort(cross.begin(), cross.end(),
                      [](const Cross& l, const Cross& r) { return l.t < r.t; });
            for (std::size_t k = 0; k < cross.size(); ++k) {
                Cross c = cross[k];
                // Through a block corner both lines give the same t: one vertex, the corner.
                if (k + 1 < cross.size() && cross[k + 1].t == c.t) {
                    const Cross& d = cross[++k];
                    c.x = c.vertical ? c.x : d.x;
                    c.y = c.vertical ? d.y : c.y;
                }
                const double z = dem.sample(c.x, c.y);
                out.push_back({c.x, c.y, std::isfinite(z) ? z : a.z + c.t * (b.z - a.z)});
                ++stats_.crossings;
            }
            out.push_back(b);
        }
        pieces_.push_back(std::move(out));
    }

    // Runs of each piece inside each block. A segment never crosses a border line now, so its
    // midpoint decides its block; a segment lying ON a border line belongs to both blocks beside
    // it, so that both hold its (locked) vertices.
    runs_.assign(rects_.size(), {});
    const std::size_t bx = blocksX_;
    auto blocksOf = [&](const RiverVertex& a, const RiverVertex& b, std::size_t out[2]) {
        const double cx = ((a.x + b.x) / 2 - dem.originX) / dem.cellX;
        const double cy = ((a.y + b.y) / 2 - dem.originY) / dem.cellY;
        const std::size_t ix = intervalOf(borderCols_, cx), iy = intervalOf(borderRows_, cy);
        out[0] = iy * bx + ix;
        out[1] = SIZE_MAX;
        for (std::size_t k = 1; k + 1 < borderCols_.size(); ++k) {
            const double x = dem.centreX(borderCols_[k]);
            if (a.x == x && b.x == x) out[1] = iy * bx + (k == ix ? k - 1 : k);
        }
        for (std::size_t k = 1; k + 1 < borderRows_.size(); ++k) {
            const double y = dem.centreY(borderRows_[k]);
            if (a.y == y && b.y == y) out[1] = (k == iy ? k - 1 : k) * bx + ix;
        }
    };
    for (std::uint32_t p = 0; p < pieces_.size(); ++p) {
        const RiverPiece& piece = pieces_[p];
        std::vector<std::pair<std::size_t, std::uint32_t>> open;  // (block, first vertex)
        for (std::uint32_t i = 0; i + 1 < piece.size(); ++i) {
            std::size_t now[2];
            blocksOf(piece[i], piece[i + 1], now);
            auto isNow = [&](std::size_t b) { return b == now[0] || b == now[1]; };
            for (auto it = open.begin(); it != open.end();) {
                if (isNow(it->first)) {
                    ++it;
                } else {
                    runs_[it->first].push_back({p, it->second, i});
                    it = open.erase(it);
                }
            }
            for (std::size_t b : now) {
                if (b == SIZE_MAX) continue;
                const bool isOpen = std::any_of(open.begin(), open.end(),
                                                [b](const auto& o) { return o.first == b; });
                if (!isOpen) open.push_back({b, i});
            }
        }
        for (const auto& [b, first] : open) {
            runs_[b].push_back({p, first, static_cast<std::uint32_t>(piece.size() - 1)});
        }
    }
    for (std::size_t c = 0; c < drop_.size(); ++c)
        stats_.droppedDemPoints += drop_[c];
    return true;
}

PointSet BlockSource::points(std::size_t i) const {
    const DemGrid& dem = *dem_;
    const BlockRect& r = rects_[i];
    const int s = options_.stride;
    PointSet set;
    for (int row = r.cellRow0; row <= r.cellRow1; row += s) {
        for (int col = r.cellCol0; col <= r.cellCol1; col += s) {
            const std::size_t cell = static_cast<std::size_t>(row) * dem.width + col;
            if (std::isnan(dem.z[cell]) || (!drop_.empty() && drop_[cell])) continue;
            const bool outer = options_.lockOuterEdge;
            const bool border =
                (row == r.cellRow0 && (outer || row != borderRows_.front())) ||
                (row == r.cellRow1 && (outer || row != borderRows_.back())) ||
                (col == r.cellCol0 && (outer || col != borderCols_.front())) ||
                (col == r.cellCol1 && (outer || col != borderCols_.back()));
            set.points.push_back(
                {dem.centreX(col), dem.centreY(row), double(dem.z[cell]), PointKind::Dem, border});
        }
    }
    std::vector<RiverPiece> pieces;
    for (const Run& run : runs_[i]) {
        const RiverPiece& piece = pieces_[run.piece];
        pieces.emplace_back(piece.begin() + run.first, piece.begin() + run.last + 1);
    }
    const std::size_t firstRiver = set.points.size();
    appendRiverPieces(pieces, set);
    // River vertices on a border line are shared with the neighbour: locked.
    const double x0 = dem.centreX(r.cellCol0), x1 = dem.centreX(r.cellCol1);
    const double y0 = dem.centreY(r.cellRow0), y1 = dem.centreY(r.cellRow1);
    for (std::size_t k = firstRiver; k < set.points.size(); ++k) {
        Point& p = set.points[k];
        if (p.x == x0 || p.x == x1 || p.y == y0 || p.y == y1) p.locked = true;
    }
    return set;
}

bool BlockSource::hasNodataCells(std::size_t i) const {
    const BlockRect& r = rects_[i];
    for (int row = r.cellRow0; row <= r.cellRow1; ++row)
        for (int col = r.cellCol0; col <= r.cellCol1; ++col)
            if (std::isnan(dem_->at(col, row))) return true;
    return false;
}

std::vector<std::size_t> BlockSource::bridgedNodataCells(std::size_t i, const PointSet& set) const {
    std::vector<std::size_t> cells;
    const DemGrid& dem = *dem_;
    const BlockRect& r = rects_[i];
    if (set.points.size() < 3) return cells;
    // Convex hull (monotone chain) on the exact 1 mm grid, counter-clockwise.
    const Quantizer q = Quantizer::forPoints(set.points);
    std::vector<GridPoint> pts;
    pts.reserve(set.points.size());
    for (const Point& p : set.points)
        pts.push_back(q(p));
    std::sort(pts.begin(), pts.end(), [](const GridPoint& a, const GridPoint& b) {
        return a.x < b.x || (a.x == b.x && a.y < b.y);
    });
    pts.erase(std::unique(
                  pts.begin(), pts.end(),
                  [](const GridPoint& a, const GridPoint& b) { return a.x == b.x && a.y == b.y; }),
              pts.end());
    if (pts.size() < 3) return cells;
    std::vector<GridPoint> hull(2 * pts.size());
    std::size_t k = 0;
    for (std::size_t j = 0; j < pts.size(); ++j) {
        while (k >= 2 && orient2d(hull[k - 2], hull[k - 1], pts[j]) <= 0)
            --k;
        hull[k++] = pts[j];
    }
    for (std::size_t j = pts.size() - 1, lower = k + 1; j-- > 0;) {
        while (k >= lower && orient2d(hull[k - 2], hull[k - 1], pts[j]) <= 0)
            --k;
        hull[k++] = pts[j];
    }
    hull.resize(k - 1);
    if (hull.size() < 3) return cells;
    for (int row = r.cellRow0; row <= r.cellRow1; ++row) {
        for (int col = r.cellCol0; col <= r.cellCol1; ++col) {
            if (!std::isnan(dem.at(col, row))) continue;
            const GridPoint c =
                q({dem.centreX(col), dem.centreY(row), q.oz, PointKind::Dem, false});
            bool inside = true;
            for (std::size_t e = 0; e < hull.size() && inside; ++e) {
                inside = orient2d(hull[e], hull[(e + 1) % hull.size()], c) > 0;
            }
            if (inside)
                cells.push_back(std::size_t(row) * std::size_t(dem.width) + std::size_t(col));
        }
    }
    return cells;
}

}  // namespace unilod
