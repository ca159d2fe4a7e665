// Compact block encoding (blockcodec.h). Integers are LEB128 varints (signed ones zigzag coded);
// each stream is one zstd frame. The encoder and the decoder replay the records on the same
// structure (Replay), so what the encoder leaves out is exactly what the decoder derives.
#include "blockcodec.h"

#include <zstd.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>

#include "lodlayout.h"
#include "predicates.h"

namespace unilod::format {

namespace {

// The streams of a compact block, in payload order.
enum Stream {
    kPermutation,  // per spatial position: the vertex's retention index
    kPositions,    // per spatial position: grid x, y deltas
    kHeights,      // per spatial position: z / quantum minus its prediction (HeightPredictor)
    kFlags,        // per spatial position: vertex flags
    kMesh,         // full-resolution triangles and river edges (spatial numbering)
    kStepCounts,   // per step: extra removals, additions (triangles, then edges)
    kStepRefs,     // per step: the vertex references of those records
    kStepApexes,   // per step in polygon mode: the apex codes of its triangulation
    kErrors,       // the error arrays (max, paper, river) in z quanta, delta coded
    kLevelSteps,   // level steps, delta coded
    kStreamCount
};

constexpr int kZstdLevel = 6;
constexpr std::int64_t kMaxErrorSteps = std::int64_t(1) << 24;  // k * q exact in a float
constexpr std::int64_t kMaxHeightSteps = std::int64_t(1) << 40;

// ---- varints ------------------------------------------------------------------------------------

void putU(std::vector<unsigned char>& out, std::uint64_t v) {
    while (v >= 0x80) {
        out.push_back(static_cast<unsigned char>(v | 0x80));
        v >>= 7;
    }
    out.push_back(static_cast<unsigned char>(v));
}
void putS(std::vector<unsigned char>& out, std::int64_t v) {
    putU(out, (std::uint64_t(v) << 1) ^ std::uint64_t(v >> 63));
}

// Reads varints from a byte range; past the end or on an over-long varint it sets `ok` false and
// returns 0 from then on.
struct In {
    const unsigned char* p = nullptr;
    const unsigned char* end = nullptr;
    bool ok = true;
    std::uint64_t u() {
        std::uint64_t v = 0;
        for (int shift = 0; shift < 64; shift += 7) {
            if (p == end) break;
            const unsigned char c = *p++;
            v |= std::uint64_t(c & 0x7F) << shift;
            if ((c & 0x80) == 0) return v;
        }
        ok = false;
        p = end;
        return 0;
    }
    std::int64_t s() {
        const std::uint64_t v = u();
        return std::int64_t(v >> 1) ^ -std::int64_t(v & 1);
    }
    // A value < limit, or failure.
    std::uint64_t below(std::uint64_t limit) {
        const std::uint64_t v = u();
        if (v >= limit) ok = false;
        return ok ? v : 0;
    }
};

// ---- zstd -----------------------------------------------------------------------------------------

struct ZstdContexts {
    ZSTD_CCtx* c = ZSTD_createCCtx();
    ZSTD_DCtx* d = ZSTD_createDCtx();
    ~ZstdContexts() {
        ZSTD_freeCCtx(c);
        ZSTD_freeDCtx(d);
    }
};
ZstdContexts& zstd() {
    thread_local ZstdContexts contexts;
    return contexts;
}

// Appends: varint raw size, varint frame size, frame.
void putStream(std::vector<unsigned char>& out, const std::vector<unsigned char>& raw) {
    putU(out, raw.size());
    if (raw.empty()) {
        putU(out, 0);
        return;
    }
    std::vector<unsigned char> frame(ZSTD_compressBound(raw.size()));
    const std::size_t n =
        ZSTD_compressCCtx(zstd().c, frame.data(), frame.size(), raw.data(), raw.size(), kZstdLevel);
    frame.resize(ZSTD_isError(n) ? 0 : n);
    putU(out, frame.size());
    out.insert(out.end(), frame.begin(), frame.end());
}

// ---- replay ---------------------------------------------------------------------------------------

bool hasVertex(const Triangle& t, std::uint32_t v) { return t.a == v || t.b == v || t.c == v; }
bool hasVertex(const Edge& e, std::uint32_t v) { return e.a == v || e.b == v; }
void forVertices(const Triangle& t, auto&& f) {
    f(t.a);
    f(t.b);
    f(t.c);
}
void forVertices(const Edge& e, auto&& f) {
    f(e.a);
    f(e.b);
}

constexpr std::uint32_t kNone = 0xFFFFFFFFu;

std::uint32_t maxVertex(const Triangle& t) { return std::max({t.a, t.b, t.c}); }
std::uint32_t maxVertex(const Edge& e) { return std::max(e.a, e.b); }

// Every element (triangle or river edge) ever alive, with its life, and per vertex a singly
// linked list (flat arrays: no allocation per element) through the elements whose LARGEST vertex
// index it is. Step s deletes vertex n - 1 - s, the largest index still alive, so the elements
// alive at it are exactly the alive ones of its list: a star costs its own size, not the
// vertex's whole history. Dead elements are unlinked as the lists are walked.
template <class T>
class AliveSet {
public:
    explicit AliveSet(std::size_t vertices, std::size_t reserve = 0) : head_(vertices, kNone) {
        lives_.reserve(reserve);
        dead_.reserve(reserve);
        next_.reserve(reserve);
    }
    void add(const T& t, std::uint32_t step) {
        const auto slot = static_cast<std::uint32_t>(lives_.size());
        lives_.push_back({t, step, kAliveToTheEnd});
        dead_.push_back(0);
        ++count_;
        const std::uint32_t key = maxVertex(t);
        next_.push_back(head_[key]);
        head_[key] = slot;
    }
    // The alive elements at v, sorted, and their slots (for kill).
    void star(std::uint32_t v, std::vector<T>& out) {
        found_.clear();
        walk(v, [&](std::uint32_t slot) {
            found_.push_back({lives_[slot].item, slot});
            return false;
        });
        std::sort(found_.begin(), found_.end(),
                  [](const auto& l, const auto& r) { return lessIndex(l.first, r.first); });
        out.clear();
        for (const auto& f : found_)
            out.push_back(f.first);
    }
    // Ends the lives of the elements the last star() returned at `step`.
    void killStar(std::uint32_t step) {
        for (const auto& f : found_) {
            lives_[f.second].death = step;
            dead_[f.second] = 1;
            --count_;
        }
        found_.clear();
    }
    // Ends the life of the alive element t at `step`; false when none is alive.
    bool remove(const T& t, std::uint32_t step) {
        if (maxVertex(t) >= head_.size()) return false;
        bool found = false;
        walk(maxVertex(t), [&](std::uint32_t slot) {
            if (!sameIndex(lives_[slot].item, t)) return false;
            lives_[slot].death = step;
            dead_[slot] = 1;
            --count_;
            return found = true;
        });
        return found;
    }
    std::uint32_t count() const { return count_; }
    std::vector<Life<T>>& lives() { return lives_; }

private:
    // Calls f(slot) for each alive element of v's list until f returns true; unlinks dead ones.
    template <class F>
    void walk(std::uint32_t v, F&& f) {
        std::uint32_t* at = &head_[v];
        while (*at != kNone) {
            const std::uint32_t slot = *at;
            if (dead_[slot]) {
                *at = next_[slot];
                continue;
            }
            if (f(slot)) return;
            at = &next_[slot];
        }
    }
    std::vector<Life<T>> lives_;
    std::vector<std::uint32_t> head_, next_;
    std::vector<std::uint8_t> dead_;  // lives_[slot].death != kAliveToTheEnd, compact for walks
    std::vector<std::pair<T, std::uint32_t>> found_;
    std::uint32_t count_ = 0;
};

// The vertices of `items` other than v, sorted and unique (a step's hole vertices).
template <class T>
void holeOf(const std::vector<T>& items, std::uint32_t v, std::vector<std::uint32_t>& hole) {
    for (const T& t : items)
        forVertices(t, [&](std::uint32_t x) {
            if (x != v) hole.push_back(x);
        });
    std::sort(hole.begin(), hole.end());
    hole.erase(std::unique(hole.begin(), hole.end()), hole.end());
}

std::uint64_t refOf(const std::vector<std::uint32_t>& hole, std::uint32_t x) {
    const auto it = std::lower_bound(hole.begin(), hole.end(), x);
    if (it != hole.end() && *it == x) return std::uint64_t(it - hole.begin());
    return hole.size() + std::uint64_t(x);
}

// ---- polygon mode -------------------------------------------------------------------------------
// A deletion that removes just the star of v and fills the hole with triangles of its link
// polygon stores only that triangulation: for each sub-polygon p_i..p_j (base edge p_i p_j, the
// whole polygon first with its closing edge p_0 p_(d-1)), the apex p_k of the triangle on the
// base, i < k < j, as k - i - 1 when there is a choice (j - i >= 3); then p_i..p_k, then
// p_k..p_j. The polygon starts at its smallest vertex index.

// Polygon mode takes links of up to this many vertices (larger ones are stored explicitly).
constexpr std::uint32_t kMaxLink = 64;

// The link of v as a counter-clockwise cycle from its smallest vertex; false when the star is
// not a closed fan (v on the mesh boundary, or a pinched link).
bool linkPolygon(const std::vector<Triangle>& star, std::uint32_t v, std::vector<std::uint32_t>& out) {
    out.clear();
    const std::size_t d = star.size();
    if (d < 3) return false;
    // Directed link edges p -> q of the triangles (v, p, q); the cycle from the smallest p.
    std::uint32_t from[kMaxLink], to[kMaxLink];
    if (d > kMaxLink) return false;
    std::size_t start = 0;
    for (std::size_t i = 0; i < d; ++i) {
        const Triangle& t = star[i];
        if (t.a == v) from[i] = t.b, to[i] = t.c;
        else if (t.b == v) from[i] = t.c, to[i] = t.a;
        else from[i] = t.a, to[i] = t.b;
        if (from[i] < from[start]) start = i;
    }
    std::size_t at = start;
    for (std::size_t k = 0; k < d; ++k) {
        out.push_back(from[at]);
        const std::uint32_t q = to[at];
        std::size_t next = d;
        for (std::size_t i = 0; i < d; ++i) {
            if (from[i] == q) {
                if (next != d) return false;  // two edges leave q: a pinched link
                next = i;
            }
        }
        if (next == d) return false;  // the fan is open: v on the boundary
        if (next == start && k + 1 != d) return false;  // a shorter cycle: not one polygon
        at = next;
    }
    return at == start;
}

// The triangles of `polygon` for the apex codes that next() returns (kNone: none left), sorted;
// false on a code out of range or a code missing.
template <class Next>
bool fillPolygon(const std::vector<std::uint32_t>& polygon, Next&& next, std::vector<Triangle>& out) {
    const auto d = static_cast<std::uint32_t>(polygon.size());
    if (d < 3 || d > kMaxLink) return false;
    std::pair<std::uint32_t, std::uint32_t> bases[kMaxLink];  // at most d - 2 pending
    std::size_t pending = 0;
    bases[pending++] = {0, d - 1};
    while (pending > 0) {
        const auto [i, j] = bases[--pending];
        std::uint32_t k = i + 1;
        if (j - i >= 3) {
            const std::uint32_t code = next();
            if (code >= j - i - 1) return false;
            k = i + 1 + code;
        }
        out.push_back(canonicalTriangle({polygon[i], polygon[k], polygon[j]}));
        if (j - k >= 2) bases[pending++] = {k, j};
        if (k - i >= 2) bases[pending++] = {i, k};
    }
    std::sort(out.begin(), out.end(), [](auto& l, auto& r) { return lessIndex(l, r); });
    return true;
}

// The apex codes of `added` as a triangulation of `polygon`; false when it is not one.
bool apexCodes(const std::vector<std::uint32_t>& polygon, const std::vector<Triangle>& added,
               std::vector<std::uint32_t>& codes) {
    const auto d = static_cast<std::uint32_t>(polygon.size());
    if (added.size() + 2 != d || d > kMaxLink) return false;
    auto position = [&](std::uint32_t x) {
        for (std::uint32_t i = 0; i < d; ++i)
            if (polygon[i] == x) return i;
        return kNone;
    };
    std::pair<std::uint32_t, std::uint32_t> bases[kMaxLink];
    std::size_t pending = 0;
    bases[pending++] = {0, d - 1};
    while (pending > 0) {
        const auto [i, j] = bases[--pending];
        std::uint32_t k = kNone;
        for (const Triangle& t : added) {
            std::uint32_t pi = kNone, pj = kNone, other = kNone;
            forVertices(t, [&](std::uint32_t x) {
                if (x == polygon[i]) pi = x;
                else if (x == polygon[j]) pj = x;
                else other = x;
            });
            if (pi == kNone || pj == kNone || other == kNone) continue;
            const std::uint32_t at = position(other);
            if (at > i && at < j && at != kNone) {
                k = at;
                break;
            }
        }
        if (k == kNone) return false;
        if (j - i >= 3) codes.push_back(k - i - 1);
        if (j - k >= 2) bases[pending++] = {k, j};
        if (k - i >= 2) bases[pending++] = {i, k};
    }
    return true;
}

// ---- heights --------------------------------------------------------------------------------------
// Heights are coded as the difference from a prediction made from the vertices before them in
// spatial order (the same on both sides): a DEM vertex from its left neighbour a, the one above it
// b (same grid x in the previous row of DEM vertices) and the one above-left c with LOCO-I's median
// edge detector (Weinberger et al. 2000): min(a, b) if c >= max(a, b), max(a, b) if c <= min(a, b),
// else a + b - c; a river vertex from the previous river vertex.
class HeightPredictor {
public:
    std::int64_t predict(std::int32_t gx, std::int32_t gy, bool river) {
        if (river) return seenRiver_ ? lastRiver_ : last_;
        if (!rowStarted_ || gy != rowY_) {
            prev_.swap(row_);
            row_.clear();
            rowY_ = gy;
            rowStarted_ = true;
            up_ = 0;
        }
        while (up_ < prev_.size() && prev_[up_].first < gx)
            ++up_;
        hasUp_ = up_ < prev_.size() && prev_[up_].first == gx;
        upZ_ = hasUp_ ? prev_[up_].second : 0;
        if (row_.empty()) return hasUp_ ? upZ_ : last_;
        const std::int64_t a = row_.back().second;
        if (!hasUp_ || !leftHadUp_) return a;
        const std::int64_t b = upZ_, c = leftUpZ_;
        if (c >= std::max(a, b)) return std::min(a, b);
        if (c <= std::min(a, b)) return std::max(a, b);
        return a + b - c;
    }
    // After predict(): the vertex's height.
    void push(std::int32_t gx, bool river, std::int64_t z) {
        last_ = z;
        if (river) {
            lastRiver_ = z;
            seenRiver_ = true;
            return;
        }
        row_.push_back({gx, z});
        leftHadUp_ = hasUp_;
        leftUpZ_ = upZ_;
    }

private:
    std::vector<std::pair<std::int32_t, std::int64_t>> prev_, row_;
    std::size_t up_ = 0;
    std::int32_t rowY_ = 0;
    bool rowStarted_ = false, seenRiver_ = false, hasUp_ = false, leftHadUp_ = false;
    std::int64_t last_ = 0, lastRiver_ = 0, upZ_ = 0, leftUpZ_ = 0;
};

// ---- spatial order ------------------------------------------------------------------------------

std::vector<std::uint32_t> spatialOrder(const std::vector<GridXY>& grid) {
    std::vector<std::uint32_t> order(grid.size());
    for (std::uint32_t i = 0; i < order.size(); ++i)
        order[i] = i;
    std::sort(order.begin(), order.end(), [&](std::uint32_t l, std::uint32_t r) {
        const GridXY a = grid[l], b = grid[r];
        return a.y != b.y ? a.y < b.y : (a.x != b.x ? a.x < b.x : l < r);
    });
    return order;
}

template <class T>
bool sameBytes(const std::vector<T>& a, const std::vector<T>& b) {
    return a.size() == b.size() &&
           (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(T)) == 0);
}

std::uint32_t floatBits(float f) { return std::bit_cast<std::uint32_t>(f); }

}  // namespace

double quantizeZ(double z, double q) {
    return double(std::llround(z / q)) * q;
}

float quantizeError(double e, double q) {
    const double k = std::ceil(e / q);
    if (k >= 0 && k < double(kMaxErrorSteps)) return static_cast<float>(k * q);  // exact
    auto f = static_cast<float>(e);
    return double(f) < e ? std::nextafter(f, HUGE_VALF) : f;
}

BlockCounts countsOf(const Block& b) {
    BlockCounts c;
    c.vertices = std::uint32_t(b.vertices.size());
    c.steps = std::uint32_t(b.steps.size());
    c.levels = std::uint32_t(b.levels.size());
    c.removedTriangles = std::uint32_t(b.removedTriangles.size());
    c.addedTriangles = std::uint32_t(b.addedTriangles.size());
    c.removedEdges = std::uint32_t(b.removedEdges.size());
    c.addedEdges = std::uint32_t(b.addedEdges.size());
    c.terrainTriangles = std::uint32_t(b.terrainIndices.size());
    c.riverEdges = std::uint32_t(b.riverIndices.size());
    c.errorMax = !b.errorMax.empty();
    c.errorPaper = !b.errorPaper.empty();
    c.errorRiver = !b.errorRiver.empty();
    return c;
}

bool compactStreamSizes(const unsigned char* data, std::size_t size, std::vector<StreamSize>& out) {
    static constexpr const char* kNames[kStreamCount] = {
        "permutation", "positions", "heights", "flags", "mesh", "step_counts", "step_refs",
        "step_apexes", "errors", "level_steps"};
    out.clear();
    In frames{data, data + size};
    for (int k = 0; k < kStreamCount; ++k) {
        const std::uint64_t decoded = frames.u(), stored = frames.u();
        if (!frames.ok || stored > std::uint64_t(frames.end - frames.p)) return false;
        frames.p += stored;
        out.push_back({kNames[k], decoded, stored});
    }
    return frames.p == frames.end;
}

bool sameArrays(const Block& a, const Block& b) {
    return sameBytes(a.vertices, b.vertices) && sameBytes(a.steps, b.steps) &&
           sameBytes(a.removedTriangleOffset, b.removedTriangleOffset) &&
           sameBytes(a.addedTriangleOffset, b.addedTriangleOffset) &&
           sameBytes(a.removedEdgeOffset, b.removedEdgeOffset) &&
           sameBytes(a.addedEdgeOffset, b.addedEdgeOffset) &&
           sameBytes(a.removedTriangles, b.removedTriangles) &&
           sameBytes(a.addedTriangles, b.addedTriangles) &&
           sameBytes(a.removedEdges, b.removedEdges) && sameBytes(a.addedEdges, b.addedEdges) &&
           sameBytes(a.errorMax, b.errorMax) && sameBytes(a.errorPaper, b.errorPaper) &&
           sameBytes(a.errorRiver, b.errorRiver) && sameBytes(a.levels, b.levels) &&
           sameBytes(a.terrainIndices, b.terrainIndices) &&
           sameBytes(a.riverIndices, b.riverIndices) && sameBytes(a.grid, b.grid);
}

bool encodeCompact(const Block& b, double q, std::vector<unsigned char>& out, std::string& why) {
    const auto n = static_cast<std::uint32_t>(b.vertices.size());
    const auto steps = static_cast<std::uint32_t>(b.steps.size());
    if (b.grid.size() != n) return why = "no grid positions", false;
    if (b.levels.empty() || b.levels[0].step != 0) return why = "no full-resolution level", false;
    std::vector<unsigned char> s[kStreamCount];

    // Vertices in spatial order.
    const std::vector<std::uint32_t> order = spatialOrder(b.grid);
    std::vector<std::uint32_t> spatial(n);
    std::int64_t px = 0, py = 0;
    HeightPredictor heights;
    for (std::uint32_t k = 0; k < n; ++k) {
        const std::uint32_t i = order[k];
        spatial[i] = k;
        const Vertex& v = b.vertices[i];
        const GridXY g = b.grid[i];
        if (floatBits(v.x) != floatBits(float(double(g.x) * kGridUnit)) ||
            floatBits(v.y) != floatBits(float(double(g.y) * kGridUnit))) {
            return why = "vertex " + std::to_string(i) + " is not at its grid position", false;
        }
        const double zk = std::round(double(v.z) / q);
        if (!(std::fabs(zk) < double(kMaxHeightSteps)) ||
            floatBits(v.z) != floatBits(float(zk * q))) {
            return why = "vertex " + std::to_string(i) + " height is not on the z quantum", false;
        }
        const auto z = std::int64_t(zk);
        putU(s[kPermutation], i);
        putS(s[kPositions], std::int64_t(g.x) - px);
        putS(s[kPositions], std::int64_t(g.y) - py);
        const bool river = (v.flags & kVertexRiver) != 0;
        putS(s[kHeights], z - heights.predict(g.x, g.y, river));
        heights.push(g.x, river, z);
        s[kFlags].push_back(static_cast<unsigned char>(v.flags));
        px = g.x, py = g.y;
    }

    // The full-resolution mesh, in spatial numbering.
    const Level& full = b.levels[0];
    std::vector<Triangle> tris;
    for (std::uint32_t t = full.triangleFirst; t < full.triangleFirst + full.triangleCount; ++t) {
        const Triangle& x = b.terrainIndices[t];
        tris.push_back(canonicalTriangle({spatial[x.a], spatial[x.b], spatial[x.c]}));
    }
    std::sort(tris.begin(), tris.end(), [](auto& l, auto& r) { return lessIndex(l, r); });
    putU(s[kMesh], tris.size());
    std::uint32_t prev = 0;
    for (const Triangle& t : tris) {
        putU(s[kMesh], t.a - prev);
        putU(s[kMesh], t.b - t.a);
        putU(s[kMesh], t.c - t.a);
        prev = t.a;
    }
    std::vector<Edge> edges;
    for (std::uint32_t e = full.riverFirst; e < full.riverFirst + full.riverCount; ++e) {
        const Edge& x = b.riverIndices[e];
        edges.push_back({std::min(spatial[x.a], spatial[x.b]), std::max(spatial[x.a], spatial[x.b])});
    }
    std::sort(edges.begin(), edges.end(), [](auto& l, auto& r) { return lessIndex(l, r); });
    putU(s[kMesh], edges.size());
    prev = 0;
    for (const Edge& e : edges) {
        putU(s[kMesh], e.a - prev);
        putU(s[kMesh], e.b - e.a);
        prev = e.a;
    }

    // Records: what the replayed mesh does not imply.
    AliveSet<Triangle> aliveTris(n, full.triangleCount + b.addedTriangles.size());
    AliveSet<Edge> aliveEdges(n, full.riverCount + b.addedEdges.size());
    for (std::uint32_t t = full.triangleFirst; t < full.triangleFirst + full.triangleCount; ++t)
        aliveTris.add(b.terrainIndices[t], 0);
    for (std::uint32_t e = full.riverFirst; e < full.riverFirst + full.riverCount; ++e)
        aliveEdges.add(b.riverIndices[e], 0);
    std::vector<Triangle> star, removedAtV, extra, fill, added;
    std::vector<Edge> edgeStar, edgesAtV, extraEdges;
    std::vector<std::uint32_t> hole, polygon, codes;
    for (std::uint32_t st = 0; st < steps; ++st) {
        auto at = [&] { return "step " + std::to_string(st + 1) + ": "; };
        const std::uint32_t v = n - 1 - st;
        if (b.steps[st].vertex != v) return why = at() + "not the retention order's vertex", false;
        aliveTris.star(v, star);
        aliveEdges.star(v, edgeStar);
        hole.clear();
        holeOf(star, v, hole);
        const auto rBegin = b.removedTriangles.begin() + b.removedTriangleOffset[st];
        const auto rEnd = b.removedTriangles.begin() + b.removedTriangleOffset[st + 1];
        removedAtV.clear();
        extra.clear();
        for (auto it = rBegin; it != rEnd; ++it)
            (hasVertex(*it, v) ? removedAtV : extra).push_back(*it);
        if (!sameBytes(removedAtV, star)) return why = at() + "removals are not the vertex's star", false;
        const auto aBegin = b.addedTriangles.begin() + b.addedTriangleOffset[st];
        const auto aEnd = b.addedTriangles.begin() + b.addedTriangleOffset[st + 1];
        added.assign(aBegin, aEnd);
        // Mode 0: the additions are a triangulation of the star's link polygon, given by apexes.
        codes.clear();
        bool polygonMode = extra.empty() && linkPolygon(star, v, polygon) &&
                           apexCodes(polygon, added, codes);
        if (polygonMode) {
            fill.clear();
            std::size_t next = 0;
            polygonMode = fillPolygon(polygon, [&] { return next < codes.size() ? codes[next++] : kNone; },
                                      fill) &&
                          next == codes.size() && sameBytes(fill, added);
        }
        if (polygonMode) {
            s[kStepCounts].push_back(0);
            for (std::uint32_t c : codes)
                putU(s[kStepApexes], c);
        } else {
            s[kStepCounts].push_back(1);
            putU(s[kStepCounts], extra.size());
            for (const Triangle& t : extra)
                forVertices(t, [&](std::uint32_t x) { putU(s[kStepRefs], refOf(hole, x)); });
            holeOf(extra, v, hole);
            putU(s[kStepCounts], added.size());
            for (const Triangle& t : added)
                forVertices(t, [&](std::uint32_t x) { putU(s[kStepRefs], refOf(hole, x)); });
        }

        const auto eBegin = b.removedEdges.begin() + b.removedEdgeOffset[st];
        const auto eEnd = b.removedEdges.begin() + b.removedEdgeOffset[st + 1];
        edgesAtV.clear();
        extraEdges.clear();
        for (auto it = eBegin; it != eEnd; ++it)
            (hasVertex(*it, v) ? edgesAtV : extraEdges).push_back(*it);
        if (!sameBytes(edgesAtV, edgeStar)) return why = at() + "river removals are not the vertex's", false;
        putU(s[kStepCounts], extraEdges.size());
        for (const Edge& e : extraEdges)
            forVertices(e, [&](std::uint32_t x) { putU(s[kStepRefs], refOf(hole, x)); });
        putU(s[kStepCounts], b.addedEdgeOffset[st + 1] - b.addedEdgeOffset[st]);
        for (std::uint32_t i = b.addedEdgeOffset[st]; i < b.addedEdgeOffset[st + 1]; ++i)
            forVertices(b.addedEdges[i], [&](std::uint32_t x) { putU(s[kStepRefs], refOf(hole, x)); });

        aliveTris.killStar(st + 1);
        for (const Triangle& t : extra)
            if (!aliveTris.remove(t, st + 1)) return why = at() + "removes a triangle not alive", false;
        for (auto it = aBegin; it != aEnd; ++it)
            aliveTris.add(*it, st + 1);
        aliveEdges.killStar(st + 1);
        for (const Edge& e : extraEdges)
            if (!aliveEdges.remove(e, st + 1)) return why = at() + "removes a river edge not alive", false;
        for (std::uint32_t i = b.addedEdgeOffset[st]; i < b.addedEdgeOffset[st + 1]; ++i)
            aliveEdges.add(b.addedEdges[i], st + 1);
        if (b.steps[st].trianglesAlive != aliveTris.count() ||
            b.steps[st].riverEdgesAlive != aliveEdges.count())
            return why = at() + "alive counts differ from the replay", false;
    }
    // What the decoder derives from the replay must be what the block stores: the levels' index
    // data and ranges (the paired layout of lodlayout.h).
    {
        Block derived;
        derived.levels = b.levels;
        layOutLevels(derived, aliveTris.lives(), aliveEdges.lives());
        if (!sameBytes(derived.levels, b.levels) ||
            !sameBytes(derived.terrainIndices, b.terrainIndices) ||
            !sameBytes(derived.riverIndices, b.riverIndices))
            return why = "the levels' index data is not the paired layout of the records", false;
    }

    for (const std::vector<float>* e : {&b.errorMax, &b.errorPaper, &b.errorRiver}) {
        std::int64_t last = 0;
        for (float f : *e) {
            const double k = std::round(double(f) / q);
            if (!(k >= double(last) && k < double(kMaxErrorSteps)) ||
                floatBits(f) != floatBits(float(k * q)))
                return why = "errors are not on the z quantum", false;
            putU(s[kErrors], std::uint64_t(std::int64_t(k) - last));
            last = std::int64_t(k);
        }
    }
    std::uint32_t lastStep = 0;
    for (const Level& l : b.levels) {
        putU(s[kLevelSteps], l.step - lastStep);
        lastStep = l.step;
    }

    out.clear();
    for (const auto& stream : s)
        putStream(out, stream);
    return true;
}

bool decodeCompact(const unsigned char* data, std::size_t size, const BlockCounts& c, double q,
                   Block& b, std::string& error) {
    const std::uint32_t n = c.vertices;
    auto fail = [&](const std::string& what) {
        error = "compact data: " + what;
        return false;
    };
    // Every stream holds at most a few varints per counted element; a hostile raw size beyond
    // that is refused before anything is allocated.
    const std::uint64_t elements = std::uint64_t(n) + c.steps + c.levels + c.removedTriangles +
                                   c.addedTriangles + c.removedEdges + c.addedEdges +
                                   c.terrainTriangles + c.riverEdges;
    const std::uint64_t maxRaw = 10 * 4 * (elements + 1) + 64;
    std::vector<unsigned char> raw[kStreamCount];
    In frames{data, data + size};
    for (int k = 0; k < kStreamCount; ++k) {
        const std::uint64_t rawSize = frames.u(), frameSize = frames.u();
        if (!frames.ok || rawSize > maxRaw || frameSize > std::uint64_t(frames.end - frames.p) ||
            (rawSize == 0) != (frameSize == 0)) {
            return fail("stream " + std::to_string(k) + " header is damaged");
        }
        raw[k].resize(rawSize);
        if (rawSize > 0) {
            const std::size_t got =
                ZSTD_decompressDCtx(zstd().d, raw[k].data(), rawSize, frames.p, frameSize);
            if (ZSTD_isError(got) || got != rawSize) {
                return fail("stream " + std::to_string(k) + " does not decompress");
            }
        }
        frames.p += frameSize;
    }
    if (frames.p != frames.end) return fail("bytes after the last stream");
    auto in = [&](Stream k) { return In{raw[k].data(), raw[k].data() + raw[k].size()}; };

    // Vertices.
    Block d;
    d.vertices.resize(n);
    d.grid.resize(n);
    std::vector<std::uint32_t> order(n);
    {
        In perm = in(kPermutation), pos = in(kPositions), hz = in(kHeights);
        if (raw[kFlags].size() != n) return fail("flags stream has the wrong size");
        std::vector<std::uint8_t> seen(n, 0);
        std::int64_t px = 0, py = 0;
        HeightPredictor heights;
        for (std::uint32_t k = 0; k < n; ++k) {
            const auto i = std::uint32_t(perm.below(n));
            if (!perm.ok || seen[i]) return fail("the vertex permutation is damaged");
            seen[i] = 1;
            order[k] = i;
            const std::int64_t dx = pos.s(), dy = pos.s(), dz = hz.s();
            // Bounded steps keep the sums far from overflow; the range is checked after.
            if (std::abs(dx) > (std::int64_t(1) << 33) || std::abs(dy) > (std::int64_t(1) << 33) ||
                std::abs(dz) > 2 * kMaxHeightSteps)
                return fail("a vertex delta is out of range");
            px += dx, py += dy;
            if (std::abs(px) > kMaxGridCoordinate || std::abs(py) > kMaxGridCoordinate)
                return fail("vertex " + std::to_string(i) + " lies beyond the grid");
            const bool river = (raw[kFlags][k] & kVertexRiver) != 0;
            const std::int64_t pz = heights.predict(std::int32_t(px), std::int32_t(py), river) + dz;
            if (std::abs(pz) >= kMaxHeightSteps)
                return fail("vertex " + std::to_string(i) + " lies beyond the height range");
            heights.push(std::int32_t(px), river, pz);
            d.grid[i] = {std::int32_t(px), std::int32_t(py)};
            d.vertices[i] = {float(double(px) * kGridUnit), float(double(py) * kGridUnit),
                             float(double(pz) * q), raw[kFlags][k]};
        }
        if (!perm.ok || !pos.ok || !hz.ok || perm.p != perm.end || pos.p != pos.end ||
            hz.p != hz.end)
            return fail("vertex streams are damaged");
    }

    // Full-resolution mesh.
    std::vector<Triangle> initialTris;
    std::vector<Edge> initialEdges;
    {
        In mesh = in(kMesh);
        const std::uint64_t tn = mesh.u();
        if (!mesh.ok || tn > c.terrainTriangles) return fail("the mesh has too many triangles");
        initialTris.resize(tn);
        std::uint64_t a = 0;
        for (Triangle& t : initialTris) {
            a += mesh.u();
            const std::uint64_t bb = a + mesh.u(), cc = a + mesh.u();
            if (!mesh.ok || a >= n || bb >= n || cc >= n) return fail("a mesh triangle is damaged");
            t = canonicalTriangle({order[a], order[bb], order[cc]});
        }
        const std::uint64_t en = mesh.u();
        if (!mesh.ok || en > c.riverEdges) return fail("the mesh has too many river edges");
        initialEdges.resize(en);
        a = 0;
        for (Edge& e : initialEdges) {
            a += mesh.u();
            const std::uint64_t bb = a + mesh.u();
            if (!mesh.ok || a >= n || bb >= n) return fail("a mesh river edge is damaged");
            e = {std::min(order[a], order[bb]), std::max(order[a], order[bb])};
        }
        if (mesh.p != mesh.end) return fail("the mesh stream is damaged");
    }

    // Records, replayed.
    AliveSet<Triangle> aliveTris(n, initialTris.size() + c.addedTriangles);
    AliveSet<Edge> aliveEdges(n, initialEdges.size() + c.addedEdges);
    {
        In counts = in(kStepCounts), refs = in(kStepRefs), apexes = in(kStepApexes);
        for (const Triangle& t : initialTris)
            aliveTris.add(t, 0);
        for (const Edge& e : initialEdges)
            aliveEdges.add(e, 0);
        d.steps.resize(c.steps);
        for (auto* o : {&d.removedTriangleOffset, &d.addedTriangleOffset, &d.removedEdgeOffset,
                        &d.addedEdgeOffset}) {
            o->assign(1, 0);
            o->reserve(std::size_t(c.steps) + 1);
        }
        d.removedTriangles.reserve(c.removedTriangles);
        d.addedTriangles.reserve(c.addedTriangles);
        d.removedEdges.reserve(c.removedEdges);
        d.addedEdges.reserve(c.addedEdges);
        std::vector<Triangle> star, extraTris, fill;
        std::vector<Edge> edgeStar, extraEdgeList;
        std::vector<std::uint32_t> hole, polygon;
        auto vertex = [&](std::uint64_t ref) -> std::uint32_t {
            if (ref < hole.size()) return hole[ref];
            const std::uint64_t x = ref - hole.size();
            if (x >= n) {
                refs.ok = false;
                return 0;
            }
            return std::uint32_t(x);
        };
        auto room = [&](std::uint64_t have, std::uint64_t more, std::uint32_t limit) {
            return more <= limit && have + more <= limit;
        };
        if (c.steps > n) return fail("more steps than vertices");
        for (std::uint32_t st = 0; st < c.steps; ++st) {
            auto at = [&] { return "step " + std::to_string(st + 1) + " "; };
            const std::uint32_t v = n - 1 - st;
            aliveTris.star(v, star);
            aliveEdges.star(v, edgeStar);
            bool holeReady = false;
            auto ensureHole = [&] {
                if (!holeReady) holeOf(star, v, hole);
                holeReady = true;
            };
            const std::size_t first = d.removedTriangles.size();
            const std::size_t firstAdded = d.addedTriangles.size();
            const std::uint64_t mode = counts.u();
            extraTris.clear();
            if (mode == 0) {  // the star, and a triangulation of its link polygon
                if (!linkPolygon(star, v, polygon)) return fail(at() + "has no link polygon");
                if (!room(d.removedTriangles.size(), star.size(), c.removedTriangles) ||
                    !room(d.addedTriangles.size(), star.size() - 2, c.addedTriangles))
                    return fail(at() + "changes too many triangles");
                d.removedTriangles.insert(d.removedTriangles.end(), star.begin(), star.end());
                fill.clear();
                if (!fillPolygon(polygon, [&]() -> std::uint32_t {
                        const std::uint64_t code = apexes.u();
                        return apexes.ok && code < kNone ? std::uint32_t(code) : kNone;
                    }, fill))
                    return fail(at() + "has a damaged triangulation");
                d.addedTriangles.insert(d.addedTriangles.end(), fill.begin(), fill.end());
            } else if (mode == 1) {  // the star, extra removals, explicit additions
                hole.clear();
                ensureHole();
                const std::uint64_t extra = counts.u();
                if (!room(d.removedTriangles.size(), star.size() + extra, c.removedTriangles))
                    return fail(at() + "removes too many triangles");
                d.removedTriangles.insert(d.removedTriangles.end(), star.begin(), star.end());
                extraTris.clear();
                for (std::uint64_t i = 0; i < extra; ++i) {
                    const std::uint32_t x = vertex(refs.u()), y = vertex(refs.u()), z = vertex(refs.u());
                    extraTris.push_back(canonicalTriangle({x, y, z}));
                }
                d.removedTriangles.insert(d.removedTriangles.end(), extraTris.begin(), extraTris.end());
                std::sort(d.removedTriangles.begin() + first, d.removedTriangles.end(),
                          [](auto& l, auto& r) { return lessIndex(l, r); });
                holeOf(extraTris, v, hole);
                const std::uint64_t added = counts.u();
                if (!room(d.addedTriangles.size(), added, c.addedTriangles))
                    return fail(at() + "adds too many triangles");
                for (std::uint64_t i = 0; i < added; ++i) {
                    const std::uint32_t x = vertex(refs.u()), y = vertex(refs.u()), z = vertex(refs.u());
                    d.addedTriangles.push_back({x, y, z});
                }
            } else {
                return fail(at() + "has an unknown mode");
            }

            auto needHole = [&] {
                if (!holeReady) {
                    hole.clear();
                    ensureHole();
                }
            };
            const std::uint64_t extraEdges = counts.u();
            if (extraEdges > 0) needHole();
            if (!room(d.removedEdges.size(), edgeStar.size() + extraEdges, c.removedEdges))
                return fail(at() + "removes too many river edges");
            const std::size_t firstEdge = d.removedEdges.size();
            d.removedEdges.insert(d.removedEdges.end(), edgeStar.begin(), edgeStar.end());
            extraEdgeList.clear();
            for (std::uint64_t i = 0; i < extraEdges; ++i) {
                const std::uint32_t x = vertex(refs.u()), y = vertex(refs.u());
                extraEdgeList.push_back({std::min(x, y), std::max(x, y)});
            }
            d.removedEdges.insert(d.removedEdges.end(), extraEdgeList.begin(), extraEdgeList.end());
            if (extraEdges > 0)
                std::sort(d.removedEdges.begin() + firstEdge, d.removedEdges.end(),
                          [](auto& l, auto& r) { return lessIndex(l, r); });
            const std::uint64_t addedEdges = counts.u();
            if (!room(d.addedEdges.size(), addedEdges, c.addedEdges))
                return fail(at() + "adds too many river edges");
            if (addedEdges > 0) needHole();
            const std::size_t firstAddedEdge = d.addedEdges.size();
            for (std::uint64_t i = 0; i < addedEdges; ++i) {
                const std::uint32_t x = vertex(refs.u()), y = vertex(refs.u());
                d.addedEdges.push_back({std::min(x, y), std::max(x, y)});
            }
            if (!counts.ok || !refs.ok) return fail(at() + "is damaged");

            aliveTris.killStar(st + 1);
            for (const Triangle& t : extraTris)
                if (!aliveTris.remove(t, st + 1)) return fail(at() + "removes a triangle not alive");
            for (std::size_t i = firstAdded; i < d.addedTriangles.size(); ++i)
                aliveTris.add(d.addedTriangles[i], st + 1);
            aliveEdges.killStar(st + 1);
            for (const Edge& e : extraEdgeList)
                if (!aliveEdges.remove(e, st + 1)) return fail(at() + "removes a river edge not alive");
            for (std::size_t i = firstAddedEdge; i < d.addedEdges.size(); ++i)
                aliveEdges.add(d.addedEdges[i], st + 1);
            d.steps[st] = {v, aliveTris.count(), aliveEdges.count()};
            d.removedTriangleOffset.push_back(std::uint32_t(d.removedTriangles.size()));
            d.addedTriangleOffset.push_back(std::uint32_t(d.addedTriangles.size()));
            d.removedEdgeOffset.push_back(std::uint32_t(d.removedEdges.size()));
            d.addedEdgeOffset.push_back(std::uint32_t(d.addedEdges.size()));
        }
        if (counts.p != counts.end || refs.p != refs.end || apexes.p != apexes.end)
            return fail("the record streams are damaged");
    }

    // Errors and levels.
    {
        In errors = in(kErrors);
        for (auto [present, e] : {std::pair{c.errorMax, &d.errorMax}, {c.errorPaper, &d.errorPaper},
                                  {c.errorRiver, &d.errorRiver}}) {
            if (!present) continue;
            e->resize(std::size_t(c.steps) + 1);
            std::uint64_t k = 0;
            for (float& f : *e) {
                k += errors.u();
                if (!errors.ok || k >= std::uint64_t(kMaxErrorSteps))
                    return fail("the error stream is damaged");
                f = static_cast<float>(double(k) * q);
            }
        }
        if (errors.p != errors.end) return fail("the error stream is damaged");
        In lv = in(kLevelSteps);
        d.levels.resize(c.levels);
        std::uint64_t step = 0;
        for (std::size_t j = 0; j < d.levels.size(); ++j) {
            Level& l = d.levels[j];
            const std::uint64_t delta = lv.u();
            step += delta;
            // Strictly ascending from 0 (validateBlock's rule, needed here already: the layout
            // below relies on it to bound its output).
            if (!lv.ok || delta > c.steps || step > c.steps || (j > 0 && delta == 0) ||
                (j == 0 && step != 0))
                return fail("a level step is out of range or out of order");
            l.step = std::uint32_t(step);
            l.vertexCount = n - l.step;
            l.errorMax = d.errorMax.empty() ? 0.0f : d.errorMax[l.step];
            l.errorPaper = d.errorPaper.empty() ? 0.0f : d.errorPaper[l.step];
            l.errorRiver = d.errorRiver.empty() ? 0.0f : d.errorRiver[l.step];
        }
        if (lv.p != lv.end) return fail("the level stream is damaged");
    }
    // The index data the layout will write, bounded before it is allocated: each pair of levels
    // stores at least the larger of its two alive sets, so the header's counts cap the total.
    {
        auto alive = [&](std::uint32_t k, bool tris) -> std::uint64_t {
            if (k == 0) return tris ? initialTris.size() : initialEdges.size();
            return tris ? d.steps[k - 1].trianglesAlive : d.steps[k - 1].riverEdgesAlive;
        };
        std::uint64_t tris = 0, edges = 0;
        for (std::size_t j = 0; j < d.levels.size(); j += 2) {
            const std::uint32_t f = d.levels[j].step;
            const std::uint32_t cs = j + 1 < d.levels.size() ? d.levels[j + 1].step : f;
            tris += std::max(alive(f, true), alive(cs, true));
            edges += std::max(alive(f, false), alive(cs, false));
        }
        if (tris > c.terrainTriangles || edges > c.riverEdges)
            return fail("the levels need more index data than the block header counts");
    }
    layOutLevels(d, aliveTris.lives(), aliveEdges.lives());
    if (d.terrainIndices.size() != c.terrainTriangles || d.riverIndices.size() != c.riverEdges)
        return fail("the derived index data does not match the block header's counts");
    d.col = b.col, d.row = b.row, d.level = b.level, d.firstChild = b.firstChild;
    d.childCount = b.childCount, d.originX = b.originX, d.originY = b.originY;
    d.minX = b.minX, d.minY = b.minY, d.minZ = b.minZ, d.maxX = b.maxX, d.maxY = b.maxY;
    d.maxZ = b.maxZ;
    b = std::move(d);
    return true;
}

}  // namespace unilod::format
