// The paper's Tables 2 and 3 for a .ulod file (stats.h; paper §3.4 Eq. 11, §4.2.1).
#include "stats.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <numbers>

#include "ulod.h"

namespace unilod {

double screenErrorLimit(double pixels, double distance, double fovDegrees, double heightPixels) {
    const double alpha = fovDegrees * std::numbers::pi / 180.0;
    return 2.0 * pixels * distance * std::tan(alpha / 2.0) / heightPixels;
}

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
    if (s.empty() || s.front() == ' ') return false;
    char* end = nullptr;
    const double v = std::strtod(s.c_str(), &end);
    if (end != s.c_str() + s.size() || !std::isfinite(v)) return false;
    metres = v * scale;
    return true;
}

namespace {

// Index in `blocks` of the block at (col, row), or of the nearest stored one.
std::size_t findBlock(const std::vector<format::BlockInfo>& blocks, std::uint32_t col,
                      std::uint32_t row) {
    std::size_t best = 0;
    long bestDistance = -1;
    for (std::size_t i = 0; i < blocks.size(); ++i) {
        const long d =
            std::labs(long(blocks[i].col) - long(col)) + std::labs(long(blocks[i].row) - long(row));
        if (bestDistance < 0 || d < bestDistance) {
            best = i;
            bestDistance = d;
        }
    }
    return best;
}

// What the stats need of one block: its centre and, per step, the counts of that state.
struct BlockSummary {
    double cx = 0, cy = 0, cz = 0;
    std::vector<float> error;  // chosen metric, steps + 1 entries
    std::uint32_t vertexCount = 0;
    std::vector<std::uint32_t> triangles, riverEdges;  // per step k = 0..steps
    std::vector<format::Level> levels;                 // the stored levels
};

// k* = the largest k with error[k] <= limit (0 when even error[0] exceeds it). Errors are
// non-decreasing: the states within the tolerance are a prefix.
std::size_t exactStep(const std::vector<float>& error, double limit) {
    const auto it = std::upper_bound(error.begin(), error.end(), limit,
                                     [](double v, float e) { return v < double(e); });
    return it == error.begin() ? 0 : std::size_t(it - error.begin()) - 1;
}

// Opens `path`, resolves the metric (0: the file's default) and reads every block's summary.
bool loadSummaries(const std::string& path, std::uint32_t requestedMetric, format::Reader& reader,
                   std::uint32_t& metric, std::vector<BlockSummary>& blocks, std::string& error) {
    if (!reader.open(path, error)) return false;
    const format::Header& h = reader.header();
    const std::vector<format::BlockInfo>& infos = reader.blocks();
    metric = requestedMetric != 0 ? requestedMetric : h.defaultMetric;
    if ((h.metrics & metric) == 0 ||
        (metric != format::kMetricMax && metric != format::kMetricPaper)) {
        error = "'" + path + "': the file does not store the " +
                std::string(metric == format::kMetricPaper ? "paper" : "max") + " error metric";
        return false;
    }
    if (infos.empty()) {
        error = "'" + path + "': the file has no blocks";
        return false;
    }
    blocks.assign(infos.size(), {});
    format::Block b;
    for (std::size_t i = 0; i < infos.size(); ++i) {
        if (!reader.readBlock(i, b, error)) return false;
        BlockSummary& s = blocks[i];
        s.cx = 0.5 * (b.minX + b.maxX);
        s.cy = 0.5 * (b.minY + b.maxY);
        s.cz = 0.5 * (b.minZ + b.maxZ);
        s.error = metric == format::kMetricPaper ? b.errorPaper : b.errorMax;
        s.vertexCount = std::uint32_t(b.vertices.size());
        if (b.levels.empty() || s.error.size() != b.steps.size() + 1) {
            error = "'" + path + "': block (" + std::to_string(b.col) + "," +
                    std::to_string(b.row) + ") has no full-resolution level or error table";
            return false;
        }
        s.triangles.push_back(b.levels[0].triangleCount);
        s.riverEdges.push_back(b.levels[0].riverCount);
        for (const format::Step& step : b.steps) {
            s.triangles.push_back(step.trianglesAlive);
            s.riverEdges.push_back(step.riverEdgesAlive);
        }
        s.levels = std::move(b.levels);
    }
    return true;
}

}  // namespace

bool computeStats(const std::string& path, const StatsOptions& o, StatsTable& table,
                  std::string& error) {
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

    format::Reader reader;
    std::vector<BlockSummary> blocks;
    if (!loadSummaries(path, o.metric, reader, table.metric, blocks, error)) return false;
    const format::Header& h = reader.header();
    const std::vector<format::BlockInfo>& infos = reader.blocks();
    table.blocksX = h.blocksX;
    table.blocksY = h.blocksY;
    for (const BlockSummary& s : blocks)
        table.fullPoints += s.vertexCount;

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

    const double eyeX = 0.5 * (h.minX + h.maxX), eyeY = 0.5 * (h.minY + h.maxY);
    for (double d : o.distances) {
        const double eyeZ = h.maxZ + d;
        std::vector<double> s(blocks.size());
        for (std::size_t i = 0; i < blocks.size(); ++i) {
            s[i] = std::hypot(blocks[i].cx - eyeX, blocks[i].cy - eyeY, blocks[i].cz - eyeZ);
        }
        for (double p : o.pixels) {
            StatsRow row;
            row.distance = d;
            row.pixels = p;
            auto limit = [&](std::size_t i) {
                return screenErrorLimit(p, s[i], o.fovDegrees, o.heightPixels);
            };
            row.hEdge = limit(edge);
            row.hCorner = limit(corner);
            row.hMiddle = limit(middle);
            for (std::size_t i = 0; i < blocks.size(); ++i) {
                const BlockSummary& bs = blocks[i];
                const double hlim = limit(i);
                const std::size_t k = exactStep(bs.error, hlim);
                row.points += bs.vertexCount - k;
                row.riverEdges += bs.riverEdges[k];
                row.triangles += bs.triangles[k];
            }
            row.retention =
                table.fullPoints > 0 ? 100.0 * double(row.points) / double(table.fullPoints) : 0.0;
            table.rows.push_back(row);
        }
    }
    return true;
}

bool computeErrorStats(const std::string& path, const std::vector<double>& errors,
                       std::uint32_t metric, ErrorStatsTable& table, std::string& error) {
    table = {};
    for (double e : errors) {
        if (!(e >= 0 && std::isfinite(e))) {
            error = "model error thresholds must be finite and >= 0";
            return false;
        }
    }
    format::Reader reader;
    std::vector<BlockSummary> blocks;
    if (!loadSummaries(path, metric, reader, table.metric, blocks, error)) return false;
    table.blocks = blocks.size();
    for (const BlockSummary& s : blocks) {
        table.fullPoints += s.vertexCount;
        table.fullTriangles += s.triangles[0];
    }
    for (double e : errors) {
        ErrorStatsRow row;
        row.error = e;
        for (const BlockSummary& s : blocks) {
            const std::size_t k = exactStep(s.error, e);
            row.exactPoints += s.vertexCount - k;
            row.exactTriangles += s.triangles[k];
            const format::Level& level = s.levels[format::storedLevelFor(s.levels, table.metric, e)];
            row.levelPoints += level.vertexCount;
            row.levelTriangles += level.triangleCount;
        }
        table.rows.push_back(row);
    }
    return true;
}

}  // namespace unilod
