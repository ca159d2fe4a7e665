// Top-down wireframe of the levels drawn at one view distance (the paper's Figures 7-12): CPU
// line drawing (Bresenham) of every triangle edge in grey, river edges in blue on top, north up,
// under a title band; with `annotate` a scale bar and a north arrow (engine/annotate.h).
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>

#include "annotate.h"
#include "cut.h"
#include "report.h"
#include "ulod.h"

namespace unilod::report {

namespace {

struct Canvas {
    std::uint32_t size = 0;
    std::vector<std::uint8_t>* rgba = nullptr;
    void plot(long x, long y, const std::uint8_t c[3]) {
        if (x < 0 || y < 0 || x >= long(size) || y >= long(size)) return;
        std::uint8_t* p = rgba->data() + 4 * (std::size_t(y) * size + std::size_t(x));
        p[0] = c[0];
        p[1] = c[1];
        p[2] = c[2];
        p[3] = 255;
    }
    void line(double x0d, double y0d, double x1d, double y1d, const std::uint8_t c[3]) {
        long x0 = std::lround(x0d), y0 = std::lround(y0d);
        const long x1 = std::lround(x1d), y1 = std::lround(y1d);
        const long dx = std::labs(x1 - x0), dy = -std::labs(y1 - y0);
        const long sx = x0 < x1 ? 1 : -1, sy = y0 < y1 ? 1 : -1;
        long err = dx + dy;
        for (;;) {
            plot(x0, y0, c);
            if (x0 == x1 && y0 == y1) break;
            const long e2 = 2 * err;
            if (e2 >= dy) {
                err += dy;
                x0 += sx;
            }
            if (e2 <= dx) {
                err += dx;
                y0 += sy;
            }
        }
    }
};

constexpr std::uint8_t kTerrain[3] = {120, 120, 120};
constexpr std::uint8_t kRiver[3] = {0, 70, 230};

}  // namespace

std::vector<std::string> gridTitle(const GridDiagram& g) {
    char a[160], b[240];
    std::snprintf(a, sizeof a, "View distance %g km, P = %g px", g.distance / 1000, g.pixels);
    std::snprintf(b, sizeof b, "%llu node%s drawn: %llu points, %llu triangles, %llu river edges",
                  static_cast<unsigned long long>(g.nodes), g.nodes == 1 ? "" : "s",
                  static_cast<unsigned long long>(g.points),
                  static_cast<unsigned long long>(g.triangles),
                  static_cast<unsigned long long>(g.riverEdges));
    return {a, b};
}

bool renderGrid(const std::string& path, const StatsOptions& stats, double distance,
                std::uint32_t size, bool annotate, std::vector<std::uint8_t>& rgba,
                GridDiagram& counts, std::string& error) {
    format::Reader reader;
    if (!reader.open(path, error)) return false;
    const format::Header& h = reader.header();
    std::uint32_t metric = 0;
    if (!format::resolveMetric(h, path, stats.metric, metric, error)) return false;
    const double pixels = stats.pixels.empty() ? 1.0 : stats.pixels.front();
    const engine::ViewSpec view = statsView(h, stats, distance, pixels);  // as `stats` counts

    // The cut of the view through the block hierarchy, as `stats` and the engine take it, from
    // the directory (format version 5); only the drawn blocks are read, below.
    format::Block block;
    std::vector<engine::LodNode> nodes;
    for (const format::BlockInfo& info : reader.blocks())
        nodes.push_back(engine::lodNode(info));
    std::vector<engine::NodeChoice> cut;
    engine::selectCut(view, nodes, metric, cut);
    std::sort(cut.begin(), cut.end(), [](const engine::NodeChoice& a, const engine::NodeChoice& b) {
        return a.block < b.block;  // file order: the drawing does not depend on distances
    });

    // World -> image: the data's extent fitted below the title band with a margin, north up.
    const std::uint32_t band = std::min(engine::titleBandHeight(size, 2), size / 2);
    const double margin = std::max(2.0, size * 0.02);
    const double areaH = double(size - band);
    const double spanX = std::max(h.maxX - h.minX, 1e-9), spanY = std::max(h.maxY - h.minY, 1e-9);
    const double scale = std::min((size - 2 * margin) / spanX, (areaH - 2 * margin) / spanY);
    const double offX = margin + ((size - 2 * margin) - (h.maxX - h.minX) * scale) / 2;
    const double offY = margin + ((areaH - 2 * margin) - (h.maxY - h.minY) * scale) / 2;
    auto px = [&](double x) { return offX + (x - h.minX) * scale; };
    auto py = [&](double y) { return double(size) - (offY + (y - h.minY) * scale); };

    rgba.assign(std::size_t(size) * size * 4, 255);
    Canvas canvas{size, &rgba};
    counts = GridDiagram{};
    counts.distance = distance;
    counts.pixels = pixels;
    std::vector<std::pair<std::uint32_t, std::uint32_t>> edges;
    std::vector<std::array<double, 4>> riverLines;
    for (const engine::NodeChoice& choice : cut) {
        if (!reader.readBlock(choice.block, block, error)) return false;
        const format::Level& level = block.levels[choice.wanted.level];
        auto X = [&](std::uint32_t v) { return px(block.originX + double(block.vertices[v].x)); };
        auto Y = [&](std::uint32_t v) { return py(block.originY + double(block.vertices[v].y)); };
        // Each undirected edge once (shared by two triangles inside the block).
        edges.clear();
        for (std::uint32_t t = 0; t < level.triangleCount; ++t) {
            const format::Triangle& tri = block.terrainIndices[level.triangleFirst + t];
            const std::uint32_t v[3] = {tri.a, tri.b, tri.c};
            for (int k = 0; k < 3; ++k) {
                const std::uint32_t a = v[k], b = v[(k + 1) % 3];
                edges.emplace_back(std::min(a, b), std::max(a, b));
            }
        }
        std::sort(edges.begin(), edges.end());
        edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
        for (const auto& [a, b] : edges)
            canvas.line(X(a), Y(a), X(b), Y(b), kTerrain);
        for (std::uint32_t e = 0; e < level.riverCount; ++e) {
            const format::Edge& edge = block.riverIndices[level.riverFirst + e];
            riverLines.push_back({X(edge.a), Y(edge.a), X(edge.b), Y(edge.b)});
        }
        counts.nodes += 1;
        counts.points += level.vertexCount;
        counts.triangles += level.triangleCount;
        counts.triangleEdges += edges.size();
        counts.riverEdges += level.riverCount;
        counts.drawn.push_back({choice.block, choice.wanted.level});
    }
    // Rivers last, over every block's terrain.
    for (const auto& l : riverLines)
        canvas.line(l[0], l[1], l[2], l[3], kRiver);

    engine::drawTitleBand(rgba, size, size, band, gridTitle(counts));
    if (annotate) {
        engine::Annotation a;  // orthographic and north up: the scale is exact everywhere
        a.scaleBar = true;
        a.metresPerPixel = 1.0 / scale;
        a.northArrow = true;
        a.area = {0, std::int32_t(band), std::int32_t(size), std::int32_t(size - band)};
        engine::annotateImage(rgba, size, size, a);
    }
    return true;
}

}  // namespace unilod::report
