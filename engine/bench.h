// The frame-time benchmark (paper §4.2.3; issues 5 and 6): a fixed camera path rendered
// headless, without waiting for streaming, in four runs on one device:
// - "lod": the product: streamed blocks under the GPU budget, per-block level from h_lim;
// - "resident": the same level choice with every block preloaded (no streaming);
// - "bare": the draw lists of "resident" replayed frame by frame with no level selection and
//   no streaming: the cost of drawing the same triangles and nothing else;
// - "full": every visible block at full resolution, preloaded;
// - "tin" (only when asked for): a baseline mesh per frame from the caller, the best known
//   method's meshes (BenchOptions::baseline).
// Frame time is the wall-clock interval between successive frame submissions with two frames
// in flight (the pace of the slower of CPU and GPU); CPU time is the recording work; GPU time
// comes from timestamp queries.
#pragma once

#include <cstdint>
#include <functional>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "camera.h"
#include "device.h"
#include "renderer.h"
#include "scene.h"
#include "ulod.h"

namespace unilod::engine {

// One frame's mesh of the baseline run (BenchOptions::baseline): vertices as the file stores a
// block's (x, y relative to the origin, z absolute; flags unused), a triangle list.
struct BenchMesh {
    std::vector<format::Vertex> vertices;
    std::vector<std::uint32_t> indices;
    double originX = 0, originY = 0;
};

struct BenchOptions {
    std::string path;             // the .ulod file
    std::vector<Camera> cameras;  // one per frame
    std::uint32_t width = 1920, height = 1080;
    SceneOptions scene;
    DeviceOptions device;
    std::string spirvDir;
    std::uint32_t warmup = 5;  // frames rendered before each run's measured frames, at least
    // Warm-up wall time (ms), at least: back-to-back frames on the first camera until both this
    // time and `warmup` frames have passed. A GPU idle before a run (the resident run's preload)
    // runs its first frames at its idle clock: measured on an NVIDIA H200, 345 MHz for about
    // 0.1 s after a 55 s preload, then 1980 MHz, so a 200-frame run of sub-ms frames measured
    // the clock ramp (README "On a real GPU").
    double warmupMs = 500;
    bool perFrame = false;     // include every frame's numbers in the JSON
    // Paced frames (ms; 0: off): frame i starts no earlier than i * paceMs after the run's start,
    // as in an application held to a display's refresh, so the loader streams between frames
    // as it would there. Each frame is then waited for, and its frame time is its own cost
    // (record, submit, GPU done), not the interval between frames.
    double paceMs = 0;
    std::vector<std::string> runs = {"lod", "resident", "bare", "full"};
    // The "tin" run (a fifth run, only when named in `runs`): the best known method's frame
    // time on the same frames. Per frame, the mesh `baseline` returns for the camera (built once
    // before the first round and not timed; `unilod bench` gives the view-dependent greedy TIN of
    // preprocess/viewtin.h), uploaded to one device-local buffer and drawn with the same
    // pipelines, target, warm-up and timing as the other runs, one draw a frame, no rivers.
    // Its progress (done of total frames) goes to `progress` as "tin: building ...".
    std::function<bool(const Camera& camera, BenchMesh& mesh, std::string& error)> baseline;
    std::string baselineName;  // the JSON's description of the baseline mesh
    // The runs that preload every block (resident, bare, full) are checked against the device
    // before any run. When they do not fit: an error if the caller named the runs (`runsGiven`),
    // else they are skipped and the JSON says why (`skipped`), so that `bench` with its defaults
    // still measures the streamed run of a model larger than the device's memory.
    bool runsGiven = false;
    // Rounds (1: one of each run): the runs are repeated in the same order this many times and
    // each run's frames pooled, so that a slow phase of a shared machine (lavapipe's `full` run
    // moved 30-42 ms between runs of identical frames) falls on every run alike; the JSON keeps
    // each round's ratios (`round_ratios`).
    std::uint32_t rounds = 1;
    // Progress (may be empty): at the start of each run its description (done 0), after each
    // measured frame an empty description and the run's frames done of total. Called from the
    // calling thread between frames (the caller rate-limits its printing: cmd_bench.cpp).
    std::function<void(const std::string& run, std::size_t done, std::size_t total)> progress;
};

// The meshes in one device-local buffer of `device` (each one's vertices, then its indices; the
// caller destroys it once the frames drawing it are done) and one draw per mesh (none for an
// empty mesh) for HeadlessRenderer::renderMeshFrame. False with a message when the buffer cannot
// be allocated.
bool uploadBenchMeshes(const Device& device, const std::vector<BenchMesh>& meshes, Buffer& geometry,
                       std::vector<std::vector<DrawBlock>>& lists, std::string& error);

// Runs the benchmark and returns its JSON (see README "unilod bench" for the fields). False
// with a message on a data or device error or a validation message when validation is on.
bool runBench(const BenchOptions& options, nlohmann::json& out, std::string& error);
// The former form, kept while callers move (tools/report/frametimes.cpp): the flag printed
// stage lines on stderr; BenchOptions::progress replaces it, and it is ignored.
inline bool runBench(const BenchOptions& options, nlohmann::json& out, std::string& error,
                     bool /*progress*/) {
    return runBench(options, out, error);
}

}  // namespace unilod::engine
