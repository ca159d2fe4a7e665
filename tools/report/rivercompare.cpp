// BAI vs no BAI river shapes at equal point budgets (report.h; paper §2.2, Table 1), in the
// file's deletion order: greedy with and without the BAI weights, or 3ddp vs plain 3D_DP.
#include <algorithm>
#include <cmath>
#include <limits>
#include <nlohmann/json.hpp>

#include "bai.h"
#include "cdt.h"
#include "deletion.h"
#include "importance.h"
#include "ingest.h"
#include "report.h"

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

}  // namespace

bool compareRivers(const ReportOptions& options, const std::string& buildInfo,
                   std::vector<RiverRow>& rows, std::string& error) {
    const auto say = [&](const std::string& s) {
        if (options.progress) options.progress(s);
    };
    // The build's own ingestion (ingest.h) with the options it recorded, and the point set of
    // one block covering the DEM as the build's order makes it (3ddp locks the outer edge).
    const nlohmann::json info = nlohmann::json::parse(buildInfo, nullptr, false);
    IngestOptions in = ingestOptionsFromInfo(info);
    if (!options.demPath.empty()) in.demPath = options.demPath;
    if (!options.riversPath.empty()) in.riversPath = options.riversPath;
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
    // The file's own order (a file without the key predates the greedy order: 3ddp).
    const bool greedy = infoValue<std::string>(info, "order", "3ddp") == "greedy";
    Ingested data;
    BlockSource source;
    if (!ingest(in, data, error) || !splitIntoBlocks(data, in, kWholeDem, !greedy, source, error)) {
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
    const PointSet set = source.points(0);
    say("rivers: " + std::to_string(set.rivers.size()) + " polylines, " +
        std::to_string(set.points.size()) + " points; importance with and without BAI");

    ImportanceOptions withBai;
    const std::string tablePath = infoValue<std::string>(info, "bai_table", "");
    if (!tablePath.empty() && !BaiTable::load(tablePath, withBai.baiTable, error)) return false;
    // "threshold": the greedy order's C by threshold (bai.h BaiKeys); else a row.
    const bool byThreshold = info.is_object() && info.contains("bai_row") &&
                             info["bai_row"].is_string();
    withBai.baiRow = byThreshold ? kDefaultBaiRow : infoValue<double>(info, "bai_row", kDefaultBaiRow);
    ImportanceOptions plain = withBai;
    plain.useBai = false;
    std::vector<std::size_t> posBai, posPlain;
    if (greedy && byThreshold) {
        if (!greedyPositions(set, BaiKeys::byThreshold(set, withBai.baiTable), posBai, error) ||
            !greedyPositions(set, {}, posPlain, error))
            return false;
    } else if (greedy) {
        const int row = withBai.baiTable.findRow(withBai.baiRow);
        if (row < 0) {
            error = options.path + ": the BAI table has no row for its build's threshold";
            return false;
        }
        if (!greedyPositions(set, BaiKeys(baiFactors(set, withBai.baiTable, row)), posBai, error) ||
            !greedyPositions(set, {}, posPlain, error))
            return false;
    } else {
        ImportanceResult rBai, rPlain;
        if (!computeImportance(set, withBai, rBai, error)) return false;
        if (!computeImportance(set, plain, rPlain, error)) return false;
        posBai = positions(set, rBai);
        posPlain = positions(set, rPlain);
    }

    const std::vector<double> bounds = withBai.baiTable.classLowerBounds.empty()
                                           ? std::vector<double>{0, 500, 1000}
                                           : withBai.baiTable.classLowerBounds;
    const int classes = int(bounds.size());
    rows.clear();
    for (int c = 0; c < classes; ++c) {
        for (double f : options.budgets) {
            RiverRow r;
            r.landformClass = c;
            r.classLow = bounds[std::size_t(c)];
            r.classHigh = c + 1 < classes ? bounds[std::size_t(c) + 1]
                                          : std::numeric_limits<double>::infinity();
            r.budget = f;
            rows.push_back(r);
        }
    }
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
        for (std::size_t b = 0; b < options.budgets.size(); ++b) {
            RiverRow& r = rows[std::size_t(c) * options.budgets.size() + b];
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
    for (RiverRow& r : rows) {
        if (r.rivers > 0) {
            r.meanBai /= double(r.rivers);
            r.meanPlain /= double(r.rivers);
        }
    }
    return true;
}

}  // namespace unilod::report
