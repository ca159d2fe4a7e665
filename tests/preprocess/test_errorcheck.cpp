// errorcheck.h on a block small enough to compute by hand: a 1 m square, a river A-C across it
// whose middle vertex X (above the line and above the plane) is deleted at step 1.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <random>

#include "errorcheck.h"
#include "modelerror.h"

using namespace unilod;

namespace {

// Vertices in retention order: corners a b c d (z = 0), river ends A C (z = 0), then X, the one
// deleted vertex. Grid units are millimetres.
format::Block squareBlock(float zX) {
    format::Block b;
    const std::int32_t xy[7][2] = {{0, 0},     {1000, 0},  {1000, 1000}, {0, 1000},
                                   {200, 500}, {800, 500}, {500, 600}};
    for (int i = 0; i < 7; ++i) {
        b.vertices.push_back({float(xy[i][0]) * 1e-3f, float(xy[i][1]) * 1e-3f, i == 6 ? zX : 0.0f,
                              i >= 4 ? format::kVertexRiver : 0u});
        b.grid.push_back({xy[i][0], xy[i][1]});
    }
    return b;
}

// The triangulation after step 1 (X gone): six counter-clockwise triangles over the square.
const std::vector<TriangleTriple> kStep1 = {{{0, 1, 5}}, {{0, 5, 4}}, {{0, 4, 3}},
                                            {{4, 5, 2}}, {{4, 2, 3}}, {{1, 2, 5}}};

RiverReference chainAXC() {
    RiverReference r;
    r.junctions = {4, 5};
    r.chains = {{4, 6, 5}};
    return r;
}

TEST(ErrorCheck, VerticalAndRiverByHand) {
    const format::Block b = squareBlock(0.3f);
    LevelMaxError e;
    std::string error;
    ASSERT_TRUE(levelMaxError(b, 1, kStep1, {makeRiverEdge(4, 5)}, chainAXC(), e, error)) << error;
    // X lies in A-C-c, a plane at z = 0.
    EXPECT_NEAR(e.vertical, 0.3, 1e-7);
    EXPECT_EQ(e.verticalVertex, 6u);
    // X = (0.5, 0.6, 0.3) against the segment (0.2, 0.5, 0)-(0.8, 0.5, 0): sqrt(0.1^2 + 0.3^2).
    EXPECT_NEAR(e.river, std::sqrt(0.01 + 0.09), 1e-7);
    EXPECT_EQ(e.riverVertex, 6u);
    EXPECT_NEAR(e.value(), std::sqrt(0.1), 1e-7);
}

TEST(ErrorCheck, SlopedPlane) {
    // Every vertex on the plane z = 2 x + 3 y except X, 0.25 m above it.
    format::Block b = squareBlock(0);
    for (std::size_t i = 0; i < b.vertices.size(); ++i)
        b.vertices[i].z = float(2e-3 * b.grid[i].x + 3e-3 * b.grid[i].y);
    b.vertices[6].z += 0.25f;
    LevelMaxError e;
    std::string error;
    ASSERT_TRUE(levelMaxError(b, 1, kStep1, {makeRiverEdge(4, 5)}, chainAXC(), e, error)) << error;
    EXPECT_NEAR(e.vertical, 0.25, 1e-5);
    EXPECT_EQ(e.verticalVertex, 6u);
}

TEST(ErrorCheck, AliveVerticesCostNothing) {
    // At step 0 X is alive: A-C-c is split at X, which is a vertex of the triangles.
    const format::Block b = squareBlock(0.3f);
    const std::vector<TriangleTriple> step0 = {{{0, 1, 5}}, {{0, 5, 4}}, {{0, 4, 3}}, {{4, 5, 6}},
                                               {{5, 2, 6}}, {{2, 4, 6}}, {{4, 2, 3}}, {{1, 2, 5}}};
    LevelMaxError e;
    std::string error;
    ASSERT_TRUE(levelMaxError(b, 0, step0, {makeRiverEdge(4, 6), makeRiverEdge(5, 6)}, chainAXC(),
                              e, error))
        << error;
    EXPECT_EQ(e.river, 0.0);
    EXPECT_LT(e.vertical, 1e-7);
}

TEST(ErrorCheck, Tolerance) {
    format::Block b = squareBlock(0.3f);
    b.vertices[0].z = -2000.0f;
    EXPECT_NEAR(maxErrorTolerance(b), 4 * 2000.0 / 16777216.0 + 1e-6, 1e-12);
}

TEST(ErrorCheck, Refusals) {
    const format::Block b = squareBlock(0.3f);
    LevelMaxError e;
    std::string error;
    // The alive chain vertices A and C are not joined by a river edge.
    EXPECT_FALSE(levelMaxError(b, 1, kStep1, {}, chainAXC(), e, error));
    EXPECT_NE(error.find("no river edge"), std::string::npos) << error;
    // A triangle missing: X lies in no triangle, outside the level's domain (an outline vertex
    // deleted, blocks.h "Domain"): its horizontal distance to the level's outline counts.
    std::vector<TriangleTriple> holed = kStep1;
    holed.erase(holed.begin() + 3);
    ASSERT_TRUE(levelMaxError(b, 1, holed, {makeRiverEdge(4, 5)}, chainAXC(), e, error)) << error;
    EXPECT_EQ(e.riverVertex, 6u);
    EXPECT_GT(e.river, 0.0);
    // No triangle at all: nothing to measure against.
    EXPECT_FALSE(levelMaxError(b, 1, {}, {}, {}, e, error));
    EXPECT_NE(error.find("lies in no triangle"), std::string::npos) << error;
}

// A leaf holding the given river polylines (grid millimetres, z in metres) as its full-resolution
// river edges, with origin (ox, oy) in metres.
format::Block riverLeaf(double ox, double oy,
                        const std::vector<std::vector<std::array<double, 3>>>& lines) {
    format::Block leaf;
    leaf.originX = ox;
    leaf.originY = oy;
    for (const auto& line : lines) {
        for (std::size_t i = 0; i < line.size(); ++i) {
            const std::uint32_t v = std::uint32_t(leaf.vertices.size());
            leaf.vertices.push_back({float(line[i][0] * 1e-3), float(line[i][1] * 1e-3),
                                     float(line[i][2]), format::kVertexRiver});
            leaf.grid.push_back({std::int32_t(line[i][0]), std::int32_t(line[i][1])});
            if (i > 0) leaf.riverIndices.push_back({v - 1, v});
        }
    }
    leaf.levels.push_back({0, std::uint32_t(leaf.vertices.size()), 0, 0, 0,
                           std::uint32_t(leaf.riverIndices.size()), 0.0f, 0.0f, 0.0f});
    return leaf;
}

// A node's river deviation of ORIGINAL river points (the leaf's), by hand: the square block at
// step 1 (X gone, river edge A-C) as the node, a leaf holding the original chain A-X-C with X
// where the node had it, and a leaf river point the node never had, farther from A-C.
TEST(NodeOriginalError, RiverPointsOfTheLeavesByHand) {
    const format::Block node = squareBlock(0.3f);
    // The leaf's origin is 10 mm left of the node's: its grid is shifted by +10.
    const format::Block leaf =
        riverLeaf(-0.01, 0, {{{210, 500, 0}, {510, 600, 0.3}, {710, 550, 0.1}, {810, 500, 0}}});
    NodeOriginalError check(node, {kStep1}, {{makeRiverEdge(4, 5)}});
    check.add(leaf);
    ASSERT_EQ(check.riverWorst().size(), 1u);
    // X: sqrt(0.1^2 + 0.3^2); the point at (0.7, 0.55, 0.1): sqrt(0.05^2 + 0.1^2), smaller.
    EXPECT_NEAR(check.riverWorst()[0].value, std::sqrt(0.1) - kNodeRiverSlack, 1e-6);
    EXPECT_EQ(check.riverWorst()[0].vertex, 1u);

    // A second river edge nearer to X: the smallest distance over the level's edges counts.
    format::Block twoRivers = node;
    twoRivers.vertices.push_back({0.5f, 0.7f, 0.3f, format::kVertexRiver});
    twoRivers.grid.push_back({500, 700});
    twoRivers.vertices.push_back({0.9f, 0.7f, 0.3f, format::kVertexRiver});
    twoRivers.grid.push_back({900, 700});
    NodeOriginalError nearer(twoRivers, {kStep1}, {{makeRiverEdge(4, 5), makeRiverEdge(7, 8)}});
    nearer.add(leaf);
    // X is 0.1 m from (0.5, 0.7, 0.3); (0.7, 0.55, 0.1) is sqrt(0.05^2 + 0.1^2) from A-C.
    EXPECT_NEAR(nearer.riverWorst()[0].value, std::sqrt(0.0125) - kNodeRiverSlack, 1e-6);
    EXPECT_EQ(nearer.riverWorst()[0].vertex, 2u);

    // No river edge at the level: the rivers vanished, an infinite deviation.
    NodeOriginalError none(node, {kStep1}, {{}});
    none.add(leaf);
    EXPECT_TRUE(std::isinf(none.riverWorst()[0].value));
    // River levels not given: rivers not recomputed.
    NodeOriginalError off(node, {kStep1});
    off.add(leaf);
    EXPECT_EQ(off.riverWorst()[0].value, 0.0);
}

// The bucketed search against brute force: random river edges and river points over a 200 m
// node, at several levels (edge subsets), the max over points of the min 3D distance to the edges.
TEST(NodeOriginalError, RiverSearchMatchesBruteForce) {
    std::mt19937 rng(7);
    std::uniform_int_distribution<std::int32_t> coord(0, 200000);
    std::uniform_real_distribution<double> height(0, 50);
    format::Block node;
    for (int i = 0; i < 400; ++i) {
        const std::int32_t x = coord(rng), y = coord(rng);
        node.grid.push_back({x, y});
        node.vertices.push_back(
            {float(x * 1e-3), float(y * 1e-3), float(height(rng)), format::kVertexRiver});
    }
    std::vector<std::vector<RiverEdge>> levels;
    for (std::uint32_t n : {200u, 40u, 3u, 1u}) {
        std::vector<RiverEdge> e;
        for (std::uint32_t k = 0; k < n; ++k) {
            // Short edges and a few long ones.
            const std::uint32_t a = 2 * k, b = k % 7 == 0 ? 399 - k : 2 * k + 1;
            e.push_back(makeRiverEdge(a, b));
        }
        std::sort(e.begin(), e.end());
        levels.push_back(e);
    }
    std::vector<std::vector<std::array<double, 3>>> lines(1);
    for (int i = 0; i < 300; ++i)
        lines[0].push_back({double(coord(rng)), double(coord(rng)), height(rng)});
    const format::Block leaf = riverLeaf(0, 0, lines);
    NodeOriginalError check(node, std::vector<std::vector<TriangleTriple>>(levels.size()), levels);
    check.add(leaf);
    for (std::size_t l = 0; l < levels.size(); ++l) {
        double worst = 0;
        for (std::size_t p = 0; p < leaf.vertices.size(); ++p) {
            const double m[3] = {leaf.grid[p].x * 1e-3, leaf.grid[p].y * 1e-3,
                                 double(leaf.vertices[p].z)};
            double best = INFINITY;
            for (const RiverEdge& e : levels[l]) {
                const double a[3] = {node.grid[e.a].x * 1e-3, node.grid[e.a].y * 1e-3,
                                     double(node.vertices[e.a].z)};
                const double c[3] = {node.grid[e.b].x * 1e-3, node.grid[e.b].y * 1e-3,
                                     double(node.vertices[e.b].z)};
                best = std::min(best, std::sqrt(segmentDistance2(a, c, m)));
            }
            worst = std::max(worst, best);
        }
        SCOPED_TRACE(l);
        EXPECT_GT(worst, 1.0);
        EXPECT_NEAR(check.riverWorst()[l].value, worst - kNodeRiverSlack, 1e-9);
    }
}

}  // namespace
