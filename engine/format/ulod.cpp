// .ulod reader and writer. The byte layout (every field, offset, alignment and checksum) is
// described in README.md beside this file; the on-disk structs below are its source of truth and
// each has a static_assert on its size so that the two cannot drift apart silently.
//
// The reader treats the file as hostile: every count is checked against the byte range it must fit
// in before anything is allocated, all size arithmetic is done in 64 bits on values bounded by the
// (real) file size, and nothing is read outside the ranges the directory declares.
#include "ulod.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>
#include <zlib.h>

#include <algorithm>
#include <bit>
#include <cassert>
#include <cerrno>
#include <cmath>
#include <cstddef>
#include <cstring>
#include <limits>
#include <set>
#include <tuple>
#include <utility>

#include "blockcodec.h"
#include "predicates.h"

namespace unilod::format {

// v1 is defined as little-endian and written by copying the in-memory structs; a big-endian port
// would need byte swapping on every field (and a test on such a host).
static_assert(std::endian::native == std::endian::little, ".ulod v1 needs a little-endian host");

namespace {

constexpr std::uint64_t kAlign = 8;  // every array and every block starts 8-byte aligned

// The fixed part of the file header, at offset 0.
struct FileHeader {
    char magic[8];
    std::uint32_t version;
    std::uint32_t headerSize;  // sizeof(FileHeader)
    std::uint64_t fileSize;    // total file size in bytes
    double originX, originY;
    double minX, minY, minZ, maxX, maxY, maxZ;
    double blockWidth, blockHeight;
    std::uint32_t blocksX, blocksY;
    std::uint32_t metrics, defaultMetric;
    std::uint32_t blockCount;
    std::uint32_t crsWktSize;
    std::uint32_t buildInfoSize;
    std::uint32_t reserved;  // 0
    double zQuantum;         // vertex heights are multiples of it
};
static_assert(sizeof(FileHeader) == 144);
static_assert(offsetof(FileHeader, fileSize) == 16);
static_assert(offsetof(FileHeader, blocksX) == 104);
static_assert(offsetof(FileHeader, reserved) == 132);

// One block directory entry (BlockInfo on disk).
struct DirEntry {
    std::uint32_t col, row;
    double minX, minY, minZ, maxX, maxY, maxZ;
    std::uint64_t offset, size;
    std::uint32_t checksum;
    std::uint32_t vertexCount, stepCount, levelCount;
    std::uint32_t fullTriangles;
    std::uint16_t level, childCount;  // tree links (Block)
    std::uint32_t firstChild;
    std::uint32_t encoding;  // BlockEncoding, as in the block header
};
static_assert(sizeof(DirEntry) == 104);
static_assert(offsetof(DirEntry, offset) == 56);
static_assert(offsetof(DirEntry, checksum) == 72);

// Written after the directory: the CRC-32 of every byte before it.
struct HeaderTrailer {
    std::uint32_t crc;
    std::uint32_t reserved;  // 0
};
static_assert(sizeof(HeaderTrailer) == 8);

// The fixed header at the start of every block: position, bounds and the count of every array.
struct BlockHeader {
    std::uint32_t col, row;
    double originX, originY;
    double minX, minY, minZ, maxX, maxY, maxZ;
    std::uint32_t vertexCount;
    std::uint32_t stepCount;
    std::uint32_t removedTriangleOffsetCount, addedTriangleOffsetCount;
    std::uint32_t removedEdgeOffsetCount, addedEdgeOffsetCount;
    std::uint32_t removedTriangleCount, addedTriangleCount;
    std::uint32_t removedEdgeCount, addedEdgeCount;
    std::uint32_t errorMaxCount, errorPaperCount;
    std::uint32_t levelCount;
    std::uint32_t terrainTriangleCount;
    std::uint32_t riverEdgeCount;
    std::uint32_t gridCount;
    std::uint32_t encoding;     // BlockEncoding
    std::uint32_t payloadSize;  // compact: the encoded bytes after this header; raw: 0
};
static_assert(sizeof(BlockHeader) == 144);
static_assert(offsetof(BlockHeader, vertexCount) == 72);
static_assert(offsetof(BlockHeader, gridCount) == 132);

constexpr std::uint64_t alignUp(std::uint64_t n) {
    return (n + kAlign - 1) / kAlign * kAlign;
}

// The grid of tree level L: the block grid halved L times, rounding up.
std::uint32_t levelGridSize(std::uint32_t blocks, std::uint32_t level) {
    return std::uint32_t((std::uint64_t(blocks) + (std::uint64_t(1) << level) - 1) >> level);
}

// The tree links of a whole directory (issue 18): a leaf (level 0) has no children; a node of
// level L > 0 has 1 to 4 children, the entries [firstChild, firstChild + childCount) before it,
// each of level L - 1, at its position halved and inside its box; every entry is the child of at
// most one node. Positions inside their level's grid and unique per level.
bool treeValid(const Header& h, const std::vector<DirEntry>& dir, std::string& error) {
    std::set<std::tuple<std::uint32_t, std::uint32_t, std::uint32_t>> seen;
    std::vector<std::uint8_t> hasParent(dir.size(), 0);
    for (std::size_t i = 0; i < dir.size(); ++i) {
        const DirEntry& e = dir[i];
        const std::string name =
            "directory entry " + std::to_string(i) + " (" + blockName(e.col, e.row, e.level) + ")";
        if (e.level > kMaxTreeLevel) {
            error = name + ": tree level above " + std::to_string(kMaxTreeLevel);
            return false;
        }
        const std::uint32_t gx = levelGridSize(h.blocksX, e.level),
                            gy = levelGridSize(h.blocksY, e.level);
        if (e.col >= gx || e.row >= gy) {
            error = name + ": outside the " + std::to_string(gx) + "x" + std::to_string(gy) +
                    " grid of its tree level";
            return false;
        }
        if (!seen.insert({e.level, e.col, e.row}).second) {
            error = name + ": duplicate block position";
            return false;
        }
        if (e.level == 0) {
            if (e.childCount != 0 || e.firstChild != kNoChild) {
                error = name + ": a leaf with children";
                return false;
            }
            continue;
        }
        if (e.childCount < 1 || e.childCount > 4 || e.firstChild >= i ||
            e.childCount > i - e.firstChild) {
            error = name + ": children [" + std::to_string(e.firstChild) + ", +" +
                    std::to_string(e.childCount) + ") are not 1 to 4 entries before it";
            return false;
        }
        for (std::uint32_t c = e.firstChild; c < e.firstChild + e.childCount; ++c) {
            const DirEntry& k = dir[c];
            const bool inside = k.minX >= e.minX && k.maxX <= e.maxX && k.minY >= e.minY &&
                                k.maxY <= e.maxY && k.minZ >= e.minZ && k.maxZ <= e.maxZ;
            if (k.level + 1u != e.level || k.col / 2 != e.col || k.row / 2 != e.row ||
                hasParent[c] || !inside) {
                error = name + ": entry " + std::to_string(c) +
                        " is not one of its children (level, position, box or a second parent)";
                return false;
            }
            hasParent[c] = 1;
        }
    }
    return true;
}

std::string errnoText() {
    return std::strerror(errno);
}

// The arrays of a block in file order: a pointer to each vector, its element size. Used by both
// the writer and the reader so that the order is defined once.
template <typename B, typename F>
void forEachArray(B& b, F&& f) {
    f(b.vertices);
    f(b.steps);
    f(b.removedTriangleOffset);
    f(b.addedTriangleOffset);
    f(b.removedEdgeOffset);
    f(b.addedEdgeOffset);
    f(b.removedTriangles);
    f(b.addedTriangles);
    f(b.removedEdges);
    f(b.addedEdges);
    f(b.errorMax);
    f(b.errorPaper);
    f(b.levels);
    f(b.terrainIndices);
    f(b.riverIndices);
    f(b.grid);
}

// The counts of a block header in the same order as forEachArray.
std::uint32_t* blockCounts(BlockHeader& h) {
    return &h.vertexCount;
}
constexpr int kArrayCount = 16;
static_assert(offsetof(BlockHeader, gridCount) ==
              offsetof(BlockHeader, vertexCount) + (kArrayCount - 1) * sizeof(std::uint32_t));

// Byte size of a block from its header's counts; 64-bit, cannot overflow (16 arrays of at most
// 2^32 - 1 elements of at most 32 bytes each).
std::uint64_t blockByteSize(const BlockHeader& h) {
    const std::uint64_t elementSizes[kArrayCount] = {sizeof(Vertex),
                                                     sizeof(Step),
                                                     4,
                                                     4,
                                                     4,
                                                     4,
                                                     sizeof(Triangle),
                                                     sizeof(Triangle),
                                                     sizeof(Edge),
                                                     sizeof(Edge),
                                                     4,
                                                     4,
                                                     sizeof(Level),
                                                     sizeof(Triangle),
                                                     sizeof(Edge),
                                                     sizeof(GridXY)};
    const std::uint32_t* counts = &h.vertexCount;
    std::uint64_t size = sizeof(BlockHeader);
    for (int i = 0; i < kArrayCount; ++i)
        size += alignUp(counts[i] * elementSizes[i]);
    return size;
}

// The counts a compact block's decoder is held to.
BlockCounts compactCounts(const BlockHeader& h) {
    BlockCounts c;
    c.vertices = h.vertexCount;
    c.steps = h.stepCount;
    c.levels = h.levelCount;
    c.removedTriangles = h.removedTriangleCount;
    c.addedTriangles = h.addedTriangleCount;
    c.removedEdges = h.removedEdgeCount;
    c.addedEdges = h.addedEdgeCount;
    c.terrainTriangles = h.terrainTriangleCount;
    c.riverEdges = h.riverEdgeCount;
    c.errorMax = h.errorMaxCount > 0;
    c.errorPaper = h.errorPaperCount > 0;
    return c;
}

// A compact block decodes to at most this many times its stored bytes (plus 1 MiB): the reader
// refuses larger counts before it decodes, so a hostile block cannot ask for a huge allocation.
// Built blocks expand about 10-40 times.
constexpr std::uint64_t kMaxExpansion = 1024;

bool metricsValid(std::uint32_t metrics, std::uint32_t defaultMetric, std::string& error) {
    const std::uint32_t all = kMetricMax | kMetricPaper;
    if (metrics == 0 || (metrics & ~all) != 0) {
        error = "invalid metrics mask " + std::to_string(metrics);
        return false;
    }
    if ((defaultMetric != kMetricMax && defaultMetric != kMetricPaper) ||
        (metrics & defaultMetric) == 0) {
        error = "default metric " + std::to_string(defaultMetric) + " is not in metrics mask " +
                std::to_string(metrics);
        return false;
    }
    return true;
}

// The header's values (Reader::open, and Writer::finish before it writes them): every float
// finite, extents ordered, block size positive. A grid may have cells without a block, but not
// more cells than the file has bytes: whatever a reader keeps per grid cell then costs at most as
// much as the file itself (a hostile 2^32 - 1 x 2^32 - 1 grid is rejected).
bool headerValid(const Header& h, std::uint64_t fileSize, std::string& error) {
    const std::pair<const char*, double> values[] = {{"originX", h.originX},
                                                     {"originY", h.originY},
                                                     {"minX", h.minX},
                                                     {"minY", h.minY},
                                                     {"minZ", h.minZ},
                                                     {"maxX", h.maxX},
                                                     {"maxY", h.maxY},
                                                     {"maxZ", h.maxZ},
                                                     {"blockWidth", h.blockWidth},
                                                     {"blockHeight", h.blockHeight}};
    for (const auto& [name, value] : values) {
        if (!std::isfinite(value)) {
            error = std::string("header ") + name + " is not finite";
            return false;
        }
    }
    if (h.minX > h.maxX || h.minY > h.maxY || h.minZ > h.maxZ) {
        error = "header extents are inverted (a min above its max)";
        return false;
    }
    if (!(h.zQuantum > 0 && h.zQuantum <= 1)) {
        error = "z quantum " + std::to_string(h.zQuantum) + " is not in (0, 1] m";
        return false;
    }
    if (h.blockWidth <= 0 || h.blockHeight <= 0) {
        error = "block size " + std::to_string(h.blockWidth) + " x " +
                std::to_string(h.blockHeight) + " m is not positive";
        return false;
    }
    if (std::uint64_t(h.blocksX) * h.blocksY > fileSize) {
        error = "block grid " + std::to_string(h.blocksX) + "x" + std::to_string(h.blocksY) +
                " has more cells than the file has bytes (" + std::to_string(fileSize) + ")";
        return false;
    }
    return true;
}

// A directory entry's bounding box: finite, ordered and inside the header's extents. Exact: the
// writer's caller sets the extents to the min / max of the same doubles (preprocess/build.cpp),
// so no rounding lies between them. Comparisons are written so that NaN fails them.
bool directoryBoxValid(const Header& h, const double box[6], std::string& error) {
    const double lo[3] = {h.minX, h.minY, h.minZ}, hi[3] = {h.maxX, h.maxY, h.maxZ};
    for (int a = 0; a < 3; ++a) {
        if (!(box[a] >= lo[a] && box[a] <= box[a + 3] && box[a + 3] <= hi[a])) {
            error = "bounding box is not finite, inverted or outside the header's extents";
            return false;
        }
    }
    return true;
}

// ---- validation -----------------------------------------------------------------------------

bool checkOffsets(const std::vector<std::uint32_t>& offsets, std::size_t steps,
                  std::size_t arraySize, const char* name, std::string& error) {
    if (offsets.size() != steps + 1) {
        error = std::string(name) + " has " + std::to_string(offsets.size()) +
                " entries, expected steps + 1 = " + std::to_string(steps + 1);
        return false;
    }
    if (offsets[0] != 0) {
        error = std::string(name) + "[0] is " + std::to_string(offsets[0]) + ", expected 0";
        return false;
    }
    for (std::size_t s = 1; s < offsets.size(); ++s) {
        if (offsets[s] < offsets[s - 1]) {
            error = std::string(name) + " decreases at " + std::to_string(s) + " (" +
                    std::to_string(offsets[s - 1]) + " -> " + std::to_string(offsets[s]) + ")";
            return false;
        }
    }
    if (offsets.back() != arraySize) {
        error = std::string(name) + " ends at " + std::to_string(offsets.back()) +
                " but its array has " + std::to_string(arraySize) + " entries";
        return false;
    }
    return true;
}

// `where` names the element's place, built only on failure.
template <class Where>
bool checkTriangle(const Triangle& t, std::uint64_t limit, const Where& where,
                   std::string& error) {
    if (t.a >= limit || t.b >= limit || t.c >= limit) {
        error = where() + ": triangle (" + std::to_string(t.a) + "," + std::to_string(t.b) + "," +
                std::to_string(t.c) + ") has an index >= " + std::to_string(limit);
        return false;
    }
    return true;
}

template <class Where>
bool checkEdge(const Edge& e, std::uint64_t limit, const Where& where, std::string& error) {
    if (e.a >= e.b || e.b >= limit) {
        error = where() + ": edge (" + std::to_string(e.a) + "," + std::to_string(e.b) +
                ") is not a < b < " + std::to_string(limit);
        return false;
    }
    return true;
}

bool checkErrors(const std::vector<float>& errors, bool present, std::size_t steps,
                 const char* name, std::string& error) {
    if (!present) {
        if (!errors.empty()) {
            error = std::string(name) + " has " + std::to_string(errors.size()) +
                    " entries but the metric is not in the file";
            return false;
        }
        return true;
    }
    if (errors.size() != steps + 1) {
        error = std::string(name) + " has " + std::to_string(errors.size()) +
                " entries, expected steps + 1 = " + std::to_string(steps + 1);
        return false;
    }
    for (std::size_t s = 0; s < errors.size(); ++s) {
        if (!std::isfinite(errors[s]) || errors[s] < 0) {
            error = std::string(name) + "[" + std::to_string(s) + "] is not a finite value >= 0";
            return false;
        }
        if (s > 0 && errors[s] < errors[s - 1]) {
            error = std::string(name) + " decreases at step " + std::to_string(s) + " (" +
                    std::to_string(errors[s - 1]) + " -> " + std::to_string(errors[s]) + ")";
            return false;
        }
    }
    return true;
}

// The block's bounding box finite and ordered, its origin finite and inside it (the builder puts
// the origin at the centre of the box of the block's points): vertices are drawn relative to the
// origin, so a far-away origin would place them anywhere.
bool boxAndOriginValid(const Block& b, std::string& error) {
    const double lo[3] = {b.minX, b.minY, b.minZ}, hi[3] = {b.maxX, b.maxY, b.maxZ};
    for (int a = 0; a < 3; ++a) {
        if (!std::isfinite(lo[a]) || !std::isfinite(hi[a]) || lo[a] > hi[a]) {
            error = "bounding box is not finite or inverted";
            return false;
        }
    }
    if (!(b.originX >= b.minX && b.originX <= b.maxX && b.originY >= b.minY &&
          b.originY <= b.maxY)) {
        error = "origin (" + std::to_string(b.originX) + ", " + std::to_string(b.originY) +
                ") is not finite or lies outside the bounding box";
        return false;
    }
    return true;
}

// True when float coordinate `c`, at double position `at` (origin + c, or c itself for z), lies
// in [lo, hi] up to the float rounding the format allows (kFloatSlack, kAbsoluteSlack).
bool insideWithSlack(double at, float c, double lo, double hi) {
    const double slack = kFloatSlack * std::fabs(double(c)) + kAbsoluteSlack;
    return at >= lo - slack && at <= hi + slack;
}

// Vertex i: finite, known flags, inside the block's box; its grid position (if stored) bounded so
// that orient2d is exact and within a grid unit of its float position, so the orientation proved
// on the grid is the one drawn (up to slivers thinner than a millimetre).
bool vertexValid(const Block& b, std::uint64_t i, std::string& error) {
    const Vertex& v = b.vertices[i];
    const std::string name = "vertex " + std::to_string(i);
    if (!std::isfinite(v.x) || !std::isfinite(v.y) || !std::isfinite(v.z)) {
        error = name + " has a non-finite coordinate";
        return false;
    }
    if ((v.flags & ~(kVertexRiver | kVertexLocked)) != 0) {
        error = name + " has unknown flags " + std::to_string(v.flags);
        return false;
    }
    // x, y also up to a grid unit outside: a built vertex's x, y are its grid position (the exact
    // position rounded to kGridUnit, blockcodec.h), the box the exact positions'.
    if (!insideWithSlack(b.originX + double(v.x), v.x, b.minX - kGridUnit, b.maxX + kGridUnit) ||
        !insideWithSlack(b.originY + double(v.y), v.y, b.minY - kGridUnit, b.maxY + kGridUnit) ||
        !insideWithSlack(double(v.z), v.z, b.minZ, b.maxZ)) {
        error = name + " (" + std::to_string(v.x) + ", " + std::to_string(v.y) + ", " +
                std::to_string(v.z) + ") lies outside the block's bounding box";
        return false;
    }
    if (b.grid.empty()) return true;
    const GridXY g = b.grid[i];
    if (std::abs(std::int64_t(g.x)) > kMaxGridCoordinate ||
        std::abs(std::int64_t(g.y)) > kMaxGridCoordinate) {
        error = name + ": grid position (" + std::to_string(g.x) + ", " + std::to_string(g.y) +
                ") is beyond +-(2^28 - 1)";
        return false;
    }
    const double dx = std::fabs(double(v.x) - double(g.x) * kGridUnit);
    const double dy = std::fabs(double(v.y) - double(g.y) * kGridUnit);
    if (dx > kGridUnit + kFloatSlack * std::fabs(double(v.x)) ||
        dy > kGridUnit + kFloatSlack * std::fabs(double(v.y))) {
        error = name + ": float position (" + std::to_string(v.x) + ", " + std::to_string(v.y) +
                ") and grid position (" + std::to_string(g.x) + ", " + std::to_string(g.y) +
                ") differ by more than a grid unit";
        return false;
    }
    return true;
}

std::string triangleText(const Triangle& t) {
    return "(" + std::to_string(t.a) + "," + std::to_string(t.b) + "," + std::to_string(t.c) + ")";
}

constexpr std::uint64_t edgeKey(std::uint32_t a, std::uint32_t b) {
    return std::uint64_t(a) << 32 | b;
}

bool validateLevelGeometryImpl(const Block& b, std::size_t level, std::string& error) {
    const std::string where = "level " + std::to_string(level);
    if (level >= b.levels.size()) {
        error = where + " does not exist";
        return false;
    }
    const Level& l = b.levels[level];
    if (l.vertexCount > b.vertices.size() ||
        std::uint64_t(l.triangleFirst) + l.triangleCount > b.terrainIndices.size() ||
        std::uint64_t(l.riverFirst) + l.riverCount > b.riverIndices.size()) {
        error = where + ": its vertices or index ranges lie outside the block's arrays";
        return false;
    }
    const std::uint64_t n = l.vertexCount;
    const bool exact = !b.grid.empty() && b.grid.size() == b.vertices.size();
    auto gridOk = [&](std::uint32_t v) {
        return std::abs(std::int64_t(b.grid[v].x)) <= kMaxGridCoordinate &&
               std::abs(std::int64_t(b.grid[v].y)) <= kMaxGridCoordinate;
    };
    for (std::uint32_t i = 0; i < l.triangleCount; ++i) {
        const Triangle& t = b.terrainIndices[l.triangleFirst + i];
        if (!checkTriangle(t, n, [&] { return where + " terrain"; }, error)) return false;
        if (t.a == t.b || t.b == t.c || t.c == t.a) {
            error = where + ": triangle " + triangleText(t) + " repeats a vertex";
            return false;
        }
        if (exact) {
            if (!gridOk(t.a) || !gridOk(t.b) || !gridOk(t.c)) {
                error = where + ": triangle " + triangleText(t) +
                        " has a grid position beyond +-(2^28 - 1)";
                return false;
            }
            const GridXY &p = b.grid[t.a], &q = b.grid[t.b], &r = b.grid[t.c];
            if (orient2d(p.x, p.y, q.x, q.y, r.x, r.y) <= 0) {
                error = where + ": triangle " + triangleText(t) +
                        " is not counter-clockwise on the exact grid (flipped or degenerate)";
                return false;
            }
        }
    }
    // The directed edges a -> b of the triangles, bucketed by a (a counting sort, O(n + t)) and
    // each bucket sorted (a vertex's degree: a few entries). In a valid triangulation no directed
    // edge occurs twice.
    std::vector<std::uint64_t> start(n + 1, 0);
    auto forEachDirected = [&](auto&& f) {
        for (std::uint32_t i = 0; i < l.triangleCount; ++i) {
            const Triangle& t = b.terrainIndices[l.triangleFirst + i];
            f(t.a, t.b);
            f(t.b, t.c);
            f(t.c, t.a);
        }
    };
    forEachDirected([&](std::uint32_t from, std::uint32_t) { ++start[from + 1]; });
    for (std::uint64_t v = 0; v < n; ++v)
        start[v + 1] += start[v];
    std::vector<std::uint32_t> to(start[n]);
    {
        std::vector<std::uint64_t> fill(start.begin(), start.end() - 1);
        forEachDirected([&](std::uint32_t from, std::uint32_t t) { to[fill[from]++] = t; });
    }
    for (std::uint64_t v = 0; v < n; ++v) {
        const auto first = to.begin() + std::ptrdiff_t(start[v]);
        const auto last = to.begin() + std::ptrdiff_t(start[v + 1]);
        std::sort(first, last);
        const auto twice = std::adjacent_find(first, last);
        if (twice != last) {
            error = where + ": edge " + std::to_string(v) + "->" + std::to_string(*twice) +
                    " is used by two triangles in the same direction (a duplicated or flipped "
                    "triangle, or more than two triangles on one edge)";
            return false;
        }
    }
    auto hasEdge = [&](std::uint32_t from, std::uint32_t t) {
        return std::binary_search(to.begin() + std::ptrdiff_t(start[from]),
                                  to.begin() + std::ptrdiff_t(start[from + 1]), t);
    };
    std::vector<std::uint64_t> rivers;
    rivers.reserve(l.riverCount);
    for (std::uint32_t i = 0; i < l.riverCount; ++i) {
        const Edge& e = b.riverIndices[l.riverFirst + i];
        if (!checkEdge(e, n, [&] { return where + " river"; }, error)) return false;
        if (!hasEdge(e.a, e.b) && !hasEdge(e.b, e.a)) {
            error = where + ": river edge (" + std::to_string(e.a) + "," + std::to_string(e.b) +
                    ") is not an edge of the level's triangles";
            return false;
        }
        rivers.push_back(edgeKey(e.a, e.b));
    }
    std::sort(rivers.begin(), rivers.end());
    const auto dup = std::adjacent_find(rivers.begin(), rivers.end());
    if (dup != rivers.end()) {
        error = where + ": river edge (" + std::to_string(*dup >> 32) + "," +
                std::to_string(*dup & 0xffffffffu) + ") appears twice";
        return false;
    }
    return true;
}

bool validateBlockImpl(const Block& b, std::uint32_t metrics, std::string& error) {
    constexpr std::uint64_t kMax32 = std::numeric_limits<std::uint32_t>::max();
    bool tooBig = false;
    forEachArray(b, [&](const auto& v) { tooBig = tooBig || v.size() > kMax32; });
    if (tooBig) {
        error = "an array has more than 2^32 - 1 entries";
        return false;
    }

    const std::uint64_t n = b.vertices.size();
    const std::uint64_t stepCount = b.steps.size();
    if (!b.grid.empty() && b.grid.size() != n) {
        error = "grid has " + std::to_string(b.grid.size()) + " entries for " + std::to_string(n) +
                " vertices";
        return false;
    }
    if (!boxAndOriginValid(b, error)) return false;
    for (std::uint64_t i = 0; i < n; ++i) {
        if (!vertexValid(b, i, error)) return false;
    }

    // Retention order: the vertices alive before step s are [0, n - s), so step s deletes
    // vertex n - 1 - s. Anything else would break the engine's prefix rule.
    if (stepCount > n) {
        error = std::to_string(stepCount) + " steps but only " + std::to_string(n) + " vertices";
        return false;
    }
    for (std::uint64_t s = 0; s < stepCount; ++s) {
        if (b.steps[s].vertex != n - 1 - s) {
            error = "step " + std::to_string(s) + " deletes vertex " +
                    std::to_string(b.steps[s].vertex) + ", retention order requires " +
                    std::to_string(n - 1 - s);
            return false;
        }
        if ((b.vertices[n - 1 - s].flags & kVertexLocked) != 0) {
            error =
                "step " + std::to_string(s) + " deletes locked vertex " + std::to_string(n - 1 - s);
            return false;
        }
    }

    if (!checkOffsets(b.removedTriangleOffset, stepCount, b.removedTriangles.size(),
                      "removedTriangleOffset", error) ||
        !checkOffsets(b.addedTriangleOffset, stepCount, b.addedTriangles.size(),
                      "addedTriangleOffset", error) ||
        !checkOffsets(b.removedEdgeOffset, stepCount, b.removedEdges.size(), "removedEdgeOffset",
                      error) ||
        !checkOffsets(b.addedEdgeOffset, stepCount, b.addedEdges.size(), "addedEdgeOffset",
                      error)) {
        return false;
    }

    // Records of step s: removed elements existed before it (indices < n - s), added ones exist
    // after it (indices < n - s - 1, the deleted vertex is gone).
    for (std::uint64_t s = 0; s < stepCount; ++s) {
        auto where = [&] { return "step " + std::to_string(s); };
        for (auto i = b.removedTriangleOffset[s]; i < b.removedTriangleOffset[s + 1]; ++i) {
            if (!checkTriangle(b.removedTriangles[i], n - s, [&] { return where() + " removed"; }, error)) {
                return false;
            }
        }
        for (auto i = b.addedTriangleOffset[s]; i < b.addedTriangleOffset[s + 1]; ++i) {
            if (!checkTriangle(b.addedTriangles[i], n - s - 1, [&] { return where() + " added"; }, error)) {
                return false;
            }
        }
        for (auto i = b.removedEdgeOffset[s]; i < b.removedEdgeOffset[s + 1]; ++i) {
            if (!checkEdge(b.removedEdges[i], n - s, [&] { return where() + " removed"; }, error)) return false;
        }
        for (auto i = b.addedEdgeOffset[s]; i < b.addedEdgeOffset[s + 1]; ++i) {
            if (!checkEdge(b.addedEdges[i], n - s - 1, [&] { return where() + " added"; }, error)) return false;
        }
    }

    if (!checkErrors(b.errorMax, (metrics & kMetricMax) != 0, stepCount, "errorMax", error) ||
        !checkErrors(b.errorPaper, (metrics & kMetricPaper) != 0, stepCount, "errorPaper", error)) {
        return false;
    }

    if (b.levels.empty()) {
        error = "no levels (levels[0] must be the full resolution)";
        return false;
    }
    if (b.levels[0].step != 0) {
        error = "levels[0].step is " + std::to_string(b.levels[0].step) + ", expected 0";
        return false;
    }

    // Alive counts replayed from the full resolution (levels[0]) through the records.
    std::vector<std::uint64_t> trianglesAlive(stepCount + 1), edgesAlive(stepCount + 1);
    trianglesAlive[0] = b.levels[0].triangleCount;
    edgesAlive[0] = b.levels[0].riverCount;
    for (std::uint64_t s = 0; s < stepCount; ++s) {
        const std::uint64_t removedT = b.removedTriangleOffset[s + 1] - b.removedTriangleOffset[s];
        const std::uint64_t addedT = b.addedTriangleOffset[s + 1] - b.addedTriangleOffset[s];
        const std::uint64_t removedE = b.removedEdgeOffset[s + 1] - b.removedEdgeOffset[s];
        const std::uint64_t addedE = b.addedEdgeOffset[s + 1] - b.addedEdgeOffset[s];
        const auto where = [&] { return "step " + std::to_string(s); };
        if (removedT > trianglesAlive[s] || removedE > edgesAlive[s]) {
            error = where() + " removes more triangles or river edges than are alive";
            return false;
        }
        trianglesAlive[s + 1] = trianglesAlive[s] - removedT + addedT;
        edgesAlive[s + 1] = edgesAlive[s] - removedE + addedE;
        if (b.steps[s].trianglesAlive != trianglesAlive[s + 1]) {
            error = where() + ": trianglesAlive is " + std::to_string(b.steps[s].trianglesAlive) +
                    " but the records give " + std::to_string(trianglesAlive[s + 1]);
            return false;
        }
        if (b.steps[s].riverEdgesAlive != edgesAlive[s + 1]) {
            error = where() + ": riverEdgesAlive is " + std::to_string(b.steps[s].riverEdgesAlive) +
                    " but the records give " + std::to_string(edgesAlive[s + 1]);
            return false;
        }
    }

    for (std::size_t l = 0; l < b.levels.size(); ++l) {
        const Level& level = b.levels[l];
        const std::string where = "level " + std::to_string(l);
        if (l > 0 && level.step <= b.levels[l - 1].step) {
            error = where + ": step " + std::to_string(level.step) + " is not above level " +
                    std::to_string(l - 1) + "'s step " + std::to_string(b.levels[l - 1].step);
            return false;
        }
        if (level.step > stepCount) {
            error = where + ": step " + std::to_string(level.step) + " > step count " +
                    std::to_string(stepCount);
            return false;
        }
        if (level.vertexCount != n - level.step) {
            error = where + ": vertexCount " + std::to_string(level.vertexCount) +
                    ", expected vertices - step = " + std::to_string(n - level.step);
            return false;
        }
        if (level.triangleCount != trianglesAlive[level.step] ||
            level.riverCount != edgesAlive[level.step]) {
            error = where + ": " + std::to_string(level.triangleCount) + " triangles and " +
                    std::to_string(level.riverCount) + " river edges, the records give " +
                    std::to_string(trianglesAlive[level.step]) + " and " +
                    std::to_string(edgesAlive[level.step]);
            return false;
        }
        if (std::uint64_t(level.triangleFirst) + level.triangleCount > b.terrainIndices.size()) {
            error = where + ": terrain range [" + std::to_string(level.triangleFirst) + ", +" +
                    std::to_string(level.triangleCount) + ") outside the " +
                    std::to_string(b.terrainIndices.size()) + " terrain triangles";
            return false;
        }
        if (std::uint64_t(level.riverFirst) + level.riverCount > b.riverIndices.size()) {
            error = where + ": river range [" + std::to_string(level.riverFirst) + ", +" +
                    std::to_string(level.riverCount) + ") outside the " +
                    std::to_string(b.riverIndices.size()) + " river edges";
            return false;
        }
        if (!validateLevelGeometryImpl(b, l, error)) return false;
        // The level's errors are the error table's at its step (what the engine's h_s is).
        const bool maxOk = (metrics & kMetricMax) == 0 || level.errorMax == b.errorMax[level.step];
        const bool paperOk =
            (metrics & kMetricPaper) == 0 || level.errorPaper == b.errorPaper[level.step];
        if (!maxOk || !paperOk) {
            error = where + ": errors differ from the error table at step " +
                    std::to_string(level.step);
            return false;
        }
    }
    return true;
}

// ---- I/O helpers ------------------------------------------------------------------------------

bool preadAll(int fd, void* data, std::uint64_t size, std::uint64_t offset) {
    auto* p = static_cast<unsigned char*>(data);
    while (size > 0) {
        const ssize_t got = ::pread(fd, p, size, static_cast<off_t>(offset));
        if (got < 0 && errno == EINTR) continue;
        if (got <= 0) {
            if (got == 0) errno = EIO;  // the file shrank under us
            return false;
        }
        p += got;
        size -= static_cast<std::uint64_t>(got);
        offset += static_cast<std::uint64_t>(got);
    }
    return true;
}

std::uint32_t crc32Of(const void* data, std::uint64_t size, std::uint32_t crc = 0) {
    // zlib's crc32 takes a uInt length: feed it in chunks.
    const auto* p = static_cast<const Bytef*>(data);
    uLong c = crc;
    while (size > 0) {
        const uInt chunk = static_cast<uInt>(std::min<std::uint64_t>(size, 1u << 30));
        c = ::crc32(c, p, chunk);
        p += chunk;
        size -= chunk;
    }
    return static_cast<std::uint32_t>(c);
}

// Appends bytes to a buffer, then zero padding up to the next 8-byte boundary.
void appendPadded(std::vector<unsigned char>& out, const void* data, std::size_t size) {
    const auto* p = static_cast<const unsigned char*>(data);
    out.insert(out.end(), p, p + size);
    out.resize(alignUp(out.size()), 0);
}

void fillBlockHeader(const Block& b, BlockHeader& h) {
    h = BlockHeader{};
    h.col = b.col;
    h.row = b.row;
    h.originX = b.originX;
    h.originY = b.originY;
    h.minX = b.minX;
    h.minY = b.minY;
    h.minZ = b.minZ;
    h.maxX = b.maxX;
    h.maxY = b.maxY;
    h.maxZ = b.maxZ;
    std::uint32_t* counts = blockCounts(h);
    int i = 0;
    forEachArray(b, [&](const auto& v) { counts[i++] = static_cast<std::uint32_t>(v.size()); });
}

// The block's bytes: compact (blockcodec.h) when asked for, the block is in canonical form (the
// encoder replays it and proves that everything the decoder derives equals what it stores) and
// compact is smaller; raw otherwise.
void serializeBlock(const Block& b, bool compact, double zQuantum,
                    std::vector<unsigned char>& out) {
    BlockHeader h;
    fillBlockHeader(b, h);
    out.clear();
    std::vector<unsigned char> payload;
    std::string why;
    // Compact only when it is smaller (a tiny block's stream headers can cost more than raw).
    if (compact && encodeCompact(b, zQuantum, payload, why) &&
        alignUp(sizeof(h) + payload.size()) < blockByteSize(h) &&
        payload.size() <= std::numeric_limits<std::uint32_t>::max()) {
        h.encoding = std::uint32_t(BlockEncoding::kCompact);
        h.payloadSize = static_cast<std::uint32_t>(payload.size());
        appendPadded(out, &h, sizeof(h));
        appendPadded(out, payload.data(), payload.size());
        return;
    }
    h.encoding = std::uint32_t(BlockEncoding::kRaw);
    out.reserve(blockByteSize(h));
    appendPadded(out, &h, sizeof(h));
    forEachArray(b, [&](const auto& v) { appendPadded(out, v.data(), v.size() * sizeof(v[0])); });
    assert(out.size() == blockByteSize(h));
}

}  // namespace

bool validateBlock(const Block& block, std::uint32_t metrics, std::string& error) {
    if (!validateBlockImpl(block, metrics, error)) {
        error = blockName(block.col, block.row, block.level) + ": " + error;
        return false;
    }
    return true;
}

bool validateLevelGeometry(const Block& block, std::size_t level, std::string& error) {
    return validateLevelGeometryImpl(block, level, error);
}

// ---- writer -----------------------------------------------------------------------------------

// ---- writer -----------------------------------------------------------------------------------

struct Writer::Impl {
    std::string path;
    Header header;
    AtomicFile file;
    std::size_t blockCount = 0;
    std::vector<DirEntry> dir;
    std::uint64_t dataStart = 0, offset = 0;
    std::vector<unsigned char> bytes;
    bool open = false;
    bool raw = false;
};

Writer::Writer() : impl_(std::make_unique<Impl>()) {}
Writer::~Writer() = default;  // an unfinished temporary file is removed (AtomicFile)

Header& Writer::header() { return impl_->header; }

void Writer::storeRaw(bool raw) { impl_->raw = raw; }

bool Writer::open(const std::string& path, const Header& header, std::size_t blockCount,
                  const OutputOptions& output, std::string& error) {
    impl_ = std::make_unique<Impl>();
    Impl& w = *impl_;
    w.path = path;
    w.header = header;
    w.blockCount = blockCount;
    auto fail = [&](const std::string& what) {
        error = path + ": " + what;
        return false;
    };
    constexpr std::uint64_t kMax32 = std::numeric_limits<std::uint32_t>::max();
    // Header checks that need no I/O come first.
    std::string why;
    if (!metricsValid(header.metrics, header.defaultMetric, why)) return fail(why);
    if (header.crsWkt.size() > kMax32 || header.buildInfo.size() > kMax32) {
        return fail("CRS WKT or build info longer than 2^32 - 1 bytes");
    }
    if (blockCount > kMax32) return fail("more than 2^32 - 1 blocks");

    // Layout: fixed header, WKT, build info, directory, trailer, then the blocks in order. The
    // header part has a known size, so blocks are written first and the header last.
    w.dataStart = sizeof(FileHeader) + alignUp(header.crsWkt.size()) +
                  alignUp(header.buildInfo.size()) + blockCount * sizeof(DirEntry) +
                  sizeof(HeaderTrailer);
    w.offset = w.dataStart;
    if (!w.file.open(path, output, error)) return false;
    w.open = true;
    return true;
}

bool Writer::writeBlock(const Block& b, std::string& error) {
    Impl& w = *impl_;
    assert(w.open && "Writer::open() first");
    auto fail = [&](const std::string& what) {
        error = w.path + ": " + what;
        return false;
    };
    if (w.dir.size() >= w.blockCount) {
        return fail("more blocks than the " + std::to_string(w.blockCount) + " announced");
    }
    if (b.level > kMaxTreeLevel) return fail(blockName(b.col, b.row, b.level) + ": tree level too high");
    std::string why;
    if (!validateBlock(b, w.header.metrics, why)) return fail(why);
    serializeBlock(b, !w.raw, w.header.zQuantum, w.bytes);
    DirEntry e{};
    e.col = b.col;
    e.row = b.row;
    e.minX = b.minX;
    e.minY = b.minY;
    e.minZ = b.minZ;
    e.maxX = b.maxX;
    e.maxY = b.maxY;
    e.maxZ = b.maxZ;
    e.offset = w.offset;
    e.size = w.bytes.size();
    e.checksum = crc32Of(w.bytes.data(), w.bytes.size());
    e.vertexCount = static_cast<std::uint32_t>(b.vertices.size());
    e.stepCount = static_cast<std::uint32_t>(b.steps.size());
    e.levelCount = static_cast<std::uint32_t>(b.levels.size());
    e.fullTriangles = b.levels[0].triangleCount;  // validateBlock: levels[0] is step 0
    e.level = std::uint16_t(b.level);
    e.childCount = std::uint16_t(std::min<std::uint32_t>(b.childCount, 0xFFFF));
    e.firstChild = b.firstChild;
    std::memcpy(&e.encoding, w.bytes.data() + offsetof(BlockHeader, encoding), 4);
    // Tree links are checked as a whole in finish() (treeValid); positions here, early.
    {
        std::vector<DirEntry> one = {e};
        one[0].childCount = 0;
        one[0].firstChild = kNoChild;
        one[0].level = std::uint16_t(b.level);
        if (b.level == 0 && !treeValid(w.header, one, why)) return fail(why);
    }
    if (!w.file.writeAt(w.bytes.data(), w.bytes.size(), w.offset, error)) return false;
    w.offset += w.bytes.size();
    w.dir.push_back(e);
    return true;
}

bool Writer::finish(std::string& error) {
    Impl& w = *impl_;
    assert(w.open && "Writer::open() first");
    auto fail = [&](const std::string& what) {
        error = w.path + ": " + what;
        return false;
    };
    if (w.dir.size() != w.blockCount) {
        return fail(std::to_string(w.dir.size()) + " blocks written, " +
                    std::to_string(w.blockCount) + " announced");
    }
    const Header& header = w.header;
    const std::uint64_t expectedStart =
        sizeof(FileHeader) + alignUp(header.crsWkt.size()) + alignUp(header.buildInfo.size()) +
        w.blockCount * sizeof(DirEntry) + sizeof(HeaderTrailer);
    if (expectedStart != w.dataStart) return fail("CRS WKT or build info changed size after open");
    std::string why;
    if (!metricsValid(header.metrics, header.defaultMetric, why)) return fail(why);
    // What Reader::open checks of the header and directory holds before anything is written.
    if (!headerValid(header, w.offset, why)) return fail(why);
    for (const DirEntry& e : w.dir) {
        const double box[6] = {e.minX, e.minY, e.minZ, e.maxX, e.maxY, e.maxZ};
        if (!directoryBoxValid(header, box, why))
            return fail(blockName(e.col, e.row, e.level) + ": " + why);
    }
    if (!treeValid(header, w.dir, why)) return fail(why);

    FileHeader fh{};
    std::memcpy(fh.magic, kMagic, sizeof(kMagic));
    fh.version = kVersion;
    fh.headerSize = sizeof(FileHeader);
    fh.originX = header.originX;
    fh.originY = header.originY;
    fh.minX = header.minX;
    fh.minY = header.minY;
    fh.minZ = header.minZ;
    fh.maxX = header.maxX;
    fh.maxY = header.maxY;
    fh.maxZ = header.maxZ;
    fh.blockWidth = header.blockWidth;
    fh.blockHeight = header.blockHeight;
    fh.blocksX = header.blocksX;
    fh.blocksY = header.blocksY;
    fh.metrics = header.metrics;
    fh.defaultMetric = header.defaultMetric;
    fh.blockCount = static_cast<std::uint32_t>(w.blockCount);
    fh.crsWktSize = static_cast<std::uint32_t>(header.crsWkt.size());
    fh.buildInfoSize = static_cast<std::uint32_t>(header.buildInfo.size());
    fh.fileSize = w.offset;
    fh.zQuantum = header.zQuantum;

    std::vector<unsigned char> bytes;
    appendPadded(bytes, &fh, sizeof(fh));
    appendPadded(bytes, header.crsWkt.data(), header.crsWkt.size());
    appendPadded(bytes, header.buildInfo.data(), header.buildInfo.size());
    appendPadded(bytes, w.dir.data(), w.dir.size() * sizeof(DirEntry));
    HeaderTrailer trailer{crc32Of(bytes.data(), bytes.size()), 0};
    appendPadded(bytes, &trailer, sizeof(trailer));
    assert(bytes.size() == w.dataStart);
    if (!w.file.writeAt(bytes.data(), bytes.size(), 0, error)) return false;
    // fsync, close and the move into place: AtomicFile (no replacing unless asked to).
    if (!w.file.commit(error)) return false;
    w.open = false;
    return true;
}

bool writeUlod(const std::string& path, const Header& header, const std::vector<Block>& blocks,
               std::string& error) {
    Writer writer;
    if (!writer.open(path, header, blocks.size(), OutputOptions{.replace = true, .inputs = {}},
                     error)) {
        return false;
    }
    for (const Block& b : blocks) {
        if (!writer.writeBlock(b, error)) return false;
    }
    return writer.finish(error);
}

// ---- reader -----------------------------------------------------------------------------------

struct Reader::Impl {
    std::string path;
    int fd = -1;
    Header header;
    std::vector<BlockInfo> blocks;

    ~Impl() {
        if (fd >= 0) ::close(fd);
    }
};

Reader::Reader() : impl_(std::make_unique<Impl>()) {}
Reader::~Reader() = default;

const Header& Reader::header() const {
    assert(impl_->fd >= 0 && "Reader::open() first");
    return impl_->header;
}

const std::vector<BlockInfo>& Reader::blocks() const {
    assert(impl_->fd >= 0 && "Reader::open() first");
    return impl_->blocks;
}

const std::string& Reader::path() const {
    return impl_->path;
}

bool Reader::open(const std::string& path, std::string& error) {
    impl_ = std::make_unique<Impl>();  // a failed open leaves a closed reader
    auto fail = [&](const std::string& what) {
        error = path + ": " + what;
        impl_ = std::make_unique<Impl>();
        return false;
    };

    // Before open(): a FIFO would block it forever.
    if (std::string why; !checkInputFile(path, false, why)) return fail(why);
    Impl& r = *impl_;
    r.path = path;
    r.fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
    if (r.fd < 0) return fail("cannot open: " + errnoText());
    struct stat st {};
    if (::fstat(r.fd, &st) != 0) return fail("cannot stat: " + errnoText());
    if (!S_ISREG(st.st_mode)) return fail("not a regular file");
    const auto actualSize = static_cast<std::uint64_t>(st.st_size);

    FileHeader fh{};
    if (actualSize < sizeof(kMagic)) {
        return fail("not a .ulod file (" + std::to_string(actualSize) + " bytes)");
    }
    if (!preadAll(r.fd, &fh, std::min<std::uint64_t>(actualSize, sizeof(fh)), 0)) {
        return fail("read failed: " + errnoText());
    }
    if (std::memcmp(fh.magic, kMagic, sizeof(kMagic)) != 0) return fail("not a .ulod file");
    if (actualSize < offsetof(FileHeader, fileSize)) {
        return fail("truncated (" + std::to_string(actualSize) + " bytes, shorter than a header)");
    }
    if (fh.version != kVersion) {
        return fail("unsupported .ulod version " + std::to_string(fh.version) +
                    " (this build reads " + std::to_string(kVersion) + ")");
    }
    if (fh.headerSize != sizeof(FileHeader)) {
        return fail("header size " + std::to_string(fh.headerSize) + ", version " +
                    std::to_string(kVersion) + " has " + std::to_string(sizeof(FileHeader)));
    }
    if (actualSize < sizeof(FileHeader)) {
        return fail("truncated (" + std::to_string(actualSize) + " bytes, shorter than a header)");
    }
    if (actualSize < fh.fileSize) {
        return fail("truncated (" + std::to_string(actualSize) + " bytes, header records " +
                    std::to_string(fh.fileSize) + ")");
    }
    if (actualSize > fh.fileSize) {
        return fail("trailing bytes (" + std::to_string(actualSize) + " bytes, header records " +
                    std::to_string(fh.fileSize) + ")");
    }

    // Header region size from 32-bit counts: cannot overflow 64 bits; checked against the file
    // size before it is allocated.
    const std::uint64_t wktAt = sizeof(FileHeader);
    const std::uint64_t buildAt = wktAt + alignUp(fh.crsWktSize);
    const std::uint64_t dirAt = buildAt + alignUp(fh.buildInfoSize);
    const std::uint64_t trailerAt = dirAt + std::uint64_t(fh.blockCount) * sizeof(DirEntry);
    const std::uint64_t dataStart = trailerAt + sizeof(HeaderTrailer);
    if (dataStart > actualSize) {
        return fail("header region (" + std::to_string(dataStart) + " bytes) exceeds the file (" +
                    std::to_string(actualSize) + " bytes)");
    }
    std::vector<unsigned char> head(dataStart);
    if (!preadAll(r.fd, head.data(), head.size(), 0)) return fail("read failed: " + errnoText());
    HeaderTrailer trailer;
    std::memcpy(&trailer, head.data() + trailerAt, sizeof(trailer));
    const std::uint32_t crc = crc32Of(head.data(), trailerAt);
    if (crc != trailer.crc) return fail("header checksum mismatch");
    if (fh.reserved != 0 || trailer.reserved != 0) return fail("reserved header field not 0");
    std::string why;
    if (!metricsValid(fh.metrics, fh.defaultMetric, why)) return fail(why);

    Header& h = r.header;
    h.crsWkt.assign(reinterpret_cast<const char*>(head.data() + wktAt), fh.crsWktSize);
    h.buildInfo.assign(reinterpret_cast<const char*>(head.data() + buildAt), fh.buildInfoSize);
    h.originX = fh.originX;
    h.originY = fh.originY;
    h.minX = fh.minX;
    h.minY = fh.minY;
    h.minZ = fh.minZ;
    h.maxX = fh.maxX;
    h.maxY = fh.maxY;
    h.maxZ = fh.maxZ;
    h.blocksX = fh.blocksX;
    h.blocksY = fh.blocksY;
    h.blockWidth = fh.blockWidth;
    h.blockHeight = fh.blockHeight;
    h.metrics = fh.metrics;
    h.defaultMetric = fh.defaultMetric;
    h.zQuantum = fh.zQuantum;
    if (!headerValid(h, actualSize, why)) return fail(why);

    r.blocks.resize(fh.blockCount);
    std::vector<DirEntry> dir(fh.blockCount);
    if (fh.blockCount > 0)
        std::memcpy(dir.data(), head.data() + dirAt, dir.size() * sizeof(DirEntry));
    if (!treeValid(h, dir, why)) return fail(why);
    std::vector<std::pair<std::uint64_t, std::uint64_t>> ranges;  // (offset, size) per block
    ranges.reserve(fh.blockCount);
    for (std::uint32_t i = 0; i < fh.blockCount; ++i) {
        const DirEntry& e = dir[i];
        const std::string name = "directory entry " + std::to_string(i) + " (" +
                                 blockName(e.col, e.row, e.level) + ")";
        if (e.encoding > std::uint32_t(BlockEncoding::kCompact))
            return fail(name + ": unknown block encoding " + std::to_string(e.encoding));
        // Overflow-safe: offset <= actualSize is checked before actualSize - offset.
        if (e.offset < dataStart || e.offset % kAlign != 0 || e.offset > actualSize ||
            e.size > actualSize - e.offset || e.size < sizeof(BlockHeader)) {
            return fail(name + ": byte range [" + std::to_string(e.offset) + ", +" +
                        std::to_string(e.size) + ") is out of bounds");
        }
        const double box[6] = {e.minX, e.minY, e.minZ, e.maxX, e.maxY, e.maxZ};
        if (!directoryBoxValid(h, box, why)) return fail(name + ": " + why);
        ranges.emplace_back(e.offset, e.size);
        BlockInfo& info = r.blocks[i];
        info.col = e.col;
        info.row = e.row;
        info.minX = e.minX;
        info.minY = e.minY;
        info.minZ = e.minZ;
        info.maxX = e.maxX;
        info.maxY = e.maxY;
        info.maxZ = e.maxZ;
        info.offset = e.offset;
        info.size = e.size;
        info.checksum = e.checksum;
        info.vertexCount = e.vertexCount;
        info.stepCount = e.stepCount;
        info.levelCount = e.levelCount;
        info.fullTriangles = e.fullTriangles;
        info.encoding = e.encoding;
        info.level = e.level;
        info.firstChild = e.firstChild;
        info.childCount = e.childCount;
    }
    std::sort(ranges.begin(), ranges.end());
    for (std::size_t i = 1; i < ranges.size(); ++i) {
        if (ranges[i].first < ranges[i - 1].first + ranges[i - 1].second) {
            return fail("directory: blocks at offsets " + std::to_string(ranges[i - 1].first) +
                        " and " + std::to_string(ranges[i].first) + " overlap");
        }
    }
    return true;
}

bool Reader::readBlock(std::size_t index, Block& block, std::string& error) const {
    assert(impl_->fd >= 0 && "Reader::open() first");
    assert(index < impl_->blocks.size());
    const Impl& r = *impl_;
    const BlockInfo& info = r.blocks[index];
    auto fail = [&](const std::string& what) {
        error = r.path + ": " + blockName(info.col, info.row, info.level) + ": " + what;
        return false;
    };

    // info.size was checked against the real file size at open: this allocation is bounded.
    std::vector<unsigned char> bytes(info.size);
    if (!preadAll(r.fd, bytes.data(), bytes.size(), info.offset)) {
        return fail("read failed: " + errnoText());
    }
    if (crc32Of(bytes.data(), bytes.size()) != info.checksum) return fail("checksum mismatch");

    if (info.size < sizeof(BlockHeader)) return fail("shorter than a block header");
    BlockHeader h;
    std::memcpy(&h, bytes.data(), sizeof(h));
    if (h.col != info.col || h.row != info.row) {
        return fail("block header says " + blockName(h.col, h.row, info.level));
    }
    if (h.encoding != info.encoding) return fail("encoding differs from the directory");
    if (h.encoding == std::uint32_t(BlockEncoding::kRaw) ? h.payloadSize != 0
                                                          : alignUp(sizeof(BlockHeader) +
                                                                    std::uint64_t(h.payloadSize)) !=
                                                                info.size) {
        return fail("payload size " + std::to_string(h.payloadSize) + " does not fit the block's " +
                    std::to_string(info.size) + " bytes");
    }
    // Counts are checked against the byte size before any array is allocated.
    const std::uint64_t expected = blockByteSize(h);
    if (h.encoding == std::uint32_t(BlockEncoding::kRaw) && expected != info.size) {
        return fail("its counts need " + std::to_string(expected) + " bytes, the directory gives " +
                    std::to_string(info.size));
    }
    if (h.encoding == std::uint32_t(BlockEncoding::kCompact) &&
        expected > kMaxExpansion * info.size + (1u << 20)) {
        return fail("its counts need " + std::to_string(expected) +
                    " bytes, more than a compact block of " + std::to_string(info.size) +
                    " bytes can hold");
    }
    if (h.vertexCount != info.vertexCount || h.stepCount != info.stepCount ||
        h.levelCount != info.levelCount) {
        return fail("vertex, step or level count differs from the directory");
    }

    Block b;
    b.col = h.col;
    b.row = h.row;
    b.level = info.level;
    b.firstChild = info.firstChild;
    b.childCount = info.childCount;
    b.originX = h.originX;
    b.originY = h.originY;
    b.minX = h.minX;
    b.minY = h.minY;
    b.minZ = h.minZ;
    b.maxX = h.maxX;
    b.maxY = h.maxY;
    b.maxZ = h.maxZ;
    if (h.encoding == std::uint32_t(BlockEncoding::kRaw)) {
        const std::uint32_t* counts = &h.vertexCount;
        std::uint64_t at = sizeof(BlockHeader);
        int i = 0;
        forEachArray(b, [&](auto& v) {
            const std::uint64_t n = counts[i++];
            v.resize(n);
            const std::uint64_t size = n * sizeof(v[0]);
            if (size > 0) std::memcpy(v.data(), bytes.data() + at, size);  // data() may be null
            at += alignUp(size);
        });
        assert(at == info.size);
    } else {
        for (std::size_t at = sizeof(BlockHeader) + h.payloadSize; at < bytes.size(); ++at)
            if (bytes[at] != 0) return fail("padding not 0");
        std::string why;
        if (!decodeCompact(bytes.data() + sizeof(BlockHeader), h.payloadSize, compactCounts(h),
                           r.header.zQuantum, b, why))
            return fail(why);
        BlockHeader back;
        fillBlockHeader(b, back);
        if (std::memcmp(&h.vertexCount, &back.vertexCount, kArrayCount * 4) != 0)
            return fail("compact data: decoded array sizes differ from the block header's counts");
    }

    const double dirBox[6] = {info.minX, info.minY, info.minZ, info.maxX, info.maxY, info.maxZ};
    const double blockBox[6] = {b.minX, b.minY, b.minZ, b.maxX, b.maxY, b.maxZ};
    if (std::memcmp(dirBox, blockBox, sizeof(dirBox)) != 0) {
        return fail("bounding box differs from the directory");
    }

    std::string why;
    if (!validateBlock(b, r.header.metrics, why)) {
        error = r.path + ": " + why;  // validateBlock already names the block
        return false;
    }
    if (b.levels[0].triangleCount != info.fullTriangles) {
        return fail("full-resolution triangle count differs from the directory");
    }
    block = std::move(b);
    return true;
}

bool Reader::readGeometry(std::size_t index, int level, BlockGeometry& geometry,
                          std::string& error) const {
    // The whole block, validated as readBlock does: its checksum covers every byte, and what the
    // engine relies on (ranges, indices, level geometry) is what validateBlock proves.
    Block b;
    if (!readBlock(index, b, error)) return false;
    if (level != kLevelsOnly && level != kAllLevels &&
        (level < 0 || std::size_t(level) >= b.levels.size())) {
        error =
            impl_->path + ": " + blockName(b.col, b.row, b.level) + ": no level " + std::to_string(level);
        return false;
    }
    BlockGeometry g;
    g.col = b.col;
    g.row = b.row;
    g.level = b.level;
    g.firstChild = b.firstChild;
    g.childCount = b.childCount;
    g.originX = b.originX;
    g.originY = b.originY;
    g.minX = b.minX, g.minY = b.minY, g.minZ = b.minZ;
    g.maxX = b.maxX, g.maxY = b.maxY, g.maxZ = b.maxZ;
    g.levels = b.levels;
    if (level == kAllLevels) {
        g.vertices = std::move(b.vertices);
        g.terrainIndices = std::move(b.terrainIndices);
        g.riverIndices = std::move(b.riverIndices);
    } else if (level != kLevelsOnly) {
        // One level: the vertex prefix it uses and its index ranges, rebased to 0.
        const Level& l = b.levels[std::size_t(level)];
        g.vertices.assign(b.vertices.begin(), b.vertices.begin() + l.vertexCount);
        const auto tris = b.terrainIndices.begin() + l.triangleFirst;
        g.terrainIndices.assign(tris, tris + l.triangleCount);
        const auto edges = b.riverIndices.begin() + l.riverFirst;
        g.riverIndices.assign(edges, edges + l.riverCount);
    }
    geometry = std::move(g);
    return true;
}

std::size_t storedLevelFor(const std::vector<Level>& levels, std::uint32_t metric, double hLim) {
    assert(!levels.empty());
    std::size_t chosen = 0;
    for (std::size_t i = 0; i < levels.size(); ++i) {
        const double e = metric == kMetricPaper ? levels[i].errorPaper : levels[i].errorMax;
        if (e <= hLim) chosen = i;  // errors are non-decreasing with the step
    }
    return chosen;
}

std::string blockName(std::uint32_t col, std::uint32_t row, std::uint32_t level) {
    if (level > 0) {
        return "node (" + std::to_string(col) + "," + std::to_string(row) + ") of tree level " +
               std::to_string(level);
    }
    return "block (" + std::to_string(col) + "," + std::to_string(row) + ")";
}

}  // namespace unilod::format
