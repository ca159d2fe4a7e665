#include "refine.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <optional>
#include <unordered_map>
#include <utility>

#include "directededges.h"
#include "lod.h"
#include "predicates.h"

namespace unilod::engine {

namespace {

// A triangle's identity: its vertices rotated to start at the smallest (orientation kept).
std::uint64_t triangleKey(const format::Triangle& t) {
    const std::uint32_t v[3] = {t.a, t.b, t.c};
    int r = 0;
    if (v[1] < v[r]) r = 1;
    if (v[2] < v[r]) r = 2;
    return (std::uint64_t(v[r]) << 42) | (std::uint64_t(v[(r + 1) % 3]) << 21) |
           std::uint64_t(v[(r + 2) % 3]);
}

std::uint64_t edgeKey(const format::Edge& e) {
    return (std::uint64_t(e.a) << 32) | e.b;
}

void grow(double lo[3], double hi[3], double x, double y, double z) {
    lo[0] = std::min(lo[0], x), hi[0] = std::max(hi[0], x);
    lo[1] = std::min(lo[1], y), hi[1] = std::max(hi[1], y);
    lo[2] = std::min(lo[2], z), hi[2] = std::max(hi[2], z);
}

// The block's vertices (its original points) in a uniform grid of buckets over their grid
// positions, about one point per bucket; each bucket's points with their grid positions, so that
// a scan reads one array in order.
class PointBuckets {
public:
    explicit PointBuckets(const format::Block& b) : b_(b) {
        lo_[0] = lo_[1] = INT64_MAX;
        std::int64_t hi[2] = {INT64_MIN, INT64_MIN};
        for (const format::GridXY& g : b.grid) {
            lo_[0] = std::min<std::int64_t>(lo_[0], g.x),
            hi[0] = std::max<std::int64_t>(hi[0], g.x);
            lo_[1] = std::min<std::int64_t>(lo_[1], g.y),
            hi[1] = std::max<std::int64_t>(hi[1], g.y);
        }
        // side_: grid units a bucket, about sqrt(n) buckets a row.
        const std::int64_t cells =
            std::max<std::int64_t>(1, std::int64_t(std::sqrt(double(b.grid.size()))));
        side_ = std::max<std::int64_t>(1, std::max(hi[0] - lo_[0], hi[1] - lo_[1]) / cells + 1);
        size_[0] = (hi[0] - lo_[0]) / side_ + 1;
        size_[1] = (hi[1] - lo_[1]) / side_ + 1;
        first_.assign(std::size_t(size_[0] * size_[1]) + 1, 0);
        for (const format::GridXY& g : b.grid)
            ++first_[cell(g.x, g.y) + 1];
        for (std::size_t c = 1; c < first_.size(); ++c)
            first_[c] += first_[c - 1];
        points_.resize(b.grid.size());
        std::vector<std::uint32_t> at(first_.begin(), first_.end() - 1);
        for (std::uint32_t v = 0; v < b.grid.size(); ++v)
            points_[at[cell(b.grid[v].x, b.grid[v].y)]++] = {b.grid[v].x, b.grid[v].y, v};
    }

    // Whether vertex v lies in the closed triangle t (grid positions, exact).
    bool contains(const format::Triangle& t, std::uint32_t v) const {
        const format::GridXY a = b_.grid[t.a], b = b_.grid[t.b], c = b_.grid[t.c], p = b_.grid[v];
        return unilod::orient2d(a.x, a.y, b.x, b.y, p.x, p.y) >= 0 &&
               unilod::orient2d(b.x, b.y, c.x, c.y, p.x, p.y) >= 0 &&
               unilod::orient2d(c.x, c.y, a.x, a.y, p.x, p.y) >= 0;
    }

    // Calls f(v) for every vertex v in the closed triangle t (grid positions, exact: the three
    // edge functions of t, each exact in int64 for grid coordinates, orient2d's terms expanded).
    template <typename F>
    void inTriangle(const format::Triangle& t, F&& f) const {
        const format::GridXY a = b_.grid[t.a], b = b_.grid[t.b], c = b_.grid[t.c];
        const std::int64_t x0 = std::min({a.x, b.x, c.x}), x1 = std::max({a.x, b.x, c.x});
        const std::int64_t y0 = std::min({a.y, b.y, c.y}), y1 = std::max({a.y, b.y, c.y});
        // orient2d(p, q, r) = (qx - px)(ry - py) - (qy - py)(rx - px) = A rx + B ry + C with
        // A = py - qy, B = qx - px, C = px qy - py qx.
        const auto edge = [](format::GridXY p, format::GridXY q, std::int64_t k[3]) {
            k[0] = std::int64_t(p.y) - q.y;
            k[1] = std::int64_t(q.x) - p.x;
            k[2] = std::int64_t(p.x) * q.y - std::int64_t(p.y) * q.x;
        };
        std::int64_t e0[3], e1[3], e2[3];
        edge(a, b, e0), edge(b, c, e1), edge(c, a, e2);
        const std::int64_t i0 = (x0 - lo_[0]) / side_, i1 = (x1 - lo_[0]) / side_;
        for (std::int64_t j = (y0 - lo_[1]) / side_; j <= (y1 - lo_[1]) / side_; ++j) {
            const std::size_t row = std::size_t(j * size_[0]);
            for (std::uint32_t n = first_[row + i0]; n < first_[row + i1 + 1]; ++n) {
                const Entry& p = points_[n];
                if (p.x < x0 || p.x > x1 || p.y < y0 || p.y > y1) continue;
                if (e0[0] * p.x + e0[1] * p.y + e0[2] < 0 ||
                    e1[0] * p.x + e1[1] * p.y + e1[2] < 0 || e2[0] * p.x + e2[1] * p.y + e2[2] < 0)
                    continue;
                f(p.v);
            }
        }
    }

private:
    struct Entry {
        std::int32_t x, y;
        std::uint32_t v;
    };
    std::size_t cell(std::int64_t x, std::int64_t y) const {
        return std::size_t(((y - lo_[1]) / side_) * size_[0] + (x - lo_[0]) / side_);
    }
    const format::Block& b_;
    std::int64_t lo_[2] = {}, size_[2] = {}, side_ = 1;
    std::vector<std::uint32_t> first_;
    std::vector<Entry> points_;
};

// A table index per 64-bit key (a triangle's or river edge's identity), open addressing with
// linear probing: init() looks one up for every record, where std::unordered_map was a fifth of
// the loader's time. Key and value share a slot (one cache miss per lookup, not two), and init()
// keeps only the alive elements in it (take() removes with backward shifting), so the table is the
// size of the largest alive set, not of every element the records ever create (a quarter of that
// on a 256-cell leaf). Never more than half full: sized for `keys` (exact for a validated block,
// whose trianglesAlive are checked), doubled should an insertion pass that; ~0 is no key (vertex
// indices are below 2^21).
class IdMap {
public:
    explicit IdMap(std::size_t keys) { resize(keys); }
    // Inserts the key or replaces its value and tag.
    void set(std::uint64_t key, std::uint32_t value, std::uint32_t tag = 0) {
        if (2 * (count_ + 1) > slots_.size()) grow();
        std::size_t i = slot(key);
        while (slots_[i].key != kEmpty && slots_[i].key != key)
            i = (i + 1) & mask_;
        if (slots_[i].key == kEmpty) ++count_;
        slots_[i] = {key, value, tag};
    }
    // Starts loading the key's home slot (a lookup soon after finds it in cache).
    void prefetch(std::uint64_t key) const { __builtin_prefetch(&slots_[slot(key)]); }
    // Removes the key and gives its value and tag; false when it is not there.
    bool take(std::uint64_t key, std::uint32_t& value, std::uint32_t& tag) {
        std::size_t i = slot(key);
        while (slots_[i].key != key) {
            if (slots_[i].key == kEmpty) return false;
            i = (i + 1) & mask_;
        }
        value = slots_[i].value;
        tag = slots_[i].tag;
        // Backward shift: move up every later key of the run whose home is not between the hole
        // and it (cyclically), so that no lookup meets an empty slot before its key.
        for (std::size_t j = (i + 1) & mask_; slots_[j].key != kEmpty; j = (j + 1) & mask_) {
            const std::size_t home = slot(slots_[j].key);
            if (((j - home) & mask_) >= ((j - i) & mask_)) {
                slots_[i] = slots_[j];
                i = j;
            }
        }
        slots_[i].key = kEmpty;
        --count_;
        return true;
    }

private:
    static constexpr std::uint64_t kEmpty = ~std::uint64_t(0);
    struct Slot {
        std::uint64_t key;
        std::uint32_t value, tag;
    };
    void resize(std::size_t keys) {
        std::size_t capacity = 16;
        while (capacity < 2 * keys)
            capacity *= 2;
        slots_.assign(capacity, Slot{kEmpty, 0, 0});
        mask_ = capacity - 1;
        shift_ = 64 - unsigned(std::countr_zero(capacity));
        count_ = 0;
    }
    void grow() {
        std::vector<Slot> old = std::move(slots_);
        resize(old.size());  // twice the keys it held at most: double the capacity
        for (const Slot& s : old)
            if (s.key != kEmpty) set(s.key, s.value, s.tag);
    }
    std::size_t slot(std::uint64_t key) const {
        return std::size_t((key * 0x9E3779B97F4A7C15ull) >> shift_);  // Fibonacci hashing
    }
    std::vector<Slot> slots_;
    std::size_t mask_ = 0, count_ = 0;
    unsigned shift_ = 0;
};

// The outline of a whole triangulation over vertices [0, n): its directed edges whose reverse is
// not in it, in the triangles' order, in linear time (format/directededges.h).
void outlineEdges(const format::Triangle* first, const format::Triangle* last, std::size_t n,
                  std::vector<std::uint64_t>& out) {
    const format::DirectedEdges edges(first, last, n);
    out.clear();
    for (const format::Triangle* t = first; t != last; ++t)
        for (const auto& [from, to] : {std::pair{t->a, t->b}, {t->b, t->c}, {t->c, t->a}})
            if (!edges.has(to, from)) out.push_back((std::uint64_t(from) << 32) | to);
}

// The outer boundary of a set of triangles: its directed edges whose reverse is not in the set,
// sorted.
void outerBoundary(const format::Triangle* first, const format::Triangle* last,
                   std::vector<std::uint64_t>& all, std::vector<std::uint64_t>& out) {
    all.clear();
    for (const format::Triangle* t = first; t != last; ++t) {
        all.push_back((std::uint64_t(t->a) << 32) | t->b);
        all.push_back((std::uint64_t(t->b) << 32) | t->c);
        all.push_back((std::uint64_t(t->c) << 32) | t->a);
    }
    std::sort(all.begin(), all.end());
    out.clear();
    for (const std::uint64_t e : all) {
        const std::uint64_t reverse = (e << 32) | (e >> 32);
        if (!std::binary_search(all.begin(), all.end(), reverse)) out.push_back(e);
    }
}

}  // namespace

bool Refinement::init(const format::Block& b, std::string& why) {
    *this = Refinement{};
    const std::size_t n = b.vertices.size();
    // A tree node's original points are its leaves': its steps take the stored running maximum
    // (refine.h).
    const bool node = b.firstChild != format::kNoChild || b.level != 0;
    if (node && (b.errorMax.size() != b.steps.size() + 1 ||
                 (!b.errorRiver.empty() && b.errorRiver.size() != b.steps.size() + 1))) {
        why = "a tree node without its `max` errors";
        return false;
    }
    if (b.grid.size() != n || n == 0 || b.levels.empty()) {
        why = "no grid positions";
        return false;
    }
    if (n >= (std::size_t{1} << 21)) {
        why = "more than 2^21 vertices";
        return false;
    }
    const double unit = format::kGridUnit;
    // A vertex in metres from the block origin (exact grid x, y; the file's z).
    const auto px = [&](std::uint32_t v) { return b.grid[v].x * unit; };
    const auto py = [&](std::uint32_t v) { return b.grid[v].y * unit; };
    const auto pz = [&](std::uint32_t v) { return double(b.vertices[v].z); };

    // The alive elements only (IdMap::take at their removal): at most the largest alive set.
    std::size_t aliveTriangles = b.levels.front().triangleCount;
    std::size_t aliveEdges = b.levels.front().riverCount;
    for (const format::Step& st : b.steps) {
        aliveTriangles = std::max<std::size_t>(aliveTriangles, st.trianglesAlive);
        aliveEdges = std::max<std::size_t>(aliveEdges, st.riverEdgesAlive);
    }
    IdMap triangleId(aliveTriangles);
    IdMap edgeId(aliveEdges);
    const format::Level& full = b.levels.front();
    for (std::uint32_t t = full.triangleFirst; t < full.triangleFirst + full.triangleCount; ++t) {
        triangleId.set(triangleKey(b.terrainIndices[t]), std::uint32_t(triangles_.size()), 0);
        triangles_.push_back(b.terrainIndices[t]);
        triangleDestroyer_.push_back(0);
    }
    fullTriangles_ = full.triangleCount;
    // What each river edge alive stands for: the original river vertices strictly between its
    // ends (full resolution: none).
    std::vector<std::vector<std::uint32_t>> cover;
    for (std::uint32_t e = full.riverFirst; e < full.riverFirst + full.riverCount; ++e) {
        edgeId.set(edgeKey(b.riverIndices[e]), std::uint32_t(edges_.size()));
        edges_.push_back(b.riverIndices[e]);
        edgeDestroyer_.push_back(0);
        cover.emplace_back();
    }
    const bool outlineMoves = format::outlineMoves(b);
    horizontal_ = full.riverCount > 0 || outlineMoves;

    // The original points located per triangle (a leaf's own vertices; a node has none here).
    std::optional<PointBuckets> buckets;
    if (!node) buckets.emplace(b);
    steps_.reserve(b.steps.size());
    createdTriangles_.assign(1, 0);
    createdTriangles_.push_back(std::uint32_t(triangles_.size()));
    createdEdges_.assign(1, 0);
    createdEdges_.push_back(std::uint32_t(edges_.size()));
    std::vector<std::uint32_t> merged;
    std::vector<std::uint64_t> removedOuter, addedOuter, scratch, newOutline;
    std::vector<std::uint32_t> outside;
    // The original points outside the domain each outline edge (directed, as its triangle has
    // it) stands for; full resolution: none.
    std::unordered_map<std::uint64_t, std::vector<std::uint32_t>> outlineCover;
    outlineEdges(b.terrainIndices.data() + full.triangleFirst,
                 b.terrainIndices.data() + full.triangleFirst + full.triangleCount, n,
                 removedOuter);
    // How many outline edges each vertex has.
    std::vector<std::uint32_t> outlineDegree(n, 0);
    for (const std::uint64_t e : removedOuter) {
        outlineCover[e] = {};
        for (const std::uint32_t v : {std::uint32_t(e >> 32), std::uint32_t(e)})
            ++outlineDegree[v];
    }
    for (std::size_t s = 0; s < b.steps.size(); ++s) {
        // The table lookups of the next step are cache misses (the table is larger than the
        // cache): their slots are loaded while this step measures its errors.
        if (s + 1 < b.steps.size()) {
            for (std::uint32_t r = b.removedTriangleOffset[s + 1];
                 r < b.removedTriangleOffset[s + 2]; ++r)
                triangleId.prefetch(triangleKey(b.removedTriangles[r]));
            for (std::uint32_t a = b.addedTriangleOffset[s + 1]; a < b.addedTriangleOffset[s + 2];
                 ++a)
                triangleId.prefetch(triangleKey(b.addedTriangles[a]));
        }
        Step step;
        for (int k = 0; k < 3; ++k)
            step.boxMin[k] = INFINITY, step.boxMax[k] = -INFINITY;
        step.parentFirst = std::uint32_t(parents_.size());
        const std::uint32_t self = std::uint32_t(s + 1);
        for (std::uint32_t r = b.removedTriangleOffset[s]; r < b.removedTriangleOffset[s + 1];
             ++r) {
            std::uint32_t id = 0, creator = 0;
            if (!triangleId.take(triangleKey(b.removedTriangles[r]), id, creator)) {
                *this = Refinement{};
                why = "step " + std::to_string(s) + " removes a triangle that is not alive";
                return false;
            }
            triangleDestroyer_[id] = self;
            if (creator != 0 && std::find(parents_.begin() + step.parentFirst, parents_.end(),
                                          creator) == parents_.end())
                parents_.push_back(creator);
        }
        double vertical = 0;
        for (std::uint32_t a = b.addedTriangleOffset[s]; a < b.addedTriangleOffset[s + 1]; ++a) {
            const format::Triangle& t = b.addedTriangles[a];
            triangleId.set(triangleKey(t), std::uint32_t(triangles_.size()), self);
            triangles_.push_back(t);
            triangleDestroyer_.push_back(0);
            // The plane through the triangle: z = z_a + gx (x - x_a) + gy (y - y_a).
            const double ux = px(t.b) - px(t.a), uy = py(t.b) - py(t.a), uz = pz(t.b) - pz(t.a);
            const double wx = px(t.c) - px(t.a), wy = py(t.c) - py(t.a), wz = pz(t.c) - pz(t.a);
            const double d = ux * wy - uy * wx;  // > 0: counter-clockwise, non-degenerate
            const double gx = (uz * wy - uy * wz) / d, gy = (ux * wz - uz * wx) / d;
            for (std::uint32_t v : {t.a, t.b, t.c})
                grow(step.boxMin, step.boxMax, px(v), py(v), pz(v));
            if (node) continue;
            buckets->inTriangle(t, [&](std::uint32_t v) {
                const double surface = pz(t.a) + gx * (px(v) - px(t.a)) + gy * (py(v) - py(t.a));
                vertical = std::max(vertical, std::abs(surface - pz(v)));
                grow(step.boxMin, step.boxMax, px(v), py(v), pz(v));
            });
        }
        step.parentCount = std::uint32_t(parents_.size()) - step.parentFirst;
        // The outline (blocks.h "Domain"): a step whose created triangles do not have the outer
        // boundary of those it removes deleted an outline vertex. Its new outline edges stand
        // for the original points outside the domain there: those the outline edges it ends
        // stood for and those it leaves outside (in a removed triangle, in no created one). Their
        // horizontal distance to the nearest new outline edge bounds their distance to the drawn
        // outline, a horizontal displacement (the river part, as the build's outline deviation).
        // Only a vertex on the outline can move it (any other's star is a closed fan whose
        // re-triangulation keeps its outer boundary).
        double outline = 0;
        if (node ? outlineMoves : outlineDegree[b.steps[s].vertex] > 0) {
            outerBoundary(b.removedTriangles.data() + b.removedTriangleOffset[s],
                          b.removedTriangles.data() + b.removedTriangleOffset[s + 1], scratch,
                          removedOuter);
            outerBoundary(b.addedTriangles.data() + b.addedTriangleOffset[s],
                          b.addedTriangles.data() + b.addedTriangleOffset[s + 1], scratch,
                          addedOuter);
            step.movesOutline = removedOuter != addedOuter;
        }
        // A node's step that moves the outline is never taken beyond the stored prefix: where
        // the original points its new outline stands for lie is not known here.
        step.blocked = node && step.movesOutline;
        if (step.movesOutline && !node) {
            // The outline edges this step ends (their points are reassigned) and starts: a
            // boundary edge of the removed region that was outline goes; one that was not
            // (a neighbour on its other side) now faces the exterior from that neighbour; a
            // boundary edge of the created region faces the exterior unless a triangle across it
            // had it as outline (the region grew into a notch).
            outside.clear();
            newOutline.clear();
            const auto reverse = [](std::uint64_t e) { return (e << 32) | (e >> 32); };
            // An ended edge hands on the points it stood for and its own ends (unless they are
            // still on the outline, below).
            const auto end = [&](std::uint64_t e) {
                const auto it = outlineCover.find(e);
                outside.insert(outside.end(), it->second.begin(), it->second.end());
                outlineCover.erase(it);
                for (const std::uint32_t v : {std::uint32_t(e >> 32), std::uint32_t(e)}) {
                    --outlineDegree[v];
                    outside.push_back(v);
                }
            };
            for (const std::uint64_t e : removedOuter) {
                if (std::binary_search(addedOuter.begin(), addedOuter.end(), e)) continue;
                if (outlineCover.count(e) != 0)
                    end(e);
                else
                    newOutline.push_back(reverse(e));
            }
            for (const std::uint64_t e : addedOuter) {
                if (std::binary_search(removedOuter.begin(), removedOuter.end(), e)) continue;
                if (outlineCover.count(reverse(e)) != 0)
                    end(reverse(e));
                else
                    newOutline.push_back(e);
            }
            for (const std::uint64_t e : newOutline) {
                ++outlineDegree[std::uint32_t(e >> 32)];
                ++outlineDegree[std::uint32_t(e)];
            }
            // Ends no longer on the outline (the deleted vertex: the outline's own deviation, in
            // or out, as the build measures a ring's) stand with the new edges too.
            std::size_t kept = 0;
            for (const std::uint32_t v : outside)
                if (outlineDegree[v] == 0) outside[kept++] = v;
            outside.resize(kept);
            // So does every point the step leaves outside: in a removed triangle, in no created
            // one.
            const format::Triangle* added = b.addedTriangles.data() + b.addedTriangleOffset[s];
            const format::Triangle* addedEnd =
                b.addedTriangles.data() + b.addedTriangleOffset[s + 1];
            for (std::uint32_t r = b.removedTriangleOffset[s]; r < b.removedTriangleOffset[s + 1];
                 ++r)
                buckets->inTriangle(b.removedTriangles[r], [&](std::uint32_t v) {
                    for (const format::Triangle* t = added; t != addedEnd; ++t)
                        if (buckets->contains(*t, v)) return;
                    if (outlineDegree[v] == 0) outside.push_back(v);
                });
            std::sort(outside.begin(), outside.end());
            outside.erase(std::unique(outside.begin(), outside.end()), outside.end());
            for (const std::uint32_t v : outside) {
                double nearest = INFINITY;
                for (const std::uint64_t e : newOutline) {
                    const std::uint32_t a = std::uint32_t(e >> 32), c = std::uint32_t(e);
                    const double dx = px(c) - px(a), dy = py(c) - py(a);
                    const double qx = px(v) - px(a), qy = py(v) - py(a);
                    const double length2 = dx * dx + dy * dy;
                    const double f =
                        length2 > 0 ? std::clamp((qx * dx + qy * dy) / length2, 0.0, 1.0) : 0.0;
                    nearest = std::min(nearest, std::hypot(qx - f * dx, qy - f * dy));
                }
                outline = std::max(outline, nearest);
                grow(step.boxMin, step.boxMax, px(v), py(v), pz(v));
            }
            for (const std::uint64_t e : newOutline)
                outlineCover[e] = outside;
        }
        // River edges: the added edge stands for every original vertex its removed edges stood
        // for, and for the removed vertex.
        merged.clear();
        for (std::uint32_t r = b.removedEdgeOffset[s]; r < b.removedEdgeOffset[s + 1]; ++r) {
            std::uint32_t id = 0, tag = 0;
            if (!edgeId.take(edgeKey(b.removedEdges[r]), id, tag)) {
                *this = Refinement{};
                why = "step " + std::to_string(s) + " removes a river edge that is not alive";
                return false;
            }
            edgeDestroyer_[id] = self;
            merged.insert(merged.end(), cover[id].begin(), cover[id].end());
        }
        if (b.removedEdgeOffset[s + 1] > b.removedEdgeOffset[s] && !node)
            merged.push_back(b.steps[s].vertex);
        double river = 0;
        for (std::uint32_t a = b.addedEdgeOffset[s]; a < b.addedEdgeOffset[s + 1]; ++a) {
            const format::Edge& e = b.addedEdges[a];
            edgeId.set(edgeKey(e), std::uint32_t(edges_.size()));
            edges_.push_back(e);
            edgeDestroyer_.push_back(0);
            const double dx = px(e.b) - px(e.a), dy = py(e.b) - py(e.a), dz = pz(e.b) - pz(e.a);
            const double length2 = dx * dx + dy * dy + dz * dz;
            for (std::uint32_t v : merged) {
                const double qx = px(v) - px(e.a), qy = py(v) - py(e.a), qz = pz(v) - pz(e.a);
                const double f = length2 > 0
                                     ? std::clamp((qx * dx + qy * dy + qz * dz) / length2, 0.0, 1.0)
                                     : 0.0;
                const double rx = qx - f * dx, ry = qy - f * dy, rz = qz - f * dz;
                river = std::max(river, std::sqrt(rx * rx + ry * ry + rz * rz));
                grow(step.boxMin, step.boxMax, px(v), py(v), pz(v));
            }
            cover.push_back(merged);
        }
        if (!(step.boxMin[0] <= step.boxMax[0])) {  // nothing created: the vertex's own place
            const std::uint32_t v = b.steps[s].vertex;
            grow(step.boxMin, step.boxMax, px(v), py(v), pz(v));
        }
        if (node) {
            // The running maximum after the step bounds the error of every original point
            // under a triangle it created (and of every original river point an edge it created
            // stands for): those are alive in the sequential state after it. The points lie
            // within that error of the triangles and edges: the box grows by it.
            step.error = b.errorMax[s + 1];
            step.river = b.errorRiver.empty() ? step.error : b.errorRiver[s + 1];
            for (int k = 0; k < 3; ++k) {
                step.boxMin[k] -= double(step.error);
                step.boxMax[k] += double(step.error);
            }
        } else {
            river = std::max(river, outline);
            // Rounded up to float: a stored bound never below the double value.
            step.river = float(river);
            if (double(step.river) < river) step.river = std::nextafter(step.river, INFINITY);
            const double error = std::max(vertical, river);
            step.error = float(error);
            if (double(step.error) < error) step.error = std::nextafter(step.error, INFINITY);
        }
        for (int k = 0; k < 2; ++k) {  // world coordinates
            const double origin = k == 0 ? b.originX : b.originY;
            step.boxMin[k] += origin;
            step.boxMax[k] += origin;
        }
        steps_.push_back(step);
        createdTriangles_.push_back(std::uint32_t(triangles_.size()));
        createdEdges_.push_back(std::uint32_t(edges_.size()));
    }
    const std::uint32_t sentinel = std::uint32_t(steps_.size() + 1);
    for (std::uint32_t& d : triangleDestroyer_)
        if (d == 0) d = sentinel;
    for (std::uint32_t& d : edgeDestroyer_)
        if (d == 0) d = sentinel;
    // Kept at their size (the engine holds the tables of every resident leaf); a creator is its
    // created range (refine() walks those), the id table's tag served the dependencies above.
    for (auto* v : {&parents_, &triangleDestroyer_, &edgeDestroyer_, &createdTriangles_,
                    &createdEdges_})
        v->shrink_to_fit();
    steps_.shrink_to_fit();
    triangles_.shrink_to_fit();
    edges_.shrink_to_fit();
    // What each stored level draws, as indices into the tables (ascending): refine() starts from
    // it. Element i, created by step c and destroyed by step d (index + 1; 0: full resolution),
    // is alive at the levels whose step k has c <= k < d: a run of the levels (their steps
    // ascend), found from the first level at or after c, so the work is the output's size.
    for (const format::Level& l : b.levels)
        if (l.step <= steps_.size()) levelSteps_.push_back(l.step);
    levelTriangles_.resize(levelSteps_.size());
    levelEdges_.resize(levelSteps_.size());
    const auto assign = [&](const std::vector<std::uint32_t>& created,
                            const std::vector<std::uint32_t>& destroyer,
                            std::vector<std::vector<std::uint32_t>>& levels) {
        std::uint32_t creator = 0;
        std::size_t first = 0;  // the first level whose step is at least `creator`
        for (std::uint32_t i = 0; i < destroyer.size(); ++i) {
            while (i >= created[creator + 1]) {
                ++creator;
                while (first < levelSteps_.size() && levelSteps_[first] < creator)
                    ++first;
            }
            for (std::size_t k = first; k < levelSteps_.size() && levelSteps_[k] < destroyer[i];
                 ++k)
                levels[k].push_back(i);
        }
    };
    assign(createdTriangles_, triangleDestroyer_, levelTriangles_);
    assign(createdEdges_, edgeDestroyer_, levelEdges_);
    return true;
}

void Refinement::refine(const ViewSpec& view, RefinedMesh& out, std::uint32_t prefix) const {
    std::vector<std::uint8_t>& done = out.done;
    done.assign(steps_.size() + 2, 0);  // the last: the sentinel step (never destroyed)
    done[0] = 1;
    LodNode node;
    node.horizontal = horizontal_;
    out.stepsDone = 0;
    // A camera view in Nearest mode bounds every tolerance from below (lod.h effectiveDistance,
    // cut.cpp nodeTolerances, which never returns less than the whole box's bounds: S' >=
    // cos(theta_c) D / sin(phi) with D = max(zMin, S cos(theta_c)), as c >= cos(theta_c); the
    // river bound has no sin(phi) and, per column, the factor f / (f + P c) >= f / (f + P)):
    //   vertical >= P cos(theta_c) D / (f sin(phi)),  river >= P cos(theta_c) D / (f + P),
    // zMin the box's smallest depth, S its nearest distance, sin(phi) <= the box's bound below
    // (1 when the eye's height is within its z range). A step whose errors fit those is taken
    // without the full evaluation.
    const bool camera = view.kind == ViewSpec::Kind::Camera && view.direction;
    const bool quick = camera && view.distance == DistanceMode::Nearest;
    const CameraBasis basis = cameraBasis(view.camera);
    const double aspect = view.widthPixels / view.heightPixels;
    const Frustum frustum = viewFrustum(view.camera, basis, aspect);
    double cornerCos = 0, verticalFactor = 0, riverFactor = 0;
    if (quick) {
        const double fov = view.camera.fovDegrees * (3.14159265358979323846 / 180.0);
        const double focal = view.heightPixels / (2.0 * std::tan(fov / 2.0));
        cornerCos = std::sqrt(frustumEdgeFactor(fov, aspect));
        verticalFactor = view.pixels * cornerCos / focal * (1 - 1e-12);
        riverFactor = view.pixels * cornerCos / (focal + view.pixels) * (1 - 1e-12);
    }
    const auto visible = [&](const Step& step) {
        if (camera && view.cull)  // nodeVisible's test, the planes computed once
            return boxInFrustum(frustum, step.boxMin, step.boxMax);
        return nodeVisible(view, step.boxMin, step.boxMax);
    };
    const double* eye = view.camera.eye;
    prefix = std::min<std::uint32_t>(prefix, std::uint32_t(steps_.size()));
    std::fill(done.begin() + 1, done.begin() + 1 + prefix, 1);
    out.stepsDone = prefix;
    for (std::size_t s = prefix; s < steps_.size(); ++s) {
        const Step& step = steps_[s];
        bool ready = true;
        for (std::uint32_t p = 0; p < step.parentCount && ready; ++p)
            ready = done[parents_[step.parentFirst + p]] != 0;
        if (!ready || step.blocked) continue;
        bool take = false;
        if (quick) {
            // Squared nearest distance, smallest depth, the largest squared horizontal distance.
            double d2 = 0, depth = 0, far2 = 0;
            for (int k = 0; k < 3; ++k) {
                const double lo = step.boxMin[k] - eye[k], hi = step.boxMax[k] - eye[k];
                const double d = std::max({lo, 0.0, -hi});
                d2 += d * d;
                depth += basis.forward[k] * (basis.forward[k] >= 0 ? lo : hi);
                if (k < 2) far2 += std::max(lo * lo, hi * hi);
            }
            const double reach = std::max(depth, std::sqrt(d2) * cornerCos);
            // sin(phi) <= h / sqrt(h^2 + dz^2) at the box's largest horizontal distance h and
            // smallest height difference dz (increasing in h, decreasing in dz); 1 beside it.
            const double below = step.boxMin[2] - eye[2], above = eye[2] - step.boxMax[2];
            const double dz = std::max({below, above, 0.0});
            const double sinBound =
                dz > 0 ? std::max(std::sqrt(far2 / (far2 + dz * dz)), 1e-9) : 1.0;
            take = double(step.error) <= verticalFactor * reach / sinBound &&
                   double(step.river) <= riverFactor * reach;
        }
        if (!take && visible(step)) {
            std::copy(step.boxMin, step.boxMin + 3, node.boxMin);
            std::copy(step.boxMax, step.boxMax + 3, node.boxMax);
            const NodeTolerance t = nodeTolerances(view, basis, node);
            take = double(step.error) <= t.vertical && double(step.river) <= t.river;
        } else if (!take) {
            take = true;  // off screen
        }
        if (!take) continue;
        done[s + 1] = 1;
        ++out.stepsDone;
    }
    // The alive triangles and river edges: created at full resolution or by a step taken, not
    // destroyed by one (a never destroyed one names the sentinel step, never taken).
    out.triangles.clear();
    out.riverEdges.clear();
    // From a stored level at the prefix: its triangles and edges, then those of the steps taken
    // after it; else from full resolution.
    std::size_t from = 0;
    const auto level = std::lower_bound(levelSteps_.begin(), levelSteps_.end(), prefix);
    if (prefix > 0 && level != levelSteps_.end() && *level == prefix) {
        const std::size_t l = std::size_t(level - levelSteps_.begin());
        for (const std::uint32_t t : levelTriangles_[l])
            if (!done[triangleDestroyer_[t]]) out.triangles.push_back(triangles_[t]);
        for (const std::uint32_t e : levelEdges_[l])
            if (!done[edgeDestroyer_[e]]) out.riverEdges.push_back(edges_[e]);
        from = std::size_t(prefix) + 1;
    }
    for (std::size_t s = from; s <= steps_.size(); ++s) {
        if (!done[s]) continue;
        for (std::uint32_t t = createdTriangles_[s]; t < createdTriangles_[s + 1]; ++t)
            if (!done[triangleDestroyer_[t]]) out.triangles.push_back(triangles_[t]);
        for (std::uint32_t e = createdEdges_[s]; e < createdEdges_[s + 1]; ++e)
            if (!done[edgeDestroyer_[e]]) out.riverEdges.push_back(edges_[e]);
    }
}

std::size_t Refinement::appendAsLevel(const RefinedMesh& mesh, format::Block& block) const {
    format::Level l{};
    l.vertexCount = std::uint32_t(block.vertices.size());
    l.triangleFirst = std::uint32_t(block.terrainIndices.size());
    l.triangleCount = std::uint32_t(mesh.triangles.size());
    block.terrainIndices.insert(block.terrainIndices.end(), mesh.triangles.begin(),
                                mesh.triangles.end());
    l.riverFirst = std::uint32_t(block.riverIndices.size());
    l.riverCount = std::uint32_t(mesh.riverEdges.size());
    block.riverIndices.insert(block.riverIndices.end(), mesh.riverEdges.begin(),
                              mesh.riverEdges.end());
    float error = 0, river = 0;
    for (std::size_t k = 0; k < steps_.size() && k + 1 < mesh.done.size(); ++k) {
        if (!mesh.done[k + 1]) continue;
        error = std::max(error, steps_[k].error);
        river = std::max(river, steps_[k].river);
    }
    l.step = std::uint32_t(block.errorMax.size());
    l.errorMax = error;
    l.errorRiver = river;
    block.errorMax.push_back(error);
    block.errorRiver.push_back(river);
    block.levels.push_back(l);
    return block.levels.size() - 1;
}

std::size_t Refinement::memoryBytes() const {
    const auto bytes = [](const auto& v) { return v.capacity() * sizeof(v[0]); };
    std::size_t sum = bytes(steps_) + bytes(parents_) + bytes(triangles_) +
                      bytes(triangleDestroyer_) + bytes(edges_) + bytes(edgeDestroyer_) +
                      bytes(createdTriangles_) + bytes(createdEdges_) + bytes(levelSteps_);
    for (const auto& v : levelTriangles_)
        sum += bytes(v);
    for (const auto& v : levelEdges_)
        sum += bytes(v);
    return sum;
}

}  // namespace unilod::engine
