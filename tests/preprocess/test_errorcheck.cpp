// errorcheck.h on a block small enough to compute by hand: a 1 m square, a river A-C across it
// whose middle vertex X (above the line and above the plane) is deleted at step 1.
#include <gtest/gtest.h>

#include <cmath>

#include "errorcheck.h"

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

}  // namespace
