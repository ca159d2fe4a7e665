// `unilod build`: DEM + river network -> one .ulod file (issue 4). The library half of the
// command, so that tests call runBuild(options) directly (STYLE.md: library plus thin main).
//
// Pipeline: ingestion (ingest.h: load the DEM and the rivers, check the data, fill small nodata
// holes, clean the rivers); partition into blocks with locked shared borders (blocks.h); per block,
// in parallel: importance order, constrained Delaunay, deletion sequence with records and model
// error, LOD index data (blockbuild.h); write the blocks in grid order, so the file is
// byte-identical for any thread count.
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "blockbuild.h"
#include "blocks.h"
#include "importance.h"
#include "ingest.h"
#include "nodebuild.h"
#include "ulod.h"

namespace unilod {

// The inputs and their ingestion options (DEM, rivers, band, CRS, layer, stride, river
// cleaning, warnings) are IngestOptions, shared with `order` and `report`.
struct BuildOptions : IngestOptions {
    std::string outPath;
    // DEM cells per block side, clamped to the DEM per direction (ingest.h splitIntoBlocks);
    // 0: automaticBlockSize (kDefaultBlockSize, or less where the exact grid needs it).
    int blockSize = 0;
    int threads = 0;  // 0: all cores (fewer where memory allows only fewer: BuildSummary::threads)
    DeletionOrderKind order = DeletionOrderKind::Greedy;  // --order greedy|3ddp
    bool useBai = true;
    std::string baiTablePath;  // empty: the paper's Table 1
    // Unset: the greedy order takes Table 1's C at each key's threshold (bai.h BaiKeys), the
    // 3ddp order the kDefaultBaiRow row; set (`--bai-row R`): row R for both.
    std::optional<double> baiRow;
    std::uint32_t defaultMetric = format::kMetricMax;
    // Which metrics the file records: `max` always (the bound the greedy order and the engine
    // use); `paper` (the paper's mean nearest-point error, Eq. 3-6) with the 3ddp order (the
    // paper's Tables 2 / 3), when it is the default metric, or when asked for here. It costs the
    // greedy build about 20 % of its time (a nearest-vertex update per deleted point).
    bool paperMetric = false;
    bool force = false;  // replace an existing output (--overwrite)
    // Build issue 18's block hierarchy (nodebuild.h) above the blocks: the greedy order without
    // the paper metric only (the paper's runs keep its flat block grid). --no-tree: blocks only.
    bool tree = true;
    // Tree hand-over (nodebuild.h nodeHandoffError): a block or node of tree level L stops before
    // a deletion costing more than its extent 2^L * block side (metres) / handoffPixels.
    // --handoff-pixels.
    double handoffPixels = kDefaultHandoffPixels;
    // Blocks stored as plain arrays (format::Writer::storeRaw) instead of the compact encoding:
    // about 35-40 times larger; for tools and tests that edit the bytes. --encoding raw.
    bool rawBlocks = false;
    // Memory check before the long work (checkMemory): refuse when the estimate exceeds
    // `memoryLimitBytes`, or, when that is 0, the memory this process can get (availableMemory);
    // `memoryCheck` false: no check (--no-memory-check). --memory-limit MB.
    bool memoryCheck = true;
    double memoryLimitBytes = 0;
    // At --stride > 1 a raster larger than the memory is held in a temporary file in this
    // folder while it is read, its lattice alone in memory (dem.h CellAllocator; deleted when
    // read, also if the build is killed). Empty: the output's folder. --temp-dir.
    std::string tempDir;
    // Progress: the stages before the blocks ("splitting into blocks"), then the stage of the
    // blocks with their count, then blocks (and tree nodes) built of total and `work`, the
    // estimated share of the stage's work done (0 to 1; itemWork): items weigh what they cost,
    // and the items in progress count by their deletion steps, so that a tree's last nodes,
    // which run alone, move the share while they run. Called at least every
    // `progressInterval` seconds while items are built, and once per item written. Both called
    // from the calling thread.
    std::function<void(const std::string& stage, std::size_t total)> stage;
    std::function<void(std::size_t done, std::size_t total, double work)> progress;
    double progressInterval = 0.5;
};

// Peak memory of a build, estimated before its long work (estimateBuildMemory; README "Large
// DEMs", fitted to peaks measured in MEASURED.md): a base, bytes per cell of the raster (every
// cell while it is read, with what GDAL holds then; the stride's lattice, nodata included, while
// the blocks are built: DemGrid::keepLattice since 2026-12-02), bytes
// per point of the whole model (the point data and, with the block hierarchy, the root's error
// against every original point), and the items built at the same time: the `threads` heaviest
// blocks and tree nodes of which none lies under another (a node waits for its children), at bytes
// per point of the item. A block's points are its DEM lattice points and river vertices; a node's
// the river vertices it keeps locked (piece ends, junctions) and its locked sides' lattice points,
// a lower bound of what it starts from. A river network denser than the DEM weighs through its
// blocks and nodes: 50 000 crossing lines over the demo DEM make a root of 444 000 locked vertices.
inline constexpr double kBuildBaseBytes = 64e6;  // libraries, GDAL's cache, thread stacks
// Per cell 5: the grid's 4 and GDAL's reading buffers (its block cache, capped while a
// reprojection warps; the warp's chunks). Until 2026-12-02 8, when GDAL's block cache kept the
// whole raster again as it was read (and a reprojected raster was warped into a copy first):
// peaks of rasters with few points per cell (--stride 8 on 12 000^2 cells, a corridor clipped
// from 8 000^2) fell by a third, those of full rasters stayed; their per-point bytes took the 3
// (MEASURED.md, thirty-fourth session).
inline constexpr double kBuildBytesPerCell = 5;
// With the tree, per DEM point 19 (25 until 2026-12-01, when the root's error pool held 16 bytes
// for every original point, now 8 for one at a sampled DEM cell: modelerror.h SampleRef), per
// river point 30 (its 16 bytes kept whole, and an 8-byte reference to them).
inline constexpr double kTreeBuildBytesPerPoint = 19;
inline constexpr double kTreeBuildBytesPerRiverPoint = 30;
inline constexpr double kFlatBuildBytesPerPoint = 13;
inline constexpr double kInFlightBytesPerDemPoint = 950;
inline constexpr double kInFlightBytesPerRiverPoint = 1200;
inline constexpr double kInFlightBytesPerNodePoint = 1600;
// Small items: the items in flight take at least this much each (each thread's heap keeps
// what its items freed; a tree's upper nodes start from more than their locked points), and
// every block and node holds this much until the build ends (its result slots, its directory
// entry). Fitted to a 1M-point synthetic with 4- to 64-cell blocks (MEASURED.md, thirtieth
// session); with the default blocks the items in flight weigh more than the floor.
inline constexpr double kInFlightFloorBytes = 40e6;  // each item in flight, at least
inline constexpr double kBytesPerItem = 1500;
// Workers run at most this many items per thread ahead of the writer (build.cpp); the finished
// ones wait for it in file order: their results, at bytes per point of an average block.
inline constexpr std::size_t kWriterWindowPerThread = 4;
inline constexpr double kResultBytesPerPoint = 40;
// `unilod order` ranks the whole DEM as one point set (improved 3D_DP): 137 bytes per point over
// the base at 16M points (2.26 GB, 2026-11-30); the estimate takes a little less.
inline constexpr double kOrderBytesPerPoint = 130;

// A memory estimate (checkMemory): the points it counts and the bytes, base included.
struct MemoryEstimate {
    std::uint64_t demPoints = 0, riverPoints = 0;
    double bytes = 0;
    std::string basis;    // how it was reached, for the message ("130 bytes per point")
    std::string smaller;  // how to ask for less ("--stride 2 builds a quarter of the points")
};

// A block or tree node of a build for estimateBuildMemory: its points (a block: DEM lattice points
// and river vertices; a node: its locked sides' lattice points and its locked river vertices)
// and the range of leaves (file order) under it.
struct ItemLoad {
    bool node = false;
    std::uint64_t demPoints = 0, riverPoints = 0;
    std::size_t leafFirst = 0, leafCount = 1;
};

// The estimate of `build` (see the constants above): a raster of `cells` cells read, of which
// `heldCells` (the stride's lattice; all of them at stride 1) are held while the blocks are
// built, `demPoints` DEM points in the model, the blocks' and nodes' loads, `threads` workers,
// with or without the block hierarchy. The peak is the larger of reading (the raster's cells;
// `cellsOnDisk`: held in a temporary file, the memory holding the reading's buffers and the
// lattice) and building (the lattice, the points and the items in flight). `stride`: the build's
// --stride, for the advice (MemoryEstimate::smaller: twice it builds a quarter of the points).
MemoryEstimate estimateBuildMemory(std::uint64_t cells, std::uint64_t heldCells,
                                   std::uint64_t demPoints, const std::vector<ItemLoad>& items,
                                   unsigned threads, bool tree, bool cellsOnDisk = false,
                                   int stride = 1);

// The estimate of `order` at `stride`: kBuildBaseBytes + points * bytesPerPoint.
MemoryEstimate pointMemory(std::uint64_t demPoints, std::uint64_t riverPoints, double bytesPerPoint,
                           int stride);

// The folder of the temporary file that holds a raster larger than the memory while it is read
// at --stride > 1 (dem.h CellAllocator; build and order): `tempDir` (--temp-dir) when given,
// else the output's folder (the working folder without an output); none ("") under an
// address-space limit (`memoryWhat` from availableMemory), which counts the file's mapping
// against it like memory. checkTempDir: false and `error` when a given --temp-dir is no folder.
bool checkTempDir(const std::string& tempDir, std::string& error);
std::string spillFolder(const std::string& tempDir, const std::string& outPath,
                        const std::string& memoryWhat);

// Bytes this process can hold in all (Linux): what it holds (VmRSS) plus the smallest of the
// memory available to new allocations (/proc/meminfo MemAvailable + SwapFree), the cgroup's
// limit less its use (v2 memory.max / memory.current, v1 memory.limit_in_bytes / usage_in_bytes)
// and the address-space limit (RLIMIT_AS) less the address space in use: the estimates it is
// compared with are of the process's whole peak. 0 when none can be read. `what` receives which
// bound it is ("available memory", "the cgroup's memory limit", "the address-space limit").
std::uint64_t availableMemory(std::string* what = nullptr);

// The DEM points the blocks of `data` sample at `stride` (nodata cells that stay nodata hold
// none): what the memory estimates count.
std::uint64_t sampledDemPoints(const Ingested& data, int stride);

// What the memory checks compare with: `limitBytes` when > 0 (`what` = "--memory-limit"), else
// availableMemory(&what); 0 when none can be read.
double memoryBound(double limitBytes, std::string& what);

// The memory check of `build` and `order`, before their long work: true when the estimate fits
// `limitBytes` (0: availableMemory(); none readable: no check), else false with `error` naming
// the DEM, the estimate, the bound, how to ask for less and --no-memory-check. `doing`:
// "build", "rank ...".
bool checkMemory(const std::string& demPath, const MemoryEstimate& estimate, double limitBytes,
                 const char* doing, std::string& error);

struct BuildSummary {
    int demWidth = 0, demHeight = 0;
    std::string crsName;
    std::vector<std::string> demConversions;  // DemGrid::conversions: what reached metres
    std::size_t demPoints = 0, riverPoints = 0, lockedPoints = 0, riverLines = 0;
    int blockSize = 0;  // the block size used (cells; automatic or as given)
    std::size_t blocks = 0, steps = 0, kept = 0, deferrals = 0;
    // Tree nodes above the blocks, their levels, and the triangles of the roots' coarsest state
    // (the leaves' when there is no tree).
    std::size_t nodes = 0, treeLevels = 0, rootTriangles = 0;
    std::size_t fullTriangles = 0, coarsestTriangles = 0, indexTriangles = 0;
    std::size_t crossings = 0, droppedDemPoints = 0;
    std::size_t droppedCellVertices = 0;  // river vertices added beside them (blocks.h)
    double droppedDeviation = 0;          // the largest BlockBuildStats::droppedDeviation (metres)
    std::size_t nodataCells = 0, filledNodataCells = 0;  // nodata.h: holes and bays filled
    // Raster cells held while the blocks are built: the stride's lattice (DemGrid::keepLattice).
    std::uint64_t rasterCellsHeld = 0;
    std::uint64_t outputBytes = 0;
    double seconds = 0;
    double memoryEstimate = 0;  // bytes (estimateBuildMemory)
    // Worker threads used: BuildOptions::threads, or with 0 all cores, fewer where the memory
    // estimate with all of them exceeds the bound and with fewer does not (a warning says so).
    unsigned threads = 0;
    double peakMemory = 0;      // bytes: the process's peak resident memory (0: unknown)
    std::string cleaning;  // what river cleaning changed
};

// Returns false with `error` (naming the file and the problem) on bad input; then no output file
// exists (an existing one is untouched).
bool runBuild(const BuildOptions& options, BuildSummary& summary, std::string& error);

// The estimated cost of building an item, in units of a block's point (the progress share of
// BuildOptions::progress): a block costs its points (DEM and river); a tree node costs
// kNodeWorkPerOriginal per original point under it, since it locates every one of them in its
// triangles (measured 2026-12-01, MEASURED.md: a leaf 10-12.5 us a point, a node 0.9-2.3 us an
// original point on the bundled and a 4M-point model). An item in progress counts, once its
// first deletion step is done, its setup share (a node's: regenerating and locating its
// original points, about 30 % of its time on the 4M model) and then its deletion steps done of
// `expectedSteps` (a block: its points; a node: its starting vertices) over the steps' share;
// what follows the steps (the LOD index, encoding) completes it when it is built.
constexpr double kNodeWorkPerOriginal = 0.15;
constexpr double kBlockSetupShare = 0.1, kBlockStepsShare = 0.8;
constexpr double kNodeSetupShare = 0.3, kNodeStepsShare = 0.6;
double itemWork(bool node, std::uint64_t points);
double inProgressWork(bool node, double work, std::uint64_t steps, std::uint64_t expectedSteps);

// Whether a build with these options records the `paper` metric (BuildOptions::paperMetric).
bool recordsPaperMetric(const BuildOptions& options);

}  // namespace unilod
