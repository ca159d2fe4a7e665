// bench_order: how many triangles the deletion order needs for a uniform model error, against the
// greedy-insertion TIN (preprocess/greedytin.h, Garland and Heckbert 1995) on the same points.
// Prints JSON.
//
// Per dataset (the bundled Jacksboro DEM with its GRASS rivers; synthetic DEMs of about 1M and
// 4M points, `unilod synth --points N --seed 1`): build ONE block covering the DEM (block size =
// the DEM's longer side - 1, the largest blocks.h accepts), once with the rivers and once with an
// empty network, per deletion order (--orders). Per threshold e (--errors): the triangles of the
// exact state k* (stats.h computeErrorStats, max metric) and the greedy TIN's triangle count on the
// no-river block's own vertices (x, y = block origin + exact grid position, z), so domain and
// points are identical. The ratio with rivers is taken against the same no-river TIN: what the
// river constraints cost on top. Targets: no rivers <= 1.15 for e <= 10 m and <= 1.3 above
// (20 m); with rivers <= 1.5.
//
// With rivers, the best known method on the same points is measured too: a greedy TIN that holds
// the rivers simplified to e (3D Douglas-Peucker) as constraint edges (greedytin.h), one run per
// e (`constrained_tin_triangles`, `ratio_vs_constrained_tin`), beside a strict lower bound for any
// model (RiverDp). `--bai on,off` builds the river model with and without the BAI factor.
//
// `--build-time N`: a synthetic DEM of about N points (its river network scales with the grid,
// about 4 000 rivers at 16M points; tools/benchbuild.h as bench_build), built with the default
// options; wall seconds and peak RSS, beside the same run's reference: the bundled data built
// three times before and three times after (`build_over_reference`, against their median).
//
// `--tree N`: issue 18's block hierarchy on a default build of a synthetic DEM of about N points
// (treeBenchmark below): uniform cut vs a greedy TIN of the whole DEM, file vs leaf level, draws
// per pass on a fly-over and an orbit.
//
// Every build and every TIN runs in its own child process (benchutil.h), so each peak RSS is that
// step's alone.
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>
#include <vector>

#include "benchbuild.h"
#include "benchutil.h"
#include "campath.h"
#include "cut.h"
#include "dem.h"
#include "greedytin.h"
#include "jsontext.h"
#include "modelerror.h"
#include "refine.h"
#include "stats.h"
#include "synthetic.h"
#include "ulod.h"
#include "viewtin.h"

namespace {

using nlohmann::json;
namespace fs = std::filesystem;

[[noreturn]] void fail(const std::string& message) {
    std::fprintf(stderr, "bench_order: %s\n", message.c_str());
    std::exit(1);
}

double target(bool rivers, double e) {
    if (rivers) return 1.5;
    return e <= 10.0 ? 1.15 : 1.3;
}

std::size_t peakRssBytes() {
    rusage ru{};
    getrusage(RUSAGE_SELF, &ru);
    return std::size_t(ru.ru_maxrss) * 1024;
}

// The one block's vertices of a .ulod file.
unilod::PointSet readBlockPoints(const std::string& path) {
    unilod::format::Reader reader;
    std::string error;
    if (!reader.open(path, error)) fail(error);
    if (reader.blocks().size() != 1) {
        fail("'" + path + "': expected one block, found " +
             std::to_string(reader.blocks().size()));
    }
    unilod::format::Block b;
    if (!reader.readBlock(0, b, error)) fail(error);
    return unilod::blockPoints(b);
}

// The whole model at full resolution as ONE block (viewtin.h mergedLeaves).
unilod::format::Block mergedLeaves(const std::string& path) {
    unilod::format::Reader reader;
    std::string error;
    unilod::format::Block out;
    if (!reader.open(path, error) || !unilod::mergedLeaves(reader, out, error)) fail(error);
    return out;
}

// The nodes as the engine sees them: boxes, links and levels from the directory.
std::vector<unilod::engine::LodNode> lodNodes(const unilod::format::Reader& reader) {
    std::vector<unilod::engine::LodNode> nodes;
    for (const unilod::format::BlockInfo& info : reader.blocks())
        nodes.push_back(unilod::engine::lodNode(info));
    return nodes;
}

// Issue 18's targets on a model with the block hierarchy: the cut for a uniform h_lim (the
// triangles the engine draws, stats.h computeErrorStats) against a greedy TIN of the whole DEM
// (every leaf point once) at the same error; the file's bytes against its leaf level's; and the
// draws per pass (entries of the cut, lod/cut.h selectCut) at every frame of a fly-over (south-west
// to north-east, a fifth of the width above the top, 25 degrees down: `unilod bench`'s default
// path) and of an orbit (72 frames around the centre at 0.6 of the width, 0.3 of it above the top,
// looking at the centre), 1920 x 1080, 60 degrees, P = 1, nearest distance.
json treeBenchmark(const std::string& path, const std::vector<double>& errors) {
    json out;
    {
        unilod::ErrorStatsTable table;
        std::string error;
        if (!unilod::computeErrorStats(path, errors, unilod::format::kMetricMax, table, error))
            fail(error);
        out["leaf_blocks"] = table.blocks;
        out["tree_nodes"] = table.nodes;
        json cuts = json::array();
        for (const unilod::ErrorStatsRow& r : table.rows)
            cuts.push_back({{"error", r.error},
                            {"triangles", r.levelTriangles},
                            {"exact_triangles", r.exactTriangles},
                            {"nodes", r.nodes}});
        out["cuts"] = cuts;
    }
    unilod::format::Reader reader;
    std::string error;
    if (!reader.open(path, error)) fail(error);
    std::uint64_t leafBytes = 0, allBytes = 0;
    for (const unilod::format::BlockInfo& b : reader.blocks()) {
        allBytes += b.size;
        if (b.level == 0) leafBytes += b.size;
    }
    out["file_bytes"] = fs::file_size(path);
    out["block_bytes"] = allBytes;
    out["leaf_block_bytes"] = leafBytes;
    out["file_ratio_vs_leaf_level"] = double(allBytes) / double(leafBytes);
    out["file_target"] = 1.3;

    const std::vector<unilod::engine::LodNode> nodes = lodNodes(reader);
    // What the uniform cuts keep on the hierarchy's locked borders: vertices flagged locked that
    // lie on their node's box outline inside the model (the model's own outer edge excluded), and
    // the drawn triangles that touch one.
    {
        const unilod::format::Header& hd = reader.header();
        for (std::size_t k = 0; k < errors.size(); ++k) {
            unilod::engine::ViewSpec v;
            v.kind = unilod::engine::ViewSpec::Kind::Uniform;
            v.hLim = errors[k];
            std::vector<unilod::engine::NodeChoice> cut;
            unilod::engine::selectCut(v, nodes, unilod::format::kMetricMax, cut);
            std::uint64_t vertices = 0, border = 0, borderTriangles = 0, triangles = 0;
            for (const unilod::engine::NodeChoice& n : cut) {
                unilod::format::BlockGeometry g;
                if (!reader.readGeometry(n.block, int(n.wanted.level), g, error)) fail(error);
                const auto near = [](double a, double b) { return std::fabs(a - b) < 0.01; };
                std::vector<char> onBorder(g.vertices.size(), 0);
                for (std::size_t i = 0; i < g.vertices.size(); ++i) {
                    const unilod::format::Vertex& p = g.vertices[i];
                    if (!(p.flags & unilod::format::kVertexLocked)) continue;
                    const double x = g.originX + p.x, y = g.originY + p.y;
                    const bool edge = (near(x, g.minX) && !near(x, hd.minX)) ||
                                      (near(x, g.maxX) && !near(x, hd.maxX)) ||
                                      (near(y, g.minY) && !near(y, hd.minY)) ||
                                      (near(y, g.maxY) && !near(y, hd.maxY));
                    onBorder[i] = edge;
                    border += edge;
                }
                vertices += g.vertices.size();
                triangles += g.terrainIndices.size();
                for (const unilod::format::Triangle& t : g.terrainIndices)
                    borderTriangles += onBorder[t.a] || onBorder[t.b] || onBorder[t.c];
            }
            // Each drawn node: tree level, the level drawn and its stored error, the node's
            // finest (starting) and coarsest (hand-over) errors and triangles.
            json drawn = json::array();
            for (const unilod::engine::NodeChoice& n : cut) {
                const std::vector<unilod::format::Level>& l = *nodes[n.block].levels;
                drawn.push_back({{"tree_level", n.treeLevel},
                                 {"level", n.wanted.level},
                                 {"levels", l.size()},
                                 {"error", l[n.wanted.level].errorMax},
                                 {"triangles", l[n.wanted.level].triangleCount},
                                 {"start_error", l.front().errorMax},
                                 {"start_triangles", l.front().triangleCount},
                                 {"coarsest_error", l.back().errorMax},
                                 {"coarsest_triangles", l.back().triangleCount}});
            }
            for (json& c : out["cuts"]) {
                if (c["error"] != errors[k]) continue;
                c["drawn"] = drawn;
                c["vertices"] = vertices;
                c["locked_border_vertices"] = border;
                c["triangles_touching_locked_border"] = borderTriangles;
                c["triangles_read"] = triangles;
            }
        }
    }
    const unilod::format::Header& h = reader.header();
    const double w = std::max(h.maxX - h.minX, h.maxY - h.minY);
    const double cx = (h.minX + h.maxX) / 2, cy = (h.minY + h.maxY) / 2;
    auto measure = [&](const std::vector<unilod::engine::Camera>& cameras) {
        std::size_t maxDraws = 0;
        double sumDraws = 0;
        std::uint64_t maxTriangles = 0;
        std::vector<unilod::engine::NodeChoice> cut;
        for (const unilod::engine::Camera& c : cameras) {
            unilod::engine::ViewSpec v;
            v.camera = c;
            v.widthPixels = 1920;
            v.heightPixels = 1080;
            unilod::engine::selectCut(v, nodes, unilod::format::kMetricMax, cut);
            std::uint64_t triangles = 0;
            for (const unilod::engine::NodeChoice& n : cut)
                triangles += (*nodes[n.block].levels)[n.wanted.level].triangleCount;
            maxDraws = std::max(maxDraws, cut.size());
            sumDraws += double(cut.size());
            maxTriangles = std::max(maxTriangles, triangles);
        }
        return json{{"frames", cameras.size()},
                    {"max_draws_per_pass", maxDraws},
                    {"mean_draws_per_pass", sumDraws / double(cameras.size())},
                    {"max_triangles", maxTriangles}};
    };
    std::vector<unilod::engine::Camera> fly, orbit;
    fly = unilod::engine::sampleCameraPath(unilod::engine::defaultFlyOver(h), 200);
    for (int f = 0; f < 72; ++f) {
        const double a = f * 5.0 * 3.14159265358979323846 / 180;
        unilod::engine::Camera c;
        c.eye[0] = cx + 0.6 * w * std::sin(a);
        c.eye[1] = cy - 0.6 * w * std::cos(a);
        c.eye[2] = h.maxZ + 0.3 * w;
        c.yawDegrees = std::fmod(f * 5.0, 360.0);  // towards the centre (0 = north)
        c.pitchDegrees = -std::atan2(0.3 * w + (h.maxZ - h.minZ) / 2, 0.6 * w) * 180 /
                         3.14159265358979323846;
        orbit.push_back(c);
    }
    out["fly_over"] = measure(fly);
    out["orbit"] = measure(orbit);
    out["draws_target"] = 64;
    return out;
}

// `--view FILE`: the engine's cut against the best known method for the same views (issues 15
// and 18: full/lod on the fly-over). Per sampled frame of a camera path (default: `unilod bench`'s
// fly-over, 200 frames; 1920 x 1080, P, nearest distance, max metric):
// - the cut (lod/cut.h selectCut, what `bench` draws): triangles drawn, triangles whose bounding
//   box meets the view frustum, draws;
// - a view-dependent greedy-insertion TIN of the whole model's points (every leaf point once,
//   mergedLeaves; no river constraints): each point p on screen must lie within its own tolerance
//   h_lim(p) = lod.h blockTolerance for a box that is the point alone (S = |p - eye|, the same
//   P-pixel bound the cut applies per box: the tightest a per-point method can use), points off
//   screen need nothing (weight 0; greedytin.h setWeights); its triangles that meet the frustum.
// - the cut with every drawn leaf selectively refined from its deletion records instead of drawn
//   at a stored level (lod/refine.h; tree nodes keep their stored level): `refined_triangles`,
//   `refined_triangles_in_view`, `refine_seconds` (the CPU time of the refinements).
// `ratio_in_view` and its sums / median are of the stored-level cut; `refined_ratio_in_view`,
// `refined_ratio_of_sums_in_view` and `median_refined_ratio_in_view` of the refined one, which is
// what `bench` draws by default (SceneOptions::refine).
// The TIN is the Garland-Heckbert method with the engine's own screen-space criterion at point
// granularity: what a view-dependent simplification of the same DEM needs, rivers aside (run it
// on a model built without rivers for the like-for-like ratio).
json viewBenchmark(const std::string& path, const std::string& cameraPath, std::uint32_t frames,
                   std::uint32_t every, double pixels) {
    unilod::format::Reader reader;
    std::string error;
    if (!reader.open(path, error)) fail(error);
    const std::vector<unilod::engine::LodNode> nodes = lodNodes(reader);
    unilod::engine::CameraPath route = unilod::engine::defaultFlyOver(reader.header());
    if (!cameraPath.empty() && !unilod::engine::loadCameraPath(cameraPath, route, error))
        fail(error);
    const std::vector<unilod::engine::Camera> cameras =
        unilod::engine::sampleCameraPath(route, frames);
    const unilod::format::Block all = mergedLeaves(path);
    const unilod::PointSet set = unilod::blockPoints(all);
    const double width = 1920, height = 1080, aspect = width / height;
    // A triangle meets the view when its bounding box does (conservative, as the cut's culling).
    const auto inView = [&](const unilod::engine::Camera& c, const double a[3], const double b[3],
                            const double d[3]) {
        double lo[3], hi[3];
        for (int k = 0; k < 3; ++k) {
            lo[k] = std::min({a[k], b[k], d[k]});
            hi[k] = std::max({a[k], b[k], d[k]});
        }
        return unilod::engine::boxInFrustum(c, aspect, lo, hi);
    };
    json rows = json::array();
    std::map<std::uint32_t, std::unique_ptr<unilod::engine::Refinement>> refinements;
    std::map<std::uint32_t, std::vector<unilod::format::Vertex>> refinedVertexCache;
    const auto refineVertices =
        [&](std::uint32_t block) -> const std::vector<unilod::format::Vertex>& {
        auto it = refinedVertexCache.find(block);
        if (it == refinedVertexCache.end()) {
            unilod::format::BlockGeometry g;
            if (!reader.readGeometry(block, unilod::format::kAllLevels, g, error)) fail(error);
            it = refinedVertexCache.emplace(block, std::move(g.vertices)).first;
        }
        return it->second;
    };
    unilod::engine::RefinedMesh mesh;
    double refineSeconds = 0;
    std::uint64_t sumRefined = 0, sumRefinedInView = 0;
    std::vector<double> ratios, refinedRatios;
    std::uint64_t sumCut = 0, sumCutInView = 0, sumTin = 0, sumBlockTin = 0;
    double tinSeconds = 0;
    std::vector<double> weights(set.points.size()), blockWeights(set.points.size());
    // A greedy TIN of every point to its weight (viewtin.h weightedTin); its triangles that
    // meet the view.
    const auto weightedTin = [&](const unilod::engine::Camera& c, const std::vector<double>& w,
                                 std::uint32_t& vertices) {
        std::vector<unilod::TriangleTriple> triangles;
        std::string why;
        if (!unilod::weightedTin(set, w, triangles, vertices, why)) fail(why);
        std::uint64_t count = 0;
        for (const unilod::TriangleTriple& t : triangles) {
            double p[3][3];
            for (int k = 0; k < 3; ++k) {
                const unilod::Point& q = set.points[t.v[k]];
                p[k][0] = q.x, p[k][1] = q.y, p[k][2] = q.z;
            }
            count += inView(c, p[0], p[1], p[2]);
        }
        return count;
    };
    for (std::uint32_t f = 0; f < cameras.size(); f += every) {
        const unilod::engine::Camera& c = cameras[f];
        unilod::engine::ViewSpec v;
        v.camera = c;
        v.widthPixels = width;
        v.heightPixels = height;
        v.pixels = pixels;
        std::vector<unilod::engine::NodeChoice> cut;
        unilod::engine::selectCut(v, nodes, unilod::format::kMetricMax, cut);
        std::uint64_t drawn = 0, drawnInView = 0, refined = 0, refinedInView = 0, refinedLeaves = 0;
        for (const unilod::engine::NodeChoice& n : cut) {
            drawn += (*nodes[n.block].levels)[n.wanted.level].triangleCount;
            std::uint64_t levelInView = 0;
            // Selective refinement of a leaf's records (lod/refine.h) from its stored level on,
            // where the leaf can be refined and that level is not its last state (the engine's
            // rule, scene.cpp).
            auto known = refinements.find(n.block);
            if (known == refinements.end()) {
                unilod::format::Block b;
                if (!reader.readBlock(n.block, b, error)) fail(error);
                auto r = std::make_unique<unilod::engine::Refinement>();
                std::string why;
                if (!r->init(b, why)) r.reset();
                known = refinements.emplace(n.block, std::move(r)).first;
            }
            const bool useMt =
                known->second != nullptr && n.wanted.step < reader.blocks()[n.block].stepCount;
            if (useMt) {
                const auto t0 = std::chrono::steady_clock::now();
                known->second->refine(v, mesh, n.wanted.step);
                refineSeconds +=
                    std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
                refined += mesh.triangles.size();
                const unilod::format::BlockInfo& info = reader.blocks()[n.block];
                for (const unilod::format::Triangle& t : mesh.triangles) {
                    double p[3][3];
                    const std::uint32_t corner[3] = {t.a, t.b, t.c};
                    for (int k = 0; k < 3; ++k) {
                        const unilod::format::Vertex& q = refineVertices(n.block)[corner[k]];
                        p[k][0] = info.originX + q.x;
                        p[k][1] = info.originY + q.y;
                        p[k][2] = q.z;
                    }
                    refinedInView += inView(c, p[0], p[1], p[2]);
                }
                ++refinedLeaves;
            }
            unilod::format::BlockGeometry g;
            if (!reader.readGeometry(n.block, int(n.wanted.level), g, error)) fail(error);
            for (const unilod::format::Triangle& t : g.terrainIndices) {
                double p[3][3];
                const std::uint32_t corner[3] = {t.a, t.b, t.c};
                for (int k = 0; k < 3; ++k) {
                    const unilod::format::Vertex& q = g.vertices[corner[k]];
                    p[k][0] = g.originX + q.x;
                    p[k][1] = g.originY + q.y;
                    p[k][2] = q.z;
                }
                levelInView += inView(c, p[0], p[1], p[2]);
            }
            drawnInView += levelInView;
            if (!useMt) {
                refined += (*nodes[n.block].levels)[n.wanted.level].triangleCount;
                refinedInView += levelInView;
            }
        }
        // Each point's own tolerance (a box of one point), 0 weight off screen.
        const std::uint64_t onScreen =
            unilod::viewWeights(set, unilod::TinView{c, width, height, pixels}, weights);
        const auto start = std::chrono::steady_clock::now();
        std::uint32_t tinVertices = 0;
        const std::uint64_t tinInView = weightedTin(c, weights, tinVertices);
        tinSeconds +=
            std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        // The same TIN with the cut's own tolerances: every point on screen within the h_lim of
        // the drawn node(s) holding it (a point on a shared border: the smallest). What the
        // per-node granularity of the tolerance costs, apart from the order, the locked borders
        // and the stored levels.
        std::fill(blockWeights.begin(), blockWeights.end(), 0.0);
        for (const unilod::engine::NodeChoice& n : cut) {
            const unilod::engine::LodNode& node = nodes[n.block];
            const double w = 1.0 / std::max(n.hLim, 1e-6);
            for (std::size_t m = 0; m < set.points.size(); ++m) {
                const unilod::Point& q = set.points[m];
                if (weights[m] > 0 && q.x >= node.boxMin[0] - 1e-3 &&
                    q.x <= node.boxMax[0] + 1e-3 && q.y >= node.boxMin[1] - 1e-3 &&
                    q.y <= node.boxMax[1] + 1e-3)
                    blockWeights[m] = std::max(blockWeights[m], w);
            }
        }
        std::uint32_t blockTinVertices = 0;
        const std::uint64_t blockTinInView = weightedTin(c, blockWeights, blockTinVertices);
        const double ratio = tinInView > 0 ? double(drawnInView) / double(tinInView) : 0.0;
        if (tinInView > 0) ratios.push_back(ratio);
        const double refinedRatio =
            tinInView > 0 ? double(refinedInView) / double(tinInView) : 0.0;
        if (tinInView > 0) refinedRatios.push_back(refinedRatio);
        sumCut += drawn;
        sumCutInView += drawnInView;
        sumRefined += refined;
        sumRefinedInView += refinedInView;
        sumTin += tinInView;
        sumBlockTin += blockTinInView;
        rows.push_back({{"frame", f},
                        {"cut_draws", cut.size()},
                        {"cut_triangles", drawn},
                        {"cut_triangles_in_view", drawnInView},
                        {"refined_triangles", refined},
                        {"refined_triangles_in_view", refinedInView},
                        {"refined_leaves", refinedLeaves},
                        {"points_on_screen", onScreen},
                        {"view_tin_vertices", tinVertices},
                        {"node_tolerance_tin_triangles_in_view", blockTinInView},
                        {"view_tin_triangles_in_view", tinInView},
                        {"ratio_in_view", std::round(ratio * 1000.0) / 1000.0},
                        {"refined_ratio_in_view", std::round(refinedRatio * 1000.0) / 1000.0}});
    }
    std::sort(ratios.begin(), ratios.end());
    std::sort(refinedRatios.begin(), refinedRatios.end());
    return {{"benchmark", "view_cut_vs_view_dependent_greedy_tin"},
            {"file", path},
            {"path", cameraPath.empty() ? "default fly-over" : cameraPath},
            {"frames", frames},
            {"every", every},
            {"pixels", pixels},
            {"size", {width, height}},
            {"points", set.points.size()},
            {"tin_seconds", tinSeconds},
            {"rows", rows},
            {"sum_cut_triangles", sumCut},
            {"sum_cut_triangles_in_view", sumCutInView},
            {"sum_view_tin_triangles_in_view", sumTin},
            {"sum_refined_triangles", sumRefined},
            {"refine_seconds", refineSeconds},
            {"sum_refined_triangles_in_view", sumRefinedInView},
            {"ratio_of_sums_in_view", sumTin > 0 ? double(sumCutInView) / double(sumTin) : 0.0},
            {"sum_node_tolerance_tin_triangles_in_view", sumBlockTin},
            {"median_ratio_in_view", ratios.empty() ? 0.0 : ratios[ratios.size() / 2]},
            {"refined_ratio_of_sums_in_view",
             sumTin > 0 ? double(sumRefinedInView) / double(sumTin) : 0.0},
            {"median_refined_ratio_in_view",
             refinedRatios.empty() ? 0.0 : refinedRatios[refinedRatios.size() / 2]}};
}

// Rivers as a baseline needs them: each river chain of the one block (full-resolution river
// edges between vertices that are not of degree 2) simplified by 3D Douglas-Peucker to each
// tolerance (the same 3D distance as the model's river error); returns the distinct vertices
// kept per tolerance (chain ends once).
// Also, per tolerance, a strict lower bound on the triangles of ANY model of the block whose river
// error is <= e (vertices a subset of the original points, river ends and junctions kept, as in
// the model): a triangulation of n vertices, h of them on its convex hull, has 2n - h - 2
// triangles, and adding k vertices adds at most k hull vertices, so 2n - h - 2 over the river
// vertices alone (h: those on the block's bounding rectangle) bounds it. Per chain the vertex
// subset minimising 2n - h with every dropped vertex within e (3D) of its replacing segment is
// found exactly (shortest path over the valid shortcuts, Imai & Iri 1988), not by Douglas-Peucker.
struct RiverDp {
    std::uint64_t vertices = 0;  // distinct vertices kept by Douglas-Peucker
    std::uint64_t boundCost = 0;  // min of 2n - h over river vertex subsets within e
    std::uint64_t lowerBoundTriangles() const { return boundCost > 2 ? boundCost - 2 : 0; }
};

// The river chains of a block at full resolution: vertex ids from one end or junction (a vertex
// whose river degree is not 2) to the next; a closed loop without one starts anywhere.
std::vector<std::vector<std::uint32_t>> riverChains(const unilod::format::Block& b) {
    const unilod::format::Level& full = b.levels.front();
    std::vector<std::vector<std::uint32_t>> next(b.vertices.size());
    for (std::uint32_t e = full.riverFirst; e < full.riverFirst + full.riverCount; ++e) {
        next[b.riverIndices[e].a].push_back(b.riverIndices[e].b);
        next[b.riverIndices[e].b].push_back(b.riverIndices[e].a);
    }
    std::vector<std::vector<std::uint32_t>> chains;
    std::vector<std::uint8_t> seen(b.vertices.size(), 0);
    for (int pass = 0; pass < 2; ++pass) {
        for (std::uint32_t s = 0; s < b.vertices.size(); ++s) {
            if (next[s].empty() || (pass == 0 && next[s].size() == 2) || (pass == 1 && seen[s]))
                continue;
            for (std::uint32_t first : next[s]) {
                if (seen[first] && next[first].size() == 2) continue;
                // One edge between two ends / junctions: once, from the lower id.
                if (next[first].size() != 2 && first < s) continue;
                std::vector<std::uint32_t> chain{s};
                std::uint32_t prev = s, cur = first;
                while (true) {
                    chain.push_back(cur);
                    if (next[cur].size() != 2 || cur == s) break;
                    seen[cur] = 1;
                    const std::uint32_t n = next[cur][0] == prev ? next[cur][1] : next[cur][0];
                    prev = cur, cur = n;
                }
                seen[s] = 1;
                chains.push_back(std::move(chain));
            }
        }
    }
    return chains;
}

std::vector<RiverDp> riverDpVertices(const unilod::format::Block& b,
                                     const std::vector<double>& tolerances) {
    const std::vector<std::vector<std::uint32_t>> chains = riverChains(b);
    auto pos = [&](std::uint32_t v, int k) {
        return k == 0 ? b.grid[v].x * unilod::format::kGridUnit
                      : (k == 1 ? b.grid[v].y * unilod::format::kGridUnit : double(b.vertices[v].z));
    };
    // Squared 3D distance of chain vertex m to the segment between chain vertices i and j.
    const auto deviation2 = [&](const std::vector<std::uint32_t>& c, std::size_t i, std::size_t j,
                                std::size_t m) {
        const double a[3] = {pos(c[i], 0), pos(c[i], 1), pos(c[i], 2)};
        const double e[3] = {pos(c[j], 0), pos(c[j], 1), pos(c[j], 2)};
        const double p[3] = {pos(c[m], 0), pos(c[m], 1), pos(c[m], 2)};
        return unilod::segmentDistance2(a, e, p);
    };
    std::int32_t minX = INT32_MAX, maxX = INT32_MIN, minY = INT32_MAX, maxY = INT32_MIN;
    for (const unilod::format::GridXY& g : b.grid) {
        minX = std::min(minX, g.x), maxX = std::max(maxX, g.x);
        minY = std::min(minY, g.y), maxY = std::max(maxY, g.y);
    }
    std::vector<RiverDp> counts;
    for (double tol : tolerances) {
        std::vector<std::uint8_t> keep(b.vertices.size(), 0);
        for (const std::vector<std::uint32_t>& c : chains) {
            keep[c.front()] = keep[c.back()] = 1;
            std::vector<std::pair<std::size_t, std::size_t>> stack{{0, c.size() - 1}};
            while (!stack.empty()) {
                const auto [i, j] = stack.back();
                stack.pop_back();
                if (j <= i + 1) continue;
                double worst = -1;
                std::size_t at = i;
                for (std::size_t m = i + 1; m < j; ++m) {
                    const double e2 = deviation2(c, i, j, m);
                    if (e2 > worst) worst = e2, at = m;
                }
                if (worst > tol * tol) {
                    keep[c[at]] = 1;
                    stack.push_back({i, at});
                    stack.push_back({at, j});
                }
            }
        }
        std::uint64_t n = 0;
        for (std::uint8_t k : keep)
            n += k;
        // The exact minimum of 2n - h: ends once (2, or 1 on the hull), plus per chain the
        // cheapest path of valid shortcuts through its interior vertices.
        const auto cost = [&](std::uint32_t v) -> std::uint64_t {
            return b.grid[v].x == minX || b.grid[v].x == maxX || b.grid[v].y == minY ||
                           b.grid[v].y == maxY
                       ? 1
                       : 2;
        };
        std::vector<std::uint8_t> end(b.vertices.size(), 0);
        std::uint64_t bound = 0;
        for (const std::vector<std::uint32_t>& c : chains) {
            for (std::uint32_t v : {c.front(), c.back()}) {
                if (!end[v]) bound += cost(v);
                end[v] = 1;
            }
        }
        for (const std::vector<std::uint32_t>& c : chains) {
            const std::size_t len = c.size();
            const auto within = [&](std::size_t i, std::size_t j) {
                for (std::size_t m = i + 1; m < j; ++m)
                    if (deviation2(c, i, j, m) > tol * tol) return false;
                return true;
            };
            std::vector<std::uint64_t> best(len, UINT64_MAX);
            best[0] = 0;
            for (std::size_t j = 1; j < len; ++j) {
                const std::uint64_t here = j + 1 == len ? 0 : cost(c[j]);
                for (std::size_t i = j; i-- > 0;)
                    if (best[i] != UINT64_MAX && best[i] + here < best[j] && within(i, j))
                        best[j] = best[i] + here;
            }
            bound += best[len - 1];
        }
        counts.push_back({n, bound});
    }
    return counts;
}

std::vector<RiverDp> riverDpVertices(const std::string& path,
                                     const std::vector<double>& tolerances) {
    unilod::format::Reader reader;
    std::string error;
    if (!reader.open(path, error)) fail(error);
    unilod::format::Block b;
    if (!reader.readBlock(0, b, error)) fail(error);
    return riverDpVertices(b, tolerances);
}

struct Dataset {
    std::string name, dem, rivers;
    int width = 0, height = 0;
};

// The DEM's size after loading (a geographic DEM is warped), for the one-block size.
void measureDem(Dataset& d) {
    const json size = unilod::bench::runInChild([&] {
        unilod::DemGrid dem;
        std::string error;
        if (!unilod::loadDem(d.dem, {}, dem, error)) fail(error);
        return json{dem.width, dem.height};
    });
    d.width = size[0];
    d.height = size[1];
}

Dataset prepare(const std::string& name, const std::string& work, const std::string& assets) {
    Dataset d;
    d.name = name;
    if (name == "jacksboro") {
        d.dem = assets + "/jacksboro_dem.tif";
        d.rivers = assets + "/jacksboro_rivers_grass.geojson";
    } else {
        const std::size_t points = name == "synth1m" ? 1000000 : 4000000;
        const std::string dir = work + "/" + name;
        std::fprintf(stderr, "bench_order: %s: synthetic inputs...\n", name.c_str());
        unilod::bench::runInChild([&] {
            unilod::SyntheticOptions so;
            so.targetPoints = points;
            so.seed = 1;
            return unilod::bench::ensureSyntheticInputs(dir, so);
        });
        d.dem = dir + "/dem.tif";
        d.rivers = dir + "/rivers.geojson";
    }
    measureDem(d);
    return d;
}

// Issue 17's domain target: the bundled DEM masked by a crescent (nodata outside a disc and
// inside a second disc that bites into it) against the same DEM unmasked, one block each, no
// rivers, greedy order: triangles at the exact step of a uniform max error e, the masked model
// against the unmasked one scaled by the valid fraction (target <= 1.2 at 20 m).
json maskedBenchmark(const std::string& work, const std::vector<double>& errors, int threads) {
    const std::string source = std::string(UNILOD_ASSETS_DIR) + "/jacksboro_dem.tif";
    const std::string masked = work + "/jacksboro_crescent.tif";
    const std::string noRivers = work + "/no_rivers.geojson";
    std::ofstream(noRivers) << "{\"type\": \"FeatureCollection\", \"features\": []}\n";
    const json mask = unilod::bench::runInChild([&] {
        unilod::DemGrid dem;
        std::string error;
        if (!unilod::loadDem(source, {}, dem, error)) fail(error);
        const double cx = dem.width / 2.0, cy = dem.height / 2.0;
        const double r = 0.45 * std::min(dem.width, dem.height);
        std::size_t before = 0, after = 0;
        for (int row = 0; row < dem.height; ++row) {
            for (int col = 0; col < dem.width; ++col) {
                float& z = dem.z[std::size_t(row) * std::size_t(dem.width) + std::size_t(col)];
                if (std::isnan(z)) continue;
                ++before;
                const double x = col - cx, y = row - cy, bx = x - 0.45 * r;
                if (x * x + y * y >= r * r || bx * bx + y * y < 0.7 * 0.7 * r * r) {
                    z = NAN;
                } else {
                    ++after;
                }
            }
        }
        OGRSpatialReference srs;
        if (!dem.wkt.empty()) srs.importFromWkt(dem.wkt.c_str());
        if (!unilod::writeDemFile(dem, srs, masked, error)) fail(error);
        return json{{"valid_cells", before},
                    {"masked_valid_cells", after},
                    {"width", dem.width},
                    {"height", dem.height}};
    });
    const double fraction = double(mask["masked_valid_cells"]) / double(mask["valid_cells"]);
    std::vector<std::uint64_t> triangles[2];
    json builds = json::array();
    for (int k = 0; k < 2; ++k) {
        unilod::BuildOptions o;
        o.demPath = k == 0 ? source : masked;
        o.riversPath = noRivers;
        o.outPath = work + (k == 0 ? "/jacksboro_unmasked.ulod" : "/jacksboro_crescent.ulod");
        o.blockSize = std::max(int(mask["width"]), int(mask["height"]));
        o.threads = threads;
        o.force = true;
        const std::string label = k == 0 ? "jacksboro unmasked" : "jacksboro crescent";
        std::fprintf(stderr, "bench_order: build %s...\n", label.c_str());
        builds.push_back(unilod::bench::runInChild(
            [&] { return unilod::bench::measureBuild("bench_order: " + label, o); }));
        unilod::ErrorStatsTable table;
        std::string error;
        if (!unilod::computeErrorStats(o.outPath, errors, unilod::format::kMetricMax, table,
                                       error))
            fail(error);
        for (const unilod::ErrorStatsRow& row : table.rows)
            triangles[k].push_back(row.exactTriangles);
    }
    json rows = json::array();
    bool met = true;
    for (std::size_t i = 0; i < errors.size(); ++i) {
        const double scaled = double(triangles[0][i]) * fraction;
        const double ratio = scaled > 0 ? double(triangles[1][i]) / scaled : 0.0;
        const bool goal = errors[i] == 20.0;
        if (goal) met = met && ratio <= 1.2;
        std::fprintf(stderr, "bench_order: crescent e=%g m: %llu vs %.0f (unmasked x %.3f), "
                             "ratio %.3f%s\n",
                     errors[i], (unsigned long long)triangles[1][i], scaled, fraction, ratio,
                     goal ? (ratio <= 1.2 ? " (target 1.2) met" : " (target 1.2) NOT met") : "");
        rows.push_back({{"error_m", errors[i]},
                        {"unmasked_triangles", triangles[0][i]},
                        {"masked_triangles", triangles[1][i]},
                        {"valid_fraction", fraction},
                        {"ratio_vs_scaled_unmasked", std::round(ratio * 1000.0) / 1000.0},
                        {"target", goal ? json(1.2) : json(nullptr)}});
    }
    return {{"benchmark", "order_masked_domain"},
            {"mask", mask},
            {"builds", builds},
            {"rows", rows},
            {"all_met", met}};
}

}  // namespace

int main(int argc, char** argv) {
    CLI::App app{"Triangles per uniform model error: deletion order vs greedy-insertion TIN "
                 "(prints JSON)"};
    std::vector<std::string> datasets = {"jacksboro", "synth1m", "synth4m"};
    std::vector<std::string> orders = {"greedy"};
    std::vector<double> errors = {5, 10, 20};
    std::vector<std::string> bais = {"on"};
    std::string keep;
    std::size_t buildTime = 0;
    int threads = 0;
    app.add_option("--datasets", datasets, "comma-separated: jacksboro, synth1m, synth4m")
        ->delimiter(',')
        ->check(CLI::IsMember({"jacksboro", "synth1m", "synth4m"}));
    app.add_option("--orders", orders, "deletion orders, comma-separated: greedy, 3ddp")
        ->delimiter(',')
        ->check(CLI::IsMember({"greedy", "3ddp"}));
    app.add_option("--bai", bais,
                   "river builds with the BAI factor on, off or both (comma-separated: on,off)")
        ->delimiter(',')
        ->check(CLI::IsMember({"on", "off"}));
    app.add_option("--errors", errors, "model-error thresholds in metres, comma-separated")
        ->delimiter(',')
        ->check(CLI::NonNegativeNumber);
    app.add_option("--keep", keep, "keep inputs and .ulod files in this folder (reused)");
    app.add_option("--threads", threads, "build threads (0: all cores)")->check(CLI::Range(0, 256));
    app.add_option("--build-time", buildTime,
                   "only time a default build of a synthetic DEM of about N points")
        ->check(CLI::Range(std::size_t{1000}, std::size_t{100000000}));
    std::size_t treePoints = 0;
    app.add_option("--tree", treePoints,
                   "only issue 18's block-hierarchy benchmark on a default build of a synthetic "
                   "DEM of about N points (reuses the model kept with --keep)")
        ->check(CLI::Range(std::size_t{1000}, std::size_t{100000000}));
    double handoffPixels = unilod::kDefaultHandoffPixels;
    app.add_option("--handoff-pixels", handoffPixels,
                   "the tree builds' hand-over (unilod build --handoff-pixels)")
        ->check(CLI::Range(1.0, 1e6));
    bool masked = false;
    std::string viewFile, viewPath;
    std::uint32_t viewFrames = 200, viewEvery = 10;
    double viewPixels = 1.0;
    app.add_option("--view", viewFile,
                   "only the view benchmark on this .ulod file: per sampled frame, the engine's cut "
                   "against a view-dependent greedy TIN with each point's own P-pixel tolerance")
        ->check(CLI::ExistingFile);
    app.add_option("--view-path", viewPath,
                   "camera path JSON for --view (default: unilod bench's fly-over)")
        ->check(CLI::ExistingFile);
    app.add_option("--view-frames", viewFrames, "frames along the path for --view (default 200)")
        ->check(CLI::Range(1u, 100000u));
    app.add_option("--view-every", viewEvery, "measure every Nth frame for --view (default 10)")
        ->check(CLI::Range(1u, 100000u));
    app.add_option("--view-pixels", viewPixels, "screen-space error P for --view (default 1)")
        ->check(CLI::Range(1e-3, 1e6));
    app.add_flag("--masked", masked,
                 "only the domain benchmark: the bundled DEM masked by a crescent against the "
                 "unmasked DEM (issue 17)");
    CLI11_PARSE(app, argc, argv);

    const std::string work =
        keep.empty() ? (fs::temp_directory_path() / ("unilod-bench-order-" + std::to_string(getpid())))
                           .string()
                     : keep;
    fs::create_directories(work);

    if (!viewFile.empty()) {
        const json result = unilod::bench::runInChild(
            [&] { return viewBenchmark(viewFile, viewPath, viewFrames, viewEvery, viewPixels); });
        std::printf("%s\n", unilod::jsonText(result, 2).c_str());
        return 0;
    }
    if (masked) {
        const json result = maskedBenchmark(work, errors, threads);
        if (keep.empty()) fs::remove_all(work);
        std::printf("%s\n", unilod::jsonText(result, 2).c_str());
        return 0;
    }
    // A synthetic DEM of about `points` points with its rivers under `work` (reused), and the
    // default build options for it, output `work`/synthetic_N`suffix`.ulod.
    const auto syntheticBuild = [&](std::size_t points, const std::string& suffix, json& inputs) {
        const std::string dir = work + "/synthetic_" + std::to_string(points);
        std::fprintf(stderr, "bench_order: synthetic inputs of %zu points...\n", points);
        inputs = unilod::bench::runInChild([&] {
            unilod::SyntheticOptions so;
            so.targetPoints = points;
            so.seed = 1;
            return unilod::bench::ensureSyntheticInputs(dir, so);
        });
        unilod::BuildOptions o;
        o.demPath = dir + "/dem.tif";
        o.riversPath = dir + "/rivers.geojson";
        const std::string handoff =
            handoffPixels == unilod::kDefaultHandoffPixels
                ? ""
                : "_h" + std::to_string(std::lround(handoffPixels));
        o.outPath = work + "/synthetic_" + std::to_string(points) + suffix + handoff + ".ulod";
        o.handoffPixels = handoffPixels;
        o.threads = threads;
        o.force = true;
        return o;
    };
    if (treePoints > 0) {
        json inputs;
        const unilod::BuildOptions o = syntheticBuild(treePoints, "_tree", inputs);
        json build = {{"reused", true}};
        if (keep.empty() || !fs::exists(o.outPath)) {
            std::fprintf(stderr, "bench_order: building...\n");
            build = unilod::bench::runInChild([&] {
                return unilod::bench::measureBuild("synthetic_" + std::to_string(treePoints), o);
            });
        }
        if (errors == std::vector<double>{5, 10, 20}) errors = {100, 50, 20};
        std::fprintf(stderr, "bench_order: cuts, file and draws...\n");
        json tree = unilod::bench::runInChild([&] { return treeBenchmark(o.outPath, errors); });
        // The baselines on the whole model's points (every leaf point once): the greedy TIN,
        // the best known method that also holds the rivers (a greedy TIN with the rivers
        // simplified to e by 3D Douglas-Peucker as constraints, one run per e) and the strict
        // lower bound of any model whose river error is <= e (RiverDp).
        std::fprintf(stderr, "bench_order: greedy TINs of the whole DEM...\n");
        const json tin = unilod::bench::runInChild([&] {
            const unilod::format::Block all = mergedLeaves(o.outPath);
            const unilod::PointSet set = unilod::blockPoints(all);
            auto start = std::chrono::steady_clock::now();
            std::vector<std::uint64_t> counts, held;
            std::string error;
            if (!unilod::greedyTinTriangles(set, errors, counts, error)) fail(error);
            const double seconds =
                std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
            std::vector<unilod::Polyline> chains;
            for (const std::vector<std::uint32_t>& c : riverChains(all))
                chains.emplace_back(c.begin(), c.end());
            start = std::chrono::steady_clock::now();
            for (double e : errors) {
                unilod::GreedyTin t;
                if (!t.init(set, chains, e, error)) fail(error);
                t.refineTo(e);
                held.push_back(t.triangleCount());
            }
            const double heldSeconds =
                std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
            json bounds = json::array();
            for (const RiverDp& r : riverDpVertices(all, errors))
                bounds.push_back(r.lowerBoundTriangles());
            return json{{"points", set.points.size()},
                        {"river_edges", all.riverIndices.size()},
                        {"triangles", counts},
                        {"seconds", seconds},
                        {"constrained_triangles", held},
                        {"constrained_seconds", heldSeconds},
                        {"rivers_lower_bound_triangles", bounds},
                        {"max_rss_bytes", peakRssBytes()}};
        });
        for (std::size_t i = 0; i < errors.size(); ++i) {
            json& cut = tree["cuts"][i];
            const auto t = tin["triangles"][i].get<std::uint64_t>();
            const auto held = tin["constrained_triangles"][i].get<std::uint64_t>();
            cut["tin_triangles"] = t;
            cut["ratio_vs_tin"] = t ? cut["triangles"].get<double>() / double(t) : 0.0;
            cut["target"] = 1.5;
            cut["constrained_tin_triangles"] = held;
            cut["ratio_vs_constrained_tin"] =
                held ? cut["triangles"].get<double>() / double(held) : 0.0;
            cut["rivers_lower_bound_triangles"] = tin["rivers_lower_bound_triangles"][i];
        }
        if (keep.empty()) fs::remove_all(work);
        const json result = {{"benchmark", "block_hierarchy"},
                             {"target_points", treePoints},
                             {"inputs", inputs},
                             {"build", build},
                             {"tin", tin},
                             {"tree", tree}};
        std::printf("%s\n", unilod::jsonText(result, 2).c_str());
        return 0;
    }
    if (buildTime > 0) {
        json inputs;
        const unilod::BuildOptions o = syntheticBuild(buildTime, "", inputs);
        // The same run's reference: the bundled data built with the same options, three times
        // before and three times after (this machine's speed moves by up to 2.7x between days
        // and by 10 % within an hour, so the absolute time alone says little about the code).
        unilod::BuildOptions ref;
        ref.demPath = std::string(UNILOD_ASSETS_DIR) + "/jacksboro_dem.tif";
        ref.riversPath = std::string(UNILOD_ASSETS_DIR) + "/jacksboro_rivers_grass.geojson";
        ref.outPath = work + "/reference_jacksboro.ulod";
        ref.threads = threads;
        ref.force = true;
        std::vector<double> referenceSeconds;
        auto reference = [&] {
            for (int k = 0; k < 3; ++k)
                referenceSeconds.push_back(unilod::bench::runInChild([&] {
                                               return unilod::bench::measureBuild("reference", ref);
                                           })["seconds"]
                                               .get<double>());
        };
        std::fprintf(stderr, "bench_order: reference builds of the bundled data...\n");
        reference();
        std::fprintf(stderr, "bench_order: building...\n");
        const auto start = std::chrono::steady_clock::now();
        json build = unilod::bench::runInChild(
            [&] { return unilod::bench::measureBuild("synthetic_" + std::to_string(buildTime), o); });
        build["wall_seconds"] =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        std::fprintf(stderr, "bench_order: reference builds of the bundled data...\n");
        reference();
        std::vector<double> sorted = referenceSeconds;
        std::sort(sorted.begin(), sorted.end());
        const double median = (sorted[2] + sorted[3]) / 2;
        if (keep.empty()) fs::remove_all(work);
        const json result = {
            {"benchmark", "order_build_time"},
            {"hardware_threads", std::thread::hardware_concurrency()},
            {"target_points", buildTime},
            {"target_seconds", 180},
            {"inputs", inputs},
            {"build", build},
            {"reference",
             {{"case",
               "the bundled data, default options, the same threads (3 builds before, 3 "
               "after)"},
              {"seconds", referenceSeconds},
              {"median_seconds", median},
              {"build_over_reference", build["seconds"].get<double>() / median}}}};
        std::printf("%s\n", unilod::jsonText(result, 2).c_str());
        return 0;
    }

    std::vector<bool> baiSettings;
    for (const std::string& b : {std::string("on"), std::string("off")})
        if (std::find(bais.begin(), bais.end(), b) != bais.end()) baiSettings.push_back(b == "on");
    const std::string noRivers = work + "/no_rivers.geojson";
    {
        // An empty FeatureCollection is an empty network (rivers.h).
        std::ofstream(noRivers) << "{\"type\": \"FeatureCollection\", \"features\": []}\n";
    }
    json builds = json::array(), tins = json::array(), rows = json::array(), extra;
    bool allMet = true;
    for (const std::string& name : datasets) {
        const Dataset d = prepare(name, work, UNILOD_ASSETS_DIR);
        std::string tinSource;
        std::vector<std::uint64_t> tin;
        std::vector<std::pair<bool, bool>> variants{{false, true}};  // (rivers, BAI)
        for (const bool bai : baiSettings) variants.push_back({true, bai});
        for (const auto& [rivers, bai] : variants) {
            for (const std::string& order : orders) {
                unilod::BuildOptions o;
                o.demPath = d.dem;
                o.riversPath = rivers ? d.rivers : noRivers;
                o.outPath = work + "/" + name + (rivers ? "_rivers_" : "_bare_") + order +
                            (bai ? "" : "_nobai") + ".ulod";
                o.useBai = bai;
                o.blockSize = std::max(d.width, d.height) - 1;
                o.order = order == "3ddp" ? unilod::DeletionOrderKind::ThreeDdp
                                          : unilod::DeletionOrderKind::Greedy;
                o.threads = threads;
                o.force = true;
                const std::string label = name + (rivers ? " rivers " : " no rivers ") + order +
                                          (bai ? "" : " no-BAI");
                std::fprintf(stderr, "bench_order: build %s...\n", label.c_str());
                json build = unilod::bench::runInChild(
                    [&] { return unilod::bench::measureBuild("bench_order: " + label, o); });
                build["dataset"] = name;
                build["rivers"] = rivers;
                build["order"] = order;
                build["bai"] = bai;
                builds.push_back(build);

                if (tinSource.empty()) {
                    // The TIN once per dataset, on the first no-river block's vertices.
                    tinSource = o.outPath;
                    std::fprintf(stderr, "bench_order: greedy TIN %s...\n", name.c_str());
                    const json t = unilod::bench::runInChild([&] {
                        const unilod::PointSet set = readBlockPoints(tinSource);
                        const auto start = std::chrono::steady_clock::now();
                        std::vector<std::uint64_t> counts;
                        std::string error;
                        if (!unilod::greedyTinTriangles(set, errors, counts, error)) {
                            fail("'" + tinSource + "': " + error);
                        }
                        const double seconds = std::chrono::duration<double>(
                                                   std::chrono::steady_clock::now() - start)
                                                   .count();
                        return json{{"points", set.points.size()},
                                    {"triangles", counts},
                                    {"seconds", seconds},
                                    {"max_rss_bytes", peakRssBytes()}};
                    });
                    tin = t["triangles"].get<std::vector<std::uint64_t>>();
                    tins.push_back({{"dataset", name},
                                    {"points", t["points"]},
                                    {"seconds", t["seconds"]},
                                    {"max_rss_bytes", t["max_rss_bytes"]}});
                }

                unilod::ErrorStatsTable table;
                std::string error;
                if (!unilod::computeErrorStats(o.outPath, errors, unilod::format::kMetricMax,
                                               table, error)) {
                    fail(error);
                }
                const std::vector<RiverDp> riverDp =
                    rivers ? riverDpVertices(o.outPath, errors) : std::vector<RiverDp>();
                // The best known method for a model that holds its rivers, measured: a greedy TIN
                // of the same points with the rivers simplified to e (3D Douglas-Peucker) as
                // constraints (greedytin.h), one run per e.
                std::vector<std::uint64_t> constrained;
                if (rivers) {
                    std::fprintf(stderr, "bench_order: greedy TIN with rivers %s...\n",
                                 label.c_str());
                    const json t = unilod::bench::runInChild([&] {
                        const unilod::PointSet set = readBlockPoints(o.outPath);
                        unilod::format::Reader reader;
                        unilod::format::Block b;
                        std::string message;
                        if (!reader.open(o.outPath, message) || !reader.readBlock(0, b, message))
                            fail(message);
                        std::vector<unilod::Polyline> chains;
                        for (const std::vector<std::uint32_t>& c : riverChains(b))
                            chains.emplace_back(c.begin(), c.end());
                        const auto start = std::chrono::steady_clock::now();
                        std::vector<std::uint64_t> counts;
                        for (double e : errors) {
                            unilod::GreedyTin held;
                            if (!held.init(set, chains, e, message))
                                fail("'" + o.outPath + "': " + message);
                            held.refineTo(e);
                            counts.push_back(held.triangleCount());
                        }
                        const double seconds = std::chrono::duration<double>(
                                                   std::chrono::steady_clock::now() - start)
                                                   .count();
                        return json{{"triangles", counts}, {"seconds", seconds}};
                    });
                    constrained = t["triangles"].get<std::vector<std::uint64_t>>();
                    tins.push_back({{"dataset", name},
                                    {"rivers", true},
                                    {"order", order},
                                    {"bai", bai},
                                    {"seconds", t["seconds"]}});
                }
                for (std::size_t i = 0; i < errors.size(); ++i) {
                    const std::uint64_t ours = table.rows[i].exactTriangles;
                    if (rivers) {
                        // What a TIN that must also hold the rivers (each simplified to e by 3D
                        // Douglas-Peucker) needs at least, estimated: the no-river TIN plus two
                        // triangles per river vertex it has to insert.
                        const std::uint64_t withRivers = tin[i] + 2 * riverDp[i].vertices;
                        // A strict bound, no estimate: no model whose river error is <= e has
                        // fewer triangles than this (RiverDp).
                        const std::uint64_t bound = riverDp[i].lowerBoundTriangles();
                        extra = {{"river_dp_vertices", riverDp[i].vertices},
                                 {"rivers_lower_bound_triangles", bound},
                                 {"lower_bound_vs_tin",
                                  tin[i] > 0 ? std::round(double(bound) / double(tin[i]) * 1000.0) /
                                                   1000.0
                                             : 0.0},
                                 {"constrained_tin_triangles", constrained[i]},
                                 {"constrained_tin_vs_tin",
                                  tin[i] > 0 ? std::round(double(constrained[i]) /
                                                          double(tin[i]) * 1000.0) /
                                                   1000.0
                                             : 0.0},
                                 {"ratio_vs_constrained_tin",
                                  std::round(double(ours) / double(constrained[i]) * 1000.0) /
                                      1000.0},
                                 {"tin_plus_rivers_triangles", withRivers},
                                 {"ratio_vs_tin_plus_rivers",
                                  std::round(double(ours) / double(withRivers) * 1000.0) / 1000.0}};
                    } else {
                        extra = json::object();
                    }
                    const double ratio = tin[i] > 0 ? double(ours) / double(tin[i]) : 0.0;
                    const double goal = target(rivers, errors[i]);
                    const bool met = ratio <= goal;
                    allMet = allMet && met;
                    rows.push_back({{"dataset", name},
                                    {"rivers", rivers},
                                    {"order", order},
                                    {"bai", bai},
                                    {"error_m", errors[i]},
                                    {"unilod_triangles", ours},
                                    {"unilod_level_triangles", table.rows[i].levelTriangles},
                                    {"tin_triangles", tin[i]},
                                    {"ratio", std::round(ratio * 1000.0) / 1000.0},
                                    {"target", goal},
                                    {"met", met}});
                    rows.back().update(extra);
                    std::fprintf(stderr,
                                 "bench_order: %s e=%g m: %llu vs TIN %llu, ratio %.3f (target "
                                 "%.2f) %s\n",
                                 label.c_str(), errors[i], (unsigned long long)ours,
                                 (unsigned long long)tin[i], ratio, goal, met ? "met" : "NOT met");
                }
                if (keep.empty() && o.outPath != tinSource) fs::remove(o.outPath);
            }
        }
    }
    if (keep.empty()) fs::remove_all(work);
    const json result = {{"benchmark", "order"},
                         {"hardware_threads", std::thread::hardware_concurrency()},
                         {"metric", "max"},
                         {"rows", rows},
                         {"all_met", allMet},
                         {"builds", builds},
                         {"tins", tins}};
    std::printf("%s\n", unilod::jsonText(result, 2).c_str());
    return 0;
}
