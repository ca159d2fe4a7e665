// The CPU-only level choice (engine/lod: paper §3.4, Eq. 11; DESIGN.md "Screen-space error"):
// h_lim and S, the stored-level and exact-step choices, the outline test, and the cut that the
// engine, `export`, `stats`, `report` and the grid diagram all call. No Vulkan here.
#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <stdexcept>
#include <vector>

#include "cut.h"
#include "lod.h"
#include "ulod.h"
#include "workers.h"

using namespace unilod;

namespace {

TEST(Lod, ChoosesCoarsestLevelWithinTolerance) {
    std::vector<format::Level> levels(3);
    levels[0].step = 0;
    levels[1].step = 4;
    levels[2].step = 8;
    const std::vector<float> errors = {0, 0, 1, 1, 2, 2, 3, 5, 9, 9};
    EXPECT_EQ(engine::chooseLevel(levels, errors, 0.5).level, 0u);
    EXPECT_EQ(engine::chooseLevel(levels, errors, 2.0).level, 1u);  // k* = 5, level step 4
    EXPECT_EQ(engine::chooseLevel(levels, errors, 2.0).nextError, 9.0);
    EXPECT_EQ(engine::chooseLevel(levels, errors, 8.9).level, 1u);
    EXPECT_EQ(engine::chooseLevel(levels, errors, 9.0).level, 2u);
    EXPECT_EQ(engine::chooseLevel(levels, errors, 9.0).nextError, -1.0);
    // h_lim = 2 P S tan(fov/2) / H: 60 degrees, 1 px, 1000 m, 1000 px -> 1.1547 m.
    EXPECT_NEAR(engine::toleranceFor(1, 1000, 3.14159265358979 / 3, 1000), 1.1547005, 1e-6);
    const double eye[3] = {5, 5, 5}, lo[3] = {0, 0, 0}, hi[3] = {1, 2, 9};
    EXPECT_DOUBLE_EQ(engine::nearestBoxDistance(eye, lo, hi), 5.0);
    EXPECT_DOUBLE_EQ(engine::blockDistance(engine::DistanceMode::Centre, eye, lo, hi),
                     std::sqrt(4.5 * 4.5 + 4 * 4 + 0.5 * 0.5));
    // 90 degree field of view, square viewport: the corner ray is at tan^2 = 2, cos^2 = 1/3.
    EXPECT_NEAR(engine::frustumEdgeFactor(3.14159265358979 / 2, 1.0), 1.0 / 3.0, 1e-12);
}

TEST(Lod, ExactStepIsTheLastStateWithinTolerance) {
    const std::vector<float> errors = {0, 0, 1, 1, 2, 2, 3, 5, 9, 9};
    EXPECT_EQ(engine::exactStep(errors, -1.0), 0u);  // nothing within: full resolution
    EXPECT_EQ(engine::exactStep(errors, 0.0), 1u);
    EXPECT_EQ(engine::exactStep(errors, 2.5), 5u);
    EXPECT_EQ(engine::exactStep(errors, 9.0), 9u);
    EXPECT_EQ(engine::exactStep(errors, 1e9), 9u);
    // With the river part held to its own tolerance: the shorter of the two prefixes.
    const std::vector<float> river = {0, 0, 0, 1, 1, 1, 1, 4, 4, 4};
    EXPECT_EQ(engine::exactStep(errors, 2.5, river, 0.5), 2u);
    EXPECT_EQ(engine::exactStep(errors, 2.5, river, 1.0), 5u);
    EXPECT_EQ(engine::exactStep(errors, 9.0, river, 3.0), 6u);
    EXPECT_EQ(engine::exactStep(errors, 9.0, river, INFINITY), 9u);
    EXPECT_EQ(engine::exactStep(errors, 9.0, {}, 0.0), 9u);  // no river part: errors alone
}

// Three stored levels with errors 0 / 2 / 6 (both metrics), river edges when `rivers`.
std::vector<format::Level> threeLevels(bool rivers) {
    std::vector<format::Level> levels(3);
    const float errors[3] = {0, 2, 6};
    for (int i = 0; i < 3; ++i) {
        levels[i].step = std::uint32_t(4 * i);
        levels[i].errorMax = levels[i].errorPaper = errors[i];
        levels[i].riverCount = rivers ? 1 : 0;
    }
    return levels;
}

engine::LodNode nodeAt(double x0, double y0, double size,
                       const std::vector<format::Level>& levels) {
    engine::LodNode n;
    n.boxMin[0] = x0, n.boxMin[1] = y0, n.boxMin[2] = 0;
    n.boxMax[0] = x0 + size, n.boxMax[1] = y0 + size, n.boxMax[2] = 10;
    n.levels = &levels;
    n.horizontal = levels.front().riverCount > 0;
    return n;
}

TEST(Cut, UniformToleranceChoosesEveryNodeInOrder) {
    const std::vector<format::Level> levels = threeLevels(false);
    std::vector<engine::LodNode> nodes;
    for (int i = 0; i < 4; ++i)
        nodes.push_back(nodeAt(1000.0 * i, 0, 1000, levels));
    engine::ViewSpec v;
    v.kind = engine::ViewSpec::Kind::Uniform;
    v.hLim = 2.5;
    std::vector<engine::NodeChoice> cut;
    engine::selectCut(v, nodes, format::kMetricMax, cut);
    ASSERT_EQ(cut.size(), 4u);
    for (std::uint32_t i = 0; i < 4; ++i) {
        EXPECT_EQ(cut[i].block, i);  // S = 0 for all: ties keep node order
        EXPECT_EQ(cut[i].distance, 0.0);
        EXPECT_EQ(cut[i].hLim, 2.5);
        EXPECT_EQ(cut[i].wanted.level, 1u);
    }
    v.finest = true;
    engine::selectCut(v, nodes, format::kMetricMax, cut);
    for (const engine::NodeChoice& c : cut)
        EXPECT_EQ(c.wanted.level, 0u);
}

TEST(Cut, CameraCullsAndSortsNearestFirst) {
    const std::vector<format::Level> levels = threeLevels(false);
    // A row of 1 km blocks along x; the eye at x = 500 m, 300 m up, looking east and down.
    std::vector<engine::LodNode> nodes;
    for (int i = -3; i < 20; ++i)
        nodes.push_back(nodeAt(1000.0 * i, -500, 1000, levels));
    engine::ViewSpec v;
    v.camera.eye[0] = 500, v.camera.eye[1] = 0, v.camera.eye[2] = 300;
    v.camera.yawDegrees = 90;
    v.camera.pitchDegrees = -10;
    v.camera.fovDegrees = 60;
    v.widthPixels = 800, v.heightPixels = 600;
    std::vector<engine::NodeChoice> cut;
    engine::selectCut(v, nodes, format::kMetricMax, cut);
    ASSERT_FALSE(cut.empty());
    ASSERT_LT(cut.size(), nodes.size());  // the blocks behind the eye are culled
    for (std::size_t i = 0; i < cut.size(); ++i) {
        const engine::LodNode& n = nodes[cut[i].block];
        EXPECT_TRUE(engine::nodeVisible(v, n.boxMin, n.boxMax));
        EXPECT_GE(n.boxMax[0], 0.0) << "a block behind the eye was kept";
        if (i > 0) {
            EXPECT_LE(cut[i - 1].distance, cut[i].distance);
        }
        // The cut's tolerances are nodeTolerances', its level chooseStoredLevel's.
        const engine::NodeTolerance t = engine::nodeTolerances(v, n);
        EXPECT_EQ(cut[i].hLim, t.vertical);
        EXPECT_EQ(cut[i].hLimRiver, t.river);
        EXPECT_EQ(cut[i].wanted.level,
                  engine::chooseStoredLevel(levels, format::kMetricMax, t.vertical, t.river).level);
    }
    // Farther blocks get larger tolerances and never finer levels.
    EXPECT_LT(cut.front().hLim, cut.back().hLim);
    EXPECT_LE(cut.front().wanted.level, cut.back().wanted.level);
    // Culling off: every node.
    v.cull = false;
    engine::selectCut(v, nodes, format::kMetricMax, cut);
    EXPECT_EQ(cut.size(), nodes.size());
}

TEST(Cut, RiversTakeNoCreditForASteepView) {
    // Looking straight down, a vertical error shrinks on screen (BoxView::verticalSin), a river
    // displacement does not: the same box gets a smaller h_lim when it holds rivers.
    const std::vector<format::Level> dry = threeLevels(false), wet = threeLevels(true);
    engine::ViewSpec v;
    v.camera.eye[0] = 500, v.camera.eye[1] = 500, v.camera.eye[2] = 5000;
    v.camera.pitchDegrees = -90;
    const engine::LodNode a = nodeAt(0, 0, 1000, dry), b = nodeAt(0, 0, 1000, wet);
    EXPECT_LT(engine::nodeTolerance(v, b), engine::nodeTolerance(v, a));
    // Centre mode is Eq. 11 at the box centre, rivers or not.
    v.distance = engine::DistanceMode::Centre;
    double s = 0;
    const double h = engine::nodeTolerance(v, b, &s);
    EXPECT_DOUBLE_EQ(s, 4995.0);
    EXPECT_DOUBLE_EQ(h, engine::toleranceFor(1, 4995.0, 60 * 3.14159265358979323846 / 180, 1080));
    EXPECT_DOUBLE_EQ(engine::nodeTolerance(v, a), h);
    // Without a direction (export --camera x,y,z): no box credit, no culling.
    v.distance = engine::DistanceMode::Nearest;
    v.direction = false;
    engine::BoxView box;
    engine::nodeTolerance(v, a, &s, &box);
    EXPECT_EQ(box.axisCos, 0.0);
    EXPECT_EQ(box.verticalSin, 1.0);
    v.camera.eye[2] = -5000;  // below the ground, looking down: nothing visible, nothing culled
    EXPECT_TRUE(engine::nodeVisible(v, a.boxMin, a.boxMax));
}

// Columns (cut.h kToleranceColumns): a large node whose nearest edge is below the eye, off
// screen, gets a larger h_lim than its whole box allows, yet never more than any point of it on
// screen allows by the same bound taken at the point alone; a node small against its distance keeps
// the box's bound.
TEST(Cut, ColumnsBoundEveryPointOnScreen) {
    const std::vector<format::Level> dry = threeLevels(false), wet = threeLevels(true);
    engine::ViewSpec v;
    v.camera.eye[0] = 4000, v.camera.eye[1] = -300, v.camera.eye[2] = 800;
    v.camera.yawDegrees = 0;  // north, over the node
    v.camera.pitchDegrees = -20;
    v.widthPixels = 1920, v.heightPixels = 1080;
    const double fov = v.camera.fovDegrees * 3.14159265358979323846 / 180;
    const engine::ViewTolerance alone{v.pixels, fov, v.widthPixels, v.heightPixels,
                                      engine::DistanceMode::Nearest};
    for (const auto* levels : {&dry, &wet}) {
        const engine::LodNode n = nodeAt(0, 0, 8000, *levels);
        double s = 0;
        engine::BoxView box;
        const double h = engine::nodeTolerance(v, n, &s, &box);
        EXPECT_GE(h, engine::blockTolerance(alone, s, box));
        if (!n.horizontal) {
            EXPECT_GT(h, engine::blockTolerance(alone, s, box) * 1.02)
                << "the columns at the near edge are partly off screen, with better view angles";
        }
        std::size_t onScreen = 0;
        for (int i = 0; i <= 80; ++i) {
            for (int j = 0; j <= 80; ++j) {
                for (double z : {0.0, 5.0, 10.0}) {
                    const double p[3] = {100.0 * i, 100.0 * j, z};
                    if (!engine::boxInFrustum(v.camera, v.widthPixels / v.heightPixels, p, p))
                        continue;
                    ++onScreen;
                    engine::BoxView at = engine::boxView(v.camera, p, p);
                    at.horizontal = n.horizontal;
                    const double own = engine::blockTolerance(
                        alone, engine::nearestBoxDistance(v.camera.eye, p, p), at);
                    ASSERT_LE(h, own) << "point " << p[0] << ", " << p[1] << ", " << z;
                }
            }
        }
        EXPECT_GT(onScreen, 1000u);
    }
    // Far away (diagonal under a quarter of S): the whole box's bound.
    const engine::LodNode far = nodeAt(20000, 20000, 1000, dry);
    double s = 0;
    engine::BoxView box;
    const double h = engine::nodeTolerance(v, far, &s, &box);
    EXPECT_EQ(h, engine::blockTolerance(alone, s, box));
    // The paper's centre distance: Eq. 11 at the centre, no columns.
    v.distance = engine::DistanceMode::Centre;
    const engine::LodNode n = nodeAt(0, 0, 8000, dry);
    const double centre = engine::nodeTolerance(v, n, &s);
    EXPECT_EQ(centre, engine::toleranceFor(1, s, fov, 1080));
}

// Format version 4: the `max` error is held to the tolerance with sin(phi) and its river part
// (Level::errorRiver) to the tolerance without it. Seen steeply from above, the two differ by
// about 1 / sin(phi); a level whose river part exceeds the river tolerance is not drawn, one
// whose combined error exceeds the river tolerance but whose river part does not is.
TEST(Cut, RiverPartHasItsOwnTolerance) {
    engine::ViewSpec v;
    v.camera.eye[0] = 4000, v.camera.eye[1] = 4000, v.camera.eye[2] = 20000;
    v.camera.yawDegrees = 0;
    v.camera.pitchDegrees = -89;
    v.widthPixels = 1920, v.heightPixels = 1080;
    std::vector<format::Level> wet = threeLevels(true);
    const std::vector<format::Level> dry = threeLevels(false);
    const engine::LodNode nodeDry = nodeAt(0, 0, 8000, dry);
    const engine::NodeTolerance tDry = engine::nodeTolerances(v, nodeDry);
    EXPECT_EQ(tDry.river, INFINITY);  // no river, fixed outline: nothing moves sideways
    EXPECT_EQ(engine::nodeTolerance(v, nodeDry), tDry.vertical);
    engine::LodNode nodeWet = nodeAt(0, 0, 8000, wet);
    const engine::NodeTolerance t = engine::nodeTolerances(v, nodeWet);
    EXPECT_EQ(t.vertical, tDry.vertical);
    ASSERT_GT(t.vertical, 2.5 * t.river) << "steep view: sin(phi) about 0.3";
    EXPECT_EQ(engine::nodeTolerance(v, nodeWet), t.river);  // the single (paper) tolerance

    // Level 2: combined error above the river tolerance, river part 1 % above it: not drawn.
    const float errorMax[3] = {0, float(0.5 * t.river), float(0.99 * t.vertical)};
    const float river[3] = {0, float(0.5 * t.river), float(1.01 * t.river)};
    for (int i = 0; i < 3; ++i)
        wet[std::size_t(i)].errorMax = errorMax[i], wet[std::size_t(i)].errorRiver = river[i];
    engine::NodeChoice c = engine::chooseNode(v, nodeWet, 0, format::kMetricMax);
    EXPECT_EQ(c.hLim, t.vertical);
    EXPECT_EQ(c.hLimRiver, t.river);
    EXPECT_EQ(c.wanted.level, 1u);
    EXPECT_FALSE(format::levelFits(wet[2], format::kMetricMax, t.vertical, t.river));
    // River part 1 % below it: drawn, though its combined error is 2.5 times the river
    // tolerance (the version 3 rule, one number without sin(phi), would draw level 1).
    wet[2].errorRiver = float(0.99 * t.river);
    c = engine::chooseNode(v, nodeWet, 0, format::kMetricMax);
    EXPECT_EQ(c.wanted.level, 2u);
    EXPECT_DOUBLE_EQ(c.wanted.riverError, double(wet[2].errorRiver));
    EXPECT_EQ(format::storedLevelFor(wet, format::kMetricMax, t.river), 1u);  // errorMax alone
    // The paper metric has no river part: its error is held to the single tolerance.
    c = engine::chooseNode(v, nodeWet, 0, format::kMetricPaper);
    EXPECT_EQ(c.hLim, t.river);
    EXPECT_EQ(c.hLimRiver, INFINITY);
    EXPECT_EQ(c.wanted.level, 2u);  // errorPaper 6 from threeLevels, far below t.river here
    ASSERT_LT(6.0, t.river);

    // A node with children gives way to them when its finest level's river part does not fit.
    std::vector<format::Level> parentLevels = wet;
    parentLevels[0].errorRiver = parentLevels[0].errorMax = float(1.5 * t.river);
    std::vector<engine::LodNode> nodes = {nodeAt(0, 0, 4000, dry), nodeAt(4000, 0, 4000, dry),
                                          nodeAt(0, 4000, 4000, dry),
                                          nodeAt(4000, 4000, 4000, dry),
                                          nodeAt(0, 0, 8000, parentLevels)};
    nodes[4].firstChild = 0, nodes[4].childCount = 4, nodes[4].level = 1;
    std::vector<engine::NodeChoice> cut;
    engine::selectCut(v, nodes, format::kMetricMax, cut);
    EXPECT_EQ(cut.size(), 4u);
    for (const engine::NodeChoice& k : cut)
        EXPECT_LT(k.block, 4u);
    parentLevels[0].errorRiver = float(0.5 * t.river);
    engine::selectCut(v, nodes, format::kMetricMax, cut);
    ASSERT_EQ(cut.size(), 1u);
    EXPECT_EQ(cut[0].block, 4u);
}

TEST(Cut, GridModeCullsTheTopDownRectangle) {
    const std::vector<format::Level> levels = threeLevels(false);
    std::vector<engine::LodNode> nodes;
    for (int i = 0; i < 10; ++i)
        nodes.push_back(nodeAt(1000.0 * i, 0, 1000, levels));
    engine::ViewSpec v;
    v.kind = engine::ViewSpec::Kind::Grid;
    v.camera.eye[0] = 500, v.camera.eye[1] = 500, v.camera.eye[2] = 1000;
    v.widthPixels = v.heightPixels = 100;
    v.gridHalfHeight = 1200;  // x in [-700, 1700]: blocks 0 and 1
    std::vector<engine::NodeChoice> cut;
    engine::selectCut(v, nodes, format::kMetricMax, cut);
    ASSERT_EQ(cut.size(), 2u);
    EXPECT_EQ(cut[0].block, 0u);
    EXPECT_EQ(cut[1].block, 1u);
}

// A root over [0, 2000]^2 (levels with errors 10 / 20) and its four 1 km children (0 / 2 / 6).
struct Tree {
    std::vector<format::Level> parentLevels, childLevels;
    std::vector<engine::LodNode> nodes;
    Tree() {
        parentLevels = threeLevels(false);
        parentLevels.pop_back();
        parentLevels[0].errorMax = parentLevels[0].errorPaper = 10;
        parentLevels[1].errorMax = parentLevels[1].errorPaper = 20;
        childLevels = threeLevels(false);
        nodes.push_back(nodeAt(0, 0, 2000, parentLevels));
        nodes[0].firstChild = 1;
        nodes[0].childCount = 4;
        for (int k = 0; k < 4; ++k)
            nodes.push_back(nodeAt(1000.0 * (k % 2), 1000.0 * (k / 2), 1000, childLevels));
    }
};

TEST(Cut, TreeDrawsANodeWhenItsStartingErrorFits) {
    Tree t;
    engine::ViewSpec v;
    v.kind = engine::ViewSpec::Kind::Uniform;
    std::vector<engine::NodeChoice> cut;
    // h_lim 25: the root at its coarsest level; 15: the root at full resolution (10 <= 15 < 20).
    v.hLim = 25;
    engine::selectCut(v, t.nodes, format::kMetricMax, cut);
    ASSERT_EQ(cut.size(), 1u);
    EXPECT_EQ(cut[0].block, 0u);
    EXPECT_EQ(cut[0].wanted.level, 1u);
    v.hLim = 15;
    engine::selectCut(v, t.nodes, format::kMetricMax, cut);
    ASSERT_EQ(cut.size(), 1u);
    EXPECT_EQ(cut[0].wanted.level, 0u);
    // h_lim 5 < the root's starting error: its four children, each at error 2 (level 1).
    v.hLim = 5;
    engine::selectCut(v, t.nodes, format::kMetricMax, cut);
    ASSERT_EQ(cut.size(), 4u);
    for (std::uint32_t k = 0; k < 4; ++k) {
        EXPECT_EQ(cut[k].block, k + 1);
        EXPECT_EQ(cut[k].wanted.level, 1u);
    }
    // Full resolution: the leaves at level 0, whatever h_lim allows.
    v.hLim = 1e9;
    v.finest = true;
    engine::selectCut(v, t.nodes, format::kMetricMax, cut);
    ASSERT_EQ(cut.size(), 4u);
    for (const engine::NodeChoice& c : cut)
        EXPECT_EQ(c.wanted.level, 0u);
}

TEST(Cut, TreeCullsSubtreesAndDescendsNearTheEye) {
    Tree t;
    // Low over child 0 (x, y < 1000), looking north-east along the diagonal: the root's nearest
    // point is under the eye (S small, h_lim below its starting error), so it gives way to its
    // children; child 0 and the children ahead are drawn, none behind the eye.
    engine::ViewSpec v;
    v.camera.eye[0] = 300, v.camera.eye[1] = 300, v.camera.eye[2] = 50;
    v.camera.yawDegrees = 45;
    v.camera.pitchDegrees = -5;
    std::vector<engine::NodeChoice> cut;
    engine::selectCut(v, t.nodes, format::kMetricMax, cut);
    ASSERT_FALSE(cut.empty());
    for (const engine::NodeChoice& c : cut)
        EXPECT_NE(c.block, 0u) << "the root was drawn";
    EXPECT_EQ(cut.front().block, 1u);  // the child under the eye, nearest first
    // The same view from 100 km up looking down: the root alone.
    v.camera.eye[2] = 100e3;
    v.camera.pitchDegrees = -90;
    engine::selectCut(v, t.nodes, format::kMetricMax, cut);
    ASSERT_EQ(cut.size(), 1u);
    EXPECT_EQ(cut[0].block, 0u);
    // Beyond the tree's north-east corner, looking further north-east: nothing.
    v.camera.eye[0] = v.camera.eye[1] = 2500;
    v.camera.eye[2] = 50;
    v.camera.pitchDegrees = 0;
    engine::selectCut(v, t.nodes, format::kMetricMax, cut);
    EXPECT_TRUE(cut.empty());
}

// A one-level block over the unit square [0, 10]^2 with the given triangles.
format::Block squareBlock(const std::vector<format::Vertex>& vertices,
                          const std::vector<format::Triangle>& triangles) {
    format::Block b;
    b.minX = 0, b.minY = 0, b.maxX = 10, b.maxY = 10, b.maxZ = 1;
    b.vertices = vertices;
    b.terrainIndices = triangles;
    b.levels.resize(1);
    b.levels[0].vertexCount = std::uint32_t(vertices.size());
    b.levels[0].triangleCount = std::uint32_t(triangles.size());
    return b;
}

TEST(Cut, OutlineMovesUnlessTheCoarsestOutlineIsTheRectangle) {
    // Two triangles covering the square: the outline is the rectangle.
    const format::Block full = squareBlock(
        {{0, 0, 0, 0}, {10, 0, 0, 0}, {10, 10, 0, 0}, {0, 10, 0, 0}}, {{0, 1, 2}, {0, 2, 3}});
    EXPECT_FALSE(format::outlineMoves(full));
    EXPECT_FALSE(engine::lodNode(full).horizontal);
    // One triangle: the diagonal is an outline edge inside the box (nodata beyond it).
    const format::Block half =
        squareBlock({{0, 0, 0, 0}, {10, 0, 0, 0}, {10, 10, 0, 0}}, {{0, 1, 2}});
    EXPECT_TRUE(format::outlineMoves(half));
    EXPECT_TRUE(engine::lodNode(half).horizontal);
}

// WorkerPool (engine/lod/workers.h): every index once, any pool size, an exception rethrown on the
// caller and the pool usable after it.
TEST(WorkerPool, CallsEveryIndexOnceAndRethrows) {
    for (const std::size_t threads : {std::size_t(1), std::size_t(2), std::size_t(5)}) {
        engine::WorkerPool pool(threads);
        EXPECT_GE(pool.threads(), 1u);
        EXPECT_LE(pool.threads(), threads);
        for (const std::size_t n :
             {std::size_t(0), std::size_t(1), std::size_t(7), std::size_t(1000)}) {
            std::vector<std::atomic<int>> calls(n);
            pool.run(n, [&](std::size_t i) { ++calls[i]; });
            for (std::size_t i = 0; i < n; ++i)
                ASSERT_EQ(calls[i].load(), 1) << "threads " << threads << " n " << n << " i " << i;
        }
        std::atomic<int> after{0};
        EXPECT_THROW(pool.run(100,
                              [&](std::size_t i) {
                                  if (i == 37) throw std::runtime_error("task 37");
                                  ++after;
                              }),
                     std::runtime_error);
        EXPECT_LT(after.load(), 100);
        std::atomic<int> again{0};
        pool.run(50, [&](std::size_t) { ++again; });
        EXPECT_EQ(again.load(), 50);
    }
}

}  // namespace
