#include "cut.h"

#include <algorithm>
#include <array>
#include <cassert>
#include <cmath>
#include <utility>

namespace unilod::engine {

namespace {

constexpr double kDegree = 3.14159265358979323846 / 180.0;

// Box, position, tree links, levels and whether its `max` error bounds horizontal displacements.
template <typename B>
LodNode nodeOf(const B& b, bool moves) {
    LodNode n;
    n.boxMin[0] = b.minX;
    n.boxMin[1] = b.minY;
    n.boxMin[2] = b.minZ;
    n.boxMax[0] = b.maxX;
    n.boxMax[1] = b.maxY;
    n.boxMax[2] = b.maxZ;
    n.col = b.col;
    n.row = b.row;
    n.level = b.level;
    n.firstChild = b.firstChild;
    n.childCount = b.childCount;
    n.horizontal = (!b.levels.empty() && b.levels.front().riverCount > 0) || moves;
    n.levels = &b.levels;
    return n;
}

}  // namespace

LodNode lodNode(const format::Block& b) {
    return nodeOf(b, format::outlineMoves(b));
}
LodNode lodNode(const format::BlockInfo& info) {
    return nodeOf(info, info.outlineMoves);
}

bool nodeVisible(const ViewSpec& view, const double boxMin[3], const double boxMax[3]) {
    if (view.kind == ViewSpec::Kind::Uniform || !view.cull || !view.direction) return true;
    const double aspect = view.widthPixels / view.heightPixels;
    return view.kind == ViewSpec::Kind::Grid
               ? boxInGridView(view.camera, view.gridHalfHeight, aspect, boxMin, boxMax)
               : boxInFrustum(view.camera, aspect, boxMin, boxMax);
}

NodeTolerance nodeTolerances(const ViewSpec& view, const LodNode& node, double* distance,
                             BoxView* box) {
    return nodeTolerances(view, cameraBasis(view.camera), node, distance, box);
}

NodeTolerance nodeTolerances(const ViewSpec& view, const CameraBasis& basis, const LodNode& node,
                             double* distance, BoxView* box) {
    if (distance != nullptr) *distance = 0;
    if (box != nullptr) *box = BoxView{};
    if (view.kind == ViewSpec::Kind::Uniform) return {view.hLim, INFINITY};
    // The grid mode shows, top-down, the levels the perspective view from the same eye selects
    // (the paper's 2D grid diagrams at a view distance).
    const double s = blockDistance(view.distance, view.camera.eye, node.boxMin, node.boxMax);
    BoxView place =
        view.direction ? boxView(view.camera, basis, node.boxMin, node.boxMax) : BoxView{};
    place.horizontal = node.horizontal;
    if (distance != nullptr) *distance = s;
    if (box != nullptr) *box = place;
    const ViewTolerance tolerance{view.pixels, view.camera.fovDegrees * kDegree, view.widthPixels,
                                  view.heightPixels, view.distance};
    // The bound of a box for vertical errors (sin(phi)) and for horizontal displacements (none).
    auto bounds = [&](double at, BoxView b) {
        NodeTolerance t;
        b.horizontal = false;
        t.vertical = blockTolerance(tolerance, at, b);
        if (node.horizontal) {
            b.horizontal = true;
            t.river = blockTolerance(tolerance, at, b);
        }
        return t;
    };
    const NodeTolerance whole = bounds(s, place);
    if (view.distance != DistanceMode::Nearest || !view.direction) return whole;
    // A node small against its distance gains little (every column's S is within its diagonal
    // of the box's): the whole box, and no per-column work.
    const double diagonal =
        std::hypot(node.boxMax[0] - node.boxMin[0], node.boxMax[1] - node.boxMin[1]);
    if (diagonal <= kColumnsBelowDistance * s) return whole;
    // Columns (cut.h kToleranceColumns): the bounds per column, for the points on screen.
    const double aspect = view.widthPixels / view.heightPixels;
    const double cornerCos = std::sqrt(frustumEdgeFactor(tolerance.fovRadians, aspect));
    const double focal = view.heightPixels / (2.0 * std::tan(tolerance.fovRadians / 2.0));
    const double dx = (node.boxMax[0] - node.boxMin[0]) / kToleranceColumns;
    const double dy = (node.boxMax[1] - node.boxMin[1]) / kToleranceColumns;
    struct Column {
        double lo[3], hi[3], s;
    };
    std::array<Column, kToleranceColumns * kToleranceColumns> columns;
    for (int i = 0; i < kToleranceColumns; ++i) {
        for (int j = 0; j < kToleranceColumns; ++j) {
            Column& k = columns[std::size_t(i * kToleranceColumns + j)];
            k.lo[0] = node.boxMin[0] + i * dx, k.lo[1] = node.boxMin[1] + j * dy;
            k.lo[2] = node.boxMin[2];
            k.hi[0] = i + 1 == kToleranceColumns ? node.boxMax[0] : k.lo[0] + dx;
            k.hi[1] = j + 1 == kToleranceColumns ? node.boxMax[1] : k.lo[1] + dy;
            k.hi[2] = node.boxMax[2];
            k.s = nearestBoxDistance(view.camera.eye, k.lo, k.hi);
        }
    }
    // Nearest first; a column's bounds are at least P S cos^2(theta_c) / (f + P) (c >= cos
    // theta_c, depth >= S cos theta_c, sin phi <= 1, the river factor >= f / (f + P)), so once
    // that exceeds the smallest bounds so far no farther column can lower them, and once the
    // smallest are down to the whole box's the answer is the whole box's.
    std::stable_sort(columns.begin(), columns.end(),
                     [](const Column& a, const Column& b) { return a.s < b.s; });
    NodeTolerance smallest{INFINITY, INFINITY};
    auto atWhole = [&] {
        return smallest.vertical <= whole.vertical &&
               (!node.horizontal || smallest.river <= whole.river);
    };
    for (const Column& k : columns) {
        const double reach = node.horizontal ? std::max(smallest.vertical, smallest.river)
                                             : smallest.vertical;
        if (view.pixels * k.s * cornerCos * cornerCos / (focal + view.pixels) * (1 - 1e-12) >=
            reach)
            break;
        if (view.cull && !boxInFrustum(view.camera, basis, aspect, k.lo, k.hi)) continue;
        const BoxView column = boxView(view.camera, basis, k.lo, k.hi);
        NodeTolerance h = bounds(k.s, column);
        // A river's drawn point q may lie in another column, up to h from its original point
        // p: its depth is then only >= p's bound D - h, and f h / ((D - h) c) <= P holds for
        // h = P c D / (f + P c), the column's bound times f / (f + P c).
        if (node.horizontal) {
            const double c = std::max(cornerCos, column.axisCos);
            h.river *= focal / (focal + view.pixels * c);
        }
        smallest.vertical = std::min(smallest.vertical, h.vertical);
        smallest.river = std::min(smallest.river, h.river);
        if (atWhole()) return whole;
    }
    // No column on screen (the node's box is kept by the conservative cull): the whole box.
    if (smallest.vertical == INFINITY) return whole;
    return {std::max(whole.vertical, smallest.vertical),
            node.horizontal ? std::max(whole.river, smallest.river) : INFINITY};
}

double nodeTolerance(const ViewSpec& view, const LodNode& node, double* distance, BoxView* box) {
    const NodeTolerance t = nodeTolerances(view, node, distance, box);
    return node.horizontal && view.kind != ViewSpec::Kind::Uniform ? t.river : t.vertical;
}

NodeChoice chooseNode(const ViewSpec& view, const LodNode& node, std::uint32_t index,
                      std::uint32_t metric) {
    assert(node.levels != nullptr && !node.levels->empty());
    NodeChoice c;
    c.block = index;
    c.col = node.col;
    c.treeLevel = node.level;
    c.row = node.row;
    const NodeTolerance t = nodeTolerances(view, node, &c.distance, &c.box);
    if (metric == format::kMetricPaper || view.kind == ViewSpec::Kind::Uniform) {
        c.hLim = node.horizontal && view.kind != ViewSpec::Kind::Uniform ? t.river : t.vertical;
    } else {
        c.hLim = t.vertical;
        c.hLimRiver = t.river;
    }
    c.wanted = view.finest ? chooseStoredLevel(*node.levels, metric, -1.0, -1.0)
                           : chooseStoredLevel(*node.levels, metric, c.hLim, c.hLimRiver);
    return c;
}

void selectCut(const ViewSpec& view, const std::vector<LodNode>& nodes, std::uint32_t metric,
               std::vector<NodeChoice>& out) {
    out.clear();
    // Roots: the nodes no other node names as a child.
    std::vector<std::uint8_t> isChild(nodes.size(), 0);
    for (const LodNode& n : nodes) {
        if (n.firstChild == kNoChild) continue;
        assert(std::size_t(n.firstChild) + n.childCount <= nodes.size());
        for (std::uint32_t c = 0; c < n.childCount; ++c)
            isChild[n.firstChild + c] = 1;
    }
    std::vector<std::uint32_t> stack;
    for (std::uint32_t i = std::uint32_t(nodes.size()); i-- > 0;)
        if (!isChild[i]) stack.push_back(i);
    while (!stack.empty()) {
        const std::uint32_t i = stack.back();
        stack.pop_back();
        const LodNode& n = nodes[i];
        if (!nodeVisible(view, n.boxMin, n.boxMax)) continue;
        NodeChoice c = chooseNode(view, n, i, metric);
        if (n.firstChild != kNoChild && n.childCount > 0) {
            if (view.finest || !format::levelFits(n.levels->front(), metric, c.hLim, c.hLimRiver)) {
                for (std::uint32_t k = n.childCount; k-- > 0;)
                    stack.push_back(n.firstChild + k);
                continue;
            }
        }
        out.push_back(c);
    }
    // Nearest first: the engine uploads and requests in this order. Ties: node order.
    std::stable_sort(out.begin(), out.end(), [](const NodeChoice& a, const NodeChoice& b) {
        return a.distance < b.distance || (a.distance == b.distance && a.block < b.block);
    });
}

}  // namespace unilod::engine
