// Paired level layout from lifetimes (lodlayout.h).
#include "lodlayout.h"

#include <algorithm>

namespace unilod::format {

namespace {

constexpr std::uint32_t kAlive = kAliveToTheEnd;

std::size_t hashOf(const Triangle& t) {
    std::uint64_t h = t.a * 0x9E3779B97F4A7C15ULL;
    h = (h ^ t.b) * 0xBF58476D1CE4E5B9ULL;
    h = (h ^ t.c) * 0x94D049BB133111EBULL;
    return std::size_t(h ^ (h >> 32));
}
std::size_t hashOf(const Edge& e) {
    const std::uint64_t h = (std::uint64_t(e.a) << 32 | e.b) * 0x9E3779B97F4A7C15ULL;
    return std::size_t(h ^ (h >> 32));
}

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
        for (std::size_t i = hashOf(key) & mask_;; i = (i + 1) & mask_) {
            if (values_[i] == kEmpty) {
                keys_[i] = key;
                values_[i] = value;
                return true;
            }
            if (values_[i] != kErased && sameIndex(keys_[i], key)) return false;
        }
    }
    // Removes the key; returns its value or kEmpty when absent.
    std::uint32_t erase(const T& key) {
        for (std::size_t i = hashOf(key) & mask_;; i = (i + 1) & mask_) {
            if (values_[i] == kEmpty) return kEmpty;
            if (values_[i] != kErased && sameIndex(keys_[i], key)) {
                const std::uint32_t v = values_[i];
                values_[i] = kErased;
                return v;
            }
        }
    }
    static constexpr std::uint32_t kEmpty = 0xFFFFFFFFu, kErased = 0xFFFFFFFEu;

private:
    std::vector<T> keys_;
    std::vector<std::uint32_t> values_;
    std::size_t mask_ = 0;
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
        if (!alive.insert(t, static_cast<std::uint32_t>(out.size()))) {
            error = "the full-resolution mesh holds an element twice";
            return false;
        }
        out.push_back({t, 0, kAlive});
    }
    const std::size_t steps = removedOffset.empty() ? 0 : removedOffset.size() - 1;
    if (addedOffset.size() != removedOffset.size()) {
        error = "record offsets of different lengths";
        return false;
    }
    for (std::size_t s = 0; s < steps; ++s) {
        const auto step = static_cast<std::uint32_t>(s + 1);
        if (removedOffset[s] > removedOffset[s + 1] || removedOffset[s + 1] > removed.size() ||
            addedOffset[s] > addedOffset[s + 1] || addedOffset[s + 1] > added.size()) {
            error = "step " + std::to_string(step) + ": record offsets out of range";
            return false;
        }
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

// Sorts lives by (a, b, c), then birth: a counting sort on a (vertex indices are dense), then
// each run of equal a (a vertex's few elements) by the rest.
template <class T>
void sortLives(std::vector<Life<T>>& lives) {
    auto less = [](const Life<T>& l, const Life<T>& r) {
        return lessIndex(l.item, r.item) || (!lessIndex(r.item, l.item) && l.birth < r.birth);
    };
    std::uint32_t maxA = 0;
    for (const Life<T>& l : lives)
        maxA = std::max(maxA, l.item.a);
    if (lives.size() < 64 || maxA > 4 * lives.size() + 1024) {
        std::sort(lives.begin(), lives.end(), less);
        return;
    }
    std::vector<std::uint32_t> start(std::size_t(maxA) + 2, 0);
    for (const Life<T>& l : lives)
        ++start[l.item.a + 1];
    for (std::size_t i = 1; i < start.size(); ++i)
        start[i] += start[i - 1];
    std::vector<Life<T>> sorted(lives.size());
    std::vector<std::uint32_t> at(start.begin(), start.end() - 1);
    for (const Life<T>& l : lives)
        sorted[at[l.item.a]++] = l;
    for (std::size_t a = 0; a + 1 < start.size(); ++a)
        if (start[a + 1] - start[a] > 1)
            std::sort(sorted.begin() + start[a], sorted.begin() + start[a + 1], less);
    lives.swap(sorted);
}

// The paired layout of `lives` for the level steps; sets first/count per level. The lives are
// sorted once by (a, b, c) (ties cannot occur among elements alive together), so every part
// comes out of one ordered pass.
template <class T>
void layOut(std::vector<Life<T>>& lives, const std::vector<std::uint32_t>& levelSteps,
            std::vector<T>& indices, std::vector<std::uint32_t>& first,
            std::vector<std::uint32_t>& count) {
    sortLives(lives);
    const std::size_t n = levelSteps.size(), pairs = (n + 1) / 2;
    first.assign(n, 0);
    count.assign(n, 0);
    indices.clear();
    // Each life is alive at the contiguous range [from, to) of levels (steps in [birth, death))
    // and goes into part 0 (fine level only), 1 (both) or 2 (coarse only) of every pair it
    // touches. Two passes over the sorted lives: count the parts, then write each element
    // straight to its place, so every part comes out sorted.
    std::vector<std::uint32_t> range(2 * lives.size());
    std::vector<std::uint64_t> size(3 * pairs + 1, 0);
    // levelAt[k] = the number of level steps below k (lower_bound of k), for k up to the last
    // step + 1; later k (an element alive to the end) give n.
    const std::uint32_t lastStep = n == 0 ? 0 : levelSteps.back();
    std::vector<std::uint32_t> levelAt(std::size_t(lastStep) + 2);
    for (std::uint32_t k = 0, j = 0; k < levelAt.size(); ++k) {
        while (j < n && levelSteps[j] < k)
            ++j;
        levelAt[k] = j;
    }
    auto levelOf = [&](std::uint32_t k) {
        return k < levelAt.size() ? levelAt[k] : std::uint32_t(n);
    };
    // The parts of the pairs a life at levels [from, to) touches: its first and last pair may
    // hold it in one level only (part 0: fine, 2: coarse), every pair between holds it in both
    // (part 1). Calls ends(part) for the first and the last pair and middle(p0, p1) for the
    // pairs p0 .. p1 - 1 between them.
    auto forParts = [&](std::size_t from, std::size_t to, auto&& ends, auto&& middle) {
        if (from >= to) return;
        const std::size_t pf = from / 2, pl = (to - 1) / 2;
        auto part = [&](std::size_t p) {
            const std::size_t fine = 2 * p, coarse = fine + 1;
            const bool inF = fine >= from, inC = coarse < to;  // fine < to and coarse >= from
            return 3 * p + (inF && inC ? 1 : (inF ? 0 : 2));
        };
        ends(part(pf));
        if (pl == pf) return;
        if (pl > pf + 1) middle(pf + 1, pl);
        ends(part(pl));
    };
    // Middle pairs are counted as a difference array over the pairs (one entry per life, not
    // one per pair it spans), summed into the parts' sizes after the pass.
    std::vector<std::int64_t> both(pairs + 1, 0);
    for (std::size_t i = 0; i < lives.size(); ++i) {
        const std::uint32_t from = levelOf(lives[i].birth), to = levelOf(lives[i].death);
        range[2 * i] = from;
        range[2 * i + 1] = to;
        forParts(
            from, to, [&](std::size_t part) { ++size[part + 1]; },
            [&](std::size_t p0, std::size_t p1) {
                ++both[p0];
                --both[p1];
            });
    }
    std::int64_t spanning = 0;
    for (std::size_t p = 0; p < pairs; ++p) {
        spanning += both[p];
        size[3 * p + 2] += std::uint64_t(spanning);
    }
    for (std::size_t k = 1; k < size.size(); ++k)
        size[k] += size[k - 1];  // now the start of each part
    indices.resize(size.back());
    for (std::size_t i = 0; i < lives.size(); ++i) {
        const T item = lives[i].item;
        forParts(
            range[2 * i], range[2 * i + 1], [&](std::size_t part) { indices[size[part]++] = item; },
            [&](std::size_t p0, std::size_t p1) {
                for (std::size_t p = p0; p < p1; ++p)
                    indices[size[3 * p + 1]++] = item;
            });
    }
    // size[part] is now the end of each part, i.e. the start of the next one.
    for (std::size_t p = 0; p < pairs; ++p) {
        const std::size_t j = 2 * p;
        const std::uint64_t start = p == 0 ? 0 : size[3 * p - 1];
        first[j] = static_cast<std::uint32_t>(start);
        count[j] = static_cast<std::uint32_t>(size[3 * p + 1] - start);
        if (j + 1 < n) {
            first[j + 1] = static_cast<std::uint32_t>(size[3 * p]);
            count[j + 1] = static_cast<std::uint32_t>(size[3 * p + 2] - size[3 * p]);
        }
    }
}

}  // namespace

bool layOutLevels(Block& b, const std::vector<Triangle>& initialTriangles,
                  const std::vector<Edge>& initialEdges, std::string& error) {
    std::vector<Life<Triangle>> triLives;
    std::vector<Life<Edge>> edgeLives;
    if (!lifetimes(initialTriangles, b.removedTriangleOffset, b.removedTriangles,
                   b.addedTriangleOffset, b.addedTriangles, triLives, error) ||
        !lifetimes(initialEdges, b.removedEdgeOffset, b.removedEdges, b.addedEdgeOffset,
                   b.addedEdges, edgeLives, error)) {
        return false;
    }
    layOutLevels(b, triLives, edgeLives);
    return true;
}

void layOutLevels(Block& b, std::vector<Life<Triangle>>& triangles,
                  std::vector<Life<Edge>>& edges) {
    std::vector<std::uint32_t> steps(b.levels.size());
    for (std::size_t j = 0; j < steps.size(); ++j)
        steps[j] = b.levels[j].step;
    std::vector<std::uint32_t> tFirst, tCount, rFirst, rCount;
    layOut(triangles, steps, b.terrainIndices, tFirst, tCount);
    layOut(edges, steps, b.riverIndices, rFirst, rCount);
    for (std::size_t j = 0; j < steps.size(); ++j) {
        Level& l = b.levels[j];
        l.triangleFirst = tFirst[j];
        l.triangleCount = tCount[j];
        l.riverFirst = rFirst[j];
        l.riverCount = rCount[j];
    }
}

}  // namespace unilod::format
