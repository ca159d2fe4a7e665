// `unilod build` pipeline (build.h).
#include "build.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <filesystem>
#include <mutex>
#include <nlohmann/json.hpp>
#include <thread>

#include "blockbuild.h"
#include "jsontext.h"

namespace unilod {

namespace {

// The output rules: replace only with --force, and never one of the inputs (also with --force:
// `build dem.tif rivers.geojson -o dem.tif --force` must not destroy the DEM).
format::OutputOptions outputOptions(const BuildOptions& o) {
    format::OutputOptions out;
    out.replace = o.force;
    out.inputs = {o.demPath, o.riversPath};
    if (!o.baiTablePath.empty()) out.inputs.push_back(o.baiTablePath);
    return out;
}

}  // namespace

bool recordsPaperMetric(const BuildOptions& o) {
    return o.paperMetric || o.order == DeletionOrderKind::ThreeDdp ||
           o.defaultMetric == format::kMetricPaper;
}

bool runBuild(const BuildOptions& o, BuildSummary& summary, std::string& error) {
    const auto start = std::chrono::steady_clock::now();
    summary = {};
    // Fail fast, before the long work; the Writer checks again when it creates the file.
    if (o.outPath.empty()) {
        error = "no output file given (-o OUT.ulod)";
        return false;
    }
    if (!format::checkOutputPath(o.outPath, outputOptions(o), false, error)) return false;
    if (o.threads < 0) {
        error = "--threads " + std::to_string(o.threads) + ": must be >= 0";
        return false;
    }

    // BAI table before the long work, so that a typo fails fast.
    BlockBuildOptions blockOptions;
    blockOptions.order = o.order;
    blockOptions.paperError = recordsPaperMetric(o);
    blockOptions.importance.useBai = o.useBai;
    blockOptions.importance.baiRow = o.baiRow;
    if (!o.baiTablePath.empty() &&
        !BaiTable::load(o.baiTablePath, blockOptions.importance.baiTable, error)) {
        return false;
    }
    if (o.useBai && blockOptions.importance.baiTable.findRow(o.baiRow) < 0) {
        error = "--bai-row " + jsonText(nlohmann::json(o.baiRow)) + ": the BAI table" +
                (o.baiTablePath.empty() ? std::string(" (the paper's Table 1)")
                                        : " '" + o.baiTablePath + "'") +
                " has no row for this threshold (metres)";
        return false;
    }

    Ingested data;
    if (!ingest(o, data, error)) return false;
    const DemGrid& dem = data.dem;
    summary.demWidth = dem.width;
    summary.demHeight = dem.height;
    summary.crsName = crsDisplayName(dem.wkt);
    summary.cleaning = describe(data.cleaning);
    summary.riverLines = data.rivers.size();

    // The block size clamps to the DEM (splitIntoBlocks); the default one also to the exact grid.
    int blockSize = o.blockSize;
    if (blockSize == 0) {
        blockSize = automaticBlockSize(dem, o.stride);
    } else if (!checkBlockFitsExactGrid(dem, o.stride, blockSize, error)) {
        return false;
    }
    summary.blockSize = blockSize;
    BlockSource source;
    if (!splitIntoBlocks(data, o, blockSize, o.order == DeletionOrderKind::ThreeDdp, source, error))
        return false;
    summary.nodataCells = data.nodata.nodataCells;
    summary.filledNodataCells = data.nodata.filledCells;
    summary.crossings = source.stats().crossings;
    summary.droppedDemPoints = source.stats().droppedDemPoints;

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
        {"bai_row", o.baiRow},
        {"bai_table", o.baiTablePath},
        {"lod_triangle_ratio", blockOptions.lodRatio},
        {"grid_unit_m", format::kGridUnit},
    };
    recordIngestOptions(o, info);
    header.buildInfo = jsonText(info);

    // Blocks in parallel, written in grid order by this thread as soon as each is next in line,
    // so the file does not depend on timing. Workers run at most `window` blocks ahead of the
    // writer: memory holds a few blocks' results, never the whole model. Block costs vary a lot
    // (rivers, relief), so a short window stalls the workers behind one slow block: 16M-point
    // synthetic build, 2 threads, 204 s with 2 blocks per thread, 158 s with 4 (peak RSS 467 ->
    // 554 MB).
    // Blocks without any of the domain (all nodata) are left out of the model (splitIntoBlocks
    // refuses a DEM without any).
    std::vector<std::size_t> present;
    for (std::size_t i = 0; i < source.blockCount(); ++i)
        if (source.hasDomain(i)) present.push_back(i);
    const std::size_t n = present.size();
    format::Writer writer;
    if (!writer.open(o.outPath, header, n, outputOptions(o), error)) return false;
    const unsigned threads =
        o.threads > 0 ? unsigned(o.threads) : std::max(1u, std::thread::hardware_concurrency());
    const std::size_t window = 4 * std::size_t(threads);
    std::vector<format::Block> results(n);
    std::vector<BlockBuildStats> stats(n);
    std::vector<std::string> errors(n);
    std::vector<char> ready(n, 0);
    std::mutex mutex;
    std::condition_variable changed;
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
            }
            const PointSet set = source.points(present[i]);
            const BlockRect& r = source.rect(present[i]);
            const bool ok =
                buildBlock(set, r.col, r.row, blockOptions, results[i], stats[i], errors[i]);
            {
                std::lock_guard lock(mutex);
                ready[i] = 1;
                if (!ok) failed = true;
            }
            changed.notify_all();
        }
    };
    std::vector<std::thread> pool;
    for (unsigned t = 0; t < threads && t < n; ++t)
        pool.emplace_back(work);
    std::string writeError;
    for (std::size_t i = 0; i < n; ++i) {
        {
            std::unique_lock lock(mutex);
            changed.wait(lock, [&] { return ready[i] || failed; });
            if (!ready[i] || !errors[i].empty()) break;
        }
        const format::Block& b = results[i];
        if (!writer.writeBlock(b, writeError)) {
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
        summary.demPoints += st.points - st.riverPoints;
        summary.riverPoints += st.riverPoints;
        summary.lockedPoints += st.lockedPoints;
        summary.steps += st.steps;
        summary.kept += st.kept;
        summary.deferrals += st.deferrals;
        summary.fullTriangles += st.fullTriangles;
        summary.coarsestTriangles += st.coarsestTriangles;
        summary.indexTriangles += st.indexTriangles;
        results[i] = format::Block{};  // release the block's memory
        {
            std::lock_guard lock(mutex);
            written = i + 1;
        }
        changed.notify_all();
        if (o.progress) o.progress(i + 1, n);
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
            error = "DEM '" + o.demPath + "' + rivers '" + o.riversPath + "': block (" +
                    std::to_string(source.rect(present[i]).col) + "," +
                    std::to_string(source.rect(present[i]).row) +
                    "): " + errors[i];
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
    summary.blocks = n;
    summary.seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return true;
}

}  // namespace unilod
