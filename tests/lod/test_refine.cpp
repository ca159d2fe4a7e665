// Selective refinement of a leaf's deletion records (engine/lod/refine.h) on the bundled model at
// 64-cell leaves (rivers, a clipped outline): every refined mesh is a valid triangulation of the
// block (the reader's level checks), its true error (recomputed by `check --errors`' code from
// every original point, an implementation independent of refine.cpp) is within the tolerance
// the steps were taken for, and it is not larger than the stored prefix of the same tolerance.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <string>
#include <tuple>
#include <vector>

#include "blockbuild.h"
#include "blocks.h"
#include "cut.h"
#include "demfixtures.h"
#include "errorcheck.h"
#include "lod.h"
#include "refine.h"
#include "tools/cliutil.h"
#include "ulod.h"

using namespace unilod;
namespace fs = std::filesystem;
using unilod::test::q;
using unilod::test::runCli;

namespace {

const std::string kAssets = UNILOD_ASSETS_DIR;

class Refine : public ::testing::Test {
protected:
    static void SetUpTestSuite() {
        dir_ = fs::temp_directory_path() / ("unilod_test_refine_" + std::to_string(getpid()));
        fs::create_directories(dir_);
        const std::string file = (dir_ / "jacksboro.ulod").string();
        const auto r =
            runCli("build -q --block-size 64 " + q(kAssets + "/jacksboro_dem.tif") + " " +
                   q(kAssets + "/jacksboro_rivers_grass.geojson") + " -o " + q(file));
        ASSERT_EQ(r.code, 0) << r.err;
        format::Reader reader;
        std::string error;
        ASSERT_TRUE(reader.open(file, error)) << error;
        header_ = reader.header();
        for (std::size_t i = 0; i < reader.blocks().size(); ++i) {
            if (reader.blocks()[i].level != 0) {
                nodes_.emplace_back();
                ASSERT_TRUE(reader.readBlock(i, nodes_.back(), error)) << error;
                // The leaves below it (their vertices are its original points).
                auto& below = leavesBelow_.emplace_back();
                std::vector<std::size_t> stack{i};
                while (!stack.empty()) {
                    const format::BlockInfo& info = reader.blocks()[stack.back()];
                    const std::size_t at = stack.back();
                    stack.pop_back();
                    for (std::uint32_t c = 0; c < info.childCount; ++c)
                        stack.push_back(info.firstChild + c);
                    if (info.childCount == 0) below.push_back(at);
                }
                continue;
            }
            leafIndex_.push_back(i);
            leaves_.emplace_back();
            ASSERT_TRUE(reader.readBlock(i, leaves_.back(), error)) << error;
        }
    }
    static void TearDownTestSuite() {
        leaves_.clear();
        nodes_.clear();
        fs::remove_all(dir_);
    }

    // The refined mesh as a stored level of a copy of the block: the reader's geometry checks
    // (counter-clockwise on the exact grid, every directed edge once, river edges are edges of
    // the triangles).
    static void expectValidMesh(const format::Block& leaf, const engine::RefinedMesh& mesh) {
        format::Block copy = leaf;
        copy.terrainIndices = mesh.triangles;
        copy.riverIndices = mesh.riverEdges;
        std::sort(copy.riverIndices.begin(), copy.riverIndices.end(),
                  [](const format::Edge& a, const format::Edge& b) {
                      return a.a < b.a || (a.a == b.a && a.b < b.b);
                  });
        format::Level level{};
        level.vertexCount = std::uint32_t(leaf.vertices.size());
        level.triangleCount = std::uint32_t(mesh.triangles.size());
        level.riverCount = std::uint32_t(mesh.riverEdges.size());
        copy.levels = {level};
        std::string error;
        EXPECT_TRUE(format::validateLevelGeometry(copy, 0, error))
            << format::blockName(leaf.col, leaf.row) << ": " << error;
    }

    // Twice the signed area of the triangles (grid units squared).
    static std::int64_t doubleArea(const format::Block& b,
                                   const std::vector<format::Triangle>& triangles) {
        std::int64_t sum = 0;
        for (const format::Triangle& t : triangles) {
            const format::GridXY p = b.grid[t.a], q = b.grid[t.b], r = b.grid[t.c];
            sum += (std::int64_t(q.x) - p.x) * (std::int64_t(r.y) - p.y) -
                   (std::int64_t(q.y) - p.y) * (std::int64_t(r.x) - p.x);
        }
        return sum;
    }

    // The true error of the refined mesh at every original point (vertical, and the horizontal
    // distance to the outline of a point outside it): errorcheck.h's recomputation.
    static LevelMaxError trueError(const format::Block& leaf, const engine::RefinedMesh& mesh) {
        std::vector<TriangleTriple> triangles;
        for (const format::Triangle& t : mesh.triangles)
            triangles.push_back({{t.a, t.b, t.c}});
        LevelMaxError result;
        std::string error;
        EXPECT_TRUE(levelMaxError(leaf, 0, triangles, {}, RiverReference{}, result, error))
            << error;
        return result;
    }

    // The largest 3D distance from an original river vertex (a vertex of the full-resolution
    // river edges) to the nearest river edge of the mesh.
    static double riverDeviation(const format::Block& leaf, const engine::RefinedMesh& mesh) {
        const double u = format::kGridUnit;
        const auto at = [&](std::uint32_t v) {
            return std::array<double, 3>{leaf.grid[v].x * u, leaf.grid[v].y * u,
                                         double(leaf.vertices[v].z)};
        };
        const format::Level& full = leaf.levels.front();
        double worst = 0;
        for (std::uint32_t e = full.riverFirst; e < full.riverFirst + full.riverCount; ++e)
            for (const std::uint32_t v : {leaf.riverIndices[e].a, leaf.riverIndices[e].b}) {
                const auto p = at(v);
                double nearest = INFINITY;
                for (const format::Edge& m : mesh.riverEdges) {
                    const auto a = at(m.a), c = at(m.b);
                    double d[3], w[3], dd = 0, wd = 0;
                    for (int k = 0; k < 3; ++k) {
                        d[k] = c[k] - a[k], w[k] = p[k] - a[k];
                        dd += d[k] * d[k], wd += w[k] * d[k];
                    }
                    const double f = dd > 0 ? std::clamp(wd / dd, 0.0, 1.0) : 0.0;
                    double r2 = 0;
                    for (int k = 0; k < 3; ++k)
                        r2 += (w[k] - f * d[k]) * (w[k] - f * d[k]);
                    nearest = std::min(nearest, std::sqrt(r2));
                }
                worst = std::max(worst, nearest);
            }
        return worst;
    }

    static fs::path dir_;
    static format::Header header_;
    static std::vector<format::Block> leaves_, nodes_;
    static std::vector<std::size_t> leafIndex_;                 // file index of each leaf
    static std::vector<std::vector<std::size_t>> leavesBelow_;  // per node: its leaves' indices
};

fs::path Refine::dir_;
format::Header Refine::header_;
std::vector<format::Block> Refine::leaves_, Refine::nodes_;
std::vector<std::size_t> Refine::leafIndex_;
std::vector<std::vector<std::size_t>> Refine::leavesBelow_;

TEST_F(Refine, NothingDoneIsFullResolutionEverythingDoneIsTheCoarsestState) {
    ASSERT_EQ(leaves_.size(), 42u);
    for (const format::Block& leaf : leaves_) {
        engine::Refinement r;
        std::string why;
        ASSERT_TRUE(r.init(leaf, why)) << format::blockName(leaf.col, leaf.row) << ": " << why;
        engine::ViewSpec view;
        view.kind = engine::ViewSpec::Kind::Uniform;
        view.hLim = -1;  // no step fits
        engine::RefinedMesh mesh;
        r.refine(view, mesh);
        EXPECT_EQ(mesh.stepsDone, 0u);
        EXPECT_EQ(mesh.triangles.size(), leaf.levels.front().triangleCount);
        EXPECT_EQ(mesh.riverEdges.size(), leaf.levels.front().riverCount);
        view.hLim = INFINITY;  // every step fits: the last state of the records
        r.refine(view, mesh);
        EXPECT_EQ(mesh.stepsDone, leaf.steps.size());
        if (leaf.steps.empty()) {  // a leaf with nothing to delete
            EXPECT_EQ(mesh.triangles.size(), leaf.levels.front().triangleCount);
            continue;
        }
        EXPECT_EQ(mesh.triangles.size(), leaf.steps.back().trianglesAlive);
        EXPECT_EQ(mesh.riverEdges.size(), leaf.steps.back().riverEdgesAlive);
        expectValidMesh(leaf, mesh);
    }
}

TEST_F(Refine, UniformToleranceMeetsItsBoundWithNoMoreTrianglesThanThePrefix) {
    std::size_t partial = 0, outlineSteps = 0;
    for (const format::Block& leaf : leaves_) {
        engine::Refinement r;
        std::string why;
        ASSERT_TRUE(r.init(leaf, why)) << why;
        for (std::size_t k = 0; k < r.steps(); ++k)
            outlineSteps += r.stepMovesOutline(k);
        for (const double h : {0.5, 2.0, 5.0, 20.0}) {
            engine::ViewSpec view;
            view.kind = engine::ViewSpec::Kind::Uniform;
            view.hLim = h;
            engine::RefinedMesh mesh;
            r.refine(view, mesh);
            SCOPED_TRACE(format::blockName(leaf.col, leaf.row) + " at " + std::to_string(h) + " m");
            expectValidMesh(leaf, mesh);
            partial += mesh.stepsDone > 0 && mesh.stepsDone < leaf.steps.size();
            // The true error, recomputed from every original point, within h (the float slack
            // of `check --errors`).
            const LevelMaxError e = trueError(leaf, mesh);
            const double slack = maxErrorTolerance(leaf);
            EXPECT_LE(e.vertical, h + slack);
            EXPECT_LE(e.river, h + slack);
            EXPECT_LE(riverDeviation(leaf, mesh), h + slack);
            // Every step of the stored prefix within h fits (its stored running maximum bounds
            // its own error), so the refined mesh has done at least those steps: no more
            // triangles than the exact state k* (a deletion never adds triangles).
            const std::size_t prefix = engine::exactStep(leaf.errorMax, h - 1e-3);
            const std::uint32_t prefixTriangles = prefix == 0
                                                      ? leaf.levels.front().triangleCount
                                                      : leaf.steps[prefix - 1].trianglesAlive;
            EXPECT_LE(mesh.triangles.size(), prefixTriangles);
            EXPECT_GE(mesh.stepsDone, prefix);
            // The engine starts from that prefix (the cut's stored level): the same mesh.
            engine::RefinedMesh fromPrefix;
            r.refine(view, fromPrefix, std::uint32_t(prefix));
            EXPECT_EQ(fromPrefix.stepsDone, mesh.stepsDone);
            EXPECT_EQ(fromPrefix.triangles.size(), mesh.triangles.size());
            // ... or from the stored level the cut picks (its triangles are the start).
            const std::size_t stored = format::storedLevelFor(leaf.levels, format::kMetricMax, h);
            engine::RefinedMesh fromLevel;
            r.refine(view, fromLevel, leaf.levels[stored].step);
            EXPECT_EQ(fromLevel.stepsDone, mesh.stepsDone);
            auto sorted = [](std::vector<format::Triangle> t) {
                std::sort(t.begin(), t.end(),
                          [](const format::Triangle& x, const format::Triangle& y) {
                              return std::tie(x.a, x.b, x.c) < std::tie(y.a, y.b, y.c);
                          });
                return t;
            };
            const auto a = sorted(fromLevel.triangles), c = sorted(mesh.triangles);
            EXPECT_TRUE(std::equal(a.begin(), a.end(), c.begin(), c.end(),
                                   [](const format::Triangle& x, const format::Triangle& y) {
                                       return x.a == y.a && x.b == y.b && x.c == y.c;
                                   }));
            EXPECT_EQ(fromLevel.riverEdges.size(), mesh.riverEdges.size());
        }
    }
    EXPECT_GT(partial, 40u);        // not vacuous: most meshes are neither extreme
    EXPECT_GT(outlineSteps, 100u);  // straight outline stretches simplified (clipped DEM)
}

// Tree nodes: their steps take the stored running maximum, their outline-moving steps are never
// taken. Every refined mesh is a valid triangulation, and its true error at every ORIGINAL point
// of the node's area (the leaves' vertices and river points, recomputed by `check --errors`'
// NodeOriginalError) is within the uniform tolerance.
TEST_F(Refine, TreeNodesMeetTheBoundAtTheirLeavesOriginalPoints) {
    ASSERT_EQ(nodes_.size(), 17u);
    std::size_t partial = 0, blocked = 0;
    for (std::size_t i = 0; i < nodes_.size(); ++i) {
        const format::Block& node = nodes_[i];
        engine::Refinement r;
        std::string why;
        ASSERT_TRUE(r.init(node, why)) << why;
        ASSERT_EQ(r.steps(), node.steps.size());
        for (std::size_t k = 0; k < r.steps(); ++k) {
            blocked += r.stepMovesOutline(k);
            EXPECT_EQ(r.stepError(k), node.errorMax[k + 1]);
        }
        const std::vector<double> tolerances = {5.0, 20.0, 50.0, 100.0, 200.0};
        std::vector<std::vector<TriangleTriple>> levels;
        std::vector<std::vector<RiverEdge>> rivers;
        for (const double h : tolerances) {
            engine::ViewSpec view;
            view.kind = engine::ViewSpec::Kind::Uniform;
            view.hLim = h;
            // From the stored level the cut picks, as the engine refines (outline-moving steps
            // are taken only within it).
            const format::Level& stored =
                node.levels[format::storedLevelFor(node.levels, format::kMetricMax, h)];
            engine::RefinedMesh mesh;
            r.refine(view, mesh, stored.step);
            SCOPED_TRACE("node " + std::to_string(i) + " at " + std::to_string(h) + " m");
            expectValidMesh(node, mesh);
            partial += mesh.stepsDone > stored.step && mesh.stepsDone < node.steps.size();
            EXPECT_GE(mesh.stepsDone, stored.step);
            EXPECT_LE(mesh.triangles.size(), stored.triangleCount);
            auto& t = levels.emplace_back();
            for (const format::Triangle& x : mesh.triangles)
                t.push_back(canonicalTriangle(x.a, x.b, x.c));
            auto& e = rivers.emplace_back();
            for (const format::Edge& x : mesh.riverEdges)
                e.push_back(makeRiverEdge(x.a, x.b));
        }
        // The node's starting error must fit for it to be drawn at all: tolerances below it
        // are not checked against the original points (its start is its children's coarsest).
        NodeOriginalError originals(node, levels, rivers);
        for (const std::size_t leaf : leavesBelow_[i]) {
            const auto at = std::find(leafIndex_.begin(), leafIndex_.end(), leaf);
            ASSERT_NE(at, leafIndex_.end());
            originals.add(leaves_[std::size_t(at - leafIndex_.begin())]);
        }
        for (std::size_t k = 0; k < tolerances.size(); ++k) {
            if (tolerances[k] < node.errorMax.front()) continue;
            EXPECT_LE(originals.worst()[k].value, tolerances[k] + originals.tolerance())
                << "node " << i << " at " << tolerances[k] << " m";
            EXPECT_LE(originals.riverWorst()[k].value, tolerances[k] + originals.tolerance())
                << "node " << i << " at " << tolerances[k] << " m";
        }
    }
    EXPECT_GT(partial, 2u);  // not vacuous: steps past the stored level taken
    EXPECT_GT(blocked, 0u);  // the clipped outline moves in some node
}

TEST_F(Refine, PerspectiveViewKeepsEveryOriginalPointWithinItsOwnTolerance) {
    // A low oblique view across the model (the fly-over's kind): near leaves need detail at
    // their near side only.
    engine::ViewSpec view;
    view.camera.eye[0] = header_.minX + 0.3 * (header_.maxX - header_.minX);
    view.camera.eye[1] = header_.minY - 2000;
    view.camera.eye[2] = header_.maxZ + 1500;
    view.camera.yawDegrees = 10;
    view.camera.pitchDegrees = -20;
    view.widthPixels = 1920;
    view.heightPixels = 1080;
    view.pixels = 1;
    const double aspect = view.widthPixels / view.heightPixels;
    std::uint64_t refinedTriangles = 0, storedTriangles = 0, checked = 0;
    for (const format::Block& leaf : leaves_) {
        const engine::LodNode node = engine::lodNode(leaf);
        if (!engine::nodeVisible(view, node.boxMin, node.boxMax)) continue;
        engine::Refinement r;
        std::string why;
        ASSERT_TRUE(r.init(leaf, why)) << why;
        engine::RefinedMesh mesh;
        r.refine(view, mesh);
        expectValidMesh(leaf, mesh);
        refinedTriangles += mesh.triangles.size();
        storedTriangles +=
            leaf.levels[engine::chooseNode(view, node, 0, format::kMetricMax).wanted.level]
                .triangleCount;
        // Every original point on screen: its vertical deviation from the refined surface
        // within the tolerance of a box holding the point and its surface point (the bound a
        // per-point method would use; a step's box holds both, so its tolerance is not larger).
        const double u = format::kGridUnit;
        for (std::uint32_t v = 0; v < leaf.vertices.size(); ++v) {
            const double x = leaf.grid[v].x * u, y = leaf.grid[v].y * u;
            const double z = leaf.vertices[v].z;
            for (const format::Triangle& t : mesh.triangles) {
                const format::GridXY a = leaf.grid[t.a], b = leaf.grid[t.b], c = leaf.grid[t.c];
                const format::GridXY p = leaf.grid[v];
                const auto o = [](format::GridXY i, format::GridXY j, format::GridXY k) {
                    return (std::int64_t(j.x) - i.x) * (std::int64_t(k.y) - i.y) -
                           (std::int64_t(j.y) - i.y) * (std::int64_t(k.x) - i.x);
                };
                if (o(a, b, p) < 0 || o(b, c, p) < 0 || o(c, a, p) < 0) continue;
                // Barycentric height of the triangle at the point.
                const double area = double(o(a, b, c));
                const double wa = double(o(b, c, p)) / area, wb = double(o(c, a, p)) / area;
                const double surface = wa * leaf.vertices[t.a].z + wb * leaf.vertices[t.b].z +
                                       (1 - wa - wb) * leaf.vertices[t.c].z;
                double lo[3] = {leaf.originX + x, leaf.originY + y, std::min(z, surface)};
                double hi[3] = {lo[0], lo[1], std::max(z, surface)};
                if (!engine::boxInFrustum(view.camera, aspect, lo, hi)) break;
                engine::LodNode point;
                std::copy(lo, lo + 3, point.boxMin);
                std::copy(hi, hi + 3, point.boxMax);
                const double tolerance = engine::nodeTolerances(view, point).vertical;
                EXPECT_LE(std::abs(surface - z), tolerance + maxErrorTolerance(leaf))
                    << format::blockName(leaf.col, leaf.row) << " vertex " << v;
                ++checked;
                break;
            }
        }
    }
    EXPECT_GT(checked, 10000u);
    // What refinement is for: the same guarantee with fewer triangles than the stored levels
    // the cut would draw for these leaves (about 40 % fewer on the bundled fly-over).
    EXPECT_LT(double(refinedTriangles), 0.9 * double(storedTriangles));
}

// A block whose outline corners are deleted (the library's build with the outer edge unlocked,
// as a tree root's is; the bundled leaves lock their outer edge and only straighten their
// outline): a disc with a bite and a hole, with relief. Steps that cut a corner leave original
// points outside the domain; their horizontal distance to the refined outline is within h.
TEST_F(Refine, OutlineCornersCutCountTheirHorizontalError) {
    const DemGrid d = test::discWithBiteAndHole();
    BlockSource source;
    BlockOptions bo;
    bo.blockSize = 35;
    bo.lockOuterEdge = false;
    std::string error;
    ASSERT_TRUE(source.init(d, {}, bo, error)) << error;
    ASSERT_EQ(source.blockCount(), 1u);
    BlockBuildOptions options;
    options.paperError = false;
    format::Block block;
    BlockBuildStats stats;
    ASSERT_TRUE(buildBlock(source.points(0), 0, 0, options, block, stats, error)) << error;
    engine::Refinement r;
    ASSERT_TRUE(r.init(block, error)) << error;
    std::size_t cuts = 0;
    for (std::size_t k = 0; k < r.steps(); ++k)
        cuts += r.stepMovesOutline(k) && r.stepRiverError(k) > 0;
    EXPECT_GT(cuts, 5u);
    std::size_t outside = 0;
    for (const double h : {2.0, 10.0, 20.0, 40.0, 80.0}) {
        engine::ViewSpec view;
        view.kind = engine::ViewSpec::Kind::Uniform;
        view.hLim = h;
        engine::RefinedMesh mesh;
        r.refine(view, mesh);
        SCOPED_TRACE(std::to_string(h) + " m");
        expectValidMesh(block, mesh);
        const LevelMaxError e = trueError(block, mesh);
        EXPECT_LE(e.vertical, h + maxErrorTolerance(block));
        EXPECT_LE(e.river, h + maxErrorTolerance(block));
        outside += e.river > 0;
        const std::size_t prefix = engine::exactStep(block.errorMax, h - 1e-3);
        EXPECT_GE(mesh.stepsDone, prefix);
    }
    EXPECT_GT(outside, 0u);  // some refined outline left points outside
}

}  // namespace
