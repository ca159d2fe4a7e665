// `unilod report` (report.h): runs the pieces and writes the folder.
#include "report.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

#include "ingest.h"
#include "jsontext.h"
#include "pngwrite.h"
#include "ulod.h"

namespace unilod::report {

namespace {

namespace fs = std::filesystem;

std::string fmt(const char* f, double v) {
    char buf[64];
    std::snprintf(buf, sizeof buf, f, v);
    return buf;
}

std::string fmtU(std::uint64_t v) { return std::to_string(v); }

// Inside the report's temporary folder (runReport): nothing else writes there.
const format::OutputOptions kInTempFolder{.replace = true, .inputs = {}, .inputParts = {}};

// Lists a file written into the report (report.json's "files"): only names isReportFileName
// knows, what --overwrite may replace (reportForeignPart).
void recordFile(ReportSummary& summary, const std::string& name) {
    assert(isReportFileName(name));
    summary.files.push_back(name);
}

bool writeText(const fs::path& dir, const std::string& name, const std::string& text,
               ReportSummary& summary, std::string& error) {
    if (!format::writeFileAtomically((dir / name).string(), text, kInTempFolder, error)) {
        return false;
    }
    recordFile(summary, name);
    return true;
}


std::string tablesMd(const StatsTable& t, const std::string& path) {
    std::ostringstream s;
    s << "# Tables 2 / 3: " << path << "\n\n"
      << "Metric: " << format::metricName(t.metric) << "; " << t.blocksX << " x " << t.blocksY
      << " blocks; corner (" << t.cornerCol << "," << t.cornerRow << "), edge (" << t.edgeCol << ","
      << t.edgeRow << "), middle (" << t.middleCol << "," << t.middleRow << "); " << t.fullPoints
      << " points at full resolution. Definitions: preprocess/stats.h (same as `unilod "
         "stats`).\n\n"
      << "Counts are those of the cut of the view through the block hierarchy, each drawn node "
         "at its EXACT deletion step k* (the largest step whose error fits its h_lim). The grid "
         "diagrams (report.md, grid.csv) draw the same nodes at the STORED level the engine "
         "draws (the stored level with the largest step <= k*: the levels are a subset of the "
         "steps), so their points and triangles are at least these for the same distance and "
         "the first pixel tolerance.\n\n"
      << "| View distance (km) | Pixel tolerance | h_lim edge (m) | h_lim corner (m) | h_lim "
         "middle (m) | Points | River bound edges | Triangles | Retention (%) |\n"
      << "|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n";
    for (const StatsRow& r : t.rows) {
        s << "| " << fmt("%g", r.distance / 1000) << " | " << fmt("%g", r.pixels) << " | "
          << fmt("%.2f", r.hEdge) << " | " << fmt("%.2f", r.hCorner) << " | "
          << fmt("%.2f", r.hMiddle) << " | " << r.points << " | " << r.riverEdges << " | "
          << r.triangles << " | " << fmt("%.1f", r.retention) << " |\n";
    }
    return s.str();
}

std::string curvesCsv(const ReportSummary& s) {
    std::string out = "retention_percent";
    if (s.hasMax) out += ",max_metric_max_over_blocks_m,max_metric_mean_over_blocks_m";
    if (s.hasPaper) out += ",paper_metric_max_over_blocks_m,paper_metric_mean_over_blocks_m";
    out += "\n";
    for (const CurvePoint& p : s.curve) {
        out += fmt("%g", p.retention);
        if (s.hasMax) out += fmt(",%.9g", p.maxOfMax) + fmt(",%.9g", p.meanOfMax);
        if (s.hasPaper) out += fmt(",%.9g", p.maxOfPaper) + fmt(",%.9g", p.meanOfPaper);
        out += "\n";
    }
    return out;
}

// Hand-written SVG: retention (%) on x, error (m, log10) on y; solid = mean over blocks,
// dashed = max over blocks; red = metric "max", blue = metric "paper".
std::string curvesSvg(const ReportSummary& s) {
    const double W = 800, H = 500, left = 80, right = 200, top = 30, bottom = 60;
    double lo = HUGE_VAL, hi = 0;
    for (const CurvePoint& p : s.curve) {
        for (double v : {s.hasMax ? p.maxOfMax : 0.0, s.hasMax ? p.meanOfMax : 0.0,
                         s.hasPaper ? p.maxOfPaper : 0.0, s.hasPaper ? p.meanOfPaper : 0.0}) {
            if (v > 0) {
                lo = std::min(lo, v);
                hi = std::max(hi, v);
            }
        }
    }
    if (!(hi > 0)) {
        lo = 1e-3;
        hi = 1;
    }
    const double d0 = std::floor(std::log10(lo)), d1 = std::max(d0 + 1, std::ceil(std::log10(hi)));
    const double pw = W - left - right, ph = H - top - bottom;
    auto X = [&](double r) { return left + r / 100.0 * pw; };
    auto Y = [&](double v) {
        const double l = v > 0 ? std::max(std::log10(v), d0) : d0;
        return top + ph - (l - d0) / (d1 - d0) * ph;
    };
    std::ostringstream o;
    o << "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" << W << "\" height=\"" << H
      << "\" font-family=\"sans-serif\" font-size=\"12\">\n"
      << "<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n"
      << "<text x=\"" << left << "\" y=\"18\" font-size=\"14\">Model error vs retention "
      << "(aggregated over blocks)</text>\n";
    for (double d = d0; d <= d1 + 1e-9; d += 1) {
        const double y = top + ph - (d - d0) / (d1 - d0) * ph;
        o << "<line x1=\"" << left << "\" y1=\"" << y << "\" x2=\"" << left + pw << "\" y2=\""
          << y << "\" stroke=\"#ddd\"/>\n"
          << "<text x=\"" << left - 6 << "\" y=\"" << y + 4 << "\" text-anchor=\"end\">"
          << fmt("%g", std::pow(10.0, d)) << "</text>\n";
    }
    for (int r = 0; r <= 100; r += 20) {
        o << "<line x1=\"" << X(r) << "\" y1=\"" << top << "\" x2=\"" << X(r) << "\" y2=\""
          << top + ph << "\" stroke=\"#ddd\"/>\n"
          << "<text x=\"" << X(r) << "\" y=\"" << top + ph + 16 << "\" text-anchor=\"middle\">"
          << r << "</text>\n";
    }
    o << "<rect x=\"" << left << "\" y=\"" << top << "\" width=\"" << pw << "\" height=\"" << ph
      << "\" fill=\"none\" stroke=\"black\"/>\n"
      << "<text x=\"" << left + pw / 2 << "\" y=\"" << H - 20
      << "\" text-anchor=\"middle\">Retention (% of each block's points)</text>\n"
      << "<text transform=\"translate(22," << top + ph / 2
      << ") rotate(-90)\" text-anchor=\"middle\">Model error (m, log scale)</text>\n";
    struct Series {
        bool present;
        double CurvePoint::*field;
        const char* colour;
        bool dashed;
        const char* label;
    };
    const Series series[] = {
        {s.hasMax, &CurvePoint::meanOfMax, "#c0392b", false, "max metric, mean"},
        {s.hasMax, &CurvePoint::maxOfMax, "#c0392b", true, "max metric, max"},
        {s.hasPaper, &CurvePoint::meanOfPaper, "#2155c4", false, "paper metric, mean"},
        {s.hasPaper, &CurvePoint::maxOfPaper, "#2155c4", true, "paper metric, max"},
    };
    int legend = 0;
    for (const Series& ser : series) {
        if (!ser.present) continue;
        o << "<polyline fill=\"none\" stroke=\"" << ser.colour << "\" stroke-width=\"1.5\""
          << (ser.dashed ? " stroke-dasharray=\"6,4\"" : "") << " points=\"";
        for (const CurvePoint& p : s.curve)
            o << fmt("%.2f", X(p.retention)) << "," << fmt("%.2f", Y(p.*ser.field)) << " ";
        o << "\"/>\n";
        const double ly = top + 20 + 20 * legend++;
        o << "<line x1=\"" << left + pw + 15 << "\" y1=\"" << ly << "\" x2=\"" << left + pw + 45
          << "\" y2=\"" << ly << "\" stroke=\"" << ser.colour << "\" stroke-width=\"1.5\""
          << (ser.dashed ? " stroke-dasharray=\"6,4\"" : "") << "/>\n"
          << "<text x=\"" << left + pw + 50 << "\" y=\"" << ly + 4 << "\">" << ser.label
          << "</text>\n";
    }
    o << "</svg>\n";
    return o.str();
}

std::string classLabel(const RiverRow& r) {
    return std::isinf(r.classHigh) ? fmt(">= %g m", r.classLow)
                                   : fmt("%g", r.classLow) + fmt("-%g m", r.classHigh);
}

std::string riversCsv(const std::vector<RiverRow>& rows) {
    std::string s =
        "class,altitude_low_m,altitude_high_m,budget_percent,rivers,original_points,kept_points,"
        "mean_hausdorff_bai_m,mean_hausdorff_plain_m,max_hausdorff_bai_m,max_hausdorff_plain_m,"
        "rivers_bai_better,rivers_plain_better\n";
    for (const RiverRow& r : rows) {
        s += std::to_string(r.landformClass) + fmt(",%g", r.classLow) +
             (std::isinf(r.classHigh) ? std::string(",inf") : fmt(",%g", r.classHigh)) +
             fmt(",%g", r.budget * 100) + "," + fmtU(r.rivers) + "," + fmtU(r.originalPoints) +
             "," + fmtU(r.keptPoints) + fmt(",%.6f", r.meanBai) + fmt(",%.6f", r.meanPlain) +
             fmt(",%.6f", r.maxBai) + fmt(",%.6f", r.maxPlain) + "," + fmtU(r.baiBetter) + "," +
             fmtU(r.plainBetter) + "\n";
    }
    return s;
}

std::string riversMd(const std::vector<RiverRow>& rows) {
    std::ostringstream s;
    s << "# BAI vs no BAI: river shapes at equal point budgets\n\n"
      << "Symmetric 2D Hausdorff distance (m) between each simplified river piece and the "
         "original piece: the rivers as the build's blocks hold them, cut at block borders. "
         "Budget = share of a piece's unlocked points kept (ends, border crossings and junctions "
         "always kept), the highest-ranked of the block's deletion order computed with and "
         "without BAI. Landform class by the piece's mean vertex altitude (Table 1 classes); "
         "the CSV's `rivers` columns count pieces. Definitions: tools/report/report.h.\n\n"
      << "| Landform class | Budget (%) | Pieces | Points kept / original | Mean BAI (m) | Mean "
         "plain (m) | Max BAI (m) | Max plain (m) | BAI better | Plain better |\n"
      << "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n";
    for (const RiverRow& r : rows) {
        if (r.rivers == 0) continue;
        s << "| " << classLabel(r) << " | " << fmt("%g", r.budget * 100) << " | " << r.rivers
          << " | " << r.keptPoints << " / " << r.originalPoints << " | " << fmt("%.2f", r.meanBai)
          << " | " << fmt("%.2f", r.meanPlain) << " | " << fmt("%.2f", r.maxBai) << " | "
          << fmt("%.2f", r.maxPlain) << " | " << r.baiBetter << " | " << r.plainBetter << " |\n";
    }
    bool any = false;
    for (const RiverRow& r : rows)
        any = any || r.rivers > 0;
    if (!any) s << "\n(no river with points to simplify)\n";
    return s.str();
}

constexpr std::uint32_t kPlotWidth = 900, kPlotHeight = 480;

std::string frameTimesCsv(const FrameTimes& t) {
    std::string s = "frame";
    std::size_t frames = 0;
    for (std::size_t r = 0; r < t.runs.size(); ++r) {
        s += "," + t.runs[r] + "_frame_ms";
        frames = std::max(frames, t.ms[r].size());
    }
    s += "\n";
    for (std::size_t i = 0; i < frames; ++i) {
        s += std::to_string(i);
        for (const std::vector<double>& ms : t.ms)
            s += i < ms.size() ? fmt(",%.6f", ms[i]) : std::string(",");
        s += "\n";
    }
    return s;
}

// The grid diagrams' table, next to the tables' counts for the same D, and what differs.
void gridSection(std::ostringstream& md, const ReportSummary& summary) {
    md << "## Grid diagrams (top-down, levels drawn at view distance D)\n\n"
       << "Each diagram draws the cut of the stats view (the nodes tables.md counts) with every "
          "node at the stored level the engine draws; tables.md counts each node at its exact "
          "deletion step k*, which usually lies between two stored levels: the engine draws the "
          "finer one (the largest stored step <= k*), so the diagrams' points and triangles are "
          "larger than or equal to tables.md's (columns \"tables.md\").\n\n"
       << "| D (km) | P (px) | Image | Nodes | Points | Triangles | Triangle edges | River edges "
          "| Points (tables.md) | Triangles (tables.md) |\n"
       << "|---:|---:|---|---:|---:|---:|---:|---:|---:|---:|\n";
    for (const GridDiagram& g : summary.grids) {
        std::string tablePoints = "-", tableTriangles = "-";
        for (const StatsRow& r : summary.table.rows) {
            if (r.distance == g.distance && r.pixels == g.pixels) {
                tablePoints = fmtU(r.points);
                tableTriangles = fmtU(r.triangles);
                break;
            }
        }
        md << "| " << fmt("%g", g.distance / 1000) << " | " << fmt("%g", g.pixels) << " | ["
           << g.file << "](" << g.file << ") | " << g.nodes << " | " << g.points << " | "
           << g.triangles << " | " << g.triangleEdges << " | " << g.riverEdges << " | "
           << tablePoints << " | " << tableTriangles << " |\n";
    }
    // Diagrams that draw the same nodes at the same levels are the same wireframe.
    std::vector<bool> told(summary.grids.size(), false);
    for (std::size_t i = 0; i < summary.grids.size(); ++i) {
        if (told[i]) continue;
        std::string same;
        for (std::size_t k = i + 1; k < summary.grids.size(); ++k) {
            if (summary.grids[k].drawn == summary.grids[i].drawn) {
                told[k] = true;
                same += (same.empty() ? "" : ", ") + fmt("%g km", summary.grids[k].distance / 1000);
            }
        }
        if (same.empty()) continue;
        md << "\nD = " << fmt("%g km", summary.grids[i].distance / 1000) << " and " << same
           << " draw the same nodes at the same stored levels: the wireframes are identical, "
              "only the titles differ (h_lim moved between the same two stored levels, or past "
              "a node's coarsest one, without changing the level drawn). "
              "tables.md can still differ between these distances: it counts the exact step.\n";
    }
    md << "\n";
    for (const GridDiagram& g : summary.grids)
        md << "![D = " << fmt("%g km", g.distance / 1000) << "](" << g.file << ")\n";
}

void frameTimeSection(std::ostringstream& md, const FrameTimes& t) {
    md << "\n## Frame time along a camera path\n\n"
       << "`unilod bench` (engine/bench.h) runs lod, resident, bare and full on " << t.device
       << " at " << t.width << "x" << t.height << ", cameras: " << t.cameras
       << ". Frame time = wall-clock interval between successive submissions. lod streams "
          "without waiting: until the loader delivers, it draws the coarse fallback (compare its "
          "triangles with resident's, the same level choice preloaded).\n\n"
       << "| Run | Median frame (ms) | Triangles (last frame) |\n|---|---:|---:|\n";
    for (std::size_t r = 0; r < t.runs.size(); ++r)
        md << "| " << t.runs[r] << " | " << fmt("%.3f", t.medianMs[r]) << " | " << t.triangles[r]
           << " |\n";
    md << "\n![frame time](frametime.png)\n";
}

std::string gridName(double distance) {
    return "grid_" + fmt("%g", distance / 1000) + "km.png";
}

}  // namespace

bool isReportFileName(const std::string& name) {
    static const std::set<std::string> kNames{
        "report.json", "report.md",   "tables.csv",    "tables.md",     "curves.csv",
        "curves.svg",  "rivers.csv",  "rivers.md",     "grid.csv",      "frametime.png",
        "frametime.csv"};
    if (kNames.count(name) != 0) return true;
    // gridName: "grid_" + a %g number + "km.png".
    const std::string head = "grid_", tail = "km.png";
    if (name.size() <= head.size() + tail.size() || name.rfind(head, 0) != 0 ||
        name.compare(name.size() - tail.size(), tail.size(), tail) != 0)
        return false;
    const std::string number = name.substr(head.size(), name.size() - head.size() - tail.size());
    return number.find_first_not_of("0123456789.e+-") == std::string::npos;
}

std::function<std::string(const fs::directory_entry&)> reportForeignPart(
    const std::string& folder) {
    std::set<std::string> ours;
    // A regular file of a report's size only (a FIFO would block the read).
    const fs::path path = fs::path(folder) / "report.json";
    std::error_code ec;
    if (fs::is_regular_file(fs::symlink_status(path, ec)) &&
        fs::file_size(path, ec) <= (16u << 20) && !ec) {
        std::ifstream in(path, std::ios::binary);
        const nlohmann::json j = nlohmann::json::parse(in, nullptr, false);
        if (j.is_object() && j.contains("source") && j["source"].is_string() &&
            j.contains("files") && j["files"].is_array()) {
            ours = {"report.json", "report.md"};
            for (const nlohmann::json& f : j["files"])
                if (f.is_string() && isReportFileName(f.get<std::string>()))
                    ours.insert(f.get<std::string>());
        }
    }
    return [ours = std::move(ours)](const fs::directory_entry& entry) -> std::string {
        std::string name = entry.path().filename().string();
        std::error_code e;
        if (ours.count(name) != 0 && entry.is_regular_file(e) && !entry.is_symlink(e))
            return "";
        return name;
    };
}

format::OutputOptions reportInputs(const ReportOptions& o) {
    format::OutputOptions inputs{.replace = false, .inputs = {o.path}, .inputParts = {}};
    if (!o.benchPath.empty()) inputs.inputs.push_back(o.benchPath);
    std::string dem = o.demPath, rivers = o.riversPath;
    format::Reader reader;
    std::string ignored;
    if (o.rivers && (dem.empty() || rivers.empty()) && reader.open(o.path, ignored)) {
        // The inputs compareRivers takes from the build info (rivercompare.cpp).
        const nlohmann::json info =
            nlohmann::json::parse(reader.header().buildInfo, nullptr, false);
        const IngestOptions in = ingestOptionsFromInfo(info);
        if (dem.empty()) dem = in.demPath;
        if (rivers.empty()) rivers = in.riversPath;
        const auto table = info.is_object() ? info.find("bai_table") : info.end();
        if (info.is_object() && table != info.end() && table->is_string() &&
            !table->get<std::string>().empty())
            inputs.inputs.push_back(table->get<std::string>());
    }
    addInputFiles(inputs, dem, rivers);  // every file of each (ingest.h)
    return inputs;
}

bool runReport(const ReportOptions& o, ReportSummary& summary, std::string& error) {
    summary = {};
    const auto say = [&](const std::string& s) {
        if (o.progress) o.progress(s);
    };
    // The folder is written as a temporary folder beside it and moved into place at the end
    // (AtomicFile::openFolder): an existing non-empty folder is refused now and stays untouched.
    const format::OutputOptions output = reportInputs(o);
    if (!format::checkOutputPath(o.outDir, output, true, error)) return false;
    if (o.imageSize < 16 || o.imageSize > 16384) {
        error = "image size must be in 16..16384";
        return false;
    }
    if (o.benchFrames > 0 && (o.benchWidth == 0 || o.benchHeight == 0 || o.benchWidth > 16384 ||
                              o.benchHeight > 16384)) {
        error = "benchmark size must be in 1..16384";
        return false;
    }
    for (std::size_t i = 0; i < o.stats.distances.size(); ++i) {
        for (std::size_t k = 0; k < i; ++k) {
            if (gridName(o.stats.distances[i]) == gridName(o.stats.distances[k])) {
                error = "view distance " + fmt("%g m", o.stats.distances[i]) + " listed twice";
                return false;
            }
        }
    }
    format::Reader reader;
    if (!reader.open(o.path, error)) return false;
    const std::string buildInfo = reader.header().buildInfo;

    say("tables 2/3");
    if (!computeStats(o.path, o.stats, summary.table, error, {o.threads, o.progressCount}))
        return false;
    say("error vs retention curves");
    if (!computeCurve(o.path, summary.curve, summary.hasMax, summary.hasPaper, error,
                      {o.threads, o.progressCount}))
        return false;
    if (o.rivers) {
        say("rivers, BAI vs no BAI: reading the DEM and the rivers");
        if (!compareRivers(o, buildInfo, summary.rivers, error)) return false;
    }

    if (o.benchFrames > 0) {
        say("frame times along a camera path (bench: lod, resident, bare, full)");
        if (!measureFrameTimes(o, summary.frameTimes, error)) return false;
    }

    // Everything computed: write into a temporary folder, move it into place at the end.
    format::AtomicFile folder;
    if (!folder.openFolder(o.outDir, output, error)) return false;
    const fs::path temp = folder.tempPath();

    std::vector<std::uint8_t> rgba;
    for (double d : o.stats.distances) {
        say("grid diagram at " + fmt("%g km", d / 1000));
        GridDiagram g;
        if (!renderGrid(o.path, o.stats, d, o.imageSize, o.annotate, rgba, g, error))
            return false;
        g.file = gridName(d);
        if (!format::writePng((temp / g.file).string(), o.imageSize, o.imageSize, rgba,
                              kInTempFolder, error))
            return false;
        recordFile(summary, g.file);
        summary.grids.push_back(g);
    }

    if (!writeText(temp, "tables.csv", statsCsv(summary.table), summary, error) ||
        !writeText(temp, "tables.md", tablesMd(summary.table, o.path), summary, error) ||
        !writeText(temp, "curves.csv", curvesCsv(summary), summary, error) ||
        !writeText(temp, "curves.svg", curvesSvg(summary), summary, error)) {
        return false;
    }
    if (o.rivers && (!writeText(temp, "rivers.csv", riversCsv(summary.rivers), summary, error) ||
                     !writeText(temp, "rivers.md", riversMd(summary.rivers), summary, error))) {
        return false;
    }
    std::string grid =
        "view_distance_m,pixels,file,nodes,points,triangles,triangle_edges,river_edges\n";
    for (const GridDiagram& g : summary.grids) {
        grid += fmt("%.17g", g.distance) + fmt(",%.17g", g.pixels) + "," + g.file + "," +
                fmtU(g.nodes) + "," + fmtU(g.points) + "," + fmtU(g.triangles) + "," +
                fmtU(g.triangleEdges) + "," + fmtU(g.riverEdges) + "\n";
    }
    if (!writeText(temp, "grid.csv", grid, summary, error)) return false;

    const FrameTimes& ft = summary.frameTimes;
    if (!ft.runs.empty()) {
        plotFrameTimes(ft, kPlotWidth, kPlotHeight, rgba);
        if (!format::writePng((temp / "frametime.png").string(), kPlotWidth, kPlotHeight, rgba,
                              kInTempFolder, error))
            return false;
        recordFile(summary, "frametime.png");
        if (!writeText(temp, "frametime.csv", frameTimesCsv(ft), summary, error)) return false;
    }

    nlohmann::json j;
    j["source"] = o.path;
    j["metric"] = format::metricName(summary.table.metric);
    j["grids"] = nlohmann::json::array();
    for (const GridDiagram& g : summary.grids) {
        j["grids"].push_back({{"distance_m", g.distance},
                              {"pixels", g.pixels},
                              {"file", g.file},
                              {"nodes", g.nodes},
                              {"points", g.points},
                              {"triangles", g.triangles},
                              {"triangle_edges", g.triangleEdges},
                              {"river_edges", g.riverEdges}});
    }
    j["rivers"] = nlohmann::json::array();
    for (const RiverRow& r : summary.rivers) {
        j["rivers"].push_back({{"class", r.landformClass},
                               {"altitude_low_m", r.classLow},
                               {"budget", r.budget},
                               {"rivers", r.rivers},
                               {"mean_hausdorff_bai_m", r.meanBai},
                               {"mean_hausdorff_plain_m", r.meanPlain},
                               {"max_hausdorff_bai_m", r.maxBai},
                               {"max_hausdorff_plain_m", r.maxPlain}});
    }
    if (!ft.runs.empty()) {
        nlohmann::json runs = nlohmann::json::object();
        for (std::size_t r = 0; r < ft.runs.size(); ++r)
            runs[ft.runs[r]] = {{"frame_ms", ft.ms[r]}, {"median_frame_ms", ft.medianMs[r]}};
        j["frame_times"] = {{"device", ft.device},
                            {"size", {ft.width, ft.height}},
                            {"cameras", ft.cameras},
                            {"runs", runs}};
    }
    j["files"] = summary.files;  // the files above; report.json and report.md come last
    if (!writeText(temp, "report.json", jsonText(j, 2) + "\n", summary, error)) return false;

    std::ostringstream md;
    md << "# unilod report: " << o.path << "\n\n"
       << "- [tables.md](tables.md), [tables.csv](tables.csv): the paper's Tables 2 / 3 "
          "(`unilod stats`)\n"
       << "- [curves.svg](curves.svg), [curves.csv](curves.csv): model error vs retention, both "
          "metrics\n";
    if (o.rivers) {
        md << "- [rivers.md](rivers.md), [rivers.csv](rivers.csv): BAI vs no BAI, 2D "
              "Hausdorff distance at equal point budgets by landform class\n";
    }
    if (!ft.runs.empty()) {
        md << "- [frametime.png](frametime.png), [frametime.csv](frametime.csv): frame time per "
              "frame along a camera path (`unilod bench` runs lod, resident, bare, full)\n";
    }
    md << "- [grid.csv](grid.csv), [report.json](report.json): the numbers\n\n";
    gridSection(md, summary);
    if (!ft.runs.empty()) frameTimeSection(md, ft);
    md << "\n![error vs retention](curves.svg)\n";
    if (!writeText(temp, "report.md", md.str(), summary, error)) return false;

    return folder.commit(error);
}

}  // namespace unilod::report
