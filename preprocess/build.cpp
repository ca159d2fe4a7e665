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
#include "dem.h"
#include "jsontext.h"
#include "nodata.h"
#include "rivercleaning.h"
#include "rivers.h"

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

bool runBuild(const BuildOptions& o, BuildSummary& summary, std::string& error) {
    const auto start = std::chrono::steady_clock::now();
    summary = {};
    auto warn = [&](const std::string& w) {
        if (o.warn) o.warn(w);
    };
    // Fail fast, before the long work; the Writer checks again when it creates the file.
    if (o.outPath.empty()) {
        error = "no output file given (-o OUT.ulod)";
        return false;
    }
    if (!format::checkOutputPath(o.outPath, outputOptions(o), false, error)) return false;
    if (o.stride < 1) {
        error = "stride must be at least 1 (got " + std::to_string(o.stride) + ")";
        return false;
    }
    if (o.blockSize < 1) {
        error = "block size must be positive (got " + std::to_string(o.blockSize) + ")";
        return false;
    }
    if (o.threads < 0) {
        error = "threads must be >= 0 (got " + std::to_string(o.threads) + ")";
        return false;
    }

    // BAI table before the long work, so that a typo fails fast.
    BlockBuildOptions blockOptions;
    blockOptions.order = o.order;
    blockOptions.importance.useBai = o.useBai;
    blockOptions.importance.baiRow = o.baiRow;
    if (!o.baiTablePath.empty() &&
        !BaiTable::load(o.baiTablePath, blockOptions.importance.baiTable, error)) {
        return false;
    }
    if (o.useBai && blockOptions.importance.baiTable.findRow(o.baiRow) < 0) {
        error = "the BAI table has no row for threshold " + std::to_string(o.baiRow) + " m";
        return false;
    }

    DemGrid dem;
    DemLoadOptions demOptions;
    demOptions.band = o.band;
    demOptions.targetSrs = o.targetSrs;
    if (!loadDem(o.demPath, demOptions, dem, error)) return false;
    // Before the block-size checks, so that a 1 x 1 raster is reported for what it is.
    if (dem.width < 2 || dem.height < 2) {
        error = "DEM '" + o.demPath + "': " + std::to_string(dem.width) + " x " +
                std::to_string(dem.height) + " cells is too small to triangulate (at least 2 x 2)";
        return false;
    }
    summary.demWidth = dem.width;
    summary.demHeight = dem.height;
    summary.crsName = crsDisplayName(dem.wkt);
    for (std::size_t i = 0; i < dem.z.size(); ++i) {
        const float z = dem.z[i];
        if (std::isnan(z)) {
            continue;
        } else if (z < kMinPlausibleZ || z > kMaxPlausibleZ) {
            const std::size_t col = i % std::size_t(dem.width), row = i / std::size_t(dem.width);
            error = "DEM '" + o.demPath + "': elevation " + std::to_string(z) + " at cell (" +
                    std::to_string(col) + ", " + std::to_string(row) +
                    ") is outside the plausible " + "range [" +
                    std::to_string(int(kMinPlausibleZ)) + ", " +
                    std::to_string(int(kMaxPlausibleZ)) + "] m (a wrong nodata value or units?)";
            return false;
        }
    }
    NodataStats nodata;
    if (!fillSmallHoles(dem, o.demPath, kDefaultMaxFillCells, nodata, error)) return false;
    if (nodata.nodataCells > 0) {
        warn("DEM '" + o.demPath + "': " + std::to_string(nodata.nodataCells) +
             " nodata cells (nodata value, NaN or infinite); " + std::to_string(nodata.holes) +
             " small interior holes (" + std::to_string(nodata.filledCells) +
             " cells) filled from their rims, the rest produce no points");
    }

    RiverLines rivers;
    RiverLoadOptions riverOptions;
    riverOptions.layer = o.layer;
    riverOptions.where = o.where;
    riverOptions.assumeSrs = o.assumeSrs;
    riverOptions.warn = warn;
    if (!loadRivers(o.riversPath, riverOptions, dem.wkt, rivers, error)) return false;
    {
        // The point set drops repeated consecutive vertices and lines with fewer than two
        // distinct vertices (pointset.h); say so, since the user's data changes.
        std::size_t repeated = 0, degenerate = 0;
        for (const RiverLine& line : rivers) {
            std::size_t here = 0;
            for (std::size_t i = 1; i < line.size(); ++i)
                here += line[i] == line[i - 1];
            repeated += here;
            degenerate += line.size() - here < 2;
        }
        if (repeated > 0 || degenerate > 0) {
            warn("rivers '" + o.riversPath + "': dropped " + std::to_string(repeated) +
                 " repeated vertices and " + std::to_string(degenerate) +
                 " zero-length lines (fewer than two distinct vertices)");
        }
    }
    if (rivers.empty()) {
        warn("rivers '" + o.riversPath + "': no line features: building a terrain-only model");
    } else {
        bool any = false;
        for (const RiverLine& line : rivers) {
            for (const XY& v : line) {
                if (std::isfinite(dem.sample(v.x, v.y))) {
                    any = true;
                    break;
                }
            }
            if (any) break;
        }
        if (!any) {
            error = "rivers '" + o.riversPath + "': no river vertex lies on the DEM '" + o.demPath +
                    "' (a CRS mistake? try --assume-crs or check the data)";
            return false;
        }
    }
    // River cleaning (DESIGN.md "Point set"): clip to the DEM, snap, split at crossings, drop
    // duplicates, zero-length segments and short rivers, so that the constrained triangulation
    // gets a planar network whose rivers meet only at shared vertices.
    RiverCleaningOptions cleaning;
    cleaning.minRiverLength = o.minRiverLength;
    RiverCleaningStats cleaningStats;
    rivers = cleanRivers(rivers, dem, cleaning, cleaningStats);
    summary.cleaning = describe(cleaningStats);
    if (cleaningStats.crossingsSplit + cleaningStats.selfCrossings + cleaningStats.touchesSplit >
        0) {
        warn("rivers '" + o.riversPath +
             "': crossing or touching rivers were split at the crossing");
    }
    if (cleaningStats.duplicateVertices + cleaningStats.zeroLengthSegments > 0) {
        warn("rivers '" + o.riversPath + "': duplicate vertices and zero-length segments dropped");
    }
    summary.riverLines = rivers.size();

    BlockOptions blocks;
    blocks.blockSize = o.blockSize;
    blocks.stride = o.stride;
    blocks.lockOuterEdge = o.order == DeletionOrderKind::ThreeDdp;
    BlockSource source;
    if (!source.init(dem, rivers, blocks, error)) {
        error = "DEM '" + o.demPath + "': " + error;
        return false;
    }
    // nodata.h rule 2: fill the nodata cells a block's hull would bridge (few per block), until
    // no hull contains a nodata centre; refuse a block with many.
    for (int round = 0; round < 8; ++round) {
        std::size_t filled = 0;
        for (std::size_t i = 0; i < source.blockCount(); ++i) {
            if (!source.hasNodataCells(i)) continue;
            const std::vector<std::size_t> cells = source.bridgedNodataCells(i, source.points(i));
            if (cells.size() > kMaxBridgedCells) {
                const std::size_t c = cells.front();
                error = "DEM '" + o.demPath + "': block (" + std::to_string(source.rect(i).col) +
                        "," + std::to_string(source.rect(i).row) + ") would bridge " +
                        std::to_string(cells.size()) + " nodata cells (e.g. cell (" +
                        std::to_string(c % std::size_t(dem.width)) + ", " +
                        std::to_string(c / std::size_t(dem.width)) +
                        ")): a nodata bay reaches into the block's convex hull; at most " +
                        std::to_string(kMaxBridgedCells) + " such cells per block are filled";
                return false;
            }
            filled += fillCells(dem, cells);
        }
        nodata.bayCellsFilled += filled;
        if (filled == 0) break;
    }
    if (nodata.bayCellsFilled > 0) {
        warn("DEM '" + o.demPath + "': " + std::to_string(nodata.bayCellsFilled) +
             " nodata cells inside blocks' convex hulls filled from their neighbours");
    }
    summary.nodataCells = nodata.nodataCells;
    summary.filledNodataCells = nodata.filledCells + nodata.bayCellsFilled;
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
    header.blockWidth = o.blockSize * std::fabs(dem.cellX);
    header.blockHeight = o.blockSize * std::fabs(dem.cellY);
    header.metrics = format::kMetricMax | format::kMetricPaper;
    header.defaultMetric = o.defaultMetric;
    // Provenance; nothing here may depend on the thread count or the clock.
    nlohmann::json info = {
        {"generator", "unilod build"},
        {"dem", o.demPath},
        {"rivers", o.riversPath},
        {"band", o.band},
        {"t_srs", o.targetSrs},
        {"layer", o.layer},
        {"where", o.where},
        {"assume_crs", o.assumeSrs},
        {"stride", o.stride},
        {"block_size", o.blockSize},
        {"order", deletionOrderName(o.order)},
        {"bai", o.useBai},
        {"bai_row", o.baiRow},
        {"bai_table", o.baiTablePath},
        {"min_river_length", o.minRiverLength},
        {"lod_triangle_ratio", blockOptions.lodRatio},
        {"grid_unit_m", format::kGridUnit},
    };
    header.buildInfo = jsonText(info);

    // Blocks in parallel, written in grid order by this thread as soon as each is next in line,
    // so the file does not depend on timing. Workers run at most `window` blocks ahead of the
    // writer: memory holds a few blocks' results, never the whole model. Block costs vary a lot
    // (rivers, relief), so a short window stalls the workers behind one slow block: 16M-point
    // synthetic build, 2 threads, 204 s with 2 blocks per thread, 158 s with 4 (peak RSS 467 ->
    // 554 MB).
    const std::size_t n = source.blockCount();
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
            const PointSet set = source.points(i);
            const BlockRect& r = source.rect(i);
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
                    std::to_string(source.rect(i).col) + "," + std::to_string(source.rect(i).row) +
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
