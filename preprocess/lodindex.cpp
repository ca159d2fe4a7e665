// LOD index data of one block: retention order, stored levels, paired index layout (lodindex.h).
#include "lodindex.h"

#include <algorithm>
#include <cmath>

namespace unilod {

namespace {

constexpr std::uint32_t kAlive = 0xFFFFFFFFu;  // death step of an element alive at the end

// Flat open-addressing table from an element to its index in the lifetime list. Every element
// is inserted once and erased at most once, so erased slots simply stay as tombstones and the
// table is sized once for every insertion: no rehashing, no per-node allocation.
template <class T>
class LifeTable {
public:
    explicit LifeTable(std::size_t insertions) {
        std::size_t cap = 16;
        while (cap < 2 * insertions + 16)
            cap *= 2;
        keys_.resize(cap);
        values_.assign(cap, kEmpty);
        mask_ = cap - 1;
    }
    bool insert(const T& key, std::uint32_t value) {
        for (std::size_t i = hash(key) & mask_;; i = (i + 1) & mask_) {
            if (values_[i] == kEmpty) {
                keys_[i] = key;
                values_[i] = value;
                return true;
            }
            if (values_[i] != kErased && keys_[i] == key) return false;
        }
    }
    // Removes the key; returns its value or kEmpty when absent.
    std::uint32_t erase(const T& key) {
        for (std::size_t i = hash(key) & mask_;; i = (i + 1) & mask_) {
            if (values_[i] == kEmpty) return kEmpty;
            if (values_[i] != kErased && keys_[i] == key) {
                const std::uint32_t v = values_[i];
                values_[i] = kErased;
                return v;
            }
        }
    }
    static constexpr std::uint32_t kEmpty = 0xFFFFFFFFu, kErased = 0xFFFFFFFEu;

private:
    static std::size_t hash(const TriangleTriple& t) {
        std::uint64_t h = t.v[0] * 0x9E3779B97F4A7C15ULL;
        h = (h ^ t.v[1]) * 0xBF58476D1CE4E5B9ULL;
        h = (h ^ t.v[2]) * 0x94D049BB133111EBULL;
        return std::size_t(h ^ (h >> 32));
    }
    static std::size_t hash(const RiverEdge& e) {
        const std::uint64_t h = (std::uint64_t(e.a) << 32 | e.b) * 0x9E3779B97F4A7C15ULL;
        return std::size_t(h ^ (h >> 32));
    }
    std::vector<T> keys_;
    std::vector<std::uint32_t> values_;
    std::size_t mask_ = 0;
};

bool lessIndex(const format::Triangle& l, const format::Triangle& r) {
    return l.a != r.a ? l.a < r.a : (l.b != r.b ? l.b < r.b : l.c < r.c);
}
bool lessIndex(const format::Edge& l, const format::Edge& r) {
    return l.a != r.a ? l.a < r.a : l.b < r.b;
}

// Errors are stored as float, rounded up so that "h_s <= h_lim" never accepts a level whose
// double-precision error exceeds h_lim.
float roundUp(double e) {
    const auto f = static_cast<float>(e);
    return double(f) < e ? std::nextafter(f, HUGE_VALF) : f;
}

template <class T>
struct Life {
    T item;
    std::uint32_t birth, death;  // alive after k steps iff birth <= k < death
    bool aliveAt(std::uint32_t k) const { return birth <= k && k < death; }
};

// Lifetimes of every triangle (or edge) from the initial set and the per-step removals/additions.
template <class T>
bool lifetimes(const std::vector<T>& initial, const std::vector<std::uint32_t>& removedOffset,
               const std::vector<T>& removed, const std::vector<std::uint32_t>& addedOffset,
               const std::vector<T>& added, std::vector<Life<T>>& out, std::string& error) {
    LifeTable<T> alive(initial.size() + added.size());
    out.clear();
    out.reserve(initial.size() + added.size());
    for (const T& t : initial) {
        alive.insert(t, static_cast<std::uint32_t>(out.size()));
        out.push_back({t, 0, kAlive});
    }
    const std::size_t steps = removedOffset.empty() ? 0 : removedOffset.size() - 1;
    for (std::size_t s = 0; s < steps; ++s) {
        const auto step = static_cast<std::uint32_t>(s + 1);
        for (std::uint32_t i = removedOffset[s]; i < removedOffset[s + 1]; ++i) {
            const std::uint32_t at = alive.erase(removed[i]);
            if (at == LifeTable<T>::kEmpty) {
                error = "step " + std::to_string(step) + " removes an element that is not alive";
                return false;
            }
            out[at].death = step;
        }
        for (std::uint32_t i = addedOffset[s]; i < addedOffset[s + 1]; ++i) {
            if (!alive.insert(added[i], static_cast<std::uint32_t>(out.size()))) {
                error = "step " + std::to_string(step) + " adds an element that is alive";
                return false;
            }
            out.push_back({added[i], step, kAlive});
        }
    }
    return true;
}

// Appends the paired layout of `lives` for the level steps; sets first/count per level.
template <class T, class Out, class Map>
void layOut(const std::vector<Life<T>>& lives, const std::vector<std::uint32_t>& levelSteps,
            Map map, std::vector<Out>& indices, std::vector<std::uint32_t>& first,
            std::vector<std::uint32_t>& count) {
    const std::size_t n = levelSteps.size();
    first.assign(n, 0);
    count.assign(n, 0);
    std::vector<Out> parts[3];
    for (std::size_t j = 0; j < n; j += 2) {
        const std::uint32_t f = levelSteps[j];
        const bool paired = j + 1 < n;
        const std::uint32_t c = paired ? levelSteps[j + 1] : f;
        for (auto& p : parts)
            p.clear();
        for (const Life<T>& life : lives) {
            const bool inF = life.aliveAt(f), inC = paired && life.aliveAt(c);
            if (inF || inC) parts[inF && inC ? 1 : (inF ? 0 : 2)].push_back(map(life.item));
        }
        for (auto& p : parts) {
            std::sort(p.begin(), p.end(),
                      [](const Out& l, const Out& r) { return lessIndex(l, r); });
        }
        const auto start = static_cast<std::uint32_t>(indices.size());
        for (auto& p : parts)
            indices.insert(indices.end(), p.begin(), p.end());
        first[j] = start;
        count[j] = static_cast<std::uint32_t>(parts[0].size() + parts[1].size());
        if (paired) {
            first[j + 1] = start + static_cast<std::uint32_t>(parts[0].size());
            count[j + 1] = static_cast<std::uint32_t>(parts[1].size() + parts[2].size());
        }
    }
}

}  // namespace

bool buildLodIndex(const LodIndexInput& in, format::Block& block, std::string& error) {
    const Cdt& cdt = *in.cdt;
    const DeletionRecords& rec = *in.records;
    const auto steps = static_cast<std::uint32_t>(rec.steps.size());
    const std::vector<Point>& pts = in.points->points;

    // Retention order: vertices never deleted first (ascending id), then the deleted ones from the
    // last deleted to the first.
    std::vector<std::uint32_t> index(pts.size(), kAlive);  // point id -> vertex index
    std::vector<PointId> deleted(pts.size(), 0);
    for (const DeletionStep& s : rec.steps)
        deleted[s.vertex] = 1;
    std::vector<PointId> order;
    for (PointId id = 0; id < pts.size(); ++id) {
        if (cdt.representative[id] == id && !deleted[id]) order.push_back(id);
    }
    for (std::uint32_t s = steps; s-- > 0;)
        order.push_back(rec.steps[s].vertex);
    const auto vertexCount = static_cast<std::uint32_t>(order.size());
    block.vertices.resize(vertexCount);
    block.grid.resize(vertexCount);
    for (std::uint32_t i = 0; i < vertexCount; ++i) {
        const PointId id = order[i];
        if (index[id] != kAlive) {
            error = "vertex " + std::to_string(id) + " deleted twice";
            return false;
        }
        index[id] = i;
        const Point& p = pts[id];
        block.vertices[i] = {float(p.x - in.originX), float(p.y - in.originY), float(p.z),
                             (p.kind == PointKind::River ? format::kVertexRiver : 0u) |
                                 (cdt.locked[id] ? format::kVertexLocked : 0u)};
        block.grid[i] = {cdt.gx[id], cdt.gy[id]};
    }
    auto tri = [&](const TriangleTriple& t) {
        return format::Triangle{index[t.v[0]], index[t.v[1]], index[t.v[2]]};
    };
    auto edge = [&](const RiverEdge& e) {
        const std::uint32_t a = index[e.a], b = index[e.b];
        return format::Edge{std::min(a, b), std::max(a, b)};
    };

    // Records, renumbered.
    block.steps.resize(steps);
    for (std::uint32_t s = 0; s < steps; ++s) {
        block.steps[s] = {index[rec.steps[s].vertex], rec.steps[s].trianglesAlive,
                          rec.steps[s].riverEdgesAlive};
    }
    block.removedTriangleOffset = rec.removedTriangleOffset;
    block.addedTriangleOffset = rec.addedTriangleOffset;
    block.removedEdgeOffset = rec.removedEdgeOffset;
    block.addedEdgeOffset = rec.addedEdgeOffset;
    block.removedTriangles.clear();
    block.addedTriangles.clear();
    block.removedEdges.clear();
    block.addedEdges.clear();
    for (const auto& t : rec.removedTriangles)
        block.removedTriangles.push_back(tri(t));
    for (const auto& t : rec.addedTriangles)
        block.addedTriangles.push_back(tri(t));
    for (const auto& e : rec.removedEdges)
        block.removedEdges.push_back(edge(e));
    for (const auto& e : rec.addedEdges)
        block.addedEdges.push_back(edge(e));
    if ((in.maxError && rec.errorMax.size() != steps) ||
        (in.paperError && rec.errorPaper.size() != steps)) {
        error = "error tables do not match the deletion steps";
        return false;
    }
    block.errorMax.clear();
    block.errorPaper.clear();
    if (in.maxError) {
        block.errorMax.push_back(roundUp(rec.initialErrorMax));
        for (double e : rec.errorMax)
            block.errorMax.push_back(roundUp(e));
    }
    if (in.paperError) {
        block.errorPaper.push_back(roundUp(rec.initialErrorPaper));
        for (double e : rec.errorPaper)
            block.errorPaper.push_back(roundUp(e));
    }
    // Rounding must not break monotonicity.
    for (auto* e : {&block.errorMax, &block.errorPaper}) {
        for (std::size_t i = 1; i < e->size(); ++i)
            (*e)[i] = std::max((*e)[i], (*e)[i - 1]);
    }

    // Level steps (see lodindex.h).
    auto trianglesAt = [&](std::uint32_t k) {
        return k == 0 ? std::uint32_t(in.initialTriangles.size()) : rec.steps[k - 1].trianglesAlive;
    };
    std::vector<std::uint32_t> levelSteps{0};
    for (std::uint32_t k = 1; k <= steps; ++k) {
        if (double(trianglesAt(levelSteps.back())) > in.ratio * double(trianglesAt(k))) {
            levelSteps.push_back(k);
        }
    }
    if (levelSteps.back() != steps) levelSteps.push_back(steps);

    std::vector<Life<TriangleTriple>> triLives;
    std::vector<Life<RiverEdge>> edgeLives;
    if (!lifetimes(in.initialTriangles, rec.removedTriangleOffset, rec.removedTriangles,
                   rec.addedTriangleOffset, rec.addedTriangles, triLives, error) ||
        !lifetimes(in.initialEdges, rec.removedEdgeOffset, rec.removedEdges, rec.addedEdgeOffset,
                   rec.addedEdges, edgeLives, error)) {
        return false;
    }
    block.terrainIndices.clear();
    block.riverIndices.clear();
    std::vector<std::uint32_t> tFirst, tCount, rFirst, rCount;
    layOut(triLives, levelSteps, tri, block.terrainIndices, tFirst, tCount);
    layOut(edgeLives, levelSteps, edge, block.riverIndices, rFirst, rCount);

    block.levels.resize(levelSteps.size());
    for (std::size_t j = 0; j < levelSteps.size(); ++j) {
        const std::uint32_t k = levelSteps[j];
        format::Level& l = block.levels[j];
        l.step = k;
        l.vertexCount = vertexCount - k;
        l.triangleFirst = tFirst[j];
        l.triangleCount = tCount[j];
        l.riverFirst = rFirst[j];
        l.riverCount = rCount[j];
        l.errorMax = block.errorMax.empty() ? 0.0f : block.errorMax[k];
        l.errorPaper = block.errorPaper.empty() ? 0.0f : block.errorPaper[k];
        if (l.triangleCount != trianglesAt(k)) {
            error = "level " + std::to_string(j) + " has " + std::to_string(l.triangleCount) +
                    " triangles, the records say " + std::to_string(trianglesAt(k));
            return false;
        }
    }
    return true;
}

}  // namespace unilod
