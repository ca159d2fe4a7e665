// BAI vs no BAI river shapes at equal point budgets (report.h; paper §2.2, Table 1), in the
// file's deletion order: greedy with and without the BAI weights, or 3ddp vs plain 3D_DP.
#include <algorithm>
#include <cmath>
#include <limits>
#include <mutex>
#include <nlohmann/json.hpp>

#include "bai.h"
#include "build.h"
#include "cdt.h"
#include "deletion.h"
#include "importance.h"
#include "ingest.h"
#include "report.h"
#include "workers.h"

namespace unilod::report {

namespace {

// Samples per segment for the Hausdorff supremum (error bound: segment length / 32).
constexpr int kHausdorffSamples = 16;

template <typename T>
T infoValue(const nlohmann::json& info, const char* key, T fallback) {
    if (!info.is_object() || !info.contains(key)) return fallback;
    try {
        return info.at(key).get<T>();
    } catch (const nlohmann::json::exception&) {
        return fallback;
    }
}

// Deletion position per point id (higher = deleted later = more important); locked: max.
std::vector<std::size_t> positions(const PointSet& set, const ImportanceResult& r) {
    std::vector<std::size_t> pos(set.points.size(), std::numeric_limits<std::size_t>::max());
    for (std::size_t i = 0; i < r.order.size(); ++i)
        pos[r.order[i]] = i;
    return pos;
}

std::vector<XY> simplified(const PointSet& set, const Polyline& line,
                           const std::vector<std::size_t>& pos, std::size_t keep) {
    std::vector<std::size_t> ranks;
    for (PointId id : line) {
        if (!set.points[id].locked) ranks.push_back(pos[id]);
    }
    std::sort(ranks.begin(), ranks.end(), std::greater<>());
    const std::size_t threshold = keep == 0 ? std::numeric_limits<std::size_t>::max()
                                            : ranks[std::min(keep, ranks.size()) - 1];
    std::vector<XY> out;
    for (PointId id : line) {
        const Point& p = set.points[id];
        if (p.locked || (keep > 0 && pos[id] >= threshold)) out.push_back({p.x, p.y});
    }
    return out;
}

// The greedy order (preprocess/deletion.h) of the whole point set as one block, with the given
// river keys (BAI, or none): deletion position per point id as above; a merged duplicate takes
// its vertex's position, a vertex never deleted the maximum.
bool greedyPositions(const PointSet& set, const BaiKeys& keys,
                     std::vector<std::size_t>& pos, std::string& error) {
    Cdt cdt;
    if (!buildCdt(set, {}, cdt, error)) return false;
    DeletionOptions options;
    options.paperError = false;
    DeletionRecords records;
    if (!runGreedyDeletion(set, cdt, keys, options, records, error)) return false;
    pos.assign(set.points.size(), std::numeric_limits<std::size_t>::max());
    for (std::size_t i = 0; i < records.steps.size(); ++i)
        pos[records.steps[i].vertex] = i;
    for (PointId id = 0; id < set.points.size(); ++id)
        pos[id] = pos[cdt.representative[id]];
    return true;
}

// How both rankings are computed, from the file's build info.
struct Rankings {
    bool greedy = false, byThreshold = false;
    ImportanceOptions withBai, plain;
    int row = -1;  // greedy with a fixed BAI row: its index in the table
};

// Deletion positions of one block's points with and without BAI (as positions() above).
bool rankBoth(const PointSet& set, const Rankings& k, std::vector<std::size_t>& posBai,
              std::vector<std::size_t>& posPlain, std::string& error) {
    if (k.greedy) {
        const BaiKeys keys = k.byThreshold ? BaiKeys::byThreshold(set, k.withBai.baiTable)
                                           : BaiKeys(baiFactors(set, k.withBai.baiTable, k.row));
        return greedyPositions(set, keys, posBai, error) &&
               greedyPositions(set, {}, posPlain, error);
    }
    ImportanceResult rBai, rPlain;
    if (!computeImportance(set, k.withBai, rBai, error) ||
        !computeImportance(set, k.plain, rPlain, error))
        return false;
    posBai = positions(set, rBai);
    posPlain = positions(set, rPlain);
    return true;
}

// Adds one block's river pieces to `rows` (sums: the caller divides the means at the end).
void addPieces(const PointSet& set, const std::vector<std::size_t>& posBai,
               const std::vector<std::size_t>& posPlain, const std::vector<double>& bounds,
               const std::vector<double>& budgets, std::vector<RiverRow>& rows) {
    const int classes = int(bounds.size());
    for (const Polyline& line : set.rivers) {
        std::size_t unlocked = 0;
        double meanZ = 0;
        std::vector<XY> original;
        for (PointId id : line) {
            const Point& p = set.points[id];
            unlocked += !p.locked;
            meanZ += p.z / double(line.size());
            original.push_back({p.x, p.y});
        }
        if (unlocked == 0) continue;
        int c = 0;
        while (c + 1 < classes && meanZ >= bounds[std::size_t(c) + 1])
            ++c;
        for (std::size_t b = 0; b < budgets.size(); ++b) {
            RiverRow& r = rows[std::size_t(c) * budgets.size() + b];
            const std::size_t keep = std::size_t(std::lround(r.budget * double(unlocked)));
            const std::vector<XY> a = simplified(set, line, posBai, keep);
            const std::vector<XY> p = simplified(set, line, posPlain, keep);
            const double hb = hausdorff2D(original, a, kHausdorffSamples);
            const double hp = hausdorff2D(original, p, kHausdorffSamples);
            r.rivers += 1;
            r.originalPoints += line.size();
            r.keptPoints += a.size();
            r.meanBai += hb;
            r.meanPlain += hp;
            r.maxBai = std::max(r.maxBai, hb);
            r.maxPlain = std::max(r.maxPlain, hp);
            r.baiBetter += hb < hp;
            r.plainBetter += hp < hb;
        }
    }
}

void addRows(const std::vector<RiverRow>& from, std::vector<RiverRow>& into) {
    for (std::size_t i = 0; i < into.size(); ++i) {
        RiverRow& r = into[i];
        const RiverRow& f = from[i];
        r.rivers += f.rivers;
        r.originalPoints += f.originalPoints;
        r.keptPoints += f.keptPoints;
        r.meanBai += f.meanBai;
        r.meanPlain += f.meanPlain;
        r.maxBai = std::max(r.maxBai, f.maxBai);
        r.maxPlain = std::max(r.maxPlain, f.maxPlain);
        r.baiBetter += f.baiBetter;
        r.plainBetter += f.plainBetter;
    }
}

}  // namespace

bool compareRivers(const ReportOptions& options, const std::string& buildInfo,
                   std::vector<RiverRow>& rows, std::string& error) {
    const auto say = [&](const std::string& s) {
        if (options.progress) options.progress(s);
    };
    // The build's own ingestion (ingest.h) with the options it recorded, cut into the build's
    // blocks (3ddp locks the outer edge): each block's order is computed as the build computes
    // it, so the memory and time are those of a block, not of the whole DEM.
    const nlohmann::json info = nlohmann::json::parse(buildInfo, nullptr, false);
    IngestOptions in = ingestOptionsFromInfo(info);
    if (!options.demPath.empty()) in.demPath = options.demPath;
    if (!options.riversPath.empty()) in.riversPath = options.riversPath;
    // A raster larger than the memory: refused (report has no --no-memory-check).
    in.demMemoryBytes = memoryBound(0, in.demMemoryWhat);
    in.demMemorySkippable = false;
    // A terrain-only build (no RIVERS): nothing to compare.
    if (options.riversPath.empty() && info.is_object() && info.contains("rivers") &&
        info.at("rivers") == "") {
        rows.clear();
        return true;
    }
    if (in.demPath.empty() || in.riversPath.empty()) {
        error = options.path +
                ": its build info names no DEM / rivers; give --dem and --rivers (or --no-rivers)";
        return false;
    }
    // The file's own order (a file without the key predates the greedy order: 3ddp) and block
    // size (without it, the build's default), checked against the exact grid as the build does.
    Rankings k;
    k.greedy = infoValue<std::string>(info, "order", "3ddp") == "greedy";
    int blockSize = std::clamp(infoValue<int>(info, "block_size", 0), 0, kWholeDem);
    Ingested data;
    BlockSource source;
    const auto split = [&] {
        const DemGrid& dem = data.dem;
        if (!checkCellsFitExactGrid(dem, in.stride, error)) {
            error = "DEM '" + in.demPath + "': " + error;
            return false;
        }
        if (blockSize == 0) blockSize = automaticBlockSize(dem, in.stride);
        if (!checkBlockFitsExactGrid(dem, in.stride, blockSize, error)) {
            error =
                "DEM '" + in.demPath + "': the model's block size does not fit it (" + error + ")";
            return false;
        }
        return splitIntoBlocks(data, in, blockSize, !k.greedy, source, error);
    };
    if (!ingest(in, data, error) || !split()) {
        // Where the inputs came from: the options, or the file's build info (then the option
        // that overrides it).
        const bool dem = !options.demPath.empty(), rivers = !options.riversPath.empty();
        const std::string named = "named by the build info of " + options.path;
        if (dem && rivers)
            error += " (the inputs given by --dem and --rivers)";
        else if (dem)
            error += " (the DEM given by --dem; the rivers " + named + ", override with --rivers)";
        else if (rivers)
            error += " (the rivers given by --rivers; the DEM " + named + ", override with --dem)";
        else
            error += " (the inputs " + named + "; override with --dem / --rivers)";
        return false;
    }

    const std::string tablePath = infoValue<std::string>(info, "bai_table", "");
    if (!tablePath.empty() && !BaiTable::load(tablePath, k.withBai.baiTable, error)) return false;
    // "threshold": the greedy order's C by threshold (bai.h BaiKeys); else a row.
    k.byThreshold = info.is_object() && info.contains("bai_row") && info["bai_row"].is_string();
    k.withBai.baiRow =
        k.byThreshold ? kDefaultBaiRow : infoValue<double>(info, "bai_row", kDefaultBaiRow);
    k.plain = k.withBai;
    k.plain.useBai = false;
    if (k.greedy && !k.byThreshold) {
        k.row = k.withBai.baiTable.findRow(k.withBai.baiRow);
        if (k.row < 0) {
            error = options.path + ": the BAI table has no row for its build's threshold";
            return false;
        }
    }

    const std::vector<double> bounds = k.withBai.baiTable.classLowerBounds.empty()
                                           ? std::vector<double>{0, 500, 1000}
                                           : k.withBai.baiTable.classLowerBounds;
    const int classes = int(bounds.size());
    std::vector<RiverRow> empty;
    for (int c = 0; c < classes; ++c) {
        for (double f : options.budgets) {
            RiverRow r;
            r.landformClass = c;
            r.classLow = bounds[std::size_t(c)];
            r.classHigh = c + 1 < classes ? bounds[std::size_t(c) + 1]
                                          : std::numeric_limits<double>::infinity();
            r.budget = f;
            empty.push_back(r);
        }
    }

    // Blocks with river pieces, each ranked both ways on a worker; the sums are added in block
    // order, so the rows do not depend on the thread count.
    std::vector<std::size_t> blocks;
    for (std::size_t b = 0; b < source.blockCount(); ++b) {
        if (source.hasDomain(b)) blocks.push_back(b);
    }
    say("rivers, BAI vs no BAI: ranking " + std::to_string(blocks.size()) + " blocks of " +
        std::to_string(blockSize) + " cells");
    std::vector<std::vector<RiverRow>> perBlock(blocks.size());
    std::vector<std::string> errors(blocks.size());
    std::mutex mutex;
    std::size_t done = 0;
    engine::WorkerPool pool(options.threads);
    pool.run(blocks.size(), [&](std::size_t i) {
        const PointSet set = source.points(blocks[i]);
        if (!set.rivers.empty()) {
            std::vector<std::size_t> posBai, posPlain;
            if (rankBoth(set, k, posBai, posPlain, errors[i])) {
                perBlock[i] = empty;
                addPieces(set, posBai, posPlain, bounds, options.budgets, perBlock[i]);
            }
        }
        std::lock_guard lock(mutex);
        ++done;
        if (options.progressCount) options.progressCount(done, blocks.size());
    });
    rows = empty;
    for (std::size_t i = 0; i < blocks.size(); ++i) {
        if (!errors[i].empty()) {
            const BlockRect& r = source.rect(blocks[i]);
            error = options.path + ": river comparison, block (" + std::to_string(r.col) + "," +
                    std::to_string(r.row) + "): " + errors[i];
            return false;
        }
        if (!perBlock[i].empty()) addRows(perBlock[i], rows);
    }
    for (RiverRow& r : rows) {
        if (r.rivers > 0) {
            r.meanBai /= double(r.rivers);
            r.meanPlain /= double(r.rivers);
        }
    }
    return true;
}

}  // namespace unilod::report
