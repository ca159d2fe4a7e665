// LOD index data of one block: retention order, stored levels, paired index layout (lodindex.h).
#include "lodindex.h"

#include "blockcodec.h"
#include "lodlayout.h"

#include <algorithm>
#include <cmath>

namespace unilod {

namespace {

constexpr std::uint32_t kAlive = 0xFFFFFFFFu;  // no vertex index yet

// Each step's removed triangles and edges and added triangles in (a, b, c) order: the compact
// block encoding (blockcodec.h) derives a step's removals from the mesh and its additions from a
// triangulation code, and lists them in that order.
template <class T>
void sortPerStep(const std::vector<std::uint32_t>& offset, std::vector<T>& items) {
    for (std::size_t s = 0; s + 1 < offset.size(); ++s) {
        std::sort(items.begin() + offset[s], items.begin() + offset[s + 1],
                  [](const T& l, const T& r) { return format::lessIndex(l, r); });
    }
}

}  // namespace

bool buildLodIndex(const LodIndexInput& in, format::Block& block, std::string& error) {
    const Cdt& cdt = *in.cdt;
    const DeletionRecords& rec = *in.records;
    const auto steps = static_cast<std::uint32_t>(rec.steps.size());
    const std::vector<Point>& pts = in.points->points;

    // Retention order: vertices never deleted first (ascending id), then the deleted ones from the
    // last deleted to the first.
    std::vector<std::uint32_t> index(pts.size(), kAlive);  // point id -> vertex index
    std::vector<PointId> deleted(pts.size(), 0);
    for (const DeletionStep& s : rec.steps)
        deleted[s.vertex] = 1;
    std::vector<PointId> order;
    for (PointId id = 0; id < pts.size(); ++id) {
        if (cdt.representative[id] == id && !deleted[id]) order.push_back(id);
    }
    for (std::uint32_t s = steps; s-- > 0;)
        order.push_back(rec.steps[s].vertex);
    const auto vertexCount = static_cast<std::uint32_t>(order.size());
    block.vertices.resize(vertexCount);
    block.grid.resize(vertexCount);
    for (std::uint32_t i = 0; i < vertexCount; ++i) {
        const PointId id = order[i];
        if (index[id] != kAlive) {
            error = "vertex " + std::to_string(id) + " deleted twice";
            return false;
        }
        index[id] = i;
        const Point& p = pts[id];
        // x, y from the exact grid position (a grid unit = 1 mm), so that the compact encoding
        // stores the grid alone; z as the point's (quantised at ingest, pointset.cpp).
        block.vertices[i] = {float(double(cdt.gx[id]) * format::kGridUnit),
                             float(double(cdt.gy[id]) * format::kGridUnit), float(p.z),
                             (p.kind == PointKind::River ? format::kVertexRiver : 0u) |
                                 (cdt.locked[id] ? format::kVertexLocked : 0u)};
        block.grid[i] = {cdt.gx[id], cdt.gy[id]};
    }
    auto tri = [&](const TriangleTriple& t) {
        return format::canonicalTriangle({index[t.v[0]], index[t.v[1]], index[t.v[2]]});
    };
    auto edge = [&](const RiverEdge& e) {
        const std::uint32_t a = index[e.a], b = index[e.b];
        return format::Edge{std::min(a, b), std::max(a, b)};
    };

    // Records, renumbered.
    block.steps.resize(steps);
    for (std::uint32_t s = 0; s < steps; ++s) {
        block.steps[s] = {index[rec.steps[s].vertex], rec.steps[s].trianglesAlive,
                          rec.steps[s].riverEdgesAlive};
    }
    block.removedTriangleOffset = rec.removedTriangleOffset;
    block.addedTriangleOffset = rec.addedTriangleOffset;
    block.removedEdgeOffset = rec.removedEdgeOffset;
    block.addedEdgeOffset = rec.addedEdgeOffset;
    // Sized once: grown by push_back, the largest of these (a 256-cell block's records) was the
    // build's largest allocation, up to twice its size plus the copy while it moved.
    block.removedTriangles.clear();
    block.addedTriangles.clear();
    block.removedEdges.clear();
    block.addedEdges.clear();
    block.removedTriangles.reserve(rec.removedTriangles.size());
    block.addedTriangles.reserve(rec.addedTriangles.size());
    block.removedEdges.reserve(rec.removedEdges.size());
    block.addedEdges.reserve(rec.addedEdges.size());
    for (const auto& t : rec.removedTriangles)
        block.removedTriangles.push_back(tri(t));
    for (const auto& t : rec.addedTriangles)
        block.addedTriangles.push_back(tri(t));
    for (const auto& e : rec.removedEdges)
        block.removedEdges.push_back(edge(e));
    for (const auto& e : rec.addedEdges)
        block.addedEdges.push_back(edge(e));
    sortPerStep(block.removedTriangleOffset, block.removedTriangles);
    sortPerStep(block.addedTriangleOffset, block.addedTriangles);
    sortPerStep(block.removedEdgeOffset, block.removedEdges);
    if ((in.maxError && (rec.errorMax.size() != steps || rec.errorRiver.size() != steps)) ||
        (in.paperError && rec.errorPaper.size() != steps)) {
        error = "error tables do not match the deletion steps";
        return false;
    }
    block.errorMax.clear();
    block.errorPaper.clear();
    block.errorRiver.clear();
    if (in.maxError) {
        block.errorMax.push_back(format::quantizeError(rec.initialErrorMax + in.zQuantum, in.zQuantum));
        for (double e : rec.errorMax)
            block.errorMax.push_back(format::quantizeError(e + in.zQuantum, in.zQuantum));
        // Never above errorMax (rec's river part is <= its errorMax; quantizeError is monotone).
        block.errorRiver.push_back(
            format::quantizeError(rec.initialErrorRiver + in.zQuantum, in.zQuantum));
        for (double e : rec.errorRiver)
            block.errorRiver.push_back(format::quantizeError(e + in.zQuantum, in.zQuantum));
    }
    if (in.paperError) {
        block.errorPaper.push_back(format::quantizeError(rec.initialErrorPaper + in.zQuantum, in.zQuantum));
        for (double e : rec.errorPaper)
            block.errorPaper.push_back(format::quantizeError(e + in.zQuantum, in.zQuantum));
    }
    // Rounding must not break monotonicity.
    for (auto* e : {&block.errorMax, &block.errorPaper, &block.errorRiver}) {
        for (std::size_t i = 1; i < e->size(); ++i)
            (*e)[i] = std::max((*e)[i], (*e)[i - 1]);
    }

    // Level steps (see lodindex.h).
    auto trianglesAt = [&](std::uint32_t k) {
        return k == 0 ? std::uint32_t(in.initialTriangles.size()) : rec.steps[k - 1].trianglesAlive;
    };
    std::vector<std::uint32_t> levelSteps{0};
    for (std::uint32_t k = 1; k <= steps; ++k) {
        if (double(trianglesAt(levelSteps.back())) > in.ratio * double(trianglesAt(k))) {
            levelSteps.push_back(k);
        }
    }
    if (levelSteps.back() != steps) levelSteps.push_back(steps);

    block.levels.assign(levelSteps.size(), format::Level{});
    for (std::size_t j = 0; j < levelSteps.size(); ++j)
        block.levels[j].step = levelSteps[j];
    std::vector<format::Triangle> initialTriangles;
    std::vector<format::Edge> initialEdges;
    initialTriangles.reserve(in.initialTriangles.size());
    initialEdges.reserve(in.initialEdges.size());
    for (const auto& t : in.initialTriangles)
        initialTriangles.push_back(tri(t));
    for (const auto& e : in.initialEdges)
        initialEdges.push_back(edge(e));
    if (!format::layOutLevels(block, initialTriangles, initialEdges, error)) return false;

    for (std::size_t j = 0; j < levelSteps.size(); ++j) {
        const std::uint32_t k = levelSteps[j];
        format::Level& l = block.levels[j];
        l.vertexCount = vertexCount - k;
        l.errorMax = block.errorMax.empty() ? 0.0f : block.errorMax[k];
        l.errorPaper = block.errorPaper.empty() ? 0.0f : block.errorPaper[k];
        l.errorRiver = block.errorRiver.empty() ? 0.0f : block.errorRiver[k];
        if (l.triangleCount != trianglesAt(k)) {
            error = "level " + std::to_string(j) + " has " + std::to_string(l.triangleCount) +
                    " triangles, the records say " + std::to_string(trianglesAt(k));
            return false;
        }
    }
    return true;
}

}  // namespace unilod
