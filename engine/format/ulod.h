// The .ulod file (version kVersion): one unified LOD model (terrain + rivers) in blocks. Plain structs,
// no Vulkan, no GDAL: the engine streams it, preprocess writes it. Byte layout: README.md beside
// this file. Little-endian; every on-disk struct has a fixed size (static_assert below).
#pragma once

#include <cmath>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "atomicfile.h"

namespace unilod::format {

inline constexpr char kMagic[8] = {'U', 'L', 'O', 'D', '\r', '\n', '\x1a', '\n'};
// Version 2 (issue 18): the directory holds the block hierarchy's tree links. Version 3 (issue
// 19): blocks are stored compactly (blockcodec.h) or raw, the header states the z quantum.
// Version 4 (issue 15): the `max` error's river part is stored beside it (Block::errorRiver,
// Level::errorRiver), so the engine bounds vertical errors with the sin(phi) factor and river
// displacements without it. Version 5 (issue 18, "the directory lets the engine cull and
// schedule nodes without reading them"): the directory entry carries the block's origin and
// whether its outline may move, and a level table at the end of the file holds every entry's
// stored levels, so that opening a model reads the header, the directory, the level table and
// the roots only (a 64M-point model read and decoded all 1 324 entries at open: 50 s).
inline constexpr std::uint32_t kVersion = 5;

// The height quantum of built models (Header::zQuantum): 1/128 m. A binary fraction, so k / 128
// is exact in a double and, for |z| < 131 km, in the float a vertex stores.
inline constexpr double kDefaultZQuantum = 1.0 / 128;

// Tree links (issue 18's block hierarchy, preprocess/nodebuild.h): no child.
inline constexpr std::uint32_t kNoChild = ~0u;
// Tree levels above the leaves a file may hold (a 2^24-block grid side needs 24).
inline constexpr std::uint32_t kMaxTreeLevel = 31;

// Metrics present (bit mask) and the default one.
enum Metric : std::uint32_t { kMetricMax = 1, kMetricPaper = 2 };

// "max" or "paper" (the option value, the JSON and the messages).
const char* metricName(std::uint32_t metric);
// The metric of a name: kMetricMax, kMetricPaper, 0 for "" (the file's default); false for
// anything else.
bool metricOfName(const std::string& name, std::uint32_t& metric);
struct Header;
// The metric a reader of the file `path` uses: `requested`, or the file's default for 0. False
// with "PATH: the file has no 'paper' error metric" when the file does not store it (or
// `requested` is no metric). One rule for the engine, stats, export and report.
bool resolveMetric(const Header& header, const std::string& path, std::uint32_t requested,
                   std::uint32_t& metric, std::string& error);

// Vertex flags.
inline constexpr std::uint32_t kVertexRiver = 1;   // a river point
inline constexpr std::uint32_t kVertexLocked = 2;  // never deleted (border, river end, junction)

struct Vertex {
    float x, y, z;  // x, y relative to the block origin, z absolute (metres, working CRS)
    std::uint32_t flags;
};
static_assert(sizeof(Vertex) == 16);

// Exact position of a vertex on the block's fixed grid: units of kGridUnit metres relative to the
// block origin. The constrained Delaunay triangulation was computed on these integers, so
// `unilod check` re-runs every predicate exactly.
inline constexpr double kGridUnit = 1e-3;
struct GridXY {
    std::int32_t x, y;
};
static_assert(sizeof(GridXY) == 8);

struct Triangle {
    std::uint32_t a, b, c;  // vertex indices (retention order), counter-clockwise
};
static_assert(sizeof(Triangle) == 12);

struct Edge {
    std::uint32_t a, b;  // vertex indices, a < b
};
static_assert(sizeof(Edge) == 8);

// One deletion step (paper §3.3): the vertex removed and what is alive after it.
struct Step {
    std::uint32_t vertex;
    std::uint32_t trianglesAlive;
    std::uint32_t riverEdgesAlive;
};
static_assert(sizeof(Step) == 12);

// A stored level: the triangulation after `step` deletions. The engine draws
// terrainIndices[triangleFirst, triangleFirst + triangleCount) and
// riverIndices[riverFirst, riverFirst + riverCount); every index is < vertexCount.
struct Level {
    std::uint32_t step;
    std::uint32_t vertexCount;
    std::uint32_t triangleFirst, triangleCount;
    std::uint32_t riverFirst, riverCount;
    float errorMax, errorPaper;  // model error at this level (metres)
    float errorRiver;            // the river part of errorMax (Block::errorRiver)
};
static_assert(sizeof(Level) == 36);

struct Block {
    std::uint32_t col = 0, row = 0;  // position in its tree level's grid
    // Tree level (0: a leaf, a block of the block grid; L: a node covering the 2^L x 2^L blocks
    // from (col * 2^L, row * 2^L) on) and children: the childCount directory entries from
    // firstChild on (kNoChild, 0 for a leaf). Held in the directory (BlockInfo), not in the block
    // bytes; Reader::readBlock fills them in.
    std::uint32_t level = 0, firstChild = kNoChild, childCount = 0;
    double originX = 0, originY = 0;  // vertex x, y are relative to this
    double minX = 0, minY = 0, minZ = 0, maxX = 0, maxY = 0, maxZ = 0;  // bounding box

    // Retention order: vertex i is deleted after vertex i + 1, so the vertices alive after step
    // k are the prefix [0, vertices.size() - k); locked and never-deleted vertices come first.
    std::vector<Vertex> vertices;

    // Topology-change records: step s removes removedTriangles[removedTriangleOffset[s],
    // removedTriangleOffset[s + 1]) etc. Offsets have steps.size() + 1 entries starting at 0.
    std::vector<Step> steps;
    std::vector<std::uint32_t> removedTriangleOffset, addedTriangleOffset;
    std::vector<std::uint32_t> removedEdgeOffset, addedEdgeOffset;
    std::vector<Triangle> removedTriangles, addedTriangles;
    std::vector<Edge> removedEdges, addedEdges;

    // Model error after each step, index 0 = full resolution (steps.size() + 1 entries each),
    // non-decreasing. A metric not present in the file has an empty array.
    std::vector<float> errorMax, errorPaper;
    // The river part of errorMax (present with it, same size, each entry <= errorMax's,
    // non-decreasing): the running maximum of the river deviations alone (preprocess/deletion.h:
    // the 3D distance from original river vertices to the drawn river edge, and the planimetric
    // deviation of the domain's outline). errorMax = max(vertical part, errorRiver), so a
    // vertical error is bounded by errorMax and a horizontal displacement by errorRiver: the
    // engine scales only the first by sin(phi) (engine/lod/lod.h).
    std::vector<float> errorRiver;

    // LOD index data: levels ascending in step, levels[0].step == 0 (full resolution).
    std::vector<Level> levels;
    std::vector<Triangle> terrainIndices;
    std::vector<Edge> riverIndices;

    // One per vertex (same order), or empty.
    std::vector<GridXY> grid;
};

struct Header {
    std::string crsWkt;                 // working CRS (may be empty: no CRS)
    double originX = 0, originY = 0;    // world origin: the DEM's cell (0, 0) centre
    double minX = 0, minY = 0, minZ = 0, maxX = 0, maxY = 0, maxZ = 0;  // extents and z range
    std::uint32_t blocksX = 0, blocksY = 0;  // block grid
    double blockWidth = 0, blockHeight = 0;  // block size in metres
    std::uint32_t metrics = kMetricMax | kMetricPaper;  // bit mask of Metric
    std::uint32_t defaultMetric = kMetricMax;
    std::string buildInfo;  // provenance as JSON text (command options, inputs, version)
    // Vertex heights are multiples of it (a compact block stores z / zQuantum); every stored
    // error already includes it. In (0, 1] metres.
    double zQuantum = kDefaultZQuantum;
};

// What the directory says about a block without reading it.
struct BlockInfo {
    std::uint32_t col = 0, row = 0;
    std::uint32_t level = 0, firstChild = kNoChild, childCount = 0;  // as in Block
    double minX = 0, minY = 0, minZ = 0, maxX = 0, maxY = 0, maxZ = 0;
    double originX = 0, originY = 0;  // as in Block
    // The block's stored levels (from the file's level table; Reader::readBlock checks that they
    // equal the block's own) and whether its outline may move between them (outlineMoves).
    std::vector<Level> levels;
    bool outlineMoves = false;
    std::uint64_t offset = 0, size = 0;  // byte range of the block in the file
    std::uint32_t checksum = 0;          // CRC-32 of those bytes
    std::uint32_t vertexCount = 0, stepCount = 0, levelCount = 0;
    std::uint32_t fullTriangles = 0;  // triangles at full resolution
    std::uint32_t encoding = 0;       // the block's encoding (blockcodec.h BlockEncoding)
};

// Tolerances of the geometric checks (README.md "What the reader validates"). A vertex stores
// float x, y relative to the block origin and a float z; the block's bounding box holds the
// double coordinates they were rounded from, so a float coordinate c may lie |c|·2^-24 outside
// it. The reader allows kFloatSlack·|c| + kAbsoluteSlack (4 times the rounding, plus 1 µm for the
// double sum origin + x). The grid position of a vertex is its position rounded to kGridUnit:
// float and grid agree within kGridUnit (twice the rounding) + kFloatSlack·|c|.
inline constexpr double kFloatSlack = 0x1p-22;
inline constexpr double kAbsoluteSlack = 1e-6;

// How messages name a directory entry: "block (c,r)" for a leaf, "node (c,r) of tree level L"
// above the leaves.
std::string blockName(std::uint32_t col, std::uint32_t row, std::uint32_t level = 0);

// "PATH: ERROR", unless ERROR already names the file first (the Reader's messages do; a
// validation's message does not).
inline std::string errorForFile(const std::string& path, const std::string& error) {
    if (error.compare(0, path.size() + 1, path + ":") == 0) return error;
    return path + ": " + error;
}

// Whether a block's outline (preprocess/cdt.h "Domain") may move between its levels: unless the
// coarsest level's outline is the block's bounding rectangle. The greedy order deletes an outline
// vertex only where no other changes sides (preprocess/deletion.h), and a deleted vertex never
// returns, so a rectangle at the coarsest level means only straight stretches of it were
// simplified (no displacement) at every level. The directory stores the answer (BlockInfo); the
// writer computes it and the reader checks it against the block (whose vertices and index
// ranges it trusts: call it on a validated block).
bool outlineMoves(const Block& block);

// The checks of a block's stored levels that need only the levels and the directory's counts
// (Reader::open runs them on the level table before anything is read or drawn): levels[0] is step
// 0 with `fullTriangles` triangles, steps strictly ascending and <= stepCount, vertexCount =
// vertices - step, errors of the metrics present finite, >= 0 and non-decreasing. validateBlock
// proves the rest once the block is read.
bool validateLevelTable(const std::vector<Level>& levels, std::uint32_t vertexCount,
                        std::uint32_t stepCount, std::uint32_t fullTriangles,
                        std::uint32_t metrics, std::string& error);

// Validation of one block: the one definition of a block every reader path trusts (writeUlod and
// Writer::writeBlock, Reader::readBlock, hence readGeometry, `unilod check`, export, capture,
// bench, view). Structure: finite bounding box and origin (the origin inside the box), every
// vertex finite and inside the box (tolerance above) and, with a grid, its grid position inside
// kMaxGridCoordinate and within tolerance of the float one; every vertex index in range, offsets
// monotone and matching their arrays, step and error counts consistent, errors finite and
// non-decreasing, levels ascending with ranges inside the index arrays; then every stored
// level's geometry (validateLevelGeometry). Returns false with a message naming the block.
bool validateBlock(const Block& block, std::uint32_t metrics, std::string& error);

// The geometry of stored level `level` as the engine draws it, on an otherwise structurally
// checked block (validateBlock calls it for every level; it re-checks what it reads, so it is
// safe on any block): each index below the level's vertexCount; each triangle has three distinct
// vertices and, when the block stores grid positions, is strictly counter-clockwise on them
// (exact orient2d, predicates.h); no directed edge is used twice, i.e. an undirected edge is
// shared by at most two triangles and with opposite orientations (this rejects duplicated and
// flipped triangles even without a grid); river edges have a < b, are unique and are edges of the
// level's triangles. O(t log t) for t triangles. The message names the level, not the block.
bool validateLevelGeometry(const Block& block, std::size_t level, std::string& error);

// The stored level drawn for a model-error tolerance hLim (paper Eq. 11's h_lim): the level with
// the largest step whose own stored error (errorMax / errorPaper by `metric`) is <= hLim and,
// for the `max` metric, whose river part errorRiver is <= hRiver (the tolerance of horizontal
// displacements; infinity: errorMax alone, which bounds both parts), or level 0 (full
// resolution) when none is. Stored errors are non-decreasing with the step, so this is the
// coarsest qualifying level. The one place this rule lives: the engine (engine/lod/lod.h
// chooseStoredLevel) and `unilod stats --error` both call it. `levels` non-empty.
bool levelFits(const Level& level, std::uint32_t metric, double hLim, double hRiver);
std::size_t storedLevelFor(const std::vector<Level>& levels, std::uint32_t metric, double hLim,
                           double hRiver = INFINITY);

// Writes header + blocks to `path` atomically (AtomicFile: temporary file in the same folder,
// fsync, rename), replacing an existing file. Blocks are written in the given order. Returns false
// with `error` naming the file on failure; no partial file is left.
bool writeUlod(const std::string& path, const Header& header, const std::vector<Block>& blocks,
               std::string& error);

// The same, streamed: open() with the number of blocks and the output rules (`output`: replace
// an existing file or not, the command's inputs that `path` must not be: atomicfile.h),
// writeBlock() each block (any grid position, each once; the directory keeps the write order),
// finish() to write the header and move the file into place (without `output.replace`, a file
// that appeared at `path` meanwhile makes finish() fail and stays). The header's extents may be changed through header() before
// finish(), its CRS WKT and build info may not change size. Destroying an unfinished Writer
// removes its temporary file; nothing is ever left at `path` on failure.
class Writer {
public:
    Writer();
    ~Writer();
    Writer(const Writer&) = delete;
    Writer& operator=(const Writer&) = delete;

    bool open(const std::string& path, const Header& header, std::size_t blockCount,
              const OutputOptions& output, std::string& error);
    // Blocks written after this are stored raw (plain arrays, README.md) instead of compactly;
    // for tests and tools that edit the bytes. A block that is not in canonical form is stored
    // raw anyway (blockcodec.h).
    void storeRaw(bool raw);
    bool writeBlock(const Block& block, std::string& error);
    Header& header();
    bool finish(std::string& error);

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

// Reads a .ulod file block by block (pread): open() validates magic, version, sizes, the header
// checksum, the header's values (finite, extents ordered, block size positive, grid bounded by
// the file size) and the directory (positions, byte ranges, boxes finite, ordered and inside the
// header's extents); readBlock() validates the block's checksum, its header against the
// directory and the block itself (validateBlock). README.md lists every check.
// What the engine streams of a block: its levels and LOD index data, without the topology
// records (a fraction of the block's bytes).
struct BlockGeometry {
    std::uint32_t col = 0, row = 0;
    std::uint32_t level = 0, firstChild = kNoChild, childCount = 0;  // as in Block
    double originX = 0, originY = 0;
    double minX = 0, minY = 0, minZ = 0, maxX = 0, maxY = 0, maxZ = 0;
    std::vector<Level> levels;  // every stored level, as in the file
    bool outlineMoves = false;  // as in BlockInfo
    // Read by readGeometry: all vertices and index data (level = kAllLevels), or only what one
    // level draws: the vertex prefix [0, vertexCount) and that level's index ranges, which then
    // start at 0 here.
    std::vector<Vertex> vertices;
    std::vector<Triangle> terrainIndices;
    std::vector<Edge> riverIndices;
};
inline constexpr int kLevelsOnly = -2, kAllLevels = -1;

class Reader {
public:
    Reader();
    ~Reader();
    Reader(const Reader&) = delete;
    Reader& operator=(const Reader&) = delete;

    bool open(const std::string& path, std::string& error);
    const Header& header() const;
    const std::vector<BlockInfo>& blocks() const;
    bool readBlock(std::size_t index, Block& block, std::string& error) const;
    // Reads a block's levels (kLevelsOnly), its whole LOD geometry (kAllLevels) or one level's
    // geometry (level index). The block is read and validated exactly as by readBlock (checksum,
    // directory, validateBlock: every level's geometry), whatever part is returned, so the engine
    // trusts what `unilod check` trusts; the cost is one read of the whole block. Thread-safe
    // (pread), like readBlock.
    bool readGeometry(std::size_t index, int level, BlockGeometry& geometry,
                      std::string& error) const;
    const std::string& path() const;

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

}  // namespace unilod::format
