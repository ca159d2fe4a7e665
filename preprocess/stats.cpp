// The paper's Tables 2 and 3 for a .ulod file (stats.h; paper §3.4 Eq. 11, §4.2.1).
#include "stats.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <numbers>

#include <mutex>

#include "cut.h"
#include "numtext.h"
#include "ulod.h"
#include "workers.h"

namespace unilod {

bool parseDistance(const std::string& text, double& metres) {
    std::string s = text;
    while (!s.empty() && s.back() == ' ')
        s.pop_back();
    double scale = 1.0;
    if (s.size() > 2 && s.compare(s.size() - 2, 2, "km") == 0) {
        scale = 1000.0;
        s.resize(s.size() - 2);
    } else if (s.size() > 1 && s.back() == 'm') {
        s.pop_back();
    }
    while (!s.empty() && s.back() == ' ')
        s.pop_back();
    double v = 0;
    // The number as strict as every option's (no hexadecimal, finite), and finite in metres too
    // (1e308km overflows).
    if (!format::parseFiniteNumber(s, v) || !std::isfinite(v * scale)) return false;
    metres = v * scale;
    return true;
}

std::string statsCsv(const StatsTable& t) {
    std::string s =
        "view_distance_m,pixels,hlim_edge_m,hlim_corner_m,hlim_middle_m,points,"
        "river_bound_edges,triangles,retention_percent,nodes\n";
    char buf[512];
    for (const StatsRow& r : t.rows) {
        std::snprintf(buf, sizeof buf, "%.17g,%.17g,%.17g,%.17g,%.17g,%llu,%llu,%llu,%.17g,%llu\n",
                      r.distance, r.pixels, r.hEdge, r.hCorner, r.hMiddle,
                      static_cast<unsigned long long>(r.points),
                      static_cast<unsigned long long>(r.riverEdges),
                      static_cast<unsigned long long>(r.triangles), r.retention,
                      static_cast<unsigned long long>(r.nodes));
        s += buf;
    }
    return s;
}

namespace {

// Index in `blocks` of the block at (col, row), or of the nearest stored one.
std::size_t findBlock(const std::vector<format::BlockInfo>& blocks, std::uint32_t col,
                      std::uint32_t row) {
    std::size_t best = 0;
    long bestDistance = -1;
    for (std::size_t i = 0; i < blocks.size(); ++i) {
        if (blocks[i].level != 0) continue;  // leaves only
        const long d =
            std::labs(long(blocks[i].col) - long(col)) + std::labs(long(blocks[i].row) - long(row));
        if (bestDistance < 0 || d < bestDistance) {
            best = i;
            bestDistance = d;
        }
    }
    return best;
}

// The model as the cut sees it, from the directory alone (format version 5: boxes, tree links,
// levels, outline flags), and, read only for the nodes a cut draws, each one's per-step errors
// and counts (the exact step k* of its h_lim). `stats` of a 16M-point model read and decoded
// every block first (20 s on one core); the far views of Tables 2/3 draw a few nodes.
struct StepCounts {
    std::vector<float> error;  // chosen metric, steps + 1 entries
    std::vector<float> river;  // the `max` metric's river part (empty for `paper`)
    std::vector<std::uint32_t> triangles, riverEdges;  // per step k = 0..steps
};
struct Model {
    format::Reader reader;
    std::uint32_t metric = 0;
    std::vector<engine::LodNode> nodes;  // point into reader.blocks()' levels
    std::vector<StepCounts> steps;       // read by `stepsOf` (empty until then)
};

// Opens `path` and resolves the metric (0: the file's default).
bool openModel(const std::string& path, std::uint32_t requestedMetric, Model& m,
               std::string& error) {
    if (!m.reader.open(path, error)) return false;
    const format::Header& h = m.reader.header();
    const std::vector<format::BlockInfo>& infos = m.reader.blocks();
    if (!format::resolveMetric(h, path, requestedMetric, m.metric, error)) return false;
    if (infos.empty()) {
        error = "'" + path + "': the file has no blocks";
        return false;
    }
    for (const format::BlockInfo& info : infos)
        m.nodes.push_back(engine::lodNode(info));
    m.steps.assign(infos.size(), {});
    return true;
}

// Node i's per-step errors and counts, read from its block once. Safe to call concurrently for
// different i (Reader::readBlock reads with pread).
bool stepsOf(Model& m, std::size_t i, std::string& error) {
    StepCounts& s = m.steps[i];
    if (!s.error.empty()) return true;
    format::Block b;
    if (!m.reader.readBlock(i, b, error)) return false;
    s.error = m.metric == format::kMetricPaper ? b.errorPaper : b.errorMax;
    if (m.metric != format::kMetricPaper) s.river = b.errorRiver;
    if (b.levels.empty() || s.error.size() != b.steps.size() + 1) {
        error = "'" + m.reader.path() + "': " + format::blockName(b.col, b.row, b.level) +
                " has no full-resolution level or error table";
        s.error.clear();
        return false;
    }
    s.triangles.push_back(b.levels[0].triangleCount);
    s.riverEdges.push_back(b.levels[0].riverCount);
    for (const format::Step& step : b.steps) {
        s.triangles.push_back(step.trianglesAlive);
        s.riverEdges.push_back(step.riverEdgesAlive);
    }
    return true;
}

// Reads the steps of every node the cuts draw that is not read yet, on `reading.threads`
// threads, one block a task: on a 4M-point model `stats --error 1,5,10,50` read its blocks one by
// one for 8.5 s without a word (until 2026-12-03). The first failing block in file order names
// the error, so the message does not depend on the threads.
bool readSteps(Model& m, const std::vector<std::vector<engine::NodeChoice>>& cuts,
               const StatsReading& reading, std::string& error) {
    std::vector<std::size_t> missing;
    std::vector<char> wanted(m.steps.size(), 0);
    for (const auto& cut : cuts)
        for (const engine::NodeChoice& choice : cut)
            if (m.steps[choice.block].error.empty() && !wanted[choice.block]) {
                wanted[choice.block] = 1;
                missing.push_back(choice.block);
            }
    std::sort(missing.begin(), missing.end());
    std::vector<std::string> errors(missing.size());
    std::size_t done = 0;
    std::mutex progressMutex;
    engine::WorkerPool pool(missing.size() <= 1 ? 1 : reading.threads);
    if (reading.progress) reading.progress(0, missing.size());
    pool.run(missing.size(), [&](std::size_t t) {
        stepsOf(m, missing[t], errors[t]);
        if (reading.progress) {  // counted under the lock: the counts rise one by one
            const std::lock_guard<std::mutex> lock(progressMutex);
            reading.progress(++done, missing.size());
        }
    });
    for (std::string& e : errors) {
        if (!e.empty()) {
            error = std::move(e);
            return false;
        }
    }
    return true;
}

// The cut of `view` through the file's tree (engine/lod/cut.h) and, per drawn node, the counts
// of its exact step k* for the node's h_lim (the nodes' steps read by readSteps).
struct CutCounts {
    std::uint64_t points = 0, riverEdges = 0, triangles = 0, nodes = 0;
};
void countCut(const std::vector<engine::NodeChoice>& cut, const Model& m, CutCounts& c) {
    c = {};
    c.nodes = cut.size();
    for (const engine::NodeChoice& choice : cut) {
        const StepCounts& s = m.steps[choice.block];
        const std::size_t k = engine::exactStep(s.error, choice.hLim, s.river, choice.hLimRiver);
        c.points += m.reader.blocks()[choice.block].vertexCount - k;
        c.riverEdges += s.riverEdges[k];
        c.triangles += s.triangles[k];
    }
}

}  // namespace

engine::ViewSpec statsView(const format::Header& header, const StatsOptions& options,
                           double distance, double pixels) {
    engine::ViewSpec v;
    v.kind = engine::ViewSpec::Kind::Camera;
    v.camera.eye[0] = 0.5 * (header.minX + header.maxX);
    v.camera.eye[1] = 0.5 * (header.minY + header.maxY);
    v.camera.eye[2] = header.maxZ + distance;
    v.camera.pitchDegrees = -90;
    v.camera.fovDegrees = options.fovDegrees;
    v.direction = false;  // S to the block centre, Eq. 11 as it stands
    v.distance = engine::DistanceMode::Centre;
    v.heightPixels = options.heightPixels;
    v.widthPixels = options.heightPixels * 16.0 / 9.0;
    v.pixels = pixels;
    return v;
}

bool computeStats(const std::string& path, const StatsOptions& o, StatsTable& table,
                  std::string& error, const StatsReading& reading) {
    table = {};
    if (!(o.fovDegrees > 0 && o.fovDegrees < 180)) {
        error = "field of view must be in (0, 180) degrees";
        return false;
    }
    if (!(o.heightPixels >= 1)) {
        error = "viewport height must be at least 1 pixel";
        return false;
    }
    for (double d : o.distances) {
        if (!(d > 0 && std::isfinite(d))) {
            error = "view distances must be positive";
            return false;
        }
    }
    for (double p : o.pixels) {
        if (!(p > 0 && std::isfinite(p))) {
            error = "pixel tolerances must be positive";
            return false;
        }
    }

    Model m;
    if (!openModel(path, o.metric, m, error)) return false;
    table.metric = m.metric;
    const format::Header& h = m.reader.header();
    const std::vector<format::BlockInfo>& infos = m.reader.blocks();
    table.blocksX = h.blocksX;
    table.blocksY = h.blocksY;
    for (const format::BlockInfo& info : infos)
        if (info.level == 0) table.fullPoints += info.vertexCount;

    const std::size_t corner = findBlock(infos, 0, 0);
    const std::uint32_t midCol = h.blocksX > 0 ? (h.blocksX - 1) / 2 : 0;
    const std::uint32_t midRow = h.blocksY > 0 ? (h.blocksY - 1) / 2 : 0;
    const std::size_t edge = findBlock(infos, midCol, 0);
    const std::size_t middle = findBlock(infos, midCol, midRow);
    table.cornerCol = infos[corner].col;
    table.cornerRow = infos[corner].row;
    table.edgeCol = infos[edge].col;
    table.edgeRow = infos[edge].row;
    table.middleCol = infos[middle].col;
    table.middleRow = infos[middle].row;

    std::vector<std::vector<engine::NodeChoice>> cuts;
    for (double d : o.distances) {
        for (double p : o.pixels) {
            cuts.emplace_back();
            engine::selectCut(statsView(h, o, d, p), m.nodes, m.metric, cuts.back());
        }
    }
    if (!readSteps(m, cuts, reading, error)) return false;
    std::size_t cutIndex = 0;
    for (double d : o.distances) {
        for (double p : o.pixels) {
            StatsRow row;
            row.distance = d;
            row.pixels = p;
            const engine::ViewSpec view = statsView(h, o, d, p);
            auto limit = [&](std::size_t i) { return engine::nodeTolerance(view, m.nodes[i]); };
            row.hEdge = limit(edge);
            row.hCorner = limit(corner);
            row.hMiddle = limit(middle);
            CutCounts c;
            countCut(cuts[cutIndex++], m, c);
            row.points = c.points;
            row.riverEdges = c.riverEdges;
            row.triangles = c.triangles;
            row.nodes = c.nodes;
            row.retention =
                table.fullPoints > 0 ? 100.0 * double(row.points) / double(table.fullPoints) : 0.0;
            table.rows.push_back(row);
        }
    }
    return true;
}

bool computeErrorStats(const std::string& path, const std::vector<double>& errors,
                       std::uint32_t metric, ErrorStatsTable& table, std::string& error,
                       const StatsReading& reading) {
    table = {};
    for (double e : errors) {
        if (!(e >= 0 && std::isfinite(e))) {
            error = "model error thresholds must be finite and >= 0";
            return false;
        }
    }
    Model m;
    if (!openModel(path, metric, m, error)) return false;
    table.metric = m.metric;
    for (const format::BlockInfo& info : m.reader.blocks()) {
        if (info.level != 0) continue;
        table.blocks += 1;
        table.fullPoints += info.vertexCount;
        table.fullTriangles += info.fullTriangles;
    }
    table.nodes = m.nodes.size() - table.blocks;
    std::vector<std::vector<engine::NodeChoice>> cuts;
    for (double e : errors) {
        engine::ViewSpec view;
        view.kind = engine::ViewSpec::Kind::Uniform;
        view.hLim = e;
        cuts.emplace_back();
        engine::selectCut(view, m.nodes, table.metric, cuts.back());
    }
    if (!readSteps(m, cuts, reading, error)) return false;
    for (std::size_t r = 0; r < errors.size(); ++r) {
        const double e = errors[r];
        const std::vector<engine::NodeChoice>& cut = cuts[r];
        ErrorStatsRow row;
        row.error = e;
        row.nodes = cut.size();
        for (const engine::NodeChoice& choice : cut) {
            const StepCounts& s = m.steps[choice.block];
            const std::vector<format::Level>& levels = m.reader.blocks()[choice.block].levels;
            const std::size_t k = engine::exactStep(s.error, e);
            row.exactPoints += m.reader.blocks()[choice.block].vertexCount - k;
            row.exactTriangles += s.triangles[k];
            const format::Level& level = levels[format::storedLevelFor(levels, table.metric, e)];
            row.levelPoints += level.vertexCount;
            row.levelTriangles += level.triangleCount;
        }
        table.rows.push_back(row);
    }
    return true;
}

}  // namespace unilod
