#include "viewtin.h"

#include <algorithm>
#include <cmath>
#include <utility>

#include "greedytin.h"
#include "lod.h"

namespace unilod {

bool mergedLeaves(const format::Reader& reader, format::Block& out, std::string& error) {
    const double u = format::kGridUnit;
    out = format::Block{};
    out.originX = reader.header().originX;
    out.originY = reader.header().originY;
    // (exact grid position from the header's origin, vertex number in read order)
    std::vector<std::pair<std::pair<std::int64_t, std::int64_t>, std::uint32_t>> keys;
    std::vector<std::pair<std::uint64_t, std::uint64_t>> edges;  // vertex numbers in read order
    std::vector<float> z;
    format::Block b;
    for (std::size_t i = 0; i < reader.blocks().size(); ++i) {
        if (reader.blocks()[i].level != 0) continue;
        if (!reader.readBlock(i, b, error)) return false;
        const std::uint64_t first = z.size();
        for (std::size_t k = 0; k < b.vertices.size(); ++k) {
            // The exact grid position where the block has one (a block may store none: then the
            // float offsets, which the 1 mm rounding below puts on the grid).
            const bool exact = b.grid.size() == b.vertices.size();
            const double x = b.originX + (exact ? b.grid[k].x * u : double(b.vertices[k].x));
            const double y = b.originY + (exact ? b.grid[k].y * u : double(b.vertices[k].y));
            keys.push_back(
                {{std::llround((x - out.originX) / u), std::llround((y - out.originY) / u)},
                 std::uint32_t(z.size())});
            z.push_back(b.vertices[k].z);
        }
        const format::Level& full = b.levels.front();
        for (std::uint32_t e = full.riverFirst; e < full.riverFirst + full.riverCount; ++e)
            edges.push_back({first + b.riverIndices[e].a, first + b.riverIndices[e].b});
    }
    std::sort(keys.begin(), keys.end());
    std::vector<std::uint32_t> id(z.size());
    for (std::size_t k = 0; k < keys.size(); ++k) {
        if (k == 0 || keys[k].first != keys[k - 1].first) {
            out.grid.push_back(
                {std::int32_t(keys[k].first.first), std::int32_t(keys[k].first.second)});
            out.vertices.push_back({float(double(keys[k].first.first) * u),
                                    float(double(keys[k].first.second) * u), z[keys[k].second], 0});
        }
        id[keys[k].second] = std::uint32_t(out.vertices.size() - 1);
    }
    std::vector<std::pair<std::uint32_t, std::uint32_t>> merged;
    for (const auto& [ea, eb] : edges)
        merged.push_back(std::minmax(id[ea], id[eb]));
    std::sort(merged.begin(), merged.end());
    merged.erase(std::unique(merged.begin(), merged.end()), merged.end());
    for (const auto& [ea, eb] : merged)
        out.riverIndices.push_back({ea, eb});
    format::Level full;
    full.riverCount = std::uint32_t(out.riverIndices.size());
    out.levels.push_back(full);
    return true;
}

PointSet blockPoints(const format::Block& b) {
    PointSet set;
    set.points.reserve(b.vertices.size());
    for (std::size_t i = 0; i < b.vertices.size(); ++i) {
        const format::Vertex& v = b.vertices[i];
        const double x =
            b.grid.empty() ? b.originX + v.x : b.originX + b.grid[i].x * format::kGridUnit;
        const double y =
            b.grid.empty() ? b.originY + v.y : b.originY + b.grid[i].y * format::kGridUnit;
        set.points.push_back({x, y, double(v.z)});
    }
    return set;
}

std::uint64_t viewWeights(const PointSet& set, const TinView& view, std::vector<double>& weights) {
    constexpr double kDegree = 3.14159265358979323846 / 180.0;
    const engine::Camera& c = view.camera;
    const double aspect = view.width / view.height;
    const engine::ViewTolerance tolerance{view.pixels, c.fovDegrees * kDegree, view.width,
                                          view.height, engine::DistanceMode::Nearest};
    weights.assign(set.points.size(), 0.0);
    std::uint64_t onScreen = 0;
    for (std::size_t m = 0; m < set.points.size(); ++m) {
        const double at[3] = {set.points[m].x, set.points[m].y, set.points[m].z};
        if (!engine::boxInFrustum(c, aspect, at, at)) continue;
        ++onScreen;
        const double s = engine::nearestBoxDistance(c.eye, at, at);
        const double hLim = engine::blockTolerance(tolerance, s, engine::boxView(c, at, at));
        weights[m] = 1.0 / std::max(hLim, 1e-6);
    }
    return onScreen;
}

bool weightedTin(const PointSet& set, const std::vector<double>& weights,
                 std::vector<TriangleTriple>& triangles, std::uint32_t& vertices,
                 std::string& error) {
    GreedyTin tin;
    tin.setWeights(&weights);
    if (!tin.init(set, error)) return false;
    tin.refineTo(1.0);
    vertices = tin.vertexCount();
    triangles = collectTriangles(tin.cdt());
    return true;
}

}  // namespace unilod
