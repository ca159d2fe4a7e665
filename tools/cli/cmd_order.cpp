// `unilod order DEM [RIVERS]`: the importance order of the improved 3D_DP (paper §2, §3.1) on real
// data: ingest the DEM and the rivers exactly as `unilod build` does (preprocess/ingest.h), take
// the point set of ONE block covering the DEM as `build --order 3ddp` makes it (the DEM's outer
// edge locked), rank it, print a summary (text or JSON) and optionally the deletion order as CSV
// (-o; an existing CSV needs --overwrite: outputopts.h). Progress on stderr (progress.h).
//
// Errors name the file and the problem on stderr and exit with 1; the CSV goes through a
// format::AtomicFile moved into place only after everything succeeded, so a failed run leaves no
// partial output.
#include <ogr_spatialref.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "atomicfile.h"
#include "bai.h"
#include "build.h"
#include "commands.h"
#include "importance.h"
#include "ingest.h"
#include "ingestopts.h"
#include "jsontext.h"
#include "numbers.h"
#include "outputopts.h"
#include "progress.h"

namespace unilod::cli {

namespace {

using nlohmann::json;
using Clock = std::chrono::steady_clock;

struct OrderOptions {
    IngestOptions in;  // shared with `build` (ingestopts.h)
    bool noBai = false;
    double baiRow = kDefaultBaiRow;
    std::string baiTable;
    MemoryFlags memory;
    std::string tempDir;  // --temp-dir (build.h spillFolder)
    OutputFlags out;
    JsonFlags json;
    bool quiet = false;
};

double secondsSince(Clock::time_point t) {
    return std::chrono::duration<double>(Clock::now() - t).count();
}

json quantiles(std::vector<double> v) {
    if (v.empty()) return json{{"count", 0}};
    std::sort(v.begin(), v.end());
    const auto at = [&](double q) {
        return v[static_cast<std::size_t>(std::lround(q * static_cast<double>(v.size() - 1)))];
    };
    return json{{"count", v.size()},
                {"min", v.front()},
                {"median", at(0.5)},
                {"p90", at(0.9)},
                {"max", v.back()}};
}

json pointJson(const PointSet& set, PointId id) {
    if (id == kNoPoint) return nullptr;
    const Point& p = set.points[id];
    return json{{"id", id}, {"x", p.x}, {"y", p.y}, {"z", p.z}};
}

void printText(const json& s, std::FILE* out) {
    const auto& in = s["input"];
    const auto& pts = s["points"];
    std::fprintf(out, "unilod order summary\n");
    std::fprintf(out, "  DEM            %s (%d x %d cells, %s)\n",
                 in["dem"].get<std::string>().c_str(), in["width"].get<int>(),
                 in["height"].get<int>(), in["crs"].get<std::string>().c_str());
    const std::string rivers = in["rivers"].get<std::string>();
    std::fprintf(out, "  rivers         %s\n",
                 rivers.empty() ? "none (terrain only)" : rivers.c_str());
    std::fprintf(out, "  DEM points     %zu (stride %d, %zu dropped next to rivers)\n",
                 pts["dem"].get<std::size_t>(), in["stride"].get<int>(),
                 pts["demDroppedNearRivers"].get<std::size_t>());
    std::fprintf(out, "  river points   %zu in %zu polylines\n", pts["river"].get<std::size_t>(),
                 pts["polylines"].get<std::size_t>());
    std::fprintf(out, "  locked points  %zu\n", pts["locked"].get<std::size_t>());
    for (const char* k : {"O", "A", "B"}) {
        const auto& p = s["basePlane"][k];
        if (p.is_null()) {
            std::fprintf(out, "  %s              none\n", k);
        } else {
            std::fprintf(out, "  %s              id %u (%.3f, %.3f, %.3f)\n", k,
                         p["id"].get<unsigned>(), p["x"].get<double>(), p["y"].get<double>(),
                         p["z"].get<double>());
        }
    }
    std::fprintf(out, "  chain length   %zu\n", s["chainLength"].get<std::size_t>());
    std::fprintf(out, "  BAI            %s\n",
                 s["bai"]["enabled"].get<bool>()
                     ? ("on, row " + jsonText(s["bai"]["row"]) + " m").c_str()
                     : "off (plain 3D_DP)");
    for (const char* k : {"dem", "river"}) {
        const auto& q = s["importance"][k];
        if (q["count"].get<std::size_t>() == 0) {
            std::fprintf(out, "  importance %-5s (no ranked points)\n", k);
            continue;
        }
        std::fprintf(out,
                     "  importance %-5s min %.3f  median %.3f  p90 %.3f  max %.3f  (%zu points)\n",
                     k, q["min"].get<double>(), q["median"].get<double>(), q["p90"].get<double>(),
                     q["max"].get<double>(), q["count"].get<std::size_t>());
    }
    std::fprintf(out, "  bends          %zu\n", s["bends"]["count"].get<std::size_t>());
    if (!s["bends"]["top"].empty()) {
        std::fprintf(out,
                     "  largest BAI    polyline        W (m)        L (m)       S (m2)   mean z"
                     "        BAI      C\n");
        for (const auto& b : s["bends"]["top"]) {
            std::fprintf(out, "                 %8zu %12.1f %12.1f %12.0f %8.1f %10.3f %6.2f\n",
                         b["polyline"].get<std::size_t>(), b["W"].get<double>(),
                         b["L"].get<double>(), b["S"].get<double>(), b["meanZ"].get<double>(),
                         b["bai"].get<double>(), b["c"].get<double>());
        }
    }
    if (s.contains("output")) {
        std::fprintf(out, "  output         %s (%zu rows)\n",
                     s["output"].get<std::string>().c_str(), s["outputRows"].get<std::size_t>());
    }
    std::fprintf(out, "  total          %.2f s\n", s["seconds"]["total"].get<double>());
}

int runOrder(const OrderOptions& o) {
    const Clock::time_point start = Clock::now();
    std::string error;
    auto fail = [&](const std::string& message) {
        std::fprintf(stderr, "unilod order: %s\n", message.c_str());
        return 1;
    };
    // Fail fast on an existing or unwritable output (or one of the inputs) before the long work.
    if (!checkTempDir(o.tempDir, error)) return fail(error);
    // `-o -`: the CSV on stdout, the summary on stderr (none with -q).
    const bool csvStdout = o.out.path == "-";
    if (csvStdout && o.json.requested()) {
        std::fprintf(stderr, "unilod order: -o - and --json both write to stdout: give one\n");
        return 2;
    }
    const std::string csvPath = csvStdout ? std::string() : o.out.path;
    format::AtomicFile csv;
    format::OutputOptions output = outputOptions(o.out, {});
    addInputFiles(output, o.in.demPath, o.in.riversPath);  // every file of each (ingest.h)
    if (!o.baiTable.empty()) output.inputs.push_back(o.baiTable);
    if (!csvPath.empty() && !csv.open(csvPath, output, error)) return fail(error);
    Progress bar("order", !o.quiet, "ingest");
    // Each stage's result as a line of its own (what the stage found), then the next stage.
    auto progress = [&](const char* stage, double seconds, const std::string& detail) {
        if (!o.quiet) {
            char line[64];
            std::snprintf(line, sizeof line, "  %-16s %7.2f s  ", stage, seconds);
            bar.message(line + detail);
        }
    };

    ImportanceOptions io;
    io.useBai = !o.noBai;
    io.baiRow = o.baiRow;
    if (!o.baiTable.empty()) {
        if (!BaiTable::load(o.baiTable, io.baiTable, error)) return fail(error);
        if (io.baiTable.findRow(o.baiRow) < 0) {
            return fail("BAI table '" + o.baiTable + "': no row for threshold " +
                        jsonText(json(o.baiRow)) + " m (--bai-row)");
        }
    }
    const int baiRowIndex = io.baiTable.findRow(o.baiRow);

    json seconds;
    Clock::time_point t = Clock::now();
    IngestOptions in = o.in;
    in.warn = [&bar](const std::string& w) { bar.message("unilod order: warning: " + w); };
    if (o.memory.check) in.demMemoryBytes = memoryBound(o.memory.limitBytes(), in.demMemoryWhat);
    // As in `build`: at --stride > 1 a raster too large for the memory is read through a
    // temporary file (dem.h CellAllocator), and only the lattice is kept once the river heights
    // are sampled.
    in.demBaseBytes = kBuildBaseBytes;
    in.demSpillDir = spillFolder(o.tempDir, csvPath, in.demMemoryWhat);
    Ingested data;
    if (!ingest(in, data, error)) return fail(error);
    const DemGrid& dem = data.dem;
    seconds["ingest"] = secondsSince(t);
    const std::string crs =
        dem.wkt.empty() ? "none (coordinates used as they are)" : crsDisplayName(dem.wkt);
    char cells[160];
    std::snprintf(cells, sizeof cells, "%d x %d cells of %.2f x %.2f, ", dem.width, dem.height,
                  std::abs(dem.cellX), std::abs(dem.cellY));
    std::string conversions;
    for (const std::string& c : dem.conversions)
        conversions += "; " + c;
    progress("ingest", seconds["ingest"],
             cells + crs + ", " + std::to_string(data.rivers.size()) + " river lines" +
                 conversions);

    // One block covering the DEM, its outer edge locked: the point set `build --order 3ddp`
    // ranks when the DEM is one block.
    t = Clock::now();
    bar.stage("point set");
    std::uint64_t riverVertices = 0;
    for (const RiverLine& line : data.rivers)
        riverVertices += line.size();
    if (o.memory.check && !checkMemory(o.in.demPath,
                                       pointMemory(sampledDemPoints(data, in.stride), riverVertices,
                                                   kOrderBytesPerPoint, in.stride),
                                       o.memory.limitBytes(), "rank as one block", error))
        return fail(error);
    BlockSource source;
    if (!splitIntoBlocks(data, in, kWholeDem, true, source, error)) return fail(error);
    data.dem.keepLattice(in.stride);
    const PointSet set = source.points(0);
    seconds["pointSet"] = secondsSince(t);
    std::size_t demPoints = 0, riverPoints = 0, locked = 0, unlocked = 0;
    for (const Point& p : set.points) {
        (p.kind == PointKind::Dem ? demPoints : riverPoints) += 1;
        (p.locked ? locked : unlocked) += 1;
    }
    progress("point set", seconds["pointSet"],
             std::to_string(demPoints) + " DEM + " + std::to_string(riverPoints) +
                 " river points, " + std::to_string(set.rivers.size()) + " polylines, " +
                 std::to_string(locked) + " locked");
    if (unlocked == 0) {
        return fail("DEM '" + o.in.demPath + "': no point to rank (all points locked)");
    }

    t = Clock::now();
    bar.stage("importance");
    ImportanceResult result;
    if (!computeImportance(set, io, result, error)) return fail(error);
    seconds["importance"] = secondsSince(t);
    progress("importance", seconds["importance"],
             std::string(io.useBai ? "improved 3D_DP with BAI" : "plain 3D_DP") + ", " +
                 std::to_string(result.order.size()) + " points ranked");

    // Bends, for the summary (the importance already used them through the BAI factors).
    t = Clock::now();
    bar.stage("bends");
    const Quantizer quantizer = Quantizer::forPoints(set.points);
    struct RankedBend {
        std::size_t polyline;
        Bend bend;
    };
    std::vector<RankedBend> bends;
    for (std::size_t i = 0; i < set.rivers.size(); ++i) {
        for (const Bend& b :
             computeBends(set.points, set.rivers[i], quantizer, io.baiTable, baiRowIndex)) {
            bends.push_back({i, b});
        }
    }
    const std::size_t top = std::min<std::size_t>(5, bends.size());
    std::partial_sort(bends.begin(), bends.begin() + static_cast<std::ptrdiff_t>(top), bends.end(),
                      [](const RankedBend& a, const RankedBend& b) {
                          if (a.bend.bai != b.bend.bai) return a.bend.bai > b.bend.bai;
                          return a.polyline != b.polyline ? a.polyline < b.polyline
                                                          : a.bend.first < b.bend.first;
                      });
    seconds["bends"] = secondsSince(t);
    progress("bends", seconds["bends"], std::to_string(bends.size()) + " bends");

    json summary;
    summary["input"] = {{"dem", o.in.demPath},
                        {"rivers", o.in.riversPath},
                        {"crs", crs},
                        {"dem_conversions", dem.conversions},
                        {"width", dem.width},
                        {"height", dem.height},
                        {"stride", o.in.stride},
                        {"cellX", dem.cellX},
                        {"cellY", dem.cellY},
                        {"riverClearance", o.in.riverClearance},
                        {"riverCleaning", describe(data.cleaning)}};
    summary["points"] = {
        {"dem", demPoints},     {"demDroppedNearRivers", source.stats().droppedDemPoints},
        {"river", riverPoints}, {"polylines", set.rivers.size()},
        {"locked", locked},     {"ranked", result.order.size()}};
    summary["basePlane"] = {{"O", pointJson(set, result.origin)},
                            {"A", pointJson(set, result.anchor)},
                            {"B", pointJson(set, result.floating)}};
    summary["chainLength"] = result.chain.size();
    summary["bai"] = {{"enabled", io.useBai},
                      {"row", o.baiRow},
                      {"table", o.baiTable.empty() ? "paper Table 1" : o.baiTable}};
    std::vector<double> demImportance, riverImportance;
    for (PointId id : result.order) {
        const double v = result.importance[id];
        if (!std::isfinite(v)) continue;  // O, A, B: always kept
        (set.points[id].kind == PointKind::Dem ? demImportance : riverImportance).push_back(v);
    }
    summary["importance"] = {{"dem", quantiles(std::move(demImportance))},
                             {"river", quantiles(std::move(riverImportance))}};
    json topBends = json::array();
    for (std::size_t i = 0; i < top; ++i) {
        const Bend& b = bends[i].bend;
        topBends.push_back({{"polyline", bends[i].polyline},
                            {"first", b.first},
                            {"last", b.last},
                            {"W", b.width},
                            {"L", b.length},
                            {"S", b.area},
                            {"meanZ", b.meanZ},
                            {"bai", b.bai},
                            {"c", b.c}});
    }
    summary["bends"] = {{"count", bends.size()}, {"top", topBends}};

    if (!o.out.path.empty()) {
        t = Clock::now();
        bar.stage("write CSV", result.order.size());
        // Written in chunks of about 1 MiB: the order of a large DEM is gigabytes of text.
        const auto writeCsv = [&](const std::string& text) {
            if (!csvStdout) return csv.write(text, error);
            if (std::fwrite(text.data(), 1, text.size(), stdout) == text.size()) return true;
            error = "stdout: " + std::string(std::strerror(errno));
            return false;
        };
        std::string chunk = "rank,id,x,y,z,kind,locked,importance,own_importance,bai_factor\n";
        char line[256];
        for (std::size_t rank = 0; rank < result.order.size(); ++rank) {
            const PointId id = result.order[rank];
            const Point& p = set.points[id];
            std::snprintf(line, sizeof line, "%zu,%u,%.3f,%.3f,%.3f,%s,%d,%.17g,%.17g,%.9g\n",
                          rank, id, p.x, p.y, p.z, p.kind == PointKind::Dem ? "dem" : "river",
                          p.locked ? 1 : 0, result.importance[id], result.ownImportance[id],
                          static_cast<double>(result.baiFactor[id]));
            chunk += line;
            if (chunk.size() >= (1u << 20)) {
                bar.update(rank + 1, result.order.size());
                if (!writeCsv(chunk)) return fail(error);
                chunk.clear();
            }
        }
        if (!writeCsv(chunk)) return fail(error);
        if (csvStdout ? std::fflush(stdout) != 0 : !csv.commit(error))
            return fail(csvStdout ? "stdout: " + std::string(std::strerror(errno)) : error);
        seconds["csv"] = secondsSince(t);
        progress("write CSV", seconds["csv"], csvStdout ? "stdout" : o.out.path);
        summary["output"] = csvStdout ? "stdout" : o.out.path;
        summary["outputRows"] = result.order.size();
    }
    summary["importanceStats"] = {{"maxDepth", result.stats.maxDepth},
                                  {"meanDepth", result.stats.meanDepth}};
    seconds["total"] = secondsSince(start);
    summary["seconds"] = seconds;
    bar.finish();

    if (o.json.requested()) {
        std::printf("%s\n", jsonText(summary, 2).c_str());
    } else if (!csvStdout) {
        printText(summary, stdout);
    } else if (!o.quiet) {
        printText(summary, stderr);
    }
    return 0;
}

}  // namespace

void addOrderCommand(CLI::App& app, int& exitCode) {
    auto opts = std::make_shared<OrderOptions>();
    CLI::App* sub = app.add_subcommand(
        "order", "Importance order of a DEM + river network (improved 3D_DP with BAI)");
    addIngestOptions(*sub, opts->in);
    sub->add_flag("--no-bai", opts->noBai, "Plain 3D_DP without the bending adjustment index");
    addMemoryOptions(*sub, opts->memory, "ranking");
    sub->add_option("--temp-dir", opts->tempDir,
                    "folder of the temporary file that holds a raster larger than the memory "
                    "while it is read at --stride > 1 (4 bytes a cell, deleted once read; "
                    "default: the output's folder, else the working folder)");
    CLI::Option* table =
        sub->add_option("--bai-table", opts->baiTable, "BAI constants table file (Table 1 format)");
    // Without a table file the row must be one of the paper's: checked while parsing.
    const BaiTable paper = BaiTable::paperDefault();
    sub->add_option("--bai-row", opts->baiRow,
                    "Simplification-threshold row of the BAI table, metres")
        ->capture_default_str()
        ->check(CLI::Validator(
            [paper, table](std::string& value) -> std::string {
                double v = 0;
                try {
                    std::size_t used = 0;
                    v = std::stod(value, &used);
                    if (used != value.size()) return "not a number: " + value;
                } catch (const std::exception&) {
                    return "not a number: " + value;
                }
                if (table->count() > 0 || paper.findRow(v) >= 0) return "";
                std::string rows;
                for (const auto& r : paper.rows) {
                    rows += (rows.empty() ? "" : ", ") + jsonText(json(r.threshold));
                }
                return "no such row in the paper's table (rows: " + rows + ")";
            },
            "ROW", "bai-row"));
    addOutputOptions(sub, opts->out,
                     "write the deletion order as CSV (rank ascending); '-': on stdout, the "
                     "summary then on stderr",
                     false, true);
    addJsonOption(sub, opts->json, "print the summary as JSON on stdout ('-', the default)");
    addQuietFlag(sub, opts->quiet);
    sub->callback([opts, &exitCode] { exitCode = runOrder(*opts); });
}

}  // namespace unilod::cli
