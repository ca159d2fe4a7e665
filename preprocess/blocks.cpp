// Block partition (blocks.h).
#include "blocks.h"

#include "blockcodec.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <set>
#include <tuple>

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
    // Messages name the `unilod build` options that set these values. A block size beyond the
    // DEM gives one block in that direction (borderLines), so only a block narrower than two
    // sampled cells is refused, where the DEM has more than one.
    const std::string cells =
        std::to_string(dem.width) + " x " + std::to_string(dem.height) + " cells";
    const int smallest = std::min(dem.width, dem.height) - 1;  // between the outer centres
    if (options.stride < 1) {
        error = "--stride " + std::to_string(options.stride) + ": must be at least 1";
        return false;
    }
    if (options.stride > smallest) {
        // The stride is compared with the steps between the outer cell centres, one fewer than
        // the cells: a stride equal to the cell count already leaves a single row or column.
        error = "--stride " + std::to_string(options.stride) + " is larger than the DEM (" + cells +
                (smallest >= 1
                     ? ": " + std::to_string(smallest) + " cell step" + (smallest == 1 ? "" : "s") +
                           " between its outer cell centres); use --stride " +
                           std::to_string(smallest) + " or less"
                     : "): too small to triangulate");
        return false;
    }
    for (const int n : {dem.width, dem.height}) {
        const int last = (n - 1) / options.stride * options.stride;
        if (options.blockSize < std::min(2 * options.stride, last)) {
            error = "--block-size " + std::to_string(options.blockSize) +
                    " is less than twice --stride " + std::to_string(options.stride) +
                    " (a block needs two sampled cells a side); use --block-size " +
                    std::to_string(2 * options.stride) + " or more";
            return false;
        }
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
    assert(dem.heldStride == 1);  // river heights and the clearance mask read every cell
    nodesX_ = (dem.width - 1) / options.stride + 1;
    nodesY_ = (dem.height - 1) / options.stride + 1;
    const std::vector<RiverPiece> raw = cutAtOutline(sampleRiverPieces(dem, rivers));
    stats_ = {};
    stats_.riverPieces = raw.size();
    drop_ = riverClearanceMask(dem, raw, options.riverClearance, options.stride);
    pieces_.clear();
    // A river vertex on a border line's grid column (or row) of the exact grid (points are
    // quantised to format::kGridUnit in absolute coordinates, cdt.cpp) goes exactly onto the
    // line. Left beside it, a segment from it across the line would get a crossing vertex on the
    // same grid point: one block would hold the vertex, the neighbour the crossing, and the two
    // would meet off each other's border (a sub-millimetre crack; a tree node above them could not
    // merge them).
    std::vector<double> snapX, snapY;  // interior border lines, ascending
    for (std::size_t k = 1; k + 1 < borderCols_.size(); ++k)
        snapX.push_back(dem.centreX(borderCols_[k]));
    for (std::size_t k = 1; k + 1 < borderRows_.size(); ++k)
        snapY.push_back(dem.centreY(borderRows_[k]));
    std::sort(snapX.begin(), snapX.end());
    std::sort(snapY.begin(), snapY.end());
    const auto snap = [](double& c, const std::vector<double>& lines) {
        // The lines either side of c (blocks are wider than the grid unit: at most one matches).
        const auto at = std::lower_bound(lines.begin(), lines.end(), c);
        const double q = std::round(c / format::kGridUnit);
        if (at != lines.end() && std::round(*at / format::kGridUnit) == q)
            c = *at;
        else if (at != lines.begin() && std::round(*(at - 1) / format::kGridUnit) == q)
            c = *(at - 1);
    };
    // The crossing vertices on each interior border line (not at a block corner), to keep them
    // apart on the exact grid below.
    struct OnLine {
        bool vertical;     // on borderCols_[line] (x exact), else on borderRows_[line]
        std::size_t line;  // index into borderCols_ / borderRows_
        double along;      // y on a vertical line, x on a horizontal one
        std::uint32_t piece, vertex;
    };
    std::vector<OnLine> onLine;
    for (const RiverPiece& rawPiece : raw) {
        RiverPiece piece = rawPiece;
        for (RiverVertex& v : piece) {
            snap(v.x, snapX);
            snap(v.y, snapY);
        }
        RiverPiece out{piece.front()};
        for (std::size_t i = 0; i + 1 < piece.size(); ++i) {
            const RiverVertex a = piece[i], b = piece[i + 1];
            struct Cross {
                double t, x, y;
                bool vertical;     // crossing of a vertical border line (x exact)
                std::size_t line;  // its index in borderCols_ or borderRows_
            };
            std::vector<Cross> cross;
            // Interior border lines only: the outer ones bound the DEM, no segment crosses them.
            for (std::size_t k = 1; k + 1 < borderCols_.size(); ++k) {
                const double x = dem.centreX(borderCols_[k]);
                if ((a.x - x) * (b.x - x) < 0) {
                    const double t = (x - a.x) / (b.x - a.x);
                    cross.push_back({t, x, a.y + t * (b.y - a.y), true, k});
                }
            }
            for (std::size_t k = 1; k + 1 < borderRows_.size(); ++k) {
                const double y = dem.centreY(borderRows_[k]);
                if ((a.y - y) * (b.y - y) < 0) {
                    const double t = (y - a.y) / (b.y - a.y);
                    cross.push_back({t, a.x + t * (b.x - a.x), y, false, k});
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
                } else {
                    onLine.push_back({c.vertical, c.line, c.vertical ? c.y : c.x,
                                      static_cast<std::uint32_t>(pieces_.size()),
                                      static_cast<std::uint32_t>(out.size())});
                }
                const double z = dem.sample(c.x, c.y);
                out.push_back({c.x, c.y, std::isfinite(z) ? z : a.z + c.t * (b.z - a.z)});
                ++stats_.crossings;
            }
            out.push_back(b);
        }
        pieces_.push_back(std::move(out));
    }
    // Crossings of one border line closer than the exact grid (two legs of a hairpin bend, a
    // tributary meeting at a very small angle) rounded to one grid point: the triangulation
    // merged them and found a river edge twice (the build failed). A crossing whose grid point
    // an earlier one (in order along the line) took moves along the line to the next grid point:
    // distinct, in the same order, a few units moved at most (the others stay where they are).
    std::sort(onLine.begin(), onLine.end(), [](const OnLine& l, const OnLine& r) {
        return std::tie(l.vertical, l.line, l.along, l.piece, l.vertex) <
               std::tie(r.vertical, r.line, r.along, r.piece, r.vertex);
    });
    for (std::size_t i = 0; i < onLine.size(); ++i) {
        const OnLine& c = onLine[i];
        if (i == 0 || onLine[i - 1].vertical != c.vertical || onLine[i - 1].line != c.line)
            continue;
        const RiverVertex& prev = pieces_[onLine[i - 1].piece][onLine[i - 1].vertex];
        const std::int64_t taken = std::llround((c.vertical ? prev.y : prev.x) / format::kGridUnit);
        if (std::llround(c.along / format::kGridUnit) > taken) continue;
        RiverVertex& v = pieces_[c.piece][c.vertex];
        (c.vertical ? v.y : v.x) = static_cast<double>(taken + 1) * format::kGridUnit;
        const double z = dem.sample(v.x, v.y);
        if (std::isfinite(z)) v.z = z;
    }
    // A river vertex where a river passes a dropped DEM point (after the crossings, so that none
    // comes closer than the clearance to one), snapped like the others.
    stats_.droppedCellVertices =
        addVerticesAtDroppedCells(dem, options.riverClearance, options.stride, pieces_);
    for (RiverPiece& piece : pieces_) {
        for (RiverVertex& v : piece) {
            snap(v.x, snapX);
            snap(v.y, snapY);
        }
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
    // The mask is of lattice points (the cells between them are no DEM points at --stride > 1;
    // until 2026-12-02 it held every cell and counted them as dropped points).
    for (std::size_t c = 0; c < drop_.size(); ++c)
        stats_.droppedDemPoints += drop_[c];
    return true;
}

PointSet BlockSource::points(std::size_t b) const {
    const DemGrid& dem = *dem_;
    const BlockRect& r = rects_[b];
    const int s = options_.stride;
    const int i0 = r.cellCol0 / s, i1 = r.cellCol1 / s, j0 = r.cellRow0 / s, j1 = r.cellRow1 / s;
    const int w = i1 - i0 + 1, h = j1 - j0 + 1;
    auto local = [&](int i, int j) { return std::size_t(j - j0) * std::size_t(w) + std::size_t(i - i0); };
    // The block's nodes' validity and its squares' valid corner counts, looked up once each
    // (nodeValid / validCorners on the DEM, which the loops below would ask many times).
    std::vector<std::uint8_t> valid(std::size_t(w) * std::size_t(h));
    for (int j = j0; j <= j1; ++j)
        for (int i = i0; i <= i1; ++i)
            valid[local(i, j)] = nodeValid(i, j) ? 1 : 0;
    auto isValid = [&](int i, int j) { return valid[local(i, j)] != 0; };  // in the block
    std::vector<std::uint8_t> corners(std::size_t(w) * std::size_t(h), 0);  // per square (i, j)
    for (int j = j0; j < j1; ++j)
        for (int i = i0; i < i1; ++i)
            corners[local(i, j)] = std::uint8_t(valid[local(i, j)] + valid[local(i + 1, j)] +
                                                valid[local(i + 1, j + 1)] + valid[local(i, j + 1)]);
    // Squares of this block in the domain (>= 3 valid corners).
    auto covered = [&](int i, int j) {
        return i >= i0 && i < i1 && j >= j0 && j < j1 && corners[local(i, j)] >= 3;
    };
    // The outline: directed lattice edges with the block's domain on the left (world
    // orientation: lattice (i, j) -> world (x, y) turns counter-clockwise iff cellX * cellY > 0).
    const bool flipped = dem.cellX * dem.cellY < 0;
    struct LEdge {
        std::uint32_t from, to;
    };
    std::vector<LEdge> edges;
    auto addEdge = [&](int ia, int ja, int ib, int jb, int im2, int jm2) {
        // (im2, jm2): twice the lattice position of a point on the domain side.
        const long long o = (long long)(ib - ia) * (jm2 - 2 * ja) - (long long)(jb - ja) * (im2 - 2 * ia);
        const bool left = flipped ? o < 0 : o > 0;
        if (left) {
            edges.push_back({std::uint32_t(local(ia, ja)), std::uint32_t(local(ib, jb))});
        } else {
            edges.push_back({std::uint32_t(local(ib, jb)), std::uint32_t(local(ia, ja))});
        }
    };
    for (int j = j0; j <= j1; ++j) {
        for (int i = i0; i <= i1; ++i) {
            if (!isValid(i, j)) continue;
            if (i < i1 && isValid(i + 1, j)) {  // horizontal edge: squares (i, j-1), (i, j)
                const bool up = covered(i, j - 1), down = covered(i, j);
                if (up != down) addEdge(i, j, i + 1, j, 2 * i + 1, up ? 2 * j - 1 : 2 * j + 1);
            }
            if (j < j1 && isValid(i, j + 1)) {  // vertical edge: squares (i-1, j), (i, j)
                const bool left = covered(i - 1, j), right = covered(i, j);
                if (left != right) addEdge(i, j, i, j + 1, left ? 2 * i - 1 : 2 * i + 1, 2 * j + 1);
            }
        }
    }
    for (int j = j0; j < j1; ++j) {
        for (int i = i0; i < i1; ++i) {
            if (corners[local(i, j)] != 3) continue;
            const int ci[4] = {i, i + 1, i + 1, i}, cj[4] = {j, j, j + 1, j + 1};
            int missing = 0;
            while (isValid(ci[missing], cj[missing]))
                ++missing;
            const int a = (missing + 1) % 4, c = (missing + 3) % 4, o = (missing + 2) % 4;
            addEdge(ci[a], cj[a], ci[c], cj[c], 2 * ci[o], 2 * cj[o]);
        }
    }
    // Chain the edges into closed rings (a node with two outgoing edges is a pinch point).
    std::vector<std::uint32_t> outHead(std::size_t(w) * std::size_t(h), kNoPoint), outNext(edges.size());
    std::vector<std::uint8_t> outDegree(std::size_t(w) * std::size_t(h), 0), onRing(outDegree.size(), 0);
    for (std::uint32_t e = std::uint32_t(edges.size()); e-- > 0;) {
        outNext[e] = outHead[edges[e].from];
        outHead[edges[e].from] = e;
        ++outDegree[edges[e].from];
        onRing[edges[e].from] = onRing[edges[e].to] = 1;
    }
    // Points: valid corners of the block's domain squares; ring vertices always kept.
    std::vector<PointId> id(outDegree.size(), kNoPoint);
    PointSet set;
    const bool outer = options_.lockOuterEdge;
    for (int j = j0; j <= j1; ++j) {
        for (int i = i0; i <= i1; ++i) {
            if (!isValid(i, j)) continue;
            if (!(covered(i - 1, j - 1) || covered(i, j - 1) || covered(i - 1, j) || covered(i, j)))
                continue;
            const int col = i * s, row = j * s;
            const float z = dem.at(col, row);
            const std::size_t l = local(i, j);
            if (!onRing[l] && !drop_.empty() &&
                drop_[std::size_t(j) * std::size_t(nodesX_) + std::size_t(i)]) {
                set.dropped.push_back(
                    {dem.centreX(col), dem.centreY(row), double(z), PointKind::Dem, false});
                continue;
            }
            const bool border =
                (row == r.cellRow0 && (outer || row != borderRows_.front())) ||
                (row == r.cellRow1 && (outer || row != borderRows_.back())) ||
                (col == r.cellCol0 && (outer || col != borderCols_.front())) ||
                (col == r.cellCol1 && (outer || col != borderCols_.back()));
            id[l] = PointId(set.points.size());
            set.points.push_back({dem.centreX(col), dem.centreY(row), double(z), PointKind::Dem,
                                  border || outDegree[l] > 1});
        }
    }
    std::vector<std::uint8_t> used(edges.size(), 0);
    for (std::uint32_t e0 = 0; e0 < edges.size(); ++e0) {
        if (used[e0]) continue;
        Polyline ring;
        std::uint32_t e = e0;
        while (e != kNoPoint && !used[e]) {
            used[e] = 1;
            ring.push_back(id[edges[e].from]);
            std::uint32_t next = outHead[edges[e].to];
            while (next != kNoPoint && used[next])
                next = outNext[next];
            e = next;
        }
        set.boundaries.push_back(std::move(ring));
    }
    std::vector<RiverPiece> pieces;
    for (const Run& run : runs_[b]) {
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
    addNeighbourBorderVertices(b, set);
    // Heights on the file's z quantum (format/blockcodec.h): the compact block encoding stores
    // them as integers; every stored error includes the quantum (lodindex.h).
    for (Point& p : set.points)
        p.z = format::quantizeZ(p.z, format::kDefaultZQuantum);
    return set;
}

void BlockSource::addNeighbourBorderVertices(std::size_t b, PointSet& set) const {
    // A river vertex ON a border line belongs to the blocks its segments run in; where the river
    // only touches the line there (it turns back, or ends on it) the block across the line would
    // not hold it, and its border edge would pass the vertex by: a T-junction, a crack wherever
    // the river's height differs from the edge's, and no common border for a tree node above the
    // two. So every river vertex on this block's border between two DEM nodes of a border edge in
    // its domain is a locked point of this block too (a plain terrain vertex here).
    const DemGrid& dem = *dem_;
    const BlockRect& r = rects_[b];
    const int s = options_.stride;
    const double x0 = dem.centreX(r.cellCol0), x1 = dem.centreX(r.cellCol1);
    const double y0 = dem.centreY(r.cellRow0), y1 = dem.centreY(r.cellRow1);
    const double loX = std::min(x0, x1), hiX = std::max(x0, x1);
    const double loY = std::min(y0, y1), hiY = std::max(y0, y1);
    // Lattice position t (in strides) along a border line at coordinate c, origin o, spacing d.
    auto between = [&](double c, double o, double d, int& k) {
        const double t = (c - o) / (d * s);
        k = int(std::floor(t));
        const auto q = [](double v) { return std::round(v / format::kGridUnit); };
        // On (the grid point of) a DEM node: that node is the vertex in both blocks.
        return q(c) != q(o + k * d * s) && q(c) != q(o + (k + 1) * d * s);
    };
    // The border edge between lattice nodes n and n+1 of a line is in this block's domain when
    // both nodes are valid and the square on this block's side is covered (>= 3 valid corners).
    auto inDomain = [&](int ia, int ja, int ib, int jb, int si, int sj) {
        return nodeValid(ia, ja) && nodeValid(ib, jb) && validCorners(si, sj) >= 3;
    };
    std::set<std::pair<double, double>> have;  // this block's river points
    for (const Point& p : set.points)
        if (p.kind == PointKind::River) have.insert({p.x, p.y});
    const long bx = long(r.col), by = long(r.row);
    for (long ny = by - 1; ny <= by + 1; ++ny) {
        for (long nx = bx - 1; nx <= bx + 1; ++nx) {
            if ((nx == bx && ny == by) || nx < 0 || ny < 0 || nx >= long(blocksX_) ||
                ny >= long(blocksY_))
                continue;
            for (const Run& run : runs_[std::size_t(ny) * blocksX_ + std::size_t(nx)]) {
                const RiverPiece& piece = pieces_[run.piece];
                for (std::uint32_t i = run.first; i <= run.last; ++i) {
                    const RiverVertex& v = piece[i];
                    if (v.x < loX || v.x > hiX || v.y < loY || v.y > hiY) continue;
                    if (have.count({v.x, v.y})) continue;
                    bool add = false;
                    int k = 0;
                    if ((v.x == x0 || v.x == x1) && between(v.y, dem.originY, dem.cellY, k)) {
                        const int i0 = (v.x == x0 ? r.cellCol0 : r.cellCol1) / s;
                        add = inDomain(i0, k, i0, k + 1, v.x == x0 ? i0 : i0 - 1, k);
                    } else if ((v.y == y0 || v.y == y1) &&
                               between(v.x, dem.originX, dem.cellX, k)) {
                        const int j0 = (v.y == y0 ? r.cellRow0 : r.cellRow1) / s;
                        add = inDomain(k, j0, k + 1, j0, k, v.y == y0 ? j0 : j0 - 1);
                    }
                    if (!add) continue;
                    set.points.push_back({v.x, v.y, v.z, PointKind::Dem, true});
                    have.insert({v.x, v.y});
                }
            }
        }
    }
}

bool BlockSource::nodeValid(int i, int j) const {
    if (i < 0 || j < 0 || i >= nodesX_ || j >= nodesY_) return false;
    return !std::isnan(dem_->at(i * options_.stride, j * options_.stride));
}

int BlockSource::validCorners(int i, int j) const {
    if (i < 0 || j < 0 || i + 1 >= nodesX_ || j + 1 >= nodesY_) return 0;
    return int(nodeValid(i, j)) + int(nodeValid(i + 1, j)) + int(nodeValid(i + 1, j + 1)) +
           int(nodeValid(i, j + 1));
}

bool BlockSource::hasDomain(std::size_t b) const {
    const BlockRect& r = rects_[b];
    const int s = options_.stride;
    for (int j = r.cellRow0 / s; j < r.cellRow1 / s; ++j)
        for (int i = r.cellCol0 / s; i < r.cellCol1 / s; ++i)
            if (validCorners(i, j) >= 3) return true;
    return false;
}

std::vector<BlockLoad> BlockSource::loads() const {
    const int s = options_.stride;
    std::vector<BlockLoad> out(rects_.size());
    for (std::size_t b = 0; b < rects_.size(); ++b) {
        const BlockRect& r = rects_[b];
        for (int j = r.cellRow0 / s; j <= r.cellRow1 / s; ++j)
            for (int i = r.cellCol0 / s; i <= r.cellCol1 / s; ++i)
                out[b].demPoints += nodeValid(i, j);
    }
    // Which river vertices stay locked up the tree: piece ends, and vertices at the same (x, y)
    // in more than one place (junctions, appendRiverPieces' shared point ids).
    std::vector<std::size_t> first(pieces_.size() + 1, 0);
    for (std::size_t p = 0; p < pieces_.size(); ++p)
        first[p + 1] = first[p] + pieces_[p].size();
    // 1: locked; 2: a later occurrence of a junction's (x, y), one point with the first.
    std::vector<std::uint8_t> locked(first.back(), 0);
    {
        struct At {
            double x, y;
            std::size_t index;
        };
        std::vector<At> all;
        all.reserve(first.back());
        for (std::size_t p = 0; p < pieces_.size(); ++p)
            for (std::size_t v = 0; v < pieces_[p].size(); ++v)
                all.push_back({pieces_[p][v].x, pieces_[p][v].y, first[p] + v});
        std::sort(all.begin(), all.end(), [](const At& a, const At& b) {
            return a.x != b.x ? a.x < b.x : (a.y != b.y ? a.y < b.y : a.index < b.index);
        });
        for (std::size_t i = 0; i < all.size();) {
            std::size_t j = i + 1;
            while (j < all.size() && all[j].x == all[i].x && all[j].y == all[i].y)
                ++j;
            if (j - i > 1)
                for (std::size_t k = i; k < j; ++k)
                    locked[all[k].index] = k == i ? 1 : 2;
            i = j;
        }
    }
    for (std::size_t p = 0; p < pieces_.size(); ++p) {
        if (first[p + 1] == first[p]) continue;
        for (const std::size_t end : {first[p], first[p + 1] - 1})
            if (locked[end] == 0) locked[end] = 1;
    }
    for (std::size_t b = 0; b < rects_.size(); ++b) {
        for (const Run& run : runs_[b]) {
            for (std::uint32_t v = run.first; v <= run.last; ++v) {
                const std::uint8_t l = locked[first[run.piece] + v];
                out[b].riverPoints += l != 2;
                out[b].lockedRiverPoints += l == 1;
            }
        }
    }
    return out;
}

namespace {

// Squared distance between the 2D segments p0-p1 and q0-q1 (0 when they meet).
double segmentSegmentDistance2(const double p0[2], const double p1[2], const double q0[2],
                               const double q1[2]) {
    auto cross = [](const double a[2], const double b[2], const double c[2]) {
        return (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
    };
    const double d1 = cross(p0, p1, q0), d2 = cross(p0, p1, q1);
    const double d3 = cross(q0, q1, p0), d4 = cross(q0, q1, p1);
    if (((d1 > 0 && d2 < 0) || (d1 < 0 && d2 > 0)) && ((d3 > 0 && d4 < 0) || (d3 < 0 && d4 > 0)))
        return 0;
    auto pointSegment = [](const double m[2], const double a[2], const double c[2]) {
        const double dx = c[0] - a[0], dy = c[1] - a[1];
        const double len2 = dx * dx + dy * dy;
        const double t =
            len2 > 0 ? std::clamp(((m[0] - a[0]) * dx + (m[1] - a[1]) * dy) / len2, 0.0, 1.0)
                     : 0.0;
        const double ex = m[0] - a[0] - t * dx, ey = m[1] - a[1] - t * dy;
        return ex * ex + ey * ey;
    };
    return std::min({pointSegment(p0, q0, q1), pointSegment(p1, q0, q1), pointSegment(q0, p0, p1),
                     pointSegment(q1, p0, p1)});
}

}  // namespace

std::vector<RiverPiece> BlockSource::cutAtOutline(const std::vector<RiverPiece>& pieces) const {
    const DemGrid& dem = *dem_;
    const int s = options_.stride;
    const double sx = dem.cellX * s, sy = dem.cellY * s;
    auto lattice = [&](const RiverVertex& v, double& fi, double& fj) {
        fi = (v.x - dem.originX) / sx;
        fj = (v.y - dem.originY) / sy;
    };
    auto node = [&](int i, int j, double out[2]) {
        out[0] = dem.centreX(i * s);
        out[1] = dem.centreY(j * s);
    };
    // Inside a full lattice square (the square below-left of the vertex, clamped), and within
    // the lattice: with --stride the DEM's last rows and columns may lie beyond it (1e-9 for the
    // rounding of a vertex on the lattice's outer edge).
    auto vertexInside = [&](const RiverVertex& v) {
        double fi, fj;
        lattice(v, fi, fj);
        if (!(fi >= -1e-9 && fi <= nodesX_ - 1 + 1e-9 && fj >= -1e-9 && fj <= nodesY_ - 1 + 1e-9))
            return false;
        const int i = std::clamp(int(std::floor(fi)), 0, std::max(0, nodesX_ - 2));
        const int j = std::clamp(int(std::floor(fj)), 0, std::max(0, nodesY_ - 2));
        return validCorners(i, j) == 4;
    };
    // Whether lattice edge (i0, j0)-(i1, j1) (both valid) is on the outline of the whole domain
    // and not on the DEM's outer edge.
    auto outlineEdge = [&](int i0, int j0, int i1, int j1) {
        if (!nodeValid(i0, j0) || !nodeValid(i1, j1)) return false;
        if (i0 != i1 && j0 != j1) {  // a diagonal: on the outline iff its square has 3 corners
            return validCorners(std::min(i0, i1), std::min(j0, j1)) == 3;
        }
        int a, b;  // the squares on either side
        if (i0 == i1) {
            const int j = std::min(j0, j1);
            if (i0 == 0 || i0 == nodesX_ - 1) return false;
            a = validCorners(i0 - 1, j), b = validCorners(i0, j);
        } else {
            const int i = std::min(i0, i1);
            if (j0 == 0 || j0 == nodesY_ - 1) return false;
            a = validCorners(i, j0 - 1), b = validCorners(i, j0);
        }
        return (a >= 3) != (b >= 3);
    };
    // Calls fn(u, w) for every outline edge u-w (node coordinates) of the lattice squares within
    // `reach` squares of segment p -> q (so every outline edge within kOutlineMargin of it: 2 for
    // any cell of 1 cm or more); stops when fn returns true. Row by row, only the squares near
    // the segment's stretch in that row band: O(length), where scanning its whole bounding box
    // cost O(length^2) (a 2-vertex river across a 10 000-cell DEM scanned 10^8 squares per call).
    const double cellMin = std::min(std::fabs(sx), std::fabs(sy));
    const int reach =
        1 + int(std::min(double(1 << 20), std::ceil(kOutlineMargin / std::max(cellMin, 1e-12))));
    auto forOutlineEdgesNear = [&](const RiverVertex& p, const RiverVertex& q, auto&& fn) {
        double fi0, fj0, fi1, fj1;
        lattice(p, fi0, fj0);
        lattice(q, fi1, fj1);
        const double ylo = std::min(fj0, fj1), yhi = std::max(fj0, fj1);
        const int ilo = int(std::floor(std::min(fi0, fi1))) - reach,
                  ihi = int(std::floor(std::max(fi0, fi1))) + reach;
        const int jlo = int(std::floor(ylo)) - reach, jhi = int(std::floor(yhi)) + reach;
        for (int j = std::max(0, jlo); j <= std::min(nodesY_ - 1, jhi); ++j) {
            // The segment's x extent where its y is within `reach` rows of row j, grown by
            // `reach` + 1 squares (a point of a square at x = i + 1 floors to i + 1).
            int i0 = ilo, i1 = ihi;
            if (fj1 != fj0) {
                const double ya = std::max(double(j - reach), ylo),
                             yb = std::min(double(j + reach + 1), yhi);
                const double xa = fi0 + (ya - fj0) / (fj1 - fj0) * (fi1 - fi0),
                             xb = fi0 + (yb - fj0) / (fj1 - fj0) * (fi1 - fi0);
                i0 = std::max(ilo, int(std::floor(std::min(xa, xb))) - reach - 1);
                i1 = std::min(ihi, int(std::floor(std::max(xa, xb))) + reach + 1);
            }
            for (int i = std::max(0, i0); i <= std::min(nodesX_ - 1, i1); ++i) {
                const int cand[4][4] = {
                    {i, j, i + 1, j}, {i, j, i, j + 1}, {i, j, i + 1, j + 1}, {i + 1, j, i, j + 1}};
                for (const auto& e : cand) {
                    if (!outlineEdge(e[0], e[1], e[2], e[3])) continue;
                    double u[2], w[2];
                    node(e[0], e[1], u);
                    node(e[2], e[3], w);
                    if (fn(u, w)) return true;
                }
            }
        }
        return false;
    };
    const double margin2 = kOutlineMargin * kOutlineMargin;
    auto segmentNear = [&](const RiverVertex& p, const RiverVertex& q) {
        const double a[2] = {p.x, p.y}, c[2] = {q.x, q.y};
        return forOutlineEdgesNear(p, q, [&](const double u[2], const double w[2]) {
            return segmentSegmentDistance2(a, c, u, w) < margin2;
        });
    };
    // A vertex a river may have: inside a full lattice square, at least the margin away from
    // the outline, with a finite altitude.
    auto vertexOk = [&](const RiverVertex& v) {
        return std::isfinite(v.z) && vertexInside(v) && !segmentNear(v, v);
    };
    // The point at parameter t of p -> q on the 1 mm grid, with its DEM altitude.
    auto pointAt = [&](const RiverVertex& p, const RiverVertex& q, double t) {
        RiverVertex v;
        v.x = std::round((p.x + t * (q.x - p.x)) * 1000.0) / 1000.0;
        v.y = std::round((p.y + t * (q.y - p.y)) * 1000.0) / 1000.0;
        v.z = dem.sample(v.x, v.y);
        return v;
    };
    auto same = [](const RiverVertex& a, const RiverVertex& b) { return a.x == b.x && a.y == b.y; };
    // The parts of segment p -> q that stay inside full lattice squares and the margin away from
    // the outline, in order from p: the parameter intervals within the margin of each outline edge
    // near it (the distance to an edge is convex along the segment: its minimum, then each side
    // bisected), their complement, each part's middle inside the domain, its ends pulled 2 cm
    // further in (grid rounding) and then checked exactly as any vertex and segment (pulled in
    // further, up to 2^8 times as far, where the check fails). A part that starts at p starts
    // exactly at p, one that ends at q exactly at q.
    std::vector<std::pair<RiverVertex, RiverVertex>> parts;
    auto safeParts = [&](const RiverVertex& p, const RiverVertex& q) {
        parts.clear();
        const double len = std::hypot(q.x - p.x, q.y - p.y);
        if (!(len > 0)) return;
        std::vector<std::pair<double, double>> unsafe;
        forOutlineEdgesNear(p, q, [&](const double u[2], const double w[2]) {
            const auto f = [&](double t) {  // squared distance of P(t) to the edge
                const double m[2] = {p.x + t * (q.x - p.x), p.y + t * (q.y - p.y)};
                return segmentSegmentDistance2(m, m, u, w);
            };
            double lo = 0, hi = 1;
            for (int it = 0; it < 100; ++it) {  // the minimum (ternary search)
                const double a = lo + (hi - lo) / 3, b = hi - (hi - lo) / 3;
                if (f(a) < f(b))
                    hi = b;
                else
                    lo = a;
            }
            const double tm = 0.5 * (lo + hi);
            if (!(f(tm) < margin2)) return false;
            double l0 = 0, l1 = tm, r0 = tm, r1 = 1;  // bisect each side
            for (int it = 0; it < 60; ++it) {
                const double ml = 0.5 * (l0 + l1), mr = 0.5 * (r0 + r1);
                (f(ml) < margin2 ? l1 : l0) = ml;
                (f(mr) < margin2 ? r0 : r1) = mr;
            }
            unsafe.emplace_back(f(0) < margin2 ? 0.0 : l0, f(1) < margin2 ? 1.0 : r1);
            return false;
        });
        std::sort(unsafe.begin(), unsafe.end());
        std::vector<std::pair<double, double>> safe;  // the complement in [0, 1]
        double from = 0;
        for (const auto& [a, b] : unsafe) {
            if (a > from) safe.emplace_back(from, a);
            from = std::max(from, b);
            if (from >= 1) break;
        }
        if (from < 1) safe.emplace_back(from, 1.0);
        const double pad = 2 * kOutlineMargin / len;
        for (const auto& [a, b] : safe) {
            RiverVertex middle = pointAt(p, q, 0.5 * (a + b));
            if (!vertexInside(middle)) continue;  // a stretch outside the domain
            for (int attempt = 0; attempt <= 8; ++attempt) {
                const double grow = pad * double(1 << attempt);
                const double ta = a == 0 ? 0 : a + grow, tb = b == 1 ? 1 : b - grow;
                if (!(ta < tb)) break;
                const RiverVertex va = ta == 0 ? p : pointAt(p, q, ta);
                const RiverVertex vb = tb == 1 ? q : pointAt(p, q, tb);
                if (same(va, vb)) break;
                if (vertexOk(va) && vertexOk(vb) && !segmentNear(va, vb)) {
                    parts.emplace_back(va, vb);
                    break;
                }
            }
        }
    };
    std::vector<RiverPiece> out;
    for (const RiverPiece& piece : pieces) {
        RiverPiece run;
        auto flush = [&] {
            if (run.size() >= 2) out.push_back(run);
            run.clear();
        };
        bool previousOk = !piece.empty() && vertexOk(piece[0]);
        for (std::size_t k = 1; k < piece.size(); ++k) {
            const RiverVertex& u = piece[k - 1];
            const RiverVertex& v = piece[k];
            const bool ok = vertexOk(v);
            if (previousOk && ok && !segmentNear(u, v)) {
                parts.assign(1, {u, v});
            } else {
                safeParts(u, v);  // cut where the segment leaves the domain or nears its outline
            }
            for (const auto& [a, b] : parts) {
                if (run.empty() || !same(run.back(), a)) {
                    flush();
                    run.push_back(a);
                }
                run.push_back(b);
            }
            if (!run.empty() && !same(run.back(), v)) flush();
            previousOk = ok;
        }
        flush();
    }
    return out;
}

}  // namespace unilod
