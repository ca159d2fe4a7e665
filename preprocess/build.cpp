// `unilod build` pipeline (build.h).
#include "build.h"

#include <sys/resource.h>
#include <unistd.h>

#ifdef __GLIBC__
#include <malloc.h>
#endif

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <new>
#include <nlohmann/json.hpp>
#include <sstream>
#include <system_error>
#include <thread>

#include "blockbuild.h"
#include "jsontext.h"
#include "nodebuild.h"

namespace unilod {

namespace {

// How messages name the inputs: "DEM 'a.tif' + rivers 'b.shp'", or the DEM alone.
std::string inputsName(const BuildOptions& o) {
    return "DEM '" + o.demPath + "'" +
           (o.riversPath.empty() ? "" : " + rivers '" + o.riversPath + "'");
}

// The output rules: replace only with --overwrite, and never one of the inputs (also with
// --overwrite: `build dem.tif rivers.geojson -o dem.tif --overwrite` must not destroy the DEM,
// nor `-o rivers.dbf` the Shapefile's table: every file of the inputs, ingest.h addInputFiles).
format::OutputOptions outputOptions(const BuildOptions& o) {
    format::OutputOptions out;
    out.replace = o.force;
    addInputFiles(out, o.demPath, o.riversPath);
    if (!o.baiTablePath.empty()) out.inputs.push_back(o.baiTablePath);
    return out;
}

// What availableMemory names a ulimit -v bound (RLIMIT_AS).
constexpr const char* kAddressSpaceLimit = "the address-space limit";

// What a failed allocation reports (std::bad_alloc: a memory limit such as ulimit -v; without one
// Linux's OOM killer ends the process instead, hence the estimate before the work, build.h).
const std::string outOfMemory =
    "out of memory (the build needs more memory than this process may use; README \"Large "
    "DEMs\")";

// Hands the memory the allocator keeps free (in every thread's arena) back to the system; a no-op
// off glibc. Called before a node that starts large and by RetentionGuard.
void releaseFreeMemory() {
#ifdef __GLIBC__
    malloc_trim(0);
#endif
}

// The memory the allocator keeps after the items free it, handed back to the system whenever the
// process outgrows kRetentionShare of the build's estimate: glibc keeps freed memory in each
// thread's heap (up to twice its mmap threshold, which rises to the largest buffer freed, 32 MB),
// so that with many small items the resident size was about twice the live heap (1M points,
// 64-cell blocks: 0.21 GB resident, 84 MB heap; MEASURED.md, twenty-ninth and thirtieth
// sessions). Checked at most every kInterval after an item, by the first thread to finish one.
constexpr double kRetentionShare = 0.8;
class RetentionGuard {
public:
    static constexpr std::chrono::milliseconds kInterval{250};
    explicit RetentionGuard(double limitBytes) : limit_(limitBytes) {}
    void afterItem() {
        std::unique_lock lock(mutex_, std::try_to_lock);
        if (!lock.owns_lock() || !(limit_ > 0)) return;
        const auto now = std::chrono::steady_clock::now();
        if (now - last_ < kInterval) return;
        last_ = now;
        if (residentBytes() > limit_) releaseFreeMemory();
    }

private:
    // Resident set size from /proc/self/statm (0 where unreadable).
    static double residentBytes() {
        std::FILE* f = std::fopen("/proc/self/statm", "r");
        if (f == nullptr) return 0;
        unsigned long long size = 0, resident = 0;
        const int got = std::fscanf(f, "%llu %llu", &size, &resident);
        std::fclose(f);
        return got == 2 ? double(resident) * double(sysconf(_SC_PAGESIZE)) : 0.0;
    }
    const double limit_;
    std::mutex mutex_;
    std::chrono::steady_clock::time_point last_{};
};

}  // namespace

double itemWork(bool node, std::uint64_t points) {
    return node ? kNodeWorkPerOriginal * double(points) : double(points);
}

double inProgressWork(bool node, double work, std::uint64_t steps, std::uint64_t expectedSteps) {
    if (expectedSteps == 0 || steps == 0) return 0;  // not started, or in its setup
    const double stepShare = std::min(1.0, double(steps) / double(expectedSteps));
    return work * (node ? kNodeSetupShare + kNodeStepsShare * stepShare
                        : kBlockSetupShare + kBlockStepsShare * stepShare);
}

bool recordsPaperMetric(const BuildOptions& o) {
    return o.paperMetric || o.order == DeletionOrderKind::ThreeDdp ||
           o.defaultMetric == format::kMetricPaper;
}

namespace {

bool buildModel(const BuildOptions& o, BuildSummary& summary, std::string& error) {
    const auto start = std::chrono::steady_clock::now();
    summary = {};
    // Fail fast, before the long work; the Writer checks again when it creates the file.
    if (o.outPath.empty()) {
        error = "no output file given (-o OUT.ulod)";
        return false;
    }
    const format::OutputOptions output = outputOptions(o);
    if (!format::checkOutputPath(o.outPath, output, false, error)) return false;
    if (o.threads < 0) {
        error = "--threads " + std::to_string(o.threads) + ": must be >= 0";
        return false;
    }
    if (!checkTempDir(o.tempDir, error)) return false;

    // BAI table before the long work, so that a typo fails fast.
    BlockBuildOptions blockOptions;
    blockOptions.order = o.order;
    blockOptions.paperError = recordsPaperMetric(o);
    blockOptions.importance.useBai = o.useBai;
    blockOptions.importance.baiRow = o.baiRow.value_or(kDefaultBaiRow);
    blockOptions.importance.baiByThreshold = o.order == DeletionOrderKind::Greedy && !o.baiRow;
    if (!o.baiTablePath.empty() &&
        !BaiTable::load(o.baiTablePath, blockOptions.importance.baiTable, error)) {
        return false;
    }
    if (o.useBai && !blockOptions.importance.baiByThreshold &&
        blockOptions.importance.baiTable.findRow(blockOptions.importance.baiRow) < 0) {
        error = "--bai-row " + jsonText(nlohmann::json(blockOptions.importance.baiRow)) +
                ": the BAI table" +
                (o.baiTablePath.empty() ? std::string(" (the paper's Table 1)")
                                        : " '" + o.baiTablePath + "'") +
                " has no row for this threshold (metres)";
        return false;
    }

    Ingested data;
    IngestOptions in = o;
    if (o.stage) in.onStage = [&o](const std::string& name) { o.stage(name, 0); };
    if (o.memoryCheck) in.demMemoryBytes = memoryBound(o.memoryLimitBytes, in.demMemoryWhat);
    in.demThreads = o.threads;
    in.demBytesPerCell = kBuildBytesPerCell;
    in.demBaseBytes = kBuildBaseBytes;
    // A raster too large for the memory is read through a temporary file (dem.h CellAllocator).
    in.demSpillDir = spillFolder(o.tempDir, o.outPath, in.demMemoryWhat);
    if (!ingest(in, data, error)) return false;
    const DemGrid& dem = data.dem;
    summary.demWidth = dem.width;
    summary.demHeight = dem.height;
    summary.crsName = crsDisplayName(dem.wkt);
    summary.demConversions = dem.conversions;
    summary.cleaning = describe(data.cleaning);
    summary.riverLines = data.rivers.size();

    // The block size clamps to the DEM (splitIntoBlocks); the default one also to the exact grid.
    int blockSize = o.blockSize;
    if (!checkCellsFitExactGrid(dem, o.stride, error)) {
        error = "DEM '" + o.demPath + "': " + error;
        return false;
    }
    if (blockSize == 0) {
        blockSize = automaticBlockSize(dem, o.stride);
    } else if (!checkBlockFitsExactGrid(dem, o.stride, blockSize, error)) {
        return false;
    }
    summary.blockSize = blockSize;
    if (o.stage) o.stage("splitting into blocks", 0);
    BlockSource source;
    if (!splitIntoBlocks(data, o, blockSize, o.order == DeletionOrderKind::ThreeDdp, source, error))
        return false;
    // The river heights are sampled (BlockSource::init): from here on the blocks read the
    // stride's lattice only, so the cells between its points are handed back (a quarter of the
    // raster is held at --stride 2, a 64th at 8: README "Large DEMs").
    const bool cellsOnDisk = data.dem.cellsOnDisk();
    data.dem.keepLattice(o.stride);
    summary.rasterCellsHeld = data.dem.z.size();
    summary.nodataCells = data.nodata.nodataCells;
    summary.filledNodataCells = data.nodata.filledCells;
    // The block hierarchy: the greedy order without the paper metric (build.h BuildOptions::tree).
    const bool tree = o.tree && o.order == DeletionOrderKind::Greedy && !blockOptions.paperError;
    summary.crossings = source.stats().crossings;
    summary.droppedDemPoints = source.stats().droppedDemPoints;
    summary.droppedCellVertices = source.stats().droppedCellVertices;

    format::Header header;
    header.crsWkt = dem.wkt;
    header.originX = dem.centreX(0);
    header.originY = dem.centreY(0);
    header.minX = header.minY = header.minZ = HUGE_VAL;
    header.maxX = header.maxY = header.maxZ = -HUGE_VAL;
    header.blocksX = source.blocksX();
    header.blocksY = source.blocksY();
    // The extent of a whole block, block (0, 0): the block size rounded down to the stride and
    // clamped to the DEM (the last block of a row or column may be smaller).
    const BlockRect& first = source.rect(0);
    header.blockWidth = (first.cellCol1 - first.cellCol0) * std::fabs(dem.cellX);
    header.blockHeight = (first.cellRow1 - first.cellRow0) * std::fabs(dem.cellY);
    header.metrics = format::kMetricMax | (blockOptions.paperError ? format::kMetricPaper : 0u);
    header.defaultMetric = o.defaultMetric;
    // Provenance; nothing here may depend on the thread count or the clock.
    nlohmann::json info = {
        {"generator", "unilod build"},
        {"block_size", blockSize},
        {"order", deletionOrderName(o.order)},
        {"bai", o.useBai},
        // "threshold": the greedy order's C by threshold (bai.h BaiKeys).
        {"bai_row", blockOptions.importance.baiByThreshold
                        ? nlohmann::json("threshold")
                        : nlohmann::json(blockOptions.importance.baiRow)},
        {"bai_table", o.baiTablePath},
        {"lod_triangle_ratio", blockOptions.lodRatio},
        {"node_lod_triangle_ratio", kNodeLodTriangleRatio},
        {"grid_unit_m", format::kGridUnit},
        {"z_quantum_m", header.zQuantum},
        {"encoding", o.rawBlocks ? "raw" : "compact"},
    };
    recordIngestOptions(o, info);
    header.buildInfo = jsonText(info);

    // Blocks and tree nodes in parallel, written in file order by this thread as soon as each is
    // next in line, so the file does not depend on timing. File order: the blocks in Morton
    // order (so the blocks under any tree node are contiguous), then each tree level's nodes in
    // Morton order (so every node's children are contiguous), the root last. Workers run at most
    // `window` items ahead of the writer: memory holds a few items' results and the coarsest
    // states of the items whose parent is not built yet, never the whole model. Block costs vary
    // a lot (rivers, relief), so a short window stalls the workers behind one slow block:
    // 16M-point synthetic build, 2 threads, 204 s with 2 blocks per thread, 158 s with 4 (peak
    // RSS 467 -> 554 MB).
    // Blocks without any of the domain (all nodata) are left out of the model (splitIntoBlocks
    // refuses a DEM without any).
    struct Item {
        std::uint32_t level = 0, col = 0, row = 0;
        std::size_t source = 0;  // a leaf: its BlockSource index
        std::uint32_t firstChild = format::kNoChild, childCount = 0;
        std::size_t leafFirst = 0, leafCount = 1;  // the leaves under it (file order)
        std::uint32_t parent = format::kNoChild;
    };
    std::vector<Item> items;
    for (std::size_t i = 0; i < source.blockCount(); ++i) {
        if (!source.hasDomain(i)) continue;
        Item it;
        it.col = source.rect(i).col;
        it.row = source.rect(i).row;
        it.source = i;
        items.push_back(it);
    }
    auto morton = [](std::uint32_t x, std::uint32_t y) {
        std::uint64_t m = 0;
        for (int b = 0; b < 32; ++b)
            m |= (std::uint64_t(x >> b & 1u) << (2 * b)) |
                 (std::uint64_t(y >> b & 1u) << (2 * b + 1));
        return m;
    };
    std::sort(items.begin(), items.end(), [&](const Item& a, const Item& b) {
        return morton(a.col, a.row) < morton(b.col, b.row);
    });
    for (std::size_t i = 0; i < items.size(); ++i)
        items[i].leafFirst = i;
    const std::size_t leafCount = items.size();
    // The tree (nodebuild.h): levels above the leaves until one root. The exact grid of a node
    // spans at most 2 * (2^28 - 1) grid units (cdt.h): a level whose nodes would be wider is not
    // built, and its children are the roots.
    const double gridLimit = 2.0 * double((1 << 28) - 1) * format::kGridUnit;
    std::size_t levelFirst = 0, levelCount = items.size();
    std::uint32_t levels = 0;
    while (tree && levelCount > 1) {
        const std::uint32_t L = levels + 1;
        const double span = std::max(header.blockWidth, header.blockHeight) * double(1u << L);
        if (L > format::kMaxTreeLevel || span >= gridLimit) break;
        const std::size_t next = items.size();
        for (std::size_t i = levelFirst; i < levelFirst + levelCount; ++i) {
            const Item child = items[i];
            const bool fresh = items.size() == next || items.back().col != child.col / 2 ||
                               items.back().row != child.row / 2;
            if (fresh) {
                Item node;
                node.level = L;
                node.col = child.col / 2;
                node.row = child.row / 2;
                node.firstChild = std::uint32_t(i);
                node.childCount = 0;
                node.leafFirst = child.leafFirst;
                node.leafCount = 0;
                items.push_back(node);
            }
            items.back().childCount += 1;
            items.back().leafCount += child.leafCount;
            items[i].parent = std::uint32_t(items.size() - 1);
        }
        levelFirst = next;
        levelCount = items.size() - next;
        levels = L;
    }
    const std::size_t n = items.size();
    // The first and last block column and row of an item's rectangle of blocks.
    struct BlockRange {
        std::uint32_t c0, r0, c1, r1;
    };
    auto blockRange = [&](const Item& it) {
        return BlockRange{it.col << it.level, it.row << it.level,
                          std::min(source.blocksX(), (it.col + 1) << it.level) - 1,
                          std::min(source.blocksY(), (it.row + 1) << it.level) - 1};
    };
    // The first and last block of an item's rectangle of blocks (a leaf: itself twice).
    auto cornerRects = [&](const Item& it) {
        const BlockRange r = blockRange(it);
        return std::pair<const BlockRect&, const BlockRect&>(
            source.rect(std::size_t(r.r0) * source.blocksX() + r.c0),
            source.rect(std::size_t(r.r1) * source.blocksX() + r.c1));
    };
    // The node border lines (nodebuild.h): the outer border of its leaf rectangle, locked unless
    // it is the DEM's outer edge (leaves lock that only for the 3ddp order, which builds no tree).
    auto nodeBorder = [&](const Item& it) {
        const auto [c0, r0, c1, r1] = blockRange(it);
        const auto [lo, hi] = cornerRects(it);
        NodeBorder b;
        b.x0 = dem.centreX(lo.cellCol0);
        b.x1 = dem.centreX(hi.cellCol1);
        b.y0 = dem.centreY(lo.cellRow0);
        b.y1 = dem.centreY(hi.cellRow1);
        b.lockX0 = c0 != 0;
        b.lockY0 = r0 != 0;
        b.lockX1 = c1 + 1 != source.blocksX();
        b.lockY1 = r1 + 1 != source.blocksY();
        return b;
    };
    unsigned threads =
        o.threads > 0 ? unsigned(o.threads) : std::max(1u, std::thread::hardware_concurrency());
    // Each item's estimated cost (itemWork), for the progress share.
    std::vector<double> itemCost(n);
    double totalWork = 0;
    {
        // The memory estimate (build.h), before the long work.
        const std::vector<BlockLoad> loads = source.loads();
        for (std::size_t i = 0; i < n; ++i) {
            std::uint64_t points = 0;
            for (std::size_t k = items[i].leafFirst; k < items[i].leafFirst + items[i].leafCount;
                 ++k)
                points += loads[items[k].source].demPoints + loads[items[k].source].riverPoints;
            itemCost[i] = itemWork(items[i].level > 0, points);
            totalWork += itemCost[i];
        }
        std::vector<ItemLoad> itemLoads(n);
        for (std::size_t i = 0; i < n; ++i) {
            const Item& it = items[i];
            ItemLoad& l = itemLoads[i];
            l.leafFirst = it.leafFirst;
            l.leafCount = it.leafCount;
            if (it.level == 0) {
                l.demPoints = loads[it.source].demPoints;
                l.riverPoints = loads[it.source].riverPoints;
                continue;
            }
            l.node = true;
            for (std::size_t k = it.leafFirst; k < it.leafFirst + it.leafCount; ++k)
                l.riverPoints += loads[items[k].source].lockedRiverPoints;
            const auto [lo, hi] = cornerRects(it);
            const NodeBorder b = nodeBorder(it);
            l.demPoints =
                std::uint64_t(b.lockX0 + b.lockX1) * ((hi.cellRow1 - lo.cellRow0) / o.stride) +
                std::uint64_t(b.lockY0 + b.lockY1) * ((hi.cellCol1 - lo.cellCol0) / o.stride);
        }
        const std::uint64_t cells = std::uint64_t(dem.width) * std::uint64_t(dem.height);
        const std::uint64_t held = std::uint64_t((dem.width - 1) / o.stride + 1) *
                                   std::uint64_t((dem.height - 1) / o.stride + 1);
        const std::uint64_t demPoints = sampledDemPoints(data, o.stride);
        MemoryEstimate estimate = estimateBuildMemory(cells, held, demPoints, itemLoads, threads,
                                                      tree, cellsOnDisk, o.stride);
        if (o.memoryCheck && o.threads == 0 && threads > 1) {
            // The thread count is ours to choose: fewer threads hold fewer blocks at a time.
            // The most that fit (halving, then one more at a time), else all and the refusal.
            std::string what;
            const double have = memoryBound(o.memoryLimitBytes, what);
            unsigned fit = threads;
            while (have > 0 && fit > 1 &&
                   estimateBuildMemory(cells, held, demPoints, itemLoads, fit, tree, cellsOnDisk,
                                       o.stride)
                           .bytes > have)
                fit = std::max(1u, fit / 2);
            while (fit < threads && estimateBuildMemory(cells, held, demPoints, itemLoads, fit + 1,
                                                        tree, cellsOnDisk, o.stride)
                                            .bytes <= have)
                ++fit;
            const MemoryEstimate fewer = estimateBuildMemory(cells, held, demPoints, itemLoads, fit,
                                                             tree, cellsOnDisk, o.stride);
            if (fit < threads && fewer.bytes <= have) {
                if (o.warn) {
                    char text[200];
                    std::snprintf(text, sizeof text,
                                  "%u of %u threads: with all of them the build would need about "
                                  "%.2f GB, more than %s allows (%.2f GB); with %u about %.2f GB",
                                  fit, threads, estimate.bytes / 1e9, what.c_str(), have / 1e9, fit,
                                  fewer.bytes / 1e9);
                    o.warn(text);
                }
                threads = fit;
                estimate = fewer;
            } else if (fewer.bytes > have) {
                estimate = fewer;  // refused below with the least it can need (one thread)
            }
        }
        summary.memoryEstimate = estimate.bytes;
        summary.threads = threads;
        if (o.memoryCheck && !checkMemory(o.demPath, estimate, o.memoryLimitBytes, "build", error))
            return false;
    }
    format::Writer writer;
    if (!writer.open(o.outPath, header, n, output, error)) return false;
    writer.storeRaw(o.rawBlocks);
    const std::size_t window = kWriterWindowPerThread * std::size_t(threads);
    std::vector<format::Block> results(n);
    std::vector<BlockBuildStats> stats(n);
    std::vector<CoarseState> coarse(n);
    std::vector<std::array<double, 6>> boxes(n);
    std::vector<std::string> errors(n);
    std::vector<char> ready(n, 0);
    // Progress of the items in flight: deletion steps done and expected (0: not started).
    std::vector<std::atomic<std::uint64_t>> stepsDone(n), stepsExpected(n);
    double builtWork = 0;
    std::size_t built = 0;
    std::mutex mutex;
    std::condition_variable changed;
    RetentionGuard retention(kRetentionShare * summary.memoryEstimate);
    std::size_t next = 0, written = 0;
    bool failed = false;
    auto work = [&] {
        for (;;) {
            std::size_t i;
            {
                std::unique_lock lock(mutex);
                changed.wait(lock, [&] { return failed || next >= n || next < written + window; });
                if (failed || next >= n) return;
                i = next++;
                // A node waits for its children (items before it, already taken: no deadlock).
                const Item& it = items[i];
                changed.wait(lock, [&] {
                    if (failed) return true;
                    for (std::uint32_t c = 0; c < it.childCount; ++c)
                        if (!ready[it.firstChild + c]) return false;
                    return true;
                });
                if (failed) return;
            }
            const Item& it = items[i];
            bool ok = false;
            try {
                BlockBuildOptions itemOptions = blockOptions;
                if (o.progress)
                    itemOptions.afterStep = [&stepsDone, i](std::uint32_t step) {
                        stepsDone[i].store(step, std::memory_order_relaxed);
                    };
                if (it.parent != format::kNoChild) {
                    // Its rectangle in sampled cells and the cells along its locked sides.
                    const auto [lo, hi] = cornerRects(it);
                    const NodeBorder b = nodeBorder(it);
                    const std::uint64_t w = std::uint64_t(hi.cellCol1 - lo.cellCol0) / o.stride,
                                        h = std::uint64_t(hi.cellRow1 - lo.cellRow0) / o.stride;
                    itemOptions.handoverTriangles = nodeHandoffTriangles(
                        w, h, (b.lockX0 + b.lockX1) * h + (b.lockY0 + b.lockY1) * w, it.level);
                    itemOptions.handoverKey =
                        nodeHandoffError(std::max(header.blockWidth, header.blockHeight),
                                         std::max(dem.width * std::fabs(dem.cellX),
                                                  dem.height * std::fabs(dem.cellY)),
                                         it.level, o.handoffPixels);
                }
                if (it.level > 0) itemOptions.lodRatio = kNodeLodTriangleRatio;
                // The key rule's hand-over from a share of the original points' triangles
                // (about two per point) under the item on (nodebuild.h kHandoffShare).
                auto keyTriangles = [&](std::uint64_t originals) {
                    return std::uint32_t(
                        std::min<double>(kHandoffShare * 2.0 * double(originals),
                                         double(std::numeric_limits<std::uint32_t>::max())));
                };
                if (it.level == 0) {
                    const PointSet set = source.points(it.source);
                    stepsExpected[i].store(std::max<std::size_t>(1, set.points.size()),
                                           std::memory_order_relaxed);
                    if (it.parent != format::kNoChild)
                        itemOptions.handoverKeyTriangles = keyTriangles(set.points.size());
                    ok = buildBlock(set, it.col, it.row, itemOptions, results[i], stats[i],
                                    errors[i], nullptr, tree ? &coarse[i] : nullptr);
                } else {
                    std::vector<const CoarseState*> children;
                    for (std::uint32_t c = 0; c < it.childCount; ++c)
                        children.push_back(&coarse[it.firstChild + c]);
                    auto originals = [&](const std::function<void(const Point&)>& f) {
                        for (std::size_t l = it.leafFirst; l < it.leafFirst + it.leafCount; ++l) {
                            const PointSet leaf = source.points(items[l].source);
                            for (const Point& p : leaf.points)
                                f(p);
                            for (const Point& p : leaf.dropped)
                                f(p);
                        }
                    };
                    std::size_t originalCount = 0;
                    for (std::size_t l = it.leafFirst; l < it.leafFirst + it.leafCount; ++l)
                        originalCount += stats[l].points + stats[l].droppedPoints;
                    if (it.parent != format::kNoChild)
                        itemOptions.handoverKeyTriangles = keyTriangles(originalCount);
                    std::size_t startPoints = 0;
                    for (const CoarseState* c : children)
                        startPoints += c->points.size();
                    stepsExpected[i].store(std::max<std::size_t>(1, startPoints),
                                           std::memory_order_relaxed);
                    // A node high in the tree measures its error against millions of original
                    // points (4 B each for a DEM cell, 16 B for another, in large buffers of their
                    // own: modelerror.h SampleGrid), and one of a dense river
                    // network starts from hundreds of thousands of locked vertices: first hand
                    // the pages the finished items freed (in every thread's arena) back to the
                    // system, so that peak RSS is not the sum (estimateBuildMemory counts the
                    // items built at the same time only).
                    if (originalCount >= (std::size_t(1) << 22) ||
                        startPoints >= (std::size_t(1) << 18))
                        releaseFreeMemory();
                    const auto [lo, hi] = cornerRects(it);
                    const OriginalGrid cells{&dem,        lo.cellCol0, hi.cellCol1,
                                             lo.cellRow0, hi.cellRow1, int(o.stride)};
                    ok = buildNode(children, nodeBorder(it), it.col, it.row, itemOptions, originals,
                                   originalCount, results[i], stats[i], coarse[i], errors[i],
                                   &cells);
                    if (ok) {
                        // The node's box holds its children's (the cut culls a subtree by it).
                        format::Block& b = results[i];
                        for (std::uint32_t c = 0; c < it.childCount; ++c) {
                            const auto& k = boxes[it.firstChild + c];
                            b.minX = std::min(b.minX, k[0]);
                            b.minY = std::min(b.minY, k[1]);
                            b.minZ = std::min(b.minZ, k[2]);
                            b.maxX = std::max(b.maxX, k[3]);
                            b.maxY = std::max(b.maxY, k[4]);
                            b.maxZ = std::max(b.maxZ, k[5]);
                        }
                        b.level = it.level;
                        b.firstChild = it.firstChild;
                        b.childCount = it.childCount;
                    }
                }
            } catch (const std::bad_alloc&) {
                // A memory limit: this item fails (the others stop), the file is not written.
                results[i] = format::Block{};
                errors[i] = outOfMemory;
                ok = false;
            }
            {
                std::lock_guard lock(mutex);
                if (ok) {
                    const format::Block& b = results[i];
                    boxes[i] = {b.minX, b.minY, b.minZ, b.maxX, b.maxY, b.maxZ};
                    // The children's hand-over states are no longer needed.
                    for (std::uint32_t c = 0; c < it.childCount; ++c)
                        coarse[it.firstChild + c] = CoarseState{};
                }
                ready[i] = 1;
                ++built;
                builtWork += itemCost[i];
                if (!ok) failed = true;
            }
            changed.notify_all();
            retention.afterItem();
        }
    };
    if (o.stage) o.stage(n > leafCount ? "blocks and tree nodes" : "blocks", n);
    std::vector<std::thread> pool;
    std::string writeError;
    try {
        for (unsigned t = 0; t < threads && t < n; ++t)
            pool.emplace_back(work);
    } catch (const std::system_error& e) {
        // No thread could be started: fail (the started ones stop at `failed`).
        writeError = "cannot start a worker thread: " + std::string(e.what());
        std::lock_guard lock(mutex);
        failed = true;
    }
    // The progress share (BuildOptions::progress), with `mutex` held: the built items' work,
    // plus the in-flight items' (taken, not ready: between `written` and `next`) by their steps.
    auto progressShare = [&] {
        if (built == n) return 1.0;
        double w = builtWork;
        for (std::size_t k = written; k < next; ++k) {
            if (ready[k]) continue;
            w += inProgressWork(items[k].level > 0, itemCost[k],
                                stepsDone[k].load(std::memory_order_relaxed),
                                stepsExpected[k].load(std::memory_order_relaxed));
        }
        return totalWork > 0 ? std::min(1.0, w / totalWork) : 0.0;
    };
    const auto interval = std::chrono::duration<double>(std::max(0.001, o.progressInterval));
    for (std::size_t i = 0; i < n && writeError.empty(); ++i) {
        {
            std::unique_lock lock(mutex);
            for (;;) {
                if (changed.wait_for(lock, interval, [&] { return ready[i] || failed; })) break;
                if (!o.progress) continue;
                const std::size_t done = built;
                const double share = progressShare();
                lock.unlock();
                o.progress(done, n, share);
                lock.lock();
            }
            if (!ready[i] || !errors[i].empty()) break;
        }
        const format::Block& b = results[i];
        bool wrote = false;
        try {
            wrote = writer.writeBlock(b, writeError);
        } catch (const std::bad_alloc&) {
            writeError = "'" + o.outPath + "': " + outOfMemory + " (writing a block)";
        }
        if (!wrote) {
            std::lock_guard lock(mutex);
            failed = true;
            break;
        }
        header.minX = std::min(header.minX, b.minX);
        header.minY = std::min(header.minY, b.minY);
        header.minZ = std::min(header.minZ, b.minZ);
        header.maxX = std::max(header.maxX, b.maxX);
        header.maxY = std::max(header.maxY, b.maxY);
        header.maxZ = std::max(header.maxZ, b.maxZ);
        const BlockBuildStats& st = stats[i];
        if (items[i].level == 0) {
            summary.demPoints += st.points - st.riverPoints;
            summary.riverPoints += st.riverPoints;
            summary.lockedPoints += st.lockedPoints;
            summary.fullTriangles += st.fullTriangles;
            summary.droppedDeviation = std::max(summary.droppedDeviation, st.droppedDeviation);
            summary.coarsestTriangles += st.coarsestTriangles;
        }
        if (items[i].parent == format::kNoChild) summary.rootTriangles += st.coarsestTriangles;
        summary.steps += st.steps;
        summary.kept += st.kept;
        summary.deferrals += st.deferrals;
        summary.indexTriangles += st.indexTriangles;
        results[i] = format::Block{};  // release the block's memory
        {
            std::lock_guard lock(mutex);
            written = i + 1;
        }
        changed.notify_all();
        if (o.progress) {
            std::unique_lock lock(mutex);
            const std::size_t done = built;
            const double share = progressShare();
            lock.unlock();
            o.progress(done, n, share);
        }
    }
    {
        std::lock_guard lock(mutex);
        if (written < n) failed = true;
    }
    changed.notify_all();
    for (auto& t : pool)
        t.join();
    for (std::size_t i = 0; i < n; ++i) {
        if (!errors[i].empty()) {
            const Item& it = items[i];
            error = inputsName(o) + ": " + (it.level == 0 ? "block (" : "tree node (") +
                    std::to_string(it.col) + "," + std::to_string(it.row) + ")" +
                    (it.level == 0 ? "" : " of level " + std::to_string(it.level)) + ": " +
                    errors[i];
            return false;
        }
    }
    if (!writeError.empty()) {
        error = writeError;
        return false;
    }
    writer.header().minX = header.minX;
    writer.header().minY = header.minY;
    writer.header().minZ = header.minZ;
    writer.header().maxX = header.maxX;
    writer.header().maxY = header.maxY;
    writer.header().maxZ = header.maxZ;
    if (!writer.finish(error)) return false;
    std::error_code ec;
    summary.outputBytes = std::filesystem::file_size(o.outPath, ec);
    summary.blocks = leafCount;
    summary.nodes = n - leafCount;
    summary.treeLevels = levels;
    summary.seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    struct rusage usage {};
    if (getrusage(RUSAGE_SELF, &usage) == 0) summary.peakMemory = double(usage.ru_maxrss) * 1024.0;
    return true;
}

// A number from the first line of a file ("max" or unreadable: 0).
std::uint64_t readNumber(const char* path) {
    std::ifstream in(path);
    std::uint64_t v = 0;
    if (!(in >> v)) return 0;
    return v;
}

// A "Key: N kB" line of /proc/meminfo, in bytes (0 when absent).
std::uint64_t meminfo(const std::string& text, const std::string& key) {
    const std::size_t at = text.find("\n" + key + ":");
    if (at == std::string::npos) return 0;
    return std::strtoull(text.c_str() + at + key.size() + 2, nullptr, 10) * 1024;
}

}  // namespace

std::uint64_t sampledDemPoints(const Ingested& data, int stride) {
    const auto sampled = [&](int n) {
        return std::uint64_t((std::int64_t(n) + stride - 1) / stride);
    };
    const std::uint64_t cells = sampled(data.dem.width) * sampled(data.dem.height);
    const std::uint64_t empty =
        (data.nodata.nodataCells - std::min(data.nodata.nodataCells, data.nodata.filledCells)) /
        (std::uint64_t(stride) * std::uint64_t(stride));
    return cells - std::min(cells, empty);
}

namespace {

// The advice of a refusal at `stride`: twice it takes a quarter of the DEM points.
std::string widerStride(int stride, const char* doing) {
    return "--stride " + std::to_string(2 * std::max(1, stride)) + " " + doing +
           " a quarter of the DEM points";
}

}  // namespace

MemoryEstimate pointMemory(std::uint64_t demPoints, std::uint64_t riverPoints, double bytesPerPoint,
                           int stride) {
    MemoryEstimate e;
    e.demPoints = demPoints;
    e.riverPoints = riverPoints;
    e.bytes = kBuildBaseBytes + double(demPoints + riverPoints) * bytesPerPoint;
    char text[80];
    std::snprintf(text, sizeof text, "%.0f bytes per point measured", bytesPerPoint);
    e.basis = text;
    e.smaller = widerStride(stride, "ranks");
    return e;
}

MemoryEstimate estimateBuildMemory(std::uint64_t cells, std::uint64_t heldCells,
                                   std::uint64_t demPoints, const std::vector<ItemLoad>& items,
                                   unsigned threads, bool tree, bool cellsOnDisk, int stride) {
    MemoryEstimate e;
    e.demPoints = demPoints;
    for (const ItemLoad& l : items)
        if (!l.node) e.riverPoints += l.riverPoints;
    const double perPoint = tree ? kTreeBuildBytesPerPoint : kFlatBuildBytesPerPoint;
    const double perRiverPoint = tree ? kTreeBuildBytesPerRiverPoint : kFlatBuildBytesPerPoint;
    const double whole = double(heldCells) * kBuildBytesPerCell + double(demPoints) * perPoint +
                         double(e.riverPoints) * perRiverPoint;
    // While the raster is read: its cells, or with them in a temporary file the reading's
    // buffers and the lattice (dem.h CellAllocator).
    const double read = cellsOnDisk ? double(cells) * (kBuildBytesPerCell - 4) +
                                          double(heldCells) * kBuildBytesPerCell
                                    : double(cells) * kBuildBytesPerCell;
    auto bytesOf = [](const ItemLoad& l) {
        return l.node ? double(l.demPoints + l.riverPoints) * kInFlightBytesPerNodePoint
                      : double(l.demPoints) * kInFlightBytesPerDemPoint +
                            double(l.riverPoints) * kInFlightBytesPerRiverPoint;
    };
    // The heaviest items first; an item under (or above) one already taken is never built at
    // the same time (its leaf range nests in the other's).
    std::vector<std::size_t> order(items.size());
    for (std::size_t i = 0; i < order.size(); ++i)
        order[i] = i;
    std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
        return bytesOf(items[a]) > bytesOf(items[b]);
    });
    std::vector<std::size_t> taken;
    double inFlight = 0;
    std::uint64_t largest = 0;
    for (const std::size_t i : order) {
        if (taken.size() >= std::max(1u, threads)) break;
        const ItemLoad& l = items[i];
        const bool nested = std::any_of(taken.begin(), taken.end(), [&](std::size_t t) {
            const ItemLoad& k = items[t];
            return l.leafFirst < k.leafFirst + k.leafCount &&
                   k.leafFirst < l.leafFirst + l.leafCount;
        });
        if (nested) continue;
        taken.push_back(i);
        inFlight += bytesOf(l);
        largest = std::max(largest, l.demPoints + l.riverPoints);
    }
    // The results waiting for the writer: its window of average blocks.
    std::size_t blocks = 0;
    std::uint64_t blockPoints = 0;
    for (const ItemLoad& l : items)
        if (!l.node) ++blocks, blockPoints += l.demPoints + l.riverPoints;
    const double waiting =
        blocks == 0 ? 0.0
                    : double(std::min<std::size_t>(
                          kWriterWindowPerThread * std::size_t(std::max(1u, threads)), blocks)) *
                          double(blockPoints) / double(blocks) * kResultBytesPerPoint;
    inFlight = std::max(inFlight, double(taken.size()) * kInFlightFloorBytes);
    inFlight += waiting + double(items.size()) * kBytesPerItem;
    e.bytes = kBuildBaseBytes + std::max(read, whole + inFlight);
    char points[80];
    if (perRiverPoint == perPoint)
        std::snprintf(points, sizeof points, "%.0f per point", perPoint);
    else
        std::snprintf(points, sizeof points, "%.0f per DEM point and %.0f per river point",
                      perPoint, perRiverPoint);
    char text[300];
    std::snprintf(text, sizeof text,
                  "%.0f bytes per raster cell (the stride's lattice once read) and %s, plus "
                  "%.2f GB for the %zu block%s or node%s built at a time, up to %.2f M points each",
                  kBuildBytesPerCell, points, inFlight / 1e9, taken.size(),
                  taken.size() == 1 ? "" : "s", taken.size() == 1 ? "" : "s",
                  double(largest) / 1e6);
    e.basis = text;
    if (read > whole + inFlight) {
        std::snprintf(text, sizeof text,
                      "%.0f bytes a raster cell to read it; building from the --stride lattice "
                      "then needs %.2f GB",
                      kBuildBytesPerCell, (kBuildBaseBytes + whole + inFlight) / 1e9);
        e.basis = text;
    }
    if (read > whole + inFlight)
        e.smaller =
            "reading the raster needs its cells (at any --stride): a raster resampled to larger "
            "cells first (gdalwarp -tr) or clipped to its data (gdal_translate -projwin) needs "
            "less";
    else if (e.riverPoints > demPoints)
        e.smaller = "the rivers hold more points than the DEM: a sparser river network needs less";
    else if (demPoints < heldCells / 4 && double(heldCells) * kBuildBytesPerCell > whole / 2)
        e.smaller =
            "the raster is mostly nodata: the raster clipped to its data (gdal_translate "
            "-projwin) needs less";
    else if (inFlight > whole && threads > 1)
        e.smaller = "--threads 1 builds one block at a time";
    else
        e.smaller = widerStride(stride, "builds");
    if (e.smaller.rfind("--stride", 0) == 0 && read > (whole + inFlight) / 3) {
        // Reading takes every cell at any stride (README "Large DEMs"): say what it needs then.
        char raster[300];
        std::snprintf(raster, sizeof raster,
                      ", though reading the raster takes its %.0f bytes a cell (%.2f GB) or, "
                      "where the memory cannot hold them, a temporary file of %.2f GB and "
                      "%.2f GB of memory",
                      kBuildBytesPerCell, double(cells) * kBuildBytesPerCell / 1e9,
                      double(cells) * 4 / 1e9, double(cells) * (kBuildBytesPerCell - 4) / 1e9);
        e.smaller += raster;
    }
    return e;
}

double memoryBound(double limitBytes, std::string& what) {
    what = "--memory-limit";
    return limitBytes > 0 ? limitBytes : double(availableMemory(&what));
}

bool checkMemory(const std::string& demPath, const MemoryEstimate& estimate, double limitBytes,
                 const char* doing, std::string& error) {
    const double needBytes = estimate.bytes;
    std::string what;
    const double have = memoryBound(limitBytes, what);
    if (have <= 0 || needBytes <= have) return true;
    char points[160];
    if (estimate.riverPoints > 0)
        std::snprintf(points, sizeof points, "about %.1f M points (%.1f M DEM, %.1f M river)",
                      double(estimate.demPoints + estimate.riverPoints) / 1e6,
                      double(estimate.demPoints) / 1e6, double(estimate.riverPoints) / 1e6);
    else
        std::snprintf(points, sizeof points, "about %.1f M points",
                      double(estimate.demPoints) / 1e6);
    char need[40], allows[40];
    std::snprintf(need, sizeof need, "%.2f GB", needBytes / 1e9);
    std::snprintf(allows, sizeof allows, "%.2f GB", have / 1e9);
    const std::string text = std::string(" need about ") + need + " of memory to " + doing + " (" +
                             estimate.basis + ", README \"Large DEMs\"), more than " + what +
                             " allows (" + allows + "): ";
    error = "DEM '" + demPath + "': " + points + text + estimate.smaller +
            "; --no-memory-check tries anyway";
    return false;
}

std::uint64_t availableMemory(std::string* what) {
    std::uint64_t best = 0;
    auto consider = [&](std::uint64_t bytes, const char* name) {
        if (bytes == 0 || (best != 0 && bytes >= best)) return;
        best = bytes;
        if (what) *what = name;
    };
    // What this process holds already (VmRSS) counts as its own: the estimates are of its whole
    // peak, the raster it has read included. (Until 2026-12-02 the check after reading compared
    // them with what was left beside the raster, counting it twice: a 40 000^2 raster read, 6.7
    // GB resident, was measured against 17.98 GB of 24.7.)
    std::ifstream statusIn("/proc/self/status");
    std::stringstream status;
    status << "\n" << statusIn.rdbuf();
    const std::uint64_t own = meminfo(status.str(), "VmRSS");
    {
        std::ifstream in("/proc/meminfo");
        std::stringstream text;
        text << "\n" << in.rdbuf();
        const std::string t = text.str();
        const std::uint64_t spare = meminfo(t, "MemAvailable") + meminfo(t, "SwapFree");
        consider(spare > 0 ? spare + own : 0, "the available memory");
    }
    // A cgroup's use includes this process's.
    const std::uint64_t v2max = readNumber("/sys/fs/cgroup/memory.max");
    if (v2max > 0) {
        const std::uint64_t used = readNumber("/sys/fs/cgroup/memory.current");
        consider(v2max > used ? v2max - used + own : own + 1, "the cgroup's memory limit");
    }
    const std::uint64_t v1max = readNumber("/sys/fs/cgroup/memory/memory.limit_in_bytes");
    if (v1max > 0 && v1max < (std::uint64_t(1) << 60)) {
        const std::uint64_t used = readNumber("/sys/fs/cgroup/memory/memory.usage_in_bytes");
        consider(v1max > used ? v1max - used + own : own + 1, "the cgroup's memory limit");
    }
    struct rlimit limit {};
    if (getrlimit(RLIMIT_AS, &limit) == 0 && limit.rlim_cur != RLIM_INFINITY) {
        // Address space in use (VmSize), of which the resident part is the process's own.
        const std::uint64_t used = meminfo(status.str(), "VmSize");
        consider(limit.rlim_cur > used ? limit.rlim_cur - used + own : own + 1, kAddressSpaceLimit);
    }
    return best;
}

bool checkTempDir(const std::string& tempDir, std::string& error) {
    std::error_code ec;
    if (tempDir.empty() || std::filesystem::is_directory(tempDir, ec)) return true;
    error = "--temp-dir '" + tempDir +
            "': " + (std::filesystem::exists(tempDir, ec) ? "not a folder" : "no such folder");
    return false;
}

std::string spillFolder(const std::string& tempDir, const std::string& outPath,
                        const std::string& memoryWhat) {
    if (memoryWhat == kAddressSpaceLimit) return {};
    if (!tempDir.empty()) return tempDir;
    const std::filesystem::path parent = std::filesystem::path(outPath).parent_path();
    return parent.empty() ? "." : parent.string();
}

bool runBuild(const BuildOptions& o, BuildSummary& summary, std::string& error) {
    try {
        return buildModel(o, summary, error);
    } catch (const std::bad_alloc&) {
        // Outside the workers (reading the DEM, splitting into blocks): the output's temporary
        // is removed on the way out (atomicfile.h).
        error = inputsName(o) + ": " + outOfMemory;
        return false;
    }
}

}  // namespace unilod
