// Streaming under a GPU budget, frustum culling and camera paths, on lavapipe with validation on
// (any validation message fails). The bundled data is built with 64-cell blocks (42 blocks) so
// that views cull and stream.
// - The first frame after open draws the tree's root at its resident coarse level in place of
//   the whole cut: a frame never waits on disk. Later frames bring in what h_lim asks for,
//   coarsest tree level first, and every frame draws each part of the cut exactly once.
// - A budget that holds about a third of the full blocks: over a path, memory in use never
//   exceeds the budget, blocks are evicted, every visible block is drawn every frame.
// - A tiny budget (just above the coarse set) still renders every block; below it the open
//   fails with a message naming the budget.
// - Culling never drops a block with a vertex on screen.
// - `capture --path ... --frames N` writes N frames whose cameras follow the keyframes.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <set>
#include <stdexcept>
#include <thread>

#include "bench.h"
#include "camera.h"
#include "capture.h"
#include "headless.h"
#include "testutil.h"
#include "tools/cliutil.h"
#include "ulod.h"
#include "ulodbytes.h"

namespace fs = std::filesystem;
using namespace unilod;
using unilod::test::q;
using unilod::test::runCli;
using unilod::test::slurp;

namespace {

const std::string kAssets = UNILOD_ASSETS_DIR;

class Streaming : public ::testing::Test {
protected:
    static void SetUpTestSuite() {
        dir_ = fs::temp_directory_path() / ("unilod_test_streaming_" + std::to_string(getpid()));
        fs::create_directories(dir_);
        file_ = (dir_ / "jacksboro64.ulod").string();
        const auto r =
            runCli("build -q --block-size 64 " + q(kAssets + "/jacksboro_dem.tif") + " " +
                   q(kAssets + "/jacksboro_rivers_grass.geojson") + " -o " + q(file_));
        ASSERT_EQ(r.code, 0) << r.err;
        std::string error;
        ASSERT_TRUE(reader_.open(file_, error)) << error;
    }
    static void TearDownTestSuite() { fs::remove_all(dir_); }

    static engine::HeadlessOptions options(std::uint64_t budget) {
        engine::HeadlessOptions o;
        o.path = file_;
        o.width = 320;
        o.height = 240;
        o.scene.gpuBudget = budget;
        o.device.validation = true;
        return o;
    }

    // A short benchmark of the model: 160 x 90, one warm-up frame, validation on.
    static engine::BenchOptions benchOptions() {
        engine::BenchOptions o;
        o.path = file_;
        o.width = 160;
        o.height = 90;
        o.warmup = 1;
        o.warmupMs = 0;
        o.device.validation = true;
        return o;
    }

    // Oblique camera south of the data looking north-east over it.
    static engine::Camera oblique(double t) {
        const format::Header& h = reader_.header();
        engine::Camera c;
        c.eye[0] = h.minX + t * (h.maxX - h.minX);
        c.eye[1] = h.minY + 0.2 * (h.maxY - h.minY);
        c.eye[2] = h.maxZ + 1500;
        c.yawDegrees = 20;
        c.pitchDegrees = -20;
        return c;
    }

    static fs::path dir_;
    static std::string file_;
    static format::Reader reader_;
};

fs::path Streaming::dir_;
std::string Streaming::file_;
format::Reader Streaming::reader_;

// Every cut entry is drawn exactly once: by itself, or through the entry above it that the
// frame draws in its place, and then no other cut entry below that one is drawn by itself.
void expectCoverage(const engine::StreamingScene& scene, const std::vector<std::uint32_t>& parent) {
    std::set<std::uint32_t> inPlace;
    for (const engine::BlockSelection& s : scene.selection())
        if (s.drawnBlock != s.block) inPlace.insert(s.drawnBlock);
    for (const engine::BlockSelection& s : scene.selection()) {
        bool above = false;  // drawn by itself, or through an ancestor
        for (std::uint32_t up = parent[s.block]; up != UINT32_MAX; up = parent[up]) {
            if (up == s.drawnBlock) above = true;
            // An entry drawn in place covers everything below it.
            if (inPlace.count(up)) {
                EXPECT_EQ(s.drawnBlock, up) << "entry " << s.block;
            }
        }
        EXPECT_TRUE(s.drawnBlock == s.block || above) << "entry " << s.block;
        if (s.drawnBlock != s.block) {
            EXPECT_TRUE(s.fallback);
            EXPECT_EQ(s.triangles, 0u);
        }
    }
}

TEST_F(Streaming, FirstFrameDrawsTheRootThenStreamsIn) {
    const auto& infos = reader_.blocks();
    std::vector<std::uint32_t> parent(infos.size(), UINT32_MAX);
    for (std::size_t i = 0; i < infos.size(); ++i)
        for (std::uint32_t c = 0; c < infos[i].childCount; ++c)
            parent[infos[i].firstChild + c] = std::uint32_t(i);
    const std::uint32_t root = std::uint32_t(infos.size() - 1);  // the tree's, last in the file
    ASSERT_EQ(parent[root], UINT32_MAX);
    ASSERT_GT(infos[root].level, 0u);
    engine::HeadlessRenderer r;
    std::string error;
    ASSERT_TRUE(r.open(options(engine::kDefaultGpuBudget), error)) << error;
    const engine::FrameView view = r.view(oblique(0.5));
    ASSERT_TRUE(r.renderFrame(view, true, nullptr, error)) << error;
    const engine::FrameStats first = r.scene().stats();
    // Only the root's coarse level is resident: every cut entry below it is drawn through it.
    EXPECT_GT(first.visibleBlocks, 1u);
    EXPECT_EQ(first.residentBlocks, 0u);
    const std::size_t rootCoarse = r.scene().levels(root).size() - 1;
    std::uint32_t wantFull = 0;
    for (const engine::BlockSelection& s : r.scene().selection()) {
        ASSERT_NE(s.block, root);  // the view wants more than the root
        ++wantFull;
        EXPECT_TRUE(s.fallback);
        EXPECT_EQ(s.drawnBlock, root);
        EXPECT_EQ(s.drawnLevel, rootCoarse);
    }
    EXPECT_EQ(first.fallbackBlocks, wantFull);
    EXPECT_EQ(first.triangles, r.scene().levels(root)[rootCoarse].triangleCount);  // drawn once
    expectCoverage(r.scene(), parent);
    // Frames until settled: coarsest tree level first, so nodes above the cut come in and are
    // drawn in place of their cut entries on the way; every frame covers the cut once.
    std::set<std::uint32_t> drawnInPlace;
    for (int i = 0; i < 100000 && !r.scene().settled(); ++i) {
        ASSERT_TRUE(r.renderFrame(view, true, nullptr, error)) << error;
        expectCoverage(r.scene(), parent);
        for (const engine::BlockSelection& s : r.scene().selection())
            if (s.drawnBlock != s.block) drawnInPlace.insert(s.drawnBlock);
        r.finish();
    }
    EXPECT_GT(drawnInPlace.size(), 1u) << "nodes between the root and the cut were drawn";
    ASSERT_TRUE(r.renderFrame(view, true, nullptr, error)) << error;
    r.finish();
    EXPECT_EQ(r.scene().stats().fallbackBlocks, 0u);
    EXPECT_GE(r.scene().stats().residentBlocks, wantFull);
    for (const engine::BlockSelection& s : r.scene().selection()) {
        EXPECT_EQ(s.drawnBlock, s.block);
        EXPECT_EQ(s.drawnLevel, s.wanted.level);
    }
    const std::vector<std::string> messages = r.close();
    EXPECT_TRUE(messages.empty()) << messages.front();
}

// A renderer (and its scene) closed and opened again starts from nothing and streams again: no
// state of the first opening (the loader's stop, its queue, the resident set) carries over.
TEST_F(Streaming, ReopenedSceneStreamsAgain) {
    engine::HeadlessRenderer r;
    std::string error;
    std::uint32_t resident[2] = {};
    for (int opening = 0; opening < 2; ++opening) {
        SCOPED_TRACE("opening " + std::to_string(opening));
        ASSERT_TRUE(r.open(options(engine::kDefaultGpuBudget), error)) << error;
        const engine::FrameView view = r.view(oblique(0.5));
        ASSERT_TRUE(r.renderFrame(view, true, nullptr, error)) << error;
        EXPECT_EQ(r.scene().stats().residentBlocks, 0u);  // the coarse set only
        for (int i = 0; i < 5000 && !r.scene().settled(); ++i) {
            ASSERT_TRUE(r.renderFrame(view, true, nullptr, error)) << error;
            r.finish();
        }
        ASSERT_TRUE(r.scene().settled());
        ASSERT_TRUE(r.renderFrame(view, true, nullptr, error)) << error;
        r.finish();
        EXPECT_EQ(r.scene().stats().fallbackBlocks, 0u);
        resident[opening] = r.scene().stats().residentBlocks;
        const std::vector<std::string> messages = r.close();
        EXPECT_TRUE(messages.empty()) << messages.front();
    }
    EXPECT_GT(resident[0], 0u);
    EXPECT_EQ(resident[1], resident[0]);
}

// The leaves' refinement tables stay within SceneOptions::refineMemory: with room for about two
// 64-cell leaves, at most that much is held at any frame while the view moves, leaves are still
// drawn refined, and a leaf without its table is drawn at its stored level; with no room none
// is refined.
TEST_F(Streaming, RefinementMemoryStaysWithinItsCap) {
    for (const std::uint64_t cap : {std::uint64_t(0), std::uint64_t(2500) << 10}) {
        engine::HeadlessOptions o = options(engine::kDefaultGpuBudget);
        o.scene.refineMemory = cap;
        engine::HeadlessRenderer r;
        std::string error;
        ASSERT_TRUE(r.open(o, error)) << error;
        std::uint64_t refined = 0, stored = 0;
        for (int i = 0; i < 30; ++i) {
            const engine::FrameView view = r.view(oblique(0.2 + 0.02 * i));
            // Each view settled (streaming keeps pace with any machine speed: ASan, lavapipe).
            ASSERT_TRUE(r.renderFrame(view, true, nullptr, error)) << error;
            for (int k = 0; k < 100000 && !r.scene().settled(); ++k) {
                r.finish();
                ASSERT_TRUE(r.renderFrame(view, true, nullptr, error)) << error;
            }
            r.finish();
            ASSERT_TRUE(r.renderFrame(view, true, nullptr, error)) << error;
            const engine::FrameStats& st = r.scene().stats();
            EXPECT_LE(st.refineBytes, cap);
            refined += st.refinedBlocks;
            for (const engine::BlockSelection& s : r.scene().selection())
                if (!s.refined && !s.fallback && s.treeLevel == 0 &&
                    s.drawnLevel + 1 < r.scene().levels(s.block).size()) {
                    ++stored;
                    EXPECT_EQ(s.triangles, r.scene().levels(s.block)[s.drawnLevel].triangleCount);
                }
        }
        r.finish();
        if (cap == 0) {
            EXPECT_EQ(refined, 0u);
        } else {
            EXPECT_GT(refined, 0u);
        }
        EXPECT_GT(stored, 0u);  // leaves without a table keep their stored levels
        const std::vector<std::string> messages = r.close();
        EXPECT_TRUE(messages.empty()) << messages.front();
    }
}

// The frame's refinements run in parallel (SceneOptions::threads): the draws and the refined
// index data are the same for one thread and for several, frame by frame.
TEST_F(Streaming, RefinedFramesAreTheSameForAnyThreadCount) {
    std::vector<std::vector<engine::DrawBlock>> draws[2];
    std::vector<std::vector<std::uint32_t>> words[2];
    const std::size_t threads[2] = {1, 3};
    std::uint64_t refined = 0;
    for (int run = 0; run < 2; ++run) {
        engine::HeadlessOptions o = options(engine::kDefaultGpuBudget);
        o.scene.preloadAll = true;  // no streaming: the same entries resident in both runs
        o.scene.threads = threads[run];
        engine::HeadlessRenderer r;
        std::string error;
        ASSERT_TRUE(r.open(o, error)) << error;
        for (int i = 0; i < 12; ++i) {
            engine::Camera c = oblique(0.1 + 0.07 * i);
            c.yawDegrees = 20 + 13 * i;
            ASSERT_TRUE(r.renderFrame(r.view(c), true, nullptr, error)) << error;
            draws[run].push_back(r.scene().drawList());
            words[run].push_back(r.scene().refinedIndices());
            if (run == 0) refined += r.scene().stats().refinedBlocks;
        }
        r.finish();
        const std::vector<std::string> messages = r.close();
        EXPECT_TRUE(messages.empty()) << messages.front();
    }
    EXPECT_GT(refined, 12u);  // several entries refined a frame
    ASSERT_EQ(draws[0].size(), draws[1].size());
    for (std::size_t f = 0; f < draws[0].size(); ++f) {
        ASSERT_EQ(draws[0][f].size(), draws[1][f].size()) << "frame " << f;
        for (std::size_t k = 0; k < draws[0][f].size(); ++k) {
            const engine::DrawBlock &a = draws[0][f][k], &b = draws[1][f][k];
            EXPECT_EQ(a.vertexOffset, b.vertexOffset) << "frame " << f << " draw " << k;
            EXPECT_EQ(a.terrainFirst, b.terrainFirst) << "frame " << f << " draw " << k;
            EXPECT_EQ(a.terrainCount, b.terrainCount) << "frame " << f << " draw " << k;
            EXPECT_EQ(a.riverFirst, b.riverFirst) << "frame " << f << " draw " << k;
            EXPECT_EQ(a.riverCount, b.riverCount) << "frame " << f << " draw " << k;
            EXPECT_EQ(a.dynamic, b.dynamic) << "frame " << f << " draw " << k;
        }
        EXPECT_EQ(words[0][f], words[1][f]) << "frame " << f;
    }
}

TEST_F(Streaming, BudgetIsNeverExceededAndBlocksAreEvicted) {
    // Budget: the coarse set plus about a third of the full blocks.
    std::uint64_t coarse = 0, full = 0;
    {
        engine::HeadlessRenderer probe;
        std::string error;
        engine::HeadlessOptions o = options(engine::kDefaultGpuBudget);
        o.scene.preloadAll = true;
        ASSERT_TRUE(probe.open(o, error)) << error;
        coarse = probe.scene().stats().coarseBytes;
        full = probe.scene().stats().gpuBytesUsed - coarse;
        probe.close();
    }
    const std::uint64_t budget = coarse + full / 3;
    engine::HeadlessRenderer r;
    std::string error;
    ASSERT_TRUE(r.open(options(budget), error)) << error;
    std::uint64_t evictions = 0, peak = 0;
    for (int i = 0; i <= 60; ++i) {
        // Sweep west to east and back, settling each view so the budget is really used.
        const double t = i <= 30 ? i / 30.0 : (60 - i) / 30.0;
        const engine::FrameView view = r.view(oblique(t));
        for (int k = 0; k < 100000; ++k) {
            ASSERT_TRUE(r.renderFrame(view, true, nullptr, error)) << error;
            const engine::FrameStats& s = r.scene().stats();
            EXPECT_LE(s.gpuBytesUsed, s.gpuBudget);
            EXPECT_LE(s.gpuBudget, budget);
            EXPECT_EQ(r.scene().selection().size(), s.visibleBlocks);  // every visible block drawn
            evictions += s.evictions;
            peak = std::max(peak, s.gpuBytesUsed);
            if (r.scene().settled()) break;
        }
        r.finish();
    }
    EXPECT_GT(evictions, 0u);
    EXPECT_GT(peak, coarse + full / 6);  // the budget was put to use
    const std::vector<std::string> messages = r.close();
    EXPECT_TRUE(messages.empty()) << messages.front();
}

TEST_F(Streaming, TinyBudgetStillRendersEveryBlock) {
    // The coarse set's size from a capture's JSON, then a budget 10% above it.
    const fs::path big = dir_ / "big", tiny = dir_ / "tiny", below = dir_ / "below";
    const std::string camera = "--camera " + [] {
        const engine::Camera c = oblique(0.5);
        char text[200];
        std::snprintf(text, sizeof text, "%.3f,%.3f,%.3f,%.1f,%.1f", c.eye[0], c.eye[1], c.eye[2],
                      c.yawDegrees, c.pitchDegrees);
        return std::string(text);
    }();
    auto r = runCli("capture " + q(file_) + " --validation --size 320x240 " + camera + " --out " +
                    q(big.string()));
    ASSERT_EQ(r.code, 0) << r.err;
    const nlohmann::json bigJson = nlohmann::json::parse(slurp((big / "frame_0000.json").string()));
    const auto coarse = bigJson["totals"]["coarse_bytes"].get<std::uint64_t>();
    const double tinyMiB = double(coarse) * 1.1 / 1048576.0;
    r = runCli("capture " + q(file_) + " --validation --size 320x240 " + camera + " --gpu-budget " +
               std::to_string(tinyMiB) + " --out " + q(tiny.string()));
    ASSERT_EQ(r.code, 0) << r.err;
    const nlohmann::json tinyJson =
        nlohmann::json::parse(slurp((tiny / "frame_0000.json").string()));
    const nlohmann::json& t = tinyJson["totals"];
    EXPECT_EQ(t["blocks_drawn"], bigJson["totals"]["blocks_drawn"]);
    EXPECT_LE(t["gpu_bytes_used"].get<std::uint64_t>(), t["gpu_budget"].get<std::uint64_t>());
    EXPECT_LE(t["gpu_budget"].get<double>(), tinyMiB * 1048576.0);
    EXPECT_GT(t["fallback_blocks"].get<int>(), 0);  // the budget forced coarse blocks
    EXPECT_LT(t["triangles"].get<std::uint64_t>(),
              bigJson["totals"]["triangles"].get<std::uint64_t>());
    EXPECT_GT(t["triangles"].get<std::uint64_t>(), 0u);
    EXPECT_GT(fs::file_size(tiny / "frame_0000.png"), 1000u);
    // Below the coarse set: refused, with the numbers, and no frame.
    r = runCli("capture " + q(file_) + " --size 320x240 " + camera + " --gpu-budget " +
               std::to_string(double(coarse) * 0.5 / 1048576.0) + " --out " + q(below.string()));
    EXPECT_EQ(r.code, 1);
    EXPECT_NE(r.err.find("coarse"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("jacksboro64.ulod"), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(below / "frame_0000.png"));
}

TEST_F(Streaming, CullingKeepsEveryBlockWithAVertexOnScreen) {
    const double aspect = 4.0 / 3.0;
    for (const engine::Camera& camera : {oblique(0.1), oblique(0.9)}) {
        engine::Camera c = camera;
        c.yawDegrees = 80;  // looking east along the south edge: many blocks out of view
        const engine::CameraBasis b = engine::cameraBasis(c);
        const double ty = std::tan(c.fovDegrees * 3.14159265358979323846 / 360.0);
        std::size_t kept = 0, culled = 0;
        for (std::size_t i = 0; i < reader_.blocks().size(); ++i) {
            const format::BlockInfo& info = reader_.blocks()[i];
            const double lo[3] = {info.minX, info.minY, info.minZ};
            const double hi[3] = {info.maxX, info.maxY, info.maxZ};
            if (engine::boxInFrustum(c, aspect, lo, hi)) {
                ++kept;
                continue;
            }
            ++culled;
            format::BlockGeometry g;
            std::string error;
            ASSERT_TRUE(reader_.readGeometry(i, format::kAllLevels, g, error)) << error;
            for (const format::Vertex& v : g.vertices) {
                const double p[3] = {g.originX + v.x - c.eye[0], g.originY + v.y - c.eye[1],
                                     v.z - c.eye[2]};
                const double z = p[0] * b.forward[0] + p[1] * b.forward[1] + p[2] * b.forward[2];
                const double x = p[0] * b.right[0] + p[1] * b.right[1] + p[2] * b.right[2];
                const double y = p[0] * b.up[0] + p[1] * b.up[1] + p[2] * b.up[2];
                const bool onScreen = z >= engine::kNearPlane && std::abs(x) <= z * ty * aspect &&
                                      std::abs(y) <= z * ty;
                ASSERT_FALSE(onScreen) << "block " << info.col << "," << info.row << " culled";
            }
        }
        EXPECT_GT(kept, 0u);
        EXPECT_GT(culled, 0u);
    }
}

TEST_F(Streaming, CapturePathWritesEveryFrame) {
    const engine::Camera a = oblique(0.2), b = oblique(0.8);
    const fs::path pathFile = dir_ / "path.json";
    nlohmann::json path = {
        {"fov", 50},
        {"keyframes",
         {{{"eye", {a.eye[0], a.eye[1], a.eye[2]}}, {"yaw", 350}, {"pitch", -20}},
          {{"eye", {b.eye[0], b.eye[1], b.eye[2]}}, {"yaw", 30}, {"pitch", -30}}}}};
    std::ofstream(pathFile) << path.dump();
    const fs::path out = dir_ / "path";
    auto r = runCli("capture " + q(file_) + " --validation --size 160x120 --path " +
                    q(pathFile.string()) + " --frames 5 --out " + q(out.string()));
    ASSERT_EQ(r.code, 0) << r.err;
    for (int i = 0; i < 5; ++i) {
        char name[32];
        std::snprintf(name, sizeof name, "frame_%04d", i);
        ASSERT_TRUE(fs::exists(out / (std::string(name) + ".png"))) << name;
        const nlohmann::json j =
            nlohmann::json::parse(slurp((out / (std::string(name) + ".json")).string()));
        const double u = i / 4.0;
        EXPECT_NEAR(j["camera"]["eye"][0].get<double>(), a.eye[0] + u * (b.eye[0] - a.eye[0]),
                    1e-6);
        // Yaw goes the short way round: 350 -> 390 (= 30).
        EXPECT_NEAR(j["camera"]["yaw"].get<double>(), 350 + u * 40, 1e-9);
        EXPECT_NEAR(j["camera"]["pitch"].get<double>(), -20 - u * 10, 1e-9);
        EXPECT_EQ(j["camera"]["fov"].get<double>(), 50);
        EXPECT_EQ(j["totals"]["fallback_blocks"].get<int>(), 0);
    }
    EXPECT_FALSE(fs::exists(out / "frame_0005.png"));
    // A broken path file: exit 1, named, no frames.
    std::ofstream(dir_ / "bad.json") << R"({"keyframes": [{"eye": [1, 2], "yaw": 0, "pitch": 0}]})";
    const fs::path badOut = dir_ / "badpath";
    r = runCli("capture " + q(file_) + " --path " + q((dir_ / "bad.json").string()) + " --out " +
               q(badOut.string()));
    EXPECT_EQ(r.code, 1);
    EXPECT_NE(r.err.find("bad.json"), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(badOut / "frame_0000.png"));
    // Both --camera and --path: a usage error.
    r = runCli("capture " + q(file_) + " --camera 0,0,0,0,0 --path " + q(pathFile.string()) +
               " --out " + q(badOut.string()));
    EXPECT_EQ(r.code, 2);
}

TEST_F(Streaming, BenchEmitsEveryField) {
    const fs::path json = dir_ / "bench.json";
    const auto r =
        runCli("bench " + q(file_) + " --validation --frames 10 --warmup 1 --size 320x240 --json " +
               q(json.string()));
    ASSERT_EQ(r.code, 0) << r.err;
    const nlohmann::json j = nlohmann::json::parse(slurp(json.string()));
    for (const char* k : {"device", "size", "frames", "pixels", "metric", "distance", "runs",
                          "ratios_of_median_frame_ms"})
        EXPECT_TRUE(j.contains(k)) << k;
    for (const char* run : {"lod", "resident", "bare", "full"}) {
        ASSERT_TRUE(j["runs"].contains(run)) << run;
        const nlohmann::json& x = j["runs"][run];
        EXPECT_EQ(x["frames"].get<int>(), 10) << run;
        for (const char* k : {"fps", "frame_ms", "cpu_ms", "gpu_ms", "triangles", "resident_blocks",
                              "bytes_uploaded", "gpu_bytes_used_max"})
            EXPECT_TRUE(x.contains(k)) << run << " " << k;
        for (const char* k : {"median", "p95", "p99"})
            EXPECT_GT(x["frame_ms"][k].get<double>(), 0.0) << run << " " << k;
        EXPECT_GT(x["triangles"]["mean"].get<double>(), 0.0) << run;
        // The triangle cost fit: a least-squares line through the frames, so it passes through
        // their means; null only where every frame drew the same number of triangles.
        ASSERT_TRUE(x.contains("triangle_cost_fit")) << run;
        const nlohmann::json& fit = x["triangle_cost_fit"];
        if (x["triangles"]["min"].get<double>() < x["triangles"]["max"].get<double>()) {
            ASSERT_TRUE(fit.is_object()) << run << " " << fit.dump();
            EXPECT_EQ(fit["frames"].get<int>(), 10) << run;
            const std::string of = fit["of"].get<std::string>();
            ASSERT_TRUE(of == "gpu_ms" || of == "frame_ms") << of;
            EXPECT_NEAR(fit["intercept_ms"].get<double>() +
                            fit["ms_per_1000_triangles"].get<double>() *
                                x["triangles"]["mean"].get<double>() / 1000.0,
                        x[of]["mean"].get<double>(), 1e-6 * (1 + x[of]["mean"].get<double>()))
                << run << " " << fit.dump();
        } else {
            EXPECT_TRUE(fit.is_null()) << run << " " << fit.dump();
        }
        // The renderer's open; bare replays the resident run's draws in its renderer.
        if (std::string(run) == "bare")
            EXPECT_EQ(x["open_seconds"].get<double>(), 0.0);
        else
            EXPECT_GT(x["open_seconds"].get<double>(), 0.0) << run;
    }
    // The streamed run streams: what the loader delivered was uploaded (during the warm-up or
    // the measured frames), or, where the loader had not delivered yet when the frames were
    // done (a slow disk, a quick GPU), blocks were drawn at their coarse fallback. The preloaded
    // runs upload nothing per frame and never fall back. Bare draws what resident drew; full
    // draws at least as many triangles as the LOD.
    const nlohmann::json& lod = j["runs"]["lod"];
    EXPECT_TRUE(lod["bytes_uploaded"].get<std::uint64_t>() +
                        lod["warmup_bytes_uploaded"].get<std::uint64_t>() >
                    0 ||
                lod["fallback_blocks"]["max"].get<double>() > 0)
        << lod.dump();
    EXPECT_EQ(j["runs"]["resident"]["bytes_uploaded"].get<std::uint64_t>(), 0u);
    EXPECT_EQ(j["runs"]["resident"]["warmup_bytes_uploaded"].get<std::uint64_t>(), 0u);
    EXPECT_EQ(j["runs"]["resident"]["fallback_blocks"]["max"].get<double>(), 0.0);
    EXPECT_EQ(j["runs"]["bare"]["triangles"]["mean"], j["runs"]["resident"]["triangles"]["mean"]);
    EXPECT_GE(j["runs"]["full"]["triangles"]["mean"].get<double>(),
              j["runs"]["resident"]["triangles"]["mean"].get<double>());
    EXPECT_GT(j["ratios_of_median_frame_ms"]["full_over_lod"].get<double>(), 0.0);
    // Goals: met exactly when the ratio is on the right side of the stated bound.
    const nlohmann::json& ratios = j["ratios_of_median_frame_ms"];
    EXPECT_EQ(
        j["goals_met"]["lod_over_bare_at_most"].get<bool>(),
        ratios["lod_over_bare"].get<double>() <= j["goals"]["lod_over_bare_at_most"].get<double>());
    EXPECT_EQ(j["goals_met"]["full_over_lod_at_least"].get<bool>(),
              ratios["full_over_lod"].get<double>() >=
                  j["goals"]["full_over_lod_at_least"].get<double>());
    EXPECT_EQ(j["goals"]["full_over_lod_at_least"].get<double>(), 3.0);
    EXPECT_EQ(j["goals"]["lod_over_bare_at_most"].get<double>(), 1.2);
    EXPECT_NE(r.out.find("(goal >= 3.0: "), std::string::npos) << r.out;
}

// `bench --pace-ms`: frame i starts no earlier than i * pace into the run (so a run of n frames
// lasts at least (n - 1) * pace), and a frame's time is its own cost, not the interval: with a
// one-second pace a 160x90 frame's time stays far below it (unpaced it would be the interval).
TEST_F(Streaming, BenchPacedFramesReportTheirOwnCost) {
    const fs::path json = dir_ / "bench_paced.json";
    const auto r = runCli("bench " + q(file_) +
                          " --validation --frames 3 --warmup 1 --size 160x90 --runs lod "
                          "--pace-ms 1000 -o " +
                          q(json.string()));
    ASSERT_EQ(r.code, 0) << r.err;
    EXPECT_NE(r.out.find("paced every 1000 ms"), std::string::npos) << r.out;
    const nlohmann::json j = nlohmann::json::parse(slurp(json.string()));
    EXPECT_EQ(j["pace_ms"].get<double>(), 1000.0);
    const nlohmann::json& lod = j["runs"]["lod"];
    EXPECT_GE(lod["seconds"].get<double>(), 2.0);
    EXPECT_LT(lod["frame_ms"]["max"].get<double>(), 1000.0) << lod.dump();
    EXPECT_GT(lod["frame_ms"]["min"].get<double>(), 0.0);
    // Unpaced (the default), the JSON says so.
    const auto plain =
        runCli("bench " + q(file_) + " --frames 1 --warmup 0 --size 160x90 --runs lod --json -");
    ASSERT_EQ(plain.code, 0) << plain.err;
    EXPECT_EQ(nlohmann::json::parse(plain.out)["pace_ms"].get<double>(), 0.0);
}

// `bench --warmup N --warmup-ms MS`: each run warms up for at least N frames AND at least MS of
// wall time (a GPU idle during the preload runs its first frames at its idle clock), and the
// JSON says how many frames and how long.
TEST_F(Streaming, BenchWarmsUpForItsFramesAndItsTime) {
    const std::string base =
        "bench " + q(file_) + " --frames 1 --size 160x90 --runs resident,bare --json - ";
    const auto frames = runCli(base + "--warmup 3 --warmup-ms 0");
    ASSERT_EQ(frames.code, 0) << frames.err;
    const nlohmann::json f = nlohmann::json::parse(frames.out);
    EXPECT_EQ(f["warmup_ms"].get<double>(), 0.0);
    for (const char* run : {"resident", "bare"})
        EXPECT_EQ(f["runs"][run]["warmup_frames"].get<int>(), 3) << run;
    const auto timed = runCli(base + "--warmup 1 --warmup-ms 400");
    ASSERT_EQ(timed.code, 0) << timed.err;
    const nlohmann::json t = nlohmann::json::parse(timed.out);
    EXPECT_EQ(t["warmup_ms"].get<double>(), 400.0);
    for (const char* run : {"resident", "bare"}) {
        EXPECT_GE(t["runs"][run]["warmup_seconds"].get<double>(), 0.4) << run;
        EXPECT_GE(t["runs"][run]["warmup_frames"].get<int>(), 1) << run;
    }
}

// --rounds: the runs repeated in order and each run's frames pooled; every round's ratios kept.
TEST_F(Streaming, BenchRoundsPoolTheirFrames) {
    const auto r = runCli("bench " + q(file_) +
                          " --frames 3 --size 160x90 --runs lod,full --rounds 3 --warmup 1 "
                          "--warmup-ms 0 --json -");
    ASSERT_EQ(r.code, 0) << r.err;
    const nlohmann::json j = nlohmann::json::parse(r.out);
    EXPECT_EQ(j["rounds"].get<int>(), 3);
    ASSERT_EQ(j["round_ratios"].size(), 3u);
    for (const nlohmann::json& round : j["round_ratios"])
        EXPECT_GT(round["full_over_lod"].get<double>(), 0.0);
    for (const char* run : {"lod", "full"}) {
        EXPECT_EQ(j["runs"][run]["frames"].get<int>(), 9) << run;  // 3 frames x 3 rounds
        EXPECT_EQ(j["runs"][run]["warmup_frames"].get<int>(), 3) << run;
    }
    EXPECT_FALSE(j["runs"].contains("bare"));
    // bare replays a resident run's draws; without `resident` in --runs that run is neither
    // reported nor in a ratio.
    const auto b = runCli("bench " + q(file_) +
                          " --frames 2 --size 160x90 --runs lod,bare --rounds 2 --warmup 1 "
                          "--warmup-ms 0 --json -");
    ASSERT_EQ(b.code, 0) << b.err;
    const nlohmann::json jb = nlohmann::json::parse(b.out);
    EXPECT_FALSE(jb["runs"].contains("resident"));
    EXPECT_TRUE(jb["ratios_of_median_frame_ms"].contains("lod_over_bare"));
    EXPECT_FALSE(jb["ratios_of_median_frame_ms"].contains("resident_over_bare"));
    for (const nlohmann::json& round : jb["round_ratios"])
        EXPECT_FALSE(round.contains("resident_over_bare"));
    const auto bad = runCli("bench " + q(file_) + " --rounds 0");
    EXPECT_NE(bad.code, 0);
    EXPECT_NE(bad.err.find("--rounds"), std::string::npos) << bad.err;
}

// Opening reads every entry: the progress starts at (0, total), rises in batches from the
// calling thread and ends at (total, total); bench reports it as its own stage.
TEST_F(Streaming, OpeningReportsItsProgress) {
    engine::HeadlessOptions o = options(engine::kDefaultGpuBudget);
    std::vector<std::pair<std::size_t, std::size_t>> calls;
    const std::thread::id caller = std::this_thread::get_id();
    bool otherThread = false;
    o.scene.openProgress = [&](std::size_t done, std::size_t total) {
        calls.push_back({done, total});
        otherThread = otherThread || std::this_thread::get_id() != caller;
    };
    engine::HeadlessRenderer r;
    std::string error;
    ASSERT_TRUE(r.open(o, error)) << error;
    r.close();
    // Format version 5: open reads the roots only (every other entry's levels are in the
    // directory's level table); the bundled model's tree has one root.
    std::size_t n = 0;
    for (std::size_t i = 0; i < reader_.blocks().size(); ++i) {
        bool child = false;
        for (const format::BlockInfo& info : reader_.blocks())
            child = child || (info.childCount > 0 && i >= info.firstChild &&
                              i < std::size_t(info.firstChild) + info.childCount);
        n += child ? 0 : 1;
    }
    EXPECT_EQ(n, 1u);
    ASSERT_GE(calls.size(), 2u);
    EXPECT_EQ(calls.front(), std::make_pair(std::size_t(0), n));
    EXPECT_EQ(calls.back(), std::make_pair(n, n));
    for (std::size_t i = 1; i < calls.size(); ++i) {
        EXPECT_GT(calls[i].first, calls[i - 1].first);
        EXPECT_EQ(calls[i].second, n);
    }
    EXPECT_FALSE(otherThread);
    const auto b = runCli("bench " + q(file_) + " --frames 1 --warmup 0 --size 160x90 --runs lod");
    ASSERT_EQ(b.code, 0) << b.err;
    EXPECT_NE(b.err.find("bench: opening the model  " + std::to_string(n) + "/" +
                         std::to_string(n)),
              std::string::npos)
        << b.err;
}

// Opening reads and validates the roots only (format version 5: the levels of every entry are in
// the directory's level table), so an entry below the root is first read when a frame streams
// it: a damaged one then fails that frame with the file and the entry named, and the open of a
// preloading scene (which reads every entry) fails at once.
TEST_F(Streaming, ADamagedEntryBelowTheRootFailsTheFrameThatStreamsIt) {
    const std::string damaged = (dir_ / "damaged.ulod").string();
    test::UlodBytes f = test::UlodBytes::load(file_);
    const std::size_t count = reader_.blocks().size();
    for (std::size_t i = 0; i + 1 < count; ++i)  // every entry but the root, last in the file
        f.bytes[f.blockAt(i) + f.blockSize(i) / 2] ^= 0x5a;
    ASSERT_TRUE(f.save(damaged));
    engine::HeadlessOptions o = options(engine::kDefaultGpuBudget);
    o.path = damaged;
    std::string error;
    {
        engine::HeadlessRenderer r;
        ASSERT_TRUE(r.open(o, error)) << error;
        const engine::FrameView view = r.view(oblique(0.5));
        bool failed = false;
        for (int i = 0; i < 1000 && !failed; ++i) {
            failed = !r.renderFrame(view, true, nullptr, error);
            r.finish();
        }
        ASSERT_TRUE(failed) << "no frame read a damaged entry";
        EXPECT_NE(error.find(damaged + ": "), std::string::npos) << error;
        EXPECT_NE(error.find("checksum mismatch"), std::string::npos) << error;
        EXPECT_TRUE(error.find("block (") != std::string::npos ||
                    error.find("node (") != std::string::npos)
            << error;
        r.close();
    }
    o.scene.preloadAll = true;
    engine::HeadlessRenderer r;
    EXPECT_FALSE(r.open(o, error));
    EXPECT_NE(error.find("checksum mismatch"), std::string::npos) << error;
}

// A model whose preloaded runs do not fit the device (here a device capped below what every
// block resident needs): with the default runs `bench` measures the streamed run and says why the
// others were skipped; with the runs named (--runs) it fails before any run.
TEST_F(Streaming, BenchSkipsThePreloadedRunsOfAModelLargerThanTheDevice) {
    engine::BenchOptions o = benchOptions();
    o.cameras = {oblique(0.3), oblique(0.5)};
    o.scene.gpuBudget = 4u << 20;
    o.scene.uploadBytesPerFrame = 1u << 20;
    o.device.allocationCap = 6u << 20;  // the streamed run's 4 MiB fit, the whole model does not
    nlohmann::json j;
    std::string error;
    ASSERT_TRUE(engine::runBench(o, j, error)) << error;
    EXPECT_TRUE(j["runs"].contains("lod"));
    for (const char* run : {"resident", "bare", "full"}) {
        EXPECT_FALSE(j["runs"].contains(run)) << run;
        ASSERT_TRUE(j["skipped"].contains(run)) << j["skipped"].dump();
        const std::string why = j["skipped"][run].get<std::string>();
        EXPECT_NE(why.find("every block resident needs"), std::string::npos) << why;
        EXPECT_NE(why.find("can allocate at once (6 MiB)"), std::string::npos) << why;
    }
    EXPECT_EQ(j["runs"]["lod"]["frames"].get<int>(), 2);
    EXPECT_FALSE(j["ratios_of_median_frame_ms"].contains("full_over_lod"));

    // Named runs: an error at once, no run made.
    o.runsGiven = true;
    o.runs = {"lod", "full"};
    EXPECT_FALSE(engine::runBench(o, j, error));
    EXPECT_NE(error.find("every block resident needs"), std::string::npos) << error;

    // Without the cap the same options run everything.
    o.device.allocationCap = 0;
    ASSERT_TRUE(engine::runBench(o, j, error)) << error;
    EXPECT_TRUE(j["runs"].contains("full"));
    EXPECT_TRUE(j["skipped"].empty());
}

// The whole model at full resolution as ONE mesh of the header's origin (every leaf's level 0,
// its vertices moved from the leaf's origin).
engine::BenchMesh fullResolutionMesh(const format::Reader& reader) {
    engine::BenchMesh mesh;
    mesh.originX = reader.header().originX;
    mesh.originY = reader.header().originY;
    for (std::size_t i = 0; i < reader.blocks().size(); ++i) {
        if (reader.blocks()[i].level != 0) continue;
        format::BlockGeometry g;
        std::string error;
        EXPECT_TRUE(reader.readGeometry(i, 0, g, error)) << error;
        const std::uint32_t base = std::uint32_t(mesh.vertices.size());
        for (const format::Vertex& v : g.vertices)
            mesh.vertices.push_back({float(g.originX - mesh.originX + v.x),
                                     float(g.originY - mesh.originY + v.y), v.z, 0});
        for (const format::Triangle& t : g.terrainIndices)
            for (std::uint32_t v : {t.a, t.b, t.c})
                mesh.indices.push_back(base + v);
    }
    return mesh;
}

// The benchmark's baseline meshes (`bench --runs tin`) are drawn where the model is: the whole
// model at full resolution as one mesh of the header's origin, uploaded with uploadBenchMeshes
// and drawn by renderMeshFrame, gives the image of the full-resolution scene (rivers off);
// validation on.
TEST_F(Streaming, BaselineMeshesAreDrawnWhereTheModelIs) {
    engine::HeadlessOptions o = options(512u << 20);
    o.scene.preloadAll = true;
    o.scene.policy = engine::LodPolicy::Finest;
    engine::HeadlessRenderer r;
    std::string error;
    ASSERT_TRUE(r.open(o, error)) << error;
    engine::FrameView view = r.view(oblique(0.5));
    view.rivers = false;
    std::vector<std::uint8_t> scene, mesh;
    ASSERT_TRUE(r.renderFrame(view, true, &scene, error)) << error;
    engine::Buffer geometry;
    std::vector<std::vector<engine::DrawBlock>> lists;
    const engine::BenchMesh full = fullResolutionMesh(reader_);
    ASSERT_TRUE(
        engine::uploadBenchMeshes(r.device(), {full, engine::BenchMesh{}}, geometry, lists, error))
        << error;
    ASSERT_EQ(lists.size(), 2u);
    ASSERT_EQ(lists[0].size(), 1u);
    EXPECT_EQ(lists[0][0].terrainCount, full.indices.size());
    EXPECT_TRUE(lists[1].empty()) << "an empty mesh has no draw";
    r.renderMeshFrame(view, geometry.buffer, lists[0], &mesh);
    // An empty draw list draws the background only.
    std::vector<std::uint8_t> empty;
    r.renderMeshFrame(view, geometry.buffer, lists[1], &empty);
    r.finish();
    engine::destroyBuffer(r.device(), geometry);
    const std::vector<std::string> messages = r.close();
    EXPECT_TRUE(messages.empty()) << messages.front();
    ASSERT_EQ(scene.size(), mesh.size());
    ASSERT_EQ(scene.size(), empty.size());
    // Pixels the terrain covers (background: clear colour black) and pixels that differ.
    std::size_t covered = 0, coveredEmpty = 0, differ = 0, pixels = scene.size() / 4;
    for (std::size_t p = 0; p < pixels; ++p) {
        const std::uint8_t* a = &scene[4 * p];
        const std::uint8_t* b = &mesh[4 * p];
        covered += a[0] + a[1] + a[2] > 0;
        coveredEmpty += empty[4 * p] + empty[4 * p + 1] + empty[4 * p + 2] > 0;
        int d = 0;
        for (int k = 0; k < 3; ++k)
            d = std::max(d, std::abs(int(a[k]) - int(b[k])));
        differ += d > 8;
    }
    EXPECT_GT(covered, pixels / 4) << "the view does not show the terrain";
    EXPECT_EQ(coveredEmpty, 0u);
    // The same triangles from other float origins: a few edge pixels may round the other way.
    EXPECT_LT(differ, pixels / 200) << differ << " of " << pixels << " pixels differ";
}

// The `tin` run draws the caller's mesh for each frame (built once, drawn every round) with the
// same timing as the other runs, and its ratios come out; without a baseline it is an error.
TEST_F(Streaming, BenchTinRunDrawsTheBaselineMeshOfEachFrame) {
    engine::BenchOptions o = benchOptions();
    o.cameras = {oblique(0.3), oblique(0.5), oblique(0.7)};
    o.runs = {"full", "tin"};
    o.runsGiven = true;
    o.rounds = 2;
    nlohmann::json j;
    std::string error;
    EXPECT_FALSE(engine::runBench(o, j, error));
    EXPECT_NE(error.find("baseline"), std::string::npos) << error;

    // Frame i: the first (i + 1) * 1000 triangles of the full-resolution mesh.
    const engine::BenchMesh full = fullResolutionMesh(reader_);
    int calls = 0;
    o.baselineName = "test";
    o.baseline = [&](const engine::Camera& camera, engine::BenchMesh& mesh, std::string&) {
        std::size_t frame = 0;
        while (frame < o.cameras.size() && o.cameras[frame].eye[0] != camera.eye[0])
            ++frame;
        ++calls;
        mesh = full;
        mesh.indices.resize((frame + 1) * 3000);
        return true;
    };
    ASSERT_TRUE(engine::runBench(o, j, error)) << error;
    EXPECT_EQ(calls, 3) << "one mesh per frame, built once for both rounds";
    const nlohmann::json& tin = j["runs"]["tin"];
    EXPECT_EQ(tin["frames"].get<int>(), 6);
    EXPECT_EQ(tin["triangles"]["min"].get<double>(), 1000.0);
    EXPECT_EQ(tin["triangles"]["max"].get<double>(), 3000.0);
    EXPECT_EQ(tin["baseline"].get<std::string>(), "test");
    EXPECT_GT(j["runs"]["full"]["triangles"]["min"].get<double>(), 3000.0);
    EXPECT_TRUE(j["ratios_of_median_frame_ms"].contains("full_over_tin"));
    EXPECT_FALSE(j["ratios_of_median_frame_ms"].contains("lod_over_tin")) << "no lod run";

    // A baseline that fails stops the benchmark with its message.
    o.baseline = [](const engine::Camera&, engine::BenchMesh&, std::string& why) {
        why = "no mesh here";
        return false;
    };
    EXPECT_FALSE(engine::runBench(o, j, error));
    EXPECT_EQ(error, "no mesh here");
}

}  // namespace
