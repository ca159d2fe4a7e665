#include "bench.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <numeric>
#include <thread>

#include "headless.h"

namespace unilod::engine {

namespace {

using Clock = std::chrono::steady_clock;

// Issue 5's goals, on the ratios of median frame times.
constexpr double kLodOverBareGoal = 1.2;  // the LOD machinery costs at most 20% over bare draws
constexpr double kFullOverLodGoal = 3.0;  // the LOD is at least 3x faster than full resolution

nlohmann::json summary(std::vector<double> v) {
    if (v.empty()) return nullptr;
    std::sort(v.begin(), v.end());
    auto pct = [&](double p) {
        const double at = p * double(v.size() - 1);
        const std::size_t i = std::size_t(at);
        const double f = at - double(i);
        return i + 1 < v.size() ? v[i] * (1 - f) + v[i + 1] * f : v[i];
    };
    const double mean = std::accumulate(v.begin(), v.end(), 0.0) / double(v.size());
    return {{"mean", mean},     {"median", pct(0.5)}, {"p95", pct(0.95)},
            {"p99", pct(0.99)}, {"min", v.front()},   {"max", v.back()}};
}

struct RunData {
    std::vector<double> frameMs, cpuMs, gpuMs;
    std::vector<FrameStats> stats;
    // "resident" keeps its draw lists for "bare", with their refined index data.
    std::vector<std::vector<DrawBlock>> drawLists;
    std::vector<std::vector<std::uint32_t>> refinedIndices;
    double seconds = 0;
    // The renderer's open: device, pipelines and the scene (the directory, level table and roots;
    // for the preloaded runs every entry too). 0 for `bare`, which uses the resident run's.
    double openSeconds = 0;
    std::uint64_t warmupBytesUploaded = 0;  // streamed during the unmeasured warm-up frames
    std::uint32_t warmupFrames = 0;         // warm-up frames rendered
    double warmupSeconds = 0;               // their wall time, the GPU's work included
    std::uint64_t loaderBytesAtStart = 0;   // the loader's totals when the measured frames began
    double loaderSecondsAtStart = 0;
    std::uint64_t loaderBytes = 0;  // the loader's reads during the measured frames
    double loaderSeconds = 0;
};

// Another round's run pooled into `into`: its frames appended, its totals added.
void pool(RunData& into, const RunData& r) {
    into.frameMs.insert(into.frameMs.end(), r.frameMs.begin(), r.frameMs.end());
    into.cpuMs.insert(into.cpuMs.end(), r.cpuMs.begin(), r.cpuMs.end());
    into.gpuMs.insert(into.gpuMs.end(), r.gpuMs.begin(), r.gpuMs.end());
    into.stats.insert(into.stats.end(), r.stats.begin(), r.stats.end());
    into.seconds += r.seconds;
    into.openSeconds += r.openSeconds;
    into.warmupBytesUploaded += r.warmupBytesUploaded;
    into.warmupFrames += r.warmupFrames;
    into.warmupSeconds += r.warmupSeconds;
    into.loaderBytes += r.loaderBytes;
    into.loaderSeconds += r.loaderSeconds;
}

double medianOf(std::vector<double> v) {
    return v.empty() ? 0.0 : summary(std::move(v))["median"].get<double>();
}

// The ratios of median frame times (0: a run not made).
nlohmann::json ratiosOf(double lod, double resident, double bare, double full, double tin) {
    nlohmann::json ratios = nlohmann::json::object();
    if (lod > 0 && bare > 0) ratios["lod_over_bare"] = lod / bare;
    if (resident > 0 && bare > 0) ratios["resident_over_bare"] = resident / bare;
    if (lod > 0 && full > 0) ratios["full_over_lod"] = full / lod;
    // The baseline (BenchOptions::baseline): what the best known method's meshes give.
    if (tin > 0 && full > 0) ratios["full_over_tin"] = full / tin;
    if (tin > 0 && lod > 0) ratios["lod_over_tin"] = lod / tin;
    return ratios;
}

// A run's frame cost against its triangles drawn, least squares over its frames (a + b x): what
// a triangle costs on this device, comparable between runs (our cut against the best known
// method's meshes) where a ratio of medians moves with a noisy machine (MEASURED.md, forty-third
// session). GPU time where every frame has it, else frame time; null with fewer than 3 frames or
// one triangle count.
nlohmann::json triangleCostFit(const RunData& r) {
    const bool gpu = !r.gpuMs.empty() && r.gpuMs.size() == r.stats.size();
    const std::vector<double>& ms = gpu ? r.gpuMs : r.frameMs;
    const std::size_t n = std::min(ms.size(), r.stats.size());
    if (n < 3) return nullptr;
    double mx = 0, my = 0;
    for (std::size_t i = 0; i < n; ++i)
        mx += double(r.stats[i].triangles), my += ms[i];
    mx /= double(n), my /= double(n);
    double sxx = 0, sxy = 0;
    for (std::size_t i = 0; i < n; ++i) {
        const double dx = double(r.stats[i].triangles) - mx;
        sxx += dx * dx;
        sxy += dx * (ms[i] - my);
    }
    if (!(sxx > 0)) return nullptr;
    const double slope = sxy / sxx;
    return {{"of", gpu ? "gpu_ms" : "frame_ms"},
            {"intercept_ms", my - slope * mx},
            {"ms_per_1000_triangles", slope * 1000.0},
            {"frames", n}};
}

nlohmann::json runJson(const RunData& r, bool perFrame) {
    std::vector<double> triangles, resident, fallback, visible, refineMs, refined;
    std::uint64_t uploaded = 0, gpuUsed = 0, evictions = 0;
    for (const FrameStats& s : r.stats) {
        triangles.push_back(double(s.triangles));
        resident.push_back(double(s.residentBlocks));
        fallback.push_back(double(s.fallbackBlocks));
        visible.push_back(double(s.visibleBlocks));
        refineMs.push_back(s.refineMs);
        refined.push_back(double(s.refinedBlocks));
        uploaded += s.bytesUploaded;
        gpuUsed = std::max(gpuUsed, s.gpuBytesUsed);
        evictions += s.evictions;
    }
    const double medianFrame = summary(r.frameMs)["median"].get<double>();
    nlohmann::json j = {
        {"frames", r.frameMs.size()},
        {"seconds", r.seconds},
        {"open_seconds", r.openSeconds},
        {"fps", r.seconds > 0 ? double(r.frameMs.size()) / r.seconds : 0.0},
        {"fps_median", medianFrame > 0 ? 1000.0 / medianFrame : 0.0},
        {"frame_ms", summary(r.frameMs)},
        {"cpu_ms", summary(r.cpuMs)},
        {"gpu_ms", summary(r.gpuMs)},
        {"triangles", summary(triangles)},
        {"visible_blocks", summary(visible)},
        {"resident_blocks", summary(resident)},
        {"fallback_blocks", summary(fallback)},
        // The view refinement's part of cpu_ms (SceneOptions::refine; 0 for bare) and the entries
        // it refined.
        {"refine_ms", summary(refineMs)},
        {"refined_blocks", summary(refined)},
        {"bytes_uploaded", uploaded},
        {"warmup_bytes_uploaded", r.warmupBytesUploaded},
        {"warmup_frames", r.warmupFrames},
        {"warmup_seconds", r.warmupSeconds},
        {"gpu_bytes_used_max", gpuUsed},
        {"gpu_budget", r.stats.empty() ? 0 : r.stats.back().gpuBudget},
        {"evictions", evictions},
        {"triangle_cost_fit", triangleCostFit(r)},
    };
    if (!r.stats.empty()) {
        // The loader thread's reads during the run (compact blocks decode there, not in a frame).
        const double bytes = double(r.loaderBytes);
        const double seconds = r.loaderSeconds;
        j["loader_bytes_read"] = std::uint64_t(bytes);
        j["loader_read_decode_seconds"] = seconds;
        j["loader_ms_per_mb"] = bytes > 0 ? seconds * 1000 / (bytes / 1e6) : 0.0;
    }
    if (perFrame) {
        nlohmann::json frames = nlohmann::json::array();
        for (std::size_t i = 0; i < r.frameMs.size(); ++i)
            frames.push_back({{"frame_ms", r.frameMs[i]},
                              {"cpu_ms", r.cpuMs[i]},
                              {"gpu_ms", i < r.gpuMs.size() ? r.gpuMs[i] : -1.0},
                              {"triangles", r.stats[i].triangles},
                              {"resident_blocks", r.stats[i].residentBlocks},
                              {"bytes_uploaded", r.stats[i].bytesUploaded}});
        j["per_frame"] = frames;
    }
    return j;
}

// Draw lists replayed frame by frame instead of selecting: the resident run's (with their refined
// index data, in the scene's buffer: the bare run) or the baseline meshes' (in their own buffer).
struct Replay {
    const std::vector<std::vector<DrawBlock>>* lists = nullptr;
    const std::vector<std::vector<std::uint32_t>>* indices = nullptr;  // null: `geometry`'s
    VkBuffer geometry = VK_NULL_HANDLE;

    void render(HeadlessRenderer& renderer, const FrameView& view, std::size_t frame) const {
        if (indices)
            renderer.renderBareFrame(view, (*lists)[frame], (*indices)[frame]);
        else
            renderer.renderMeshFrame(view, geometry, (*lists)[frame]);
    }
};

// One run over the path. `replay`: draw lists replayed instead of selecting (bare, tin).
bool run(HeadlessRenderer& renderer, const BenchOptions& o, bool keepLists, const Replay* replay,
         RunData& data, std::string& error) {
    const std::size_t n = o.cameras.size();
    // Warm-up on the first camera (pipelines, caches, the GPU's clock), not measured: at least
    // o.warmup frames and o.warmupMs of wall time.
    const auto warmStart = Clock::now();
    auto warmElapsedMs = [&] {
        return std::chrono::duration<double, std::milli>(Clock::now() - warmStart).count();
    };
    for (std::uint32_t i = 0; i < o.warmup || warmElapsedMs() < o.warmupMs; ++i) {
        ++data.warmupFrames;
        const FrameView view = renderer.view(o.cameras.front());
        if (replay)
            replay->render(renderer, view, 0);
        else if (!renderer.renderFrame(view, true, nullptr, error))
            return false;
        else
            data.warmupBytesUploaded += renderer.scene().stats().bytesUploaded;
    }
    renderer.finish();
    data.warmupSeconds = warmElapsedMs() / 1000.0;
    data.loaderBytesAtStart = renderer.scene().stats().loaderBytesRead;
    data.loaderSecondsAtStart = renderer.scene().stats().loaderSeconds;
    std::vector<FrameStats> stats;
    std::vector<FrameTiming> timings;
    const bool paced = o.paceMs > 0;
    const auto pace = std::chrono::duration<double, std::milli>(o.paceMs);
    const auto start = Clock::now();
    auto last = start;
    for (std::size_t i = 0; i < n; ++i) {
        if (paced) {
            std::this_thread::sleep_until(
                start + std::chrono::duration_cast<Clock::duration>(pace * double(i)));
            last = Clock::now();
        }
        const FrameView view = renderer.view(o.cameras[i]);
        if (replay) {
            replay->render(renderer, view, i);
            FrameStats s;
            for (const DrawBlock& d : (*replay->lists)[i])
                s.triangles += d.terrainCount / 3;
            s.visibleBlocks = std::uint32_t((*replay->lists)[i].size());
            s.loaderBytesRead = renderer.scene().stats().loaderBytesRead;
            s.loaderSeconds = renderer.scene().stats().loaderSeconds;
            stats.push_back(s);
        } else {
            if (!renderer.renderFrame(view, true, nullptr, error)) return false;
            stats.push_back(renderer.scene().stats());
            if (keepLists) {
                data.drawLists.push_back(renderer.scene().drawList());
                data.refinedIndices.push_back(renderer.scene().refinedIndices());
            }
        }
        if (paced) {
            // The frame's own cost: wait for it (the next one starts at its tick anyway).
            for (FrameTiming& t : renderer.finish())
                timings.push_back(t);
        }
        const auto now = Clock::now();
        data.frameMs.push_back(std::chrono::duration<double, std::milli>(now - last).count());
        last = now;
        if (o.progress) o.progress({}, i + 1, n);
    }
    for (FrameTiming& t : renderer.finish())
        timings.push_back(t);
    data.seconds = std::chrono::duration<double>(Clock::now() - start).count();
    // Unpaced, the last frames' intervals do not include their GPU work: add the drain to the
    // last one.
    if (!paced)
        data.frameMs.back() +=
            std::chrono::duration<double, std::milli>(Clock::now() - last).count();
    for (const FrameTiming& t : timings) {
        data.cpuMs.push_back(t.cpuMs);
        if (t.gpuMs >= 0) data.gpuMs.push_back(t.gpuMs);
    }
    if (!stats.empty()) {
        data.loaderBytes = stats.back().loaderBytesRead - data.loaderBytesAtStart;
        data.loaderSeconds = stats.back().loaderSeconds - data.loaderSecondsAtStart;
    }
    data.stats = std::move(stats);
    return true;
}

}  // namespace

bool uploadBenchMeshes(const Device& device, const std::vector<BenchMesh>& meshes, Buffer& geometry,
                       std::vector<std::vector<DrawBlock>>& lists, std::string& error) {
    VkDeviceSize size = 0;
    lists.assign(meshes.size(), {});
    for (std::size_t i = 0; i < meshes.size(); ++i) {
        const BenchMesh& m = meshes[i];
        DrawBlock d;
        d.vertexOffset = size;
        size += m.vertices.size() * sizeof(format::Vertex);
        d.terrainFirst = std::uint32_t(size / sizeof(std::uint32_t));
        d.terrainCount = std::uint32_t(m.indices.size());
        size += m.indices.size() * sizeof(std::uint32_t);
        d.originX = m.originX;
        d.originY = m.originY;
        if (d.terrainCount > 0) lists[i].push_back(d);
    }
    // The index offsets are in uint32 units from the buffer's start.
    if (size / sizeof(std::uint32_t) > UINT32_MAX) {
        error = "the baseline meshes take more than 16 GiB";
        return false;
    }
    size = std::max<VkDeviceSize>(size, 16);
    Buffer staging;
    if (!tryCreateBuffer(device, size, VK_BUFFER_USAGE_TRANSFER_SRC_BIT,
                         VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT,
                         staging, error))
        return false;
    auto* bytes = static_cast<std::uint8_t*>(staging.mapped);
    for (std::size_t i = 0; i < meshes.size(); ++i) {
        const BenchMesh& m = meshes[i];
        if (lists[i].empty()) continue;
        std::memcpy(bytes + lists[i][0].vertexOffset, m.vertices.data(),
                    m.vertices.size() * sizeof(format::Vertex));
        std::memcpy(bytes + VkDeviceSize(lists[i][0].terrainFirst) * sizeof(std::uint32_t),
                    m.indices.data(), m.indices.size() * sizeof(std::uint32_t));
    }
    if (!tryCreateBuffer(device, size,
                         VK_BUFFER_USAGE_TRANSFER_DST_BIT | VK_BUFFER_USAGE_VERTEX_BUFFER_BIT |
                             VK_BUFFER_USAGE_INDEX_BUFFER_BIT,
                         VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT, geometry, error)) {
        destroyBuffer(device, staging);
        return false;
    }
    submitAndWait(device, [&](VkCommandBuffer cmd) {
        const VkBufferCopy copy{0, 0, size};
        vkCmdCopyBuffer(cmd, staging.buffer, geometry.buffer, 1, &copy);
    });
    destroyBuffer(device, staging);
    return true;
}

bool runBench(const BenchOptions& o, nlohmann::json& out, std::string& error) {
    if (o.cameras.empty()) {
        error = "no frames";
        return false;
    }
    std::vector<std::string> wanted = o.runs;
    auto has = [&](const char* name) {
        return std::find(wanted.begin(), wanted.end(), name) != wanted.end();
    };
    nlohmann::json runs = nlohmann::json::object();
    std::string deviceName;
    std::vector<std::string> messages;
    auto openRenderer = [&](HeadlessRenderer& r, const SceneOptions& scene, RunData& data) {
        const auto start = Clock::now();
        HeadlessOptions ho;
        ho.path = o.path;
        ho.width = o.width;
        ho.height = o.height;
        ho.scene = scene;
        ho.scene.openProgress = [&](std::size_t done, std::size_t total) {
            if (o.progress) o.progress(done == 0 ? "opening the model" : "", done, total);
        };
        ho.device = o.device;
        ho.spirvDir = o.spirvDir;
        if (!r.open(ho, error)) return false;
        data.openSeconds = std::chrono::duration<double>(Clock::now() - start).count();
        deviceName = r.device().properties.deviceName;
        return true;
    };
    auto closeRenderer = [&](HeadlessRenderer& r) {
        for (std::string& m : r.close())
            messages.push_back(std::move(m));
    };
    auto say = [&](const char* what) {
        if (o.progress) o.progress(what, 0, o.cameras.size());
    };

    // The baseline meshes, built once for every round (not timed).
    std::vector<BenchMesh> meshes;
    double meshSeconds = 0;
    if (has("tin")) {
        if (!o.baseline) {
            error = "the tin run needs a baseline mesh for each frame (BenchOptions::baseline)";
            return false;
        }
        const auto start = Clock::now();
        say("tin: building each frame's baseline mesh");
        meshes.resize(o.cameras.size());
        for (std::size_t i = 0; i < o.cameras.size(); ++i) {
            if (!o.baseline(o.cameras[i], meshes[i], error)) return false;
            if (o.progress) o.progress({}, i + 1, o.cameras.size());
        }
        meshSeconds = std::chrono::duration<double>(Clock::now() - start).count();
    }

    // The preloaded runs need every block resident at once: checked on the streamed run's scene
    // before its first frame (BenchOptions::runsGiven); without a streamed run the first
    // preloaded run's open fails at once with the same message.
    nlohmann::json skipped = nlohmann::json::object();
    auto checkPreload = [&](HeadlessRenderer& r) {
        if (!(has("resident") || has("bare") || has("full"))) return true;
        std::string why;
        if (r.scene().preloadFits(why)) return true;
        if (o.runsGiven) {
            error = why;
            return false;
        }
        for (const char* name : {"resident", "bare", "full"})
            if (has(name)) skipped[name] = why;
        wanted =
            has("tin") ? std::vector<std::string>{"lod", "tin"} : std::vector<std::string>{"lod"};
        return true;
    };

    // The ratios of the runs reported (those --runs names): a resident run made only for
    // bare's draw lists is not reported, nor is its ratio.
    auto reportedRatios = [&](const RunData& lod, const RunData& resident, const RunData& bare,
                              const RunData& full, const RunData& tin) {
        auto ms = [&](const char* name, const RunData& r) {
            return has(name) ? medianOf(r.frameMs) : 0.0;
        };
        return ratiosOf(ms("lod", lod), ms("resident", resident), ms("bare", bare),
                        ms("full", full), ms("tin", tin));
    };
    // Rounds (BenchOptions::rounds): the runs in the same order each round, pooled per run;
    // each round's own ratios are kept too.
    RunData pooled[5];  // lod, resident, bare, full, tin
    nlohmann::json roundRatios = nlohmann::json::array();
    for (std::uint32_t round = 0; round < std::max(1u, o.rounds); ++round) {
        RunData lod, resident, bare, full, tin;
        if (has("lod")) {
            HeadlessRenderer r;
            bool ok = openRenderer(r, o.scene, lod) && (round > 0 || checkPreload(r));
            if (ok) {
                say("lod: streamed, per-block LOD");
                ok = run(r, o, false, nullptr, lod, error);
            }
            closeRenderer(r);
            if (!ok) return false;
        }
        if (has("resident") || has("bare")) {
            SceneOptions scene = o.scene;
            scene.preloadAll = true;
            HeadlessRenderer r;
            bool ok = openRenderer(r, scene, resident);
            if (ok) {
                say("resident: per-block LOD, everything preloaded");
                ok = run(r, o, true, nullptr, resident, error);
            }
            if (ok && has("bare")) {
                say("bare: the resident run's draws replayed");
                const Replay replay{&resident.drawLists, &resident.refinedIndices, VK_NULL_HANDLE};
                ok = run(r, o, false, &replay, bare, error);
            }
            closeRenderer(r);
            if (!ok) return false;
            resident.drawLists.clear();
            resident.refinedIndices.clear();
        }
        if (has("full")) {
            SceneOptions scene = o.scene;
            scene.preloadAll = true;
            scene.policy = LodPolicy::Finest;
            HeadlessRenderer r;
            bool ok = openRenderer(r, scene, full);
            if (ok) {
                say("full: every visible block at full resolution");
                ok = run(r, o, false, nullptr, full, error);
            }
            closeRenderer(r);
            if (!ok) return false;
        }
        if (has("tin")) {
            HeadlessRenderer r;
            Buffer geometry;
            std::vector<std::vector<DrawBlock>> lists;
            bool ok = openRenderer(r, o.scene, tin) &&
                      uploadBenchMeshes(r.device(), meshes, geometry, lists, error);
            if (ok) {
                say("tin: the baseline meshes drawn");
                const Replay replay{&lists, nullptr, geometry.buffer};
                ok = run(r, o, false, &replay, tin, error);
            }
            r.finish();
            if (geometry.buffer != VK_NULL_HANDLE) destroyBuffer(r.device(), geometry);
            closeRenderer(r);
            if (!ok) return false;
        }
        roundRatios.push_back(reportedRatios(lod, resident, bare, full, tin));
        pool(pooled[0], lod), pool(pooled[1], resident), pool(pooled[2], bare),
            pool(pooled[3], full), pool(pooled[4], tin);
    }
    const char* names[5] = {"lod", "resident", "bare", "full", "tin"};
    for (int k = 0; k < 5; ++k)
        if (has(names[k])) runs[names[k]] = runJson(pooled[k], o.perFrame);
    if (has("tin")) {
        runs["tin"]["baseline"] = o.baselineName;
        runs["tin"]["build_seconds"] = meshSeconds;
    }
    if (!messages.empty()) {
        error = std::to_string(messages.size()) +
                " Vulkan validation message(s) (first: " + messages.front() + ")";
        return false;
    }
    nlohmann::json ratios =
        reportedRatios(pooled[0], pooled[1], pooled[2], pooled[3], pooled[4]);
    out = {
        {"file", o.path},
        {"device", deviceName},
        {"size", {o.width, o.height}},
        {"frames", o.cameras.size()},
        {"warmup_frames", o.warmup},
        {"warmup_ms", o.warmupMs},
        {"pace_ms", o.paceMs},
        {"pixels", o.scene.pixels},
        {"metric", o.scene.metric.empty() ? "file default" : o.scene.metric},
        {"distance", o.scene.distance == DistanceMode::Nearest ? "nearest" : "centre"},
        {"gpu_budget", o.scene.gpuBudget},
        {"rounds", std::max(1u, o.rounds)},
        {"round_ratios", roundRatios},
        {"runs", runs},
        {"skipped", skipped},
        {"ratios_of_median_frame_ms", ratios},
        {"goals",
         {{"lod_over_bare_at_most", kLodOverBareGoal},
          {"full_over_lod_at_least", kFullOverLodGoal}}},
    };
    nlohmann::json met = nlohmann::json::object();
    if (ratios.contains("lod_over_bare"))
        met["lod_over_bare_at_most"] = ratios["lod_over_bare"].get<double>() <= kLodOverBareGoal;
    if (ratios.contains("full_over_lod"))
        met["full_over_lod_at_least"] = ratios["full_over_lod"].get<double>() >= kFullOverLodGoal;
    out["goals_met"] = met;
    return true;
}

}  // namespace unilod::engine
