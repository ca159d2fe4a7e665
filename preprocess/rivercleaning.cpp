// River network cleaning (paper §3 "eliminated scattered and tiny rivers"; DESIGN.md "Point set":
// "snap endpoints within a tolerance, split lines where they touch or cross so that every junction
// is an explicit shared vertex, drop zero-length segments and duplicate vertices, drop rivers
// shorter than a minimum length"). The steps, in this order:
//
// 0. Grid. Every coordinate is rounded once to the absolute 1 mm grid (g = llround(x * 1000));
//    all decisions below are exact integer predicates on these grid points (64/128-bit, as
//    grid.h / predicates.h), and the output is x = g / 1000.0, so equal grid points are identical
//    doubles and a later quantiser at 1 mm recovers the same grid up to a translation.
// 1. Clip. A vertex whose (rounded) position has no finite DemGrid::sample is dropped, and the
//    segments to and from it, and any segment crossing a void, are cut where they leave and enter
//    the valid DEM: the line ends at the last valid grid point and continues as a new line from
//    the first valid one after it (validRuns: the segment sampled at a quarter of a cell and each
//    change bisected to the grid, keeping the valid side's grid point; a void narrower than that
//    is left to blocks.cpp, which cuts the rivers exactly at the domain's outline). Before
//    2026-11-29 a vertex off the DEM cut its whole segments away and a segment over a void was
//    kept: a 2-vertex river crossing a lake of nodata was later lost whole.
// 2. Consecutive duplicates (identical input x, y) and zero-length segments (distinct input, same
//    1 mm grid point) are dropped; pieces with fewer than 2 vertices are dropped.
// 3. Snap. In line order, first then last vertex: an endpoint that is not already a vertex of
//    another line moves onto the nearest vertex of another line within snapTolerance; failing
//    that, onto the foot of the perpendicular on the nearest segment interior of another line
//    within snapTolerance, and that foot is inserted into the segment. Candidates come from a
//    uniform grid of segments; later endpoints see earlier moves and inserted feet.
// 4. Planarity, in passes until a pass changes nothing. Candidate segment pairs come from a
//    uniform grid hash (cells of twice the mean segment extent, hashed into buckets by a counting
//    sort; a long segment registers only the cells along it; never all pairs); after the first
//    pass only pairs with a segment changed by the previous pass are tested (a pair of unchanged
//    segments was already found clean). For a pair (s, t), in this order:
//      - two distinct endpoints within 1 grid unit (Chebyshev) are merged (the smaller grid point
//        wins; every occurrence in every line moves, so shared junctions stay shared);
//      - an endpoint of one within 1 grid unit of the other's interior is inserted into it (a
//        T-touch, and the collinear overlap case: the overlap's ends split both segments);
//      - a proper crossing: the exact intersection is rounded to the grid ONCE and the same point
//        is inserted into both segments (a line crossing itself likewise);
//      - identical segments (after the splits above, what remains of a collinear overlap): the
//        overlapping part is kept once — the later segment (by line, then vertex index) is
//        dropped and its line is cut there.
//    Rounded intersection points bend segments by < 1 mm, which can create new near-touches;
//    hence the passes. After kMaxPasses the later segment of every still-conflicting pair is
//    dropped (removing segments never creates a conflict), so the result is always planar.
//    Then a vertex off the valid DEM (an inserted point on the boundary) cuts its line as in 1,
//    and a line passing a vertex twice (it crossed itself) is cut at that vertex.
// 5. Lines shorter than minRiverLength (horizontal length) are dropped.
#include "rivercleaning.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <sstream>
#include <unordered_map>
#include <utility>
#include <vector>

namespace unilod {

namespace {

__extension__ typedef __int128 Int128;

constexpr double kUnitsPerMetre = 1000.0;  // 1 mm grid
// |coordinate| above this is rejected as invalid (keeps grid coordinates < 2^40, so every cross
// product of differences fits comfortably in 128 bits).
constexpr double kMaxCoordinate = 1e9;
constexpr int kMaxPasses = 32;

struct G {
    std::int64_t x = 0, y = 0;
    auto operator<=>(const G&) const = default;
};
struct GHash {
    std::size_t operator()(const G& g) const {
        std::uint64_t h = static_cast<std::uint64_t>(g.x) * 0x9E3779B97F4A7C15ull;
        h ^= static_cast<std::uint64_t>(g.y) + 0x632BE59BD9B4E019ull + (h << 6) + (h >> 2);
        return static_cast<std::size_t>(h ^ (h >> 29));
    }
};

using Line = std::vector<G>;

// A line with a per-vertex flag: 1 when the vertex was created or moved by the last change.
struct Work {
    Line v;
    std::vector<std::uint8_t> fresh;
};

double toMetres(std::int64_t g) {
    return static_cast<double>(g) / kUnitsPerMetre;
}

Int128 orient(const G& a, const G& b, const G& c) {
    return Int128(b.x - a.x) * Int128(c.y - a.y) - Int128(b.y - a.y) * Int128(c.x - a.x);
}
Int128 dot(const G& a, const G& b, const G& p) {  // (p - a) . (b - a)
    return Int128(p.x - a.x) * Int128(b.x - a.x) + Int128(p.y - a.y) * Int128(b.y - a.y);
}
int sign(Int128 v) {
    return v > 0 ? 1 : (v < 0 ? -1 : 0);
}

// floor(n / d) for d > 0.
Int128 floorDiv(Int128 n, Int128 d) {
    Int128 q = n / d;
    if ((n % d != 0) && (n < 0)) --q;
    return q;
}
// n / d rounded to nearest (halves up), d > 0.
std::int64_t roundDiv(Int128 n, Int128 d) {
    return static_cast<std::int64_t>(floorDiv(2 * n + d, 2 * d));
}

// a + (b - a) * num / den rounded to the grid (den > 0).
G pointAlong(const G& a, const G& b, Int128 num, Int128 den) {
    return {a.x + roundDiv(Int128(b.x - a.x) * num, den),
            a.y + roundDiv(Int128(b.y - a.y) * num, den)};
}

// True when p (not an endpoint) lies within 1 grid unit of the open segment ab: its projection
// falls strictly inside and its distance |cross| / |ab| <= 1, i.e. cross^2 <= |ab|^2. Exact.
bool nearInterior(const G& a, const G& b, const G& p) {
    if (p == a || p == b) return false;
    const Int128 len2 = dot(a, b, b);
    const Int128 d = dot(a, b, p);
    if (d <= 0 || d >= len2) return false;
    Int128 c = orient(a, b, p);
    if (c < 0) c = -c;
    // len2 < 2^84, so |cross| > 2^50 means distance > 1; below, cross^2 < 2^100 is exact.
    if (c > (Int128(1) << 50)) return false;
    return c * c <= len2;
}

bool adjacent(const G& p, const G& q) {
    return p != q && std::abs(p.x - q.x) <= 1 && std::abs(p.y - q.y) <= 1;
}

// --- Uniform grid hash of segments -------------------------------------------------------

struct Segment {
    G a, b;
    std::uint32_t line = 0, index = 0;  // segment index = index of its first vertex in the line
    bool dirty = true;
};

class SegmentGrid {
public:
    // Registers the segments in the cells their region padded by `pad` units (Chebyshev)
    // touches. With `dirtyOnly`, a clean segment is registered only in cells that hold a dirty
    // one (enough to find every pair with a dirty segment, at a fraction of the cost).
    void build(const std::vector<Segment>& segs, std::int64_t pad, bool dirtyOnly = false) {
        entries_.clear();
        ref_.assign(segs.size(), {0, 0});
        strip_.assign(segs.size(), 0);
        start_.assign(2, 0);
        mask_ = 0;
        if (segs.empty()) return;
        minX_ = segs[0].a.x;
        minY_ = segs[0].a.y;
        std::vector<std::int64_t> extents;
        extents.reserve(segs.size());
        double total = 0;
        for (const Segment& s : segs) {
            minX_ = std::min({minX_, s.a.x, s.b.x});
            minY_ = std::min({minY_, s.a.y, s.b.y});
            extents.push_back(std::max(std::abs(s.b.x - s.a.x), std::abs(s.b.y - s.a.y)));
            total += static_cast<double>(extents.back());
        }
        minX_ -= pad + 1;
        minY_ -= pad + 1;
        // Twice the median extent: most segments touch 1 to 4 cells, and a few long ones do not
        // make the cells of a dense network of short ones large (before 2026-11-30 twice the
        // mean: 9 000 undensified 10 km segments among 1 M of 10 m made 200 m cells of 4 000
        // segments each). At least half the mean extent, which bounds the cells registered along
        // long segments to about 4 per segment on average.
        const auto mid = extents.begin() + static_cast<std::ptrdiff_t>(extents.size() / 2);
        std::nth_element(extents.begin(), mid, extents.end());
        cell_ = std::max(
            {2 * *mid, static_cast<std::int64_t>(total / (2.0 * segs.size())), 2 * pad + 8});
        std::vector<Entry> raw;
        raw.reserve(2 * segs.size());
        auto push = [&](std::uint64_t key, std::uint32_t id) { raw.push_back({key, id}); };
        for (std::uint32_t i = 0; i < segs.size(); ++i) {
            if (!dirtyOnly || segs[i].dirty) registerSegment(segs[i].a, segs[i].b, pad, i, push);
        }
        if (dirtyOnly) {
            bucketize(raw);
            auto pushIfDirtyCell = [&](std::uint64_t key, std::uint32_t id) {
                if (inCell(key)) raw.push_back({key, id});
            };
            for (std::uint32_t i = 0; i < segs.size(); ++i) {
                if (!segs[i].dirty) registerSegment(segs[i].a, segs[i].b, pad, i, pushIfDirtyCell);
            }
        }
        bucketize(raw);
    }

    // Ids of the segments registered in the cell containing p (ascending).
    template <class F>
    void forCell(const G& p, F&& f) const {
        const std::uint64_t key = keyOf(cellOf(p.x, minX_), cellOf(p.y, minY_));
        const std::size_t b = bucketOf(key);
        for (std::size_t i = start_[b]; i < start_[b + 1]; ++i)
            if (entries_[i].key == key) f(entries_[i].id);
    }

    // Calls f(s, t), s < t, once for every pair of segments sharing a cell for which
    // want(s, t) holds. Two box-registered segments are reported only in their reference cell
    // (the lowest cell both boxes cover); pairs with a long segment are deduplicated by sorting.
    template <class W, class F>
    void forPairs(W&& want, F&& f) const {
        std::vector<std::uint64_t> pairs;  // pairs with a long segment, deduplicated at the end
        std::size_t compactAt = std::size_t{1} << 22;
        for (std::size_t b = 0; b + 1 < start_.size(); ++b) {
            for (std::size_t p = start_[b]; p < start_[b + 1]; ++p) {
                const std::uint64_t key = entries_[p].key;
                for (std::size_t q = p + 1; q < start_[b + 1]; ++q) {
                    if (entries_[q].key != key) continue;  // another cell in the same bucket
                    std::uint32_t s = entries_[p].id, t = entries_[q].id;
                    if (s == t) continue;  // (only on a key collision)
                    if (s > t) std::swap(s, t);
                    if (!want(s, t)) continue;
                    if (strip_[s] || strip_[t]) {
                        pairs.push_back((std::uint64_t{s} << 32) | t);
                        if (pairs.size() >= compactAt) {  // bound the duplicates' memory
                            std::sort(pairs.begin(), pairs.end());
                            pairs.erase(std::unique(pairs.begin(), pairs.end()), pairs.end());
                            compactAt = std::max(compactAt, 2 * pairs.size());
                        }
                    } else if (keyOf(std::max(ref_[s].first, ref_[t].first),
                                     std::max(ref_[s].second, ref_[t].second)) == key) {
                        f(s, t);
                    }
                }
            }
        }
        std::sort(pairs.begin(), pairs.end());
        pairs.erase(std::unique(pairs.begin(), pairs.end()), pairs.end());
        for (std::uint64_t k : pairs)
            f(static_cast<std::uint32_t>(k >> 32), static_cast<std::uint32_t>(k & 0xFFFFFFFFu));
    }

private:
    struct Entry {
        std::uint64_t key;
        std::uint32_t id;
    };

    std::size_t bucketOf(std::uint64_t key) const {
        const std::uint64_t h = key * 0x9E3779B97F4A7C15ull;
        return static_cast<std::size_t>((h ^ (h >> 31)) & mask_);
    }
    // Counting sort of the entries by hashed cell into buckets (stable: ids stay ascending).
    void bucketize(std::vector<Entry>& raw) {
        std::size_t n = 1;
        while (n < raw.size())
            n <<= 1;
        mask_ = n - 1;
        start_.assign(n + 1, 0);
        for (const Entry& e : raw)
            ++start_[bucketOf(e.key) + 1];
        for (std::size_t b = 0; b < n; ++b)
            start_[b + 1] += start_[b];
        entries_.resize(raw.size());
        std::vector<std::size_t> fill(start_.begin(), start_.end() - 1);
        for (const Entry& e : raw)
            entries_[fill[bucketOf(e.key)]++] = e;
    }
    bool inCell(std::uint64_t key) const {
        const std::size_t b = bucketOf(key);
        for (std::size_t i = start_[b]; i < start_[b + 1]; ++i)
            if (entries_[i].key == key) return true;
        return false;
    }

    std::int64_t cellOf(std::int64_t v, std::int64_t lo) const { return (v - lo) / cell_; }
    static std::uint64_t keyOf(std::int64_t cx, std::int64_t cy) {
        return (static_cast<std::uint64_t>(cx) << 32) ^ static_cast<std::uint64_t>(cy);
    }

    template <class Push>
    void registerSegment(const G& a, const G& b, std::int64_t pad, std::uint32_t id, Push&& push) {
        const std::int64_t x0 = std::min(a.x, b.x) - pad, x1 = std::max(a.x, b.x) + pad;
        const std::int64_t y0 = std::min(a.y, b.y) - pad, y1 = std::max(a.y, b.y) + pad;
        const std::int64_t c0 = cellOf(x0, minX_), c1 = cellOf(x1, minX_);
        const std::int64_t r0 = cellOf(y0, minY_), r1 = cellOf(y1, minY_);
        ref_[id] = {c0, r0};
        if ((c1 - c0 <= 8 && r1 - r0 <= 8 && (c1 - c0 + 1) * (r1 - r0 + 1) <= 9) || a.x == b.x) {
            for (std::int64_t c = c0; c <= c1; ++c)
                for (std::int64_t r = r0; r <= r1; ++r)
                    push(keyOf(c, r), id);
            return;
        }
        strip_[id] = 1;
        // A long segment: per column of cells, only the rows its padded band passes. The y range
        // is computed in double and widened by 2 units, which covers its rounding error.
        const double ax = static_cast<double>(a.x), ay = static_cast<double>(a.y);
        const double slope = static_cast<double>(b.y - a.y) / static_cast<double>(b.x - a.x);
        for (std::int64_t c = c0; c <= c1; ++c) {
            const std::int64_t sx0 = std::max(x0, minX_ + c * cell_);
            const std::int64_t sx1 = std::min(x1, minX_ + (c + 1) * cell_ - 1);
            // Segment points whose x is within pad of the strip.
            const double lo = static_cast<double>(std::max(sx0 - pad, std::min(a.x, b.x)));
            const double hi = static_cast<double>(std::min(sx1 + pad, std::max(a.x, b.x)));
            const double ya = ay + (lo - ax) * slope, yb = ay + (hi - ax) * slope;
            const auto ylo = static_cast<std::int64_t>(std::floor(std::min(ya, yb))) - pad - 2;
            const auto yhi = static_cast<std::int64_t>(std::ceil(std::max(ya, yb))) + pad + 2;
            const std::int64_t ra = std::max(r0, cellOf(std::max(ylo, minY_), minY_));
            const std::int64_t rb = std::min(r1, cellOf(std::max(yhi, minY_), minY_));
            for (std::int64_t r = ra; r <= rb; ++r)
                push(keyOf(c, r), id);
        }
    }

    std::int64_t minX_ = 0, minY_ = 0, cell_ = 1;
    std::vector<Entry> entries_;      // grouped by bucket
    std::vector<std::size_t> start_;  // bucket b: entries_[start_[b], start_[b + 1])
    std::size_t mask_ = 0;
    std::vector<std::pair<std::int64_t, std::int64_t>> ref_;  // lowest cell of the padded box
    std::vector<std::uint8_t> strip_;                         // registered along its length
};

std::vector<Segment> segmentsOf(const std::vector<Work>& lines, bool allDirty) {
    std::vector<Segment> segs;
    for (std::uint32_t l = 0; l < lines.size(); ++l) {
        const Work& w = lines[l];
        for (std::uint32_t k = 0; k + 1 < w.v.size(); ++k) {
            segs.push_back({w.v[k], w.v[k + 1], l, k, allDirty || w.fresh[k] || w.fresh[k + 1]});
        }
    }
    return segs;
}

// Drops consecutive equal vertices (the survivor is fresh when either was) and lines with fewer
// than 2 vertices. Returns the number of vertices dropped.
std::size_t dedupe(std::vector<Work>& lines, std::size_t& degenerate) {
    std::size_t dropped = 0;
    std::vector<Work> out;
    out.reserve(lines.size());
    for (Work& w : lines) {
        Work r;
        r.v.reserve(w.v.size());
        r.fresh.reserve(w.v.size());
        for (std::size_t k = 0; k < w.v.size(); ++k) {
            if (!r.v.empty() && r.v.back() == w.v[k]) {
                r.fresh.back() |= w.fresh[k];
                ++dropped;
                continue;
            }
            r.v.push_back(w.v[k]);
            r.fresh.push_back(w.fresh[k]);
        }
        if (r.v.size() >= 2) {
            out.push_back(std::move(r));
        } else {
            ++degenerate;
        }
    }
    lines = std::move(out);
    return dropped;
}

// --- Step 3: endpoint snapping -------------------------------------------------------------

void snapEndpoints(std::vector<Work>& lines, double tolUnits, RiverCleaningStats& stats) {
    if (!(tolUnits > 0)) return;
    const std::vector<Segment> segs = segmentsOf(lines, true);
    if (segs.empty()) return;
    // Moves of <= tol and targets within tol: pad 2 tol (+ rounding).
    const auto pad = static_cast<std::int64_t>(std::ceil(2 * tolUnits)) + 2;
    SegmentGrid grid;
    grid.build(segs, pad);
    std::vector<std::vector<G>> feet(segs.size());  // inserted per segment, in insertion order
    std::vector<std::uint32_t> segStart(lines.size() + 1, 0);  // first segment id of each line
    for (std::size_t l = 0; l < lines.size(); ++l)
        segStart[l + 1] = segStart[l] + static_cast<std::uint32_t>(lines[l].v.size() - 1);
    auto segId = [&](std::uint32_t line, std::uint32_t k) { return segStart[line] + k; };
    const double tol2 = tolUnits * tolUnits;
    auto dist2 = [](const G& p, const G& q) {
        const double dx = static_cast<double>(p.x - q.x), dy = static_cast<double>(p.y - q.y);
        return dx * dx + dy * dy;
    };
    for (std::uint32_t l = 0; l < lines.size(); ++l) {
        for (int end = 0; end < 2; ++end) {
            Work& w = lines[l];
            const std::size_t vi = end == 0 ? 0 : w.v.size() - 1;
            const G p = w.v[vi];
            std::vector<std::uint32_t> cands;
            grid.forCell(p, [&](std::uint32_t id) {
                if (segs[id].line != l) cands.push_back(id);
            });
            bool joined = false;
            double bestD = tol2;
            bool haveVertex = false;
            G bestV;
            for (std::uint32_t id : cands) {
                const Work& o = lines[segs[id].line];
                const G a = o.v[segs[id].index], b = o.v[segs[id].index + 1];
                auto consider = [&](const G& q) {
                    if (q == p) joined = true;
                    const double d = dist2(p, q);
                    if (d <= bestD && (!haveVertex || d < bestD || q < bestV)) {
                        bestD = d;
                        bestV = q;
                        haveVertex = true;
                    }
                };
                consider(a);
                consider(b);
                for (const G& f : feet[id])
                    consider(f);
            }
            if (joined) continue;
            if (haveVertex) {
                w.v[vi] = bestV;
                ++stats.snappedToVertex;
                continue;
            }
            double bestSeg = tolUnits;
            std::uint32_t bestId = 0;
            G bestFoot;
            bool haveFoot = false;
            for (std::uint32_t id : cands) {
                const Work& o = lines[segs[id].line];
                const G a = o.v[segs[id].index], b = o.v[segs[id].index + 1];
                const Int128 len2 = dot(a, b, b), d = dot(a, b, p);
                if (len2 == 0 || d <= 0 || d >= len2) continue;
                const double dist = std::abs(static_cast<double>(orient(a, b, p))) /
                                    std::sqrt(static_cast<double>(len2));
                if (dist > bestSeg || (haveFoot && dist == bestSeg)) continue;
                const G foot = pointAlong(a, b, d, len2);
                if (foot == a || foot == b) continue;
                bestSeg = dist;
                bestId = id;
                bestFoot = foot;
                haveFoot = true;
            }
            if (haveFoot) {
                w.v[vi] = bestFoot;
                feet[bestId].push_back(bestFoot);
                ++stats.snappedToSegment;
            }
        }
    }
    // Insert the feet, ordered along their segment.
    for (std::uint32_t l = 0; l < lines.size(); ++l) {
        Work& w = lines[l];
        bool any = false;
        for (std::uint32_t k = 0; k + 1 < w.v.size() && !any; ++k)
            any = !feet[segId(l, k)].empty();
        if (!any) continue;
        Work r;
        for (std::uint32_t k = 0; k + 1 < w.v.size(); ++k) {
            const G a = w.v[k], b = w.v[k + 1];
            if (r.v.empty()) r.v.push_back(a);
            std::vector<G>& f = feet[segId(l, k)];
            std::sort(f.begin(), f.end(), [&](const G& p, const G& q) {
                const Int128 dp = dot(a, b, p), dq = dot(a, b, q);
                return dp != dq ? dp < dq : p < q;
            });
            for (const G& q : f)
                r.v.push_back(q);
            r.v.push_back(b);
        }
        r.fresh.assign(r.v.size(), 1);
        w = std::move(r);
    }
    for (Work& w : lines)
        w.fresh.assign(w.v.size(), 1);
    stats.zeroLengthSegments += dedupe(lines, stats.degenerateLines);
}

// --- Step 4: planarity passes ----------------------------------------------------------------

struct Merge {
    std::unordered_map<G, G, GHash> parent;
    G find(G p) const {
        for (auto it = parent.find(p); it != parent.end(); it = parent.find(p))
            p = it->second;
        return p;
    }
    bool unite(const G& p, const G& q) {
        const G rp = find(p), rq = find(q);
        if (rp == rq) return false;
        if (rp < rq) {
            parent[rq] = rp;
        } else {
            parent[rp] = rq;
        }
        return true;
    }
};

// One pass: returns true when something changed. `dropConflicts`: instead of repairing, drop the
// later segment of every conflicting pair.
bool planarityPass(std::vector<Work>& lines, bool allDirty, bool dropConflicts,
                   RiverCleaningStats& stats) {
    const std::vector<Segment> segs = segmentsOf(lines, allDirty);
    if (segs.empty()) return false;
    SegmentGrid grid;
    grid.build(segs, 1, !allDirty);
    std::vector<std::pair<std::uint32_t, G>> inserts;
    std::vector<std::uint8_t> removed(segs.size(), 0);
    Merge merge;
    bool changed = false;
    // Every conflict below needs the boxes within 1 unit (Chebyshev) of each other.
    auto want = [&](std::uint32_t si, std::uint32_t ti) {
        const Segment& s = segs[si];
        const Segment& t = segs[ti];
        return (s.dirty || t.dirty) && std::min(s.a.x, s.b.x) <= std::max(t.a.x, t.b.x) + 1 &&
               std::min(t.a.x, t.b.x) <= std::max(s.a.x, s.b.x) + 1 &&
               std::min(s.a.y, s.b.y) <= std::max(t.a.y, t.b.y) + 1 &&
               std::min(t.a.y, t.b.y) <= std::max(s.a.y, s.b.y) + 1;
    };
    grid.forPairs(want, [&](std::uint32_t si, std::uint32_t ti) {
        const Segment& s = segs[si];
        const Segment& t = segs[ti];
        if (removed[si] || removed[ti]) return;
        const G a = s.a, b = s.b, c = t.a, d = t.b;
        auto conflict = [&]() {
            removed[ti] = 1;
            ++stats.unresolvedDropped;
            changed = true;
        };
        // Identical segments: the overlap is kept once, in the earlier line.
        if ((a == c && b == d) || (a == d && b == c)) {
            removed[ti] = 1;
            ++stats.overlapsDropped;
            changed = true;
            return;
        }
        bool merged = false;
        for (const G& p : {a, b}) {
            for (const G& q : {c, d}) {
                if (!adjacent(p, q)) continue;
                if (dropConflicts) return conflict();
                if (merge.unite(p, q)) ++stats.verticesMerged;
                merged = true;
            }
        }
        if (merged) {
            changed = true;
            return;
        }
        bool touched = false;
        auto touch = [&](std::uint32_t seg, const G& p) {
            inserts.push_back({seg, p});
            ++stats.touchesSplit;
            touched = true;
        };
        if (nearInterior(a, b, c) || nearInterior(a, b, d) || nearInterior(c, d, a) ||
            nearInterior(c, d, b)) {
            if (dropConflicts) return conflict();
            if (nearInterior(a, b, c)) touch(si, c);
            if (nearInterior(a, b, d)) touch(si, d);
            if (nearInterior(c, d, a)) touch(ti, a);
            if (nearInterior(c, d, b)) touch(ti, b);
            changed = true;
            return;
        }
        const Int128 o1 = orient(a, b, c), o2 = orient(a, b, d);
        const Int128 o3 = orient(c, d, a), o4 = orient(c, d, b);
        if (sign(o1) * sign(o2) >= 0 || sign(o3) * sign(o4) >= 0) return;
        if (dropConflicts) return conflict();
        // Proper crossing at a + (b - a) * o3 / (o3 - o4), rounded once, inserted into both.
        Int128 num = o3, den = o3 - o4;
        if (den < 0) {
            num = -num;
            den = -den;
        }
        const G x = pointAlong(a, b, num, den);
        if (x != a && x != b) inserts.push_back({si, x});
        if (x != c && x != d) inserts.push_back({ti, x});
        ++stats.crossingsSplit;
        if (s.line == t.line) ++stats.selfCrossings;
        changed = true;
    });
    if (!changed) return false;

    // Apply: inserted points in order along their segment, removed segments cut their line,
    // merged vertices move everywhere.
    std::sort(inserts.begin(), inserts.end(), [&](const auto& p, const auto& q) {
        if (p.first != q.first) return p.first < q.first;
        const Segment& s = segs[p.first];
        const Int128 dp = dot(s.a, s.b, p.second), dq = dot(s.a, s.b, q.second);
        return dp != dq ? dp < dq : p.second < q.second;
    });
    std::vector<Work> out;
    out.reserve(lines.size());
    std::size_t next = 0;  // into inserts
    std::size_t si = 0;    // segment id, in the order segmentsOf produced them
    for (const Work& w : lines) {
        Work cur;
        auto flush = [&] {
            if (cur.v.size() >= 2) out.push_back(std::move(cur));
            cur = Work{};
        };
        for (std::size_t k = 0; k + 1 < w.v.size(); ++k, ++si) {
            if (cur.v.empty()) {
                cur.v.push_back(w.v[k]);
                cur.fresh.push_back(0);
            }
            if (removed[si]) {
                for (; next < inserts.size() && inserts[next].first == si; ++next) {
                }
                flush();
                continue;
            }
            for (; next < inserts.size() && inserts[next].first == si; ++next) {
                const G& p = inserts[next].second;
                if (p == cur.v.back() || p == w.v[k + 1]) continue;
                cur.v.push_back(p);
                cur.fresh.push_back(1);
            }
            cur.v.push_back(w.v[k + 1]);
            cur.fresh.push_back(0);
        }
        flush();
    }
    assert(si == segs.size());
    if (!merge.parent.empty()) {
        for (Work& w : out) {
            for (std::size_t k = 0; k < w.v.size(); ++k) {
                const G r = merge.find(w.v[k]);
                if (r != w.v[k]) {
                    w.v[k] = r;
                    w.fresh[k] = 1;
                }
            }
        }
    }
    lines = std::move(out);
    std::size_t degenerate = 0;
    stats.zeroLengthSegments += dedupe(lines, degenerate);
    stats.degenerateLines += degenerate;
    return true;
}

// Splits every line at the vertices it passes more than once (a loop after a self-crossing).
void splitSelfLoops(std::vector<Work>& lines, RiverCleaningStats& stats) {
    std::vector<Work> out;
    out.reserve(lines.size());
    std::vector<G> sorted;
    for (Work& w : lines) {
        sorted = w.v;
        std::sort(sorted.begin(), sorted.end());
        if (std::adjacent_find(sorted.begin(), sorted.end()) == sorted.end()) {
            out.push_back(std::move(w));
            continue;
        }
        std::vector<G> repeated;
        for (std::size_t k = 0; k + 1 < sorted.size(); ++k) {
            if (sorted[k] == sorted[k + 1] && (repeated.empty() || repeated.back() != sorted[k]))
                repeated.push_back(sorted[k]);
        }
        Work cur;
        for (std::size_t k = 0; k < w.v.size(); ++k) {
            cur.v.push_back(w.v[k]);
            cur.fresh.push_back(0);
            const bool cut = k > 0 && k + 1 < w.v.size() &&
                             std::binary_search(repeated.begin(), repeated.end(), w.v[k]);
            if (cut) {
                out.push_back(std::move(cur));
                cur = Work{};
                cur.v.push_back(w.v[k]);
                cur.fresh.push_back(0);
                ++stats.selfLoopSplits;
            }
        }
        if (cur.v.size() >= 2) out.push_back(std::move(cur));
    }
    lines = std::move(out);
}

bool validOnDem(const DemGrid& dem, const G& g) {
    return std::isfinite(dem.sample(toMetres(g.x), toMetres(g.y)));
}

// Step 1 for one segment a -> b (grid points, a != b): its runs over the valid DEM, in order from
// a, each as (from, to) grid points with a finite sample (a run that starts at a starts exactly at
// a, one that ends at b ends exactly at b). The segment is sampled at every quarter of the
// smaller cell side inside the rectangle of cell centres (the only place a sample is finite), and
// each change between valid and not is bisected to within one grid unit, keeping the valid
// side's grid point. A void narrower than the sampling step can be missed here; blocks.cpp
// (cutAtOutline) cuts the rivers exactly where they leave the domain of the triangulation.
std::vector<std::pair<G, G>> validRuns(const DemGrid& dem, const G& a, const G& b) {
    std::vector<std::pair<G, G>> runs;
    const double ax = toMetres(a.x), ay = toMetres(a.y);
    const double dx = toMetres(b.x) - ax, dy = toMetres(b.y) - ay;
    const auto at = [&](double t) {
        if (t <= 0) return a;
        if (t >= 1) return b;
        return G{std::llround((ax + t * dx) * kUnitsPerMetre),
                 std::llround((ay + t * dy) * kUnitsPerMetre)};
    };
    const auto validAt = [&](double t) { return validOnDem(dem, at(t)); };
    // The parameter range inside the rectangle of the cell centres (Liang-Barsky).
    const double x0 = std::min(dem.centreX(0), dem.centreX(dem.width - 1));
    const double x1 = std::max(dem.centreX(0), dem.centreX(dem.width - 1));
    const double y0 = std::min(dem.centreY(0), dem.centreY(dem.height - 1));
    const double y1 = std::max(dem.centreY(0), dem.centreY(dem.height - 1));
    double t0 = 0, t1 = 1;
    const auto clip = [&](double p, double q) {  // keeps p * t <= q
        if (p == 0) return q >= 0;
        const double r = q / p;
        if (p < 0)
            t0 = std::max(t0, r);
        else
            t1 = std::min(t1, r);
        return t0 <= t1;
    };
    if (!(clip(-dx, ax - x0) && clip(dx, x1 - ax) && clip(-dy, ay - y0) && clip(dy, y1 - ay)))
        return runs;
    const double length = std::hypot(dx, dy);
    const double step = 0.25 * std::min(std::fabs(dem.cellX), std::fabs(dem.cellY));
    const double span = (t1 - t0) * length;
    const std::size_t n =
        std::size_t(std::min(std::ceil(span / std::max(step, 1e-3)), double(1u << 22))) + 1;
    // The samples: 0, the range [t0, t1] in n steps, 1.
    std::vector<double> ts;
    ts.reserve(n + 3);
    ts.push_back(0);
    for (std::size_t k = 0; k <= n; ++k)
        ts.push_back(t0 + (t1 - t0) * double(k) / double(n));
    ts.push_back(1);
    // The boundary between a valid parameter `in` and an invalid `out`: the valid side's grid
    // point once the two are within one grid unit.
    const auto boundary = [&](double in, double out) {
        for (int i = 0; i < 80; ++i) {
            const G gi = at(in), go = at(out);
            if (std::llabs(gi.x - go.x) <= 1 && std::llabs(gi.y - go.y) <= 1) break;
            const double mid = 0.5 * (in + out);
            (validAt(mid) ? in : out) = mid;
        }
        return at(in);
    };
    bool inside = false;
    double prevT = 0;
    G from{};
    for (std::size_t k = 0; k < ts.size(); ++k) {
        const double t = ts[k];
        if (k > 0 && t == prevT) continue;
        const bool valid = validAt(t);
        if (valid && !inside) from = k == 0 ? a : boundary(t, prevT);
        if (!valid && inside) {
            const G to = boundary(prevT, t);
            if (!(to == from)) runs.emplace_back(from, to);
        }
        inside = valid;
        prevT = t;
    }
    if (inside && !(b == from)) runs.emplace_back(from, b);
    return runs;
}

}  // namespace

RiverLines cleanRivers(const RiverLines& in, const DemGrid& dem, const RiverCleaningOptions& opt,
                       RiverCleaningStats& stats) {
    assert(dem.z.size() == static_cast<std::size_t>(dem.width) * dem.height);
    assert(opt.snapTolerance >= 0 && opt.minRiverLength >= 0);
    stats = RiverCleaningStats{};
    stats.inputLines = in.size();

    // Steps 0-2: grid, clip, duplicates.
    std::vector<Work> lines;
    for (const RiverLine& line : in) {
        stats.inputVertices += line.size();
        Work cur;
        const XY* prev = nullptr;  // input of cur.v.back()
        auto flush = [&] {
            if (cur.v.size() >= 2) {
                lines.push_back(std::move(cur));
            } else if (!cur.v.empty()) {
                ++stats.degenerateLines;
            }
            cur = Work{};
            prev = nullptr;
        };
        auto push = [&](const G& g) {
            if (!cur.v.empty() && cur.v.back() == g) {
                ++stats.zeroLengthSegments;
                return;
            }
            cur.v.push_back(g);
            cur.fresh.push_back(1);
        };
        // The previous vertex of the line (valid on the DEM or not) for the segment clip.
        bool havePrevious = false, previousValid = false;
        G previous{};
        for (const XY& p : line) {
            if (!(std::abs(p.x) < kMaxCoordinate && std::abs(p.y) < kMaxCoordinate)) {
                ++stats.verticesOutsideDem;
                flush();
                havePrevious = false;
                continue;
            }
            const G g{std::llround(p.x * kUnitsPerMetre), std::llround(p.y * kUnitsPerMetre)};
            const bool valid = validOnDem(dem, g);
            if (prev != nullptr && prev->x == p.x && prev->y == p.y) {
                ++stats.duplicateVertices;
                continue;
            }
            // The segment from the previous vertex: cut where it leaves the valid DEM, and a
            // new line where it enters it again.
            if (havePrevious && !(previous == g)) {
                const std::vector<std::pair<G, G>> runs = validRuns(dem, previous, g);
                // Counted when some of it is over the valid DEM and some is not.
                bool cut = runs.empty() ? previousValid || valid : runs.size() > 1;
                for (std::size_t r = 0; r < runs.size(); ++r) {
                    const bool fromPrevious = r == 0 && previousValid && runs[r].first == previous;
                    const bool toThis = r + 1 == runs.size() && valid && runs[r].second == g;
                    cut = cut || !fromPrevious || !toThis;
                    if (!fromPrevious) {
                        flush();
                        push(runs[r].first);
                    }
                    if (!toThis) {
                        push(runs[r].second);
                        flush();
                    }
                }
                if (cut) ++stats.segmentsCut;
                if (runs.empty() && previousValid) flush();
            }
            havePrevious = true;
            previous = g;
            previousValid = valid;
            if (!valid) {
                ++stats.verticesOutsideDem;
                flush();
                continue;
            }
            prev = &p;
            push(g);
        }
        flush();
    }

    // Step 3.
    snapEndpoints(lines, opt.snapTolerance * kUnitsPerMetre, stats);

    // Step 4.
    bool allDirty = true;
    for (int pass = 0;; ++pass) {
        const bool giveUp = pass >= kMaxPasses;
        ++stats.passes;
        if (!planarityPass(lines, allDirty || giveUp, giveUp, stats)) break;
        allDirty = false;
    }
    // Inserted points may sit just off the valid DEM: cut there (removes segments only).
    {
        std::vector<Work> out;
        for (Work& w : lines) {
            Work cur;
            for (std::size_t k = 0; k < w.v.size(); ++k) {
                if (!validOnDem(dem, w.v[k])) {
                    ++stats.verticesOutsideDem;
                    if (cur.v.size() >= 2) out.push_back(std::move(cur));
                    cur = Work{};
                    continue;
                }
                cur.v.push_back(w.v[k]);
                cur.fresh.push_back(0);
            }
            if (cur.v.size() >= 2) out.push_back(std::move(cur));
        }
        lines = std::move(out);
    }
    splitSelfLoops(lines, stats);

    // Step 5 and output.
    RiverLines result;
    result.reserve(lines.size());
    for (const Work& w : lines) {
        RiverLine r;
        r.reserve(w.v.size());
        double length = 0;
        for (std::size_t k = 0; k < w.v.size(); ++k) {
            r.push_back({toMetres(w.v[k].x), toMetres(w.v[k].y)});
            if (k > 0) length += std::hypot(r[k].x - r[k - 1].x, r[k].y - r[k - 1].y);
        }
        if (length < opt.minRiverLength) {
            ++stats.shortLinesDropped;
            continue;
        }
        stats.outputVertices += r.size();
        result.push_back(std::move(r));
    }
    stats.outputLines = result.size();
    return result;
}

std::string describe(const RiverCleaningStats& s) {
    std::ostringstream o;
    o << "River cleaning: " << s.inputLines << " lines / " << s.inputVertices << " vertices in, ";
    if (s.densifiedVertices > 0)
        o << "densified with " << s.densifiedVertices
          << " vertices (segments longer than two cells, a vertex about every cell), ";
    o << s.outputLines << " lines / " << s.outputVertices << " vertices out. Dropped "
      << s.verticesOutsideDem << " vertices off the valid DEM (lines split there; " << s.segmentsCut
      << " segments cut where they leave or enter it), " << s.duplicateVertices
      << " duplicate vertices, " << s.zeroLengthSegments << " zero-length segments, "
      << s.degenerateLines << " degenerate pieces and " << s.shortLinesDropped
      << " short lines. Snapped " << s.snappedToVertex << " endpoints to a vertex and "
      << s.snappedToSegment << " onto a segment. Split " << s.crossingsSplit << " crossings ("
      << s.selfCrossings << " self-crossings) and " << s.touchesSplit << " touches, merged "
      << s.verticesMerged << " near-coincident vertices, dropped " << s.overlapsDropped
      << " overlapping segments, cut " << s.selfLoopSplits << " self-loops";
    if (s.unresolvedDropped > 0) o << ", dropped " << s.unresolvedDropped << " unresolved segments";
    o << " (" << s.passes << " passes).";
    return o.str();
}

}  // namespace unilod
