// `unilod bench FILE [--path PATH.json] [--frames 200] [--size 1920x1080] [--pixels 1]
// [-o OUT.json] [--json [-]]`: the paper's §4.2.3 roaming experiment (engine/bench.h): one fixed
// camera path, four runs (streamed LOD, everything resident, bare replay of the same draws, full
// resolution; with --runs ...,tin a fifth: the best known method's meshes, setBaseline below), FPS
// and frame time median / p95 / p99, GPU time, triangles, resident blocks, bytes
// uploaded. Prints a table on stdout, or the JSON with --json (or -o -); -o FILE writes the JSON
// to FILE (an existing one needs --overwrite: outputopts.h; `--json FILE` is the old spelling).
// Progress on stderr (progress.h). A benchmark, not a test: it prints numbers and asserts nothing.
#include <algorithm>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "atomicfile.h"
#include "bench.h"
#include "capture.h"
#include "commands.h"
#include "engineopts.h"
#include "jsontext.h"
#include "numbers.h"
#include "outputopts.h"
#include "progress.h"
#include "ulod.h"
#include "viewtin.h"

namespace unilod::cli {

namespace {

struct BenchCli {
    engine::BenchOptions o;
    EngineCli engine;
    std::string cameraPath, runs = "lod,resident,bare,full";
    CLI::Option* runsOption = nullptr;
    OutputFlags output;
    JsonFlags json;
    std::uint32_t frames = 200;
    bool quiet = false;
};

// The "tin" run's meshes (engine/bench.h BenchOptions::baseline): per frame the view-dependent
// greedy TIN of the whole model (preprocess/viewtin.h: every point on screen within its own
// P-pixel bound, nearest distance), its vertices only. The model's points are read at the first
// frame.
void setBaseline(engine::BenchOptions& o) {
    struct Model {
        bool read = false;
        format::Block all;
        PointSet set;
        std::vector<double> weights;
    };
    auto model = std::make_shared<Model>();
    o.baselineName =
        "view-dependent greedy TIN of the whole model per frame: every point on screen within its "
        "own P-pixel bound (nearest distance), Garland-Heckbert insertion; no rivers";
    const std::string path = o.path;
    const double width = o.width, height = o.height, pixels = o.scene.pixels;
    o.baseline = [model, path, width, height, pixels](const engine::Camera& camera,
                                                      engine::BenchMesh& mesh, std::string& error) {
        if (!model->read) {
            format::Reader reader;
            if (!reader.open(path, error) || !mergedLeaves(reader, model->all, error)) return false;
            model->set = blockPoints(model->all);
            model->read = true;
        }
        viewWeights(model->set, TinView{camera, width, height, pixels}, model->weights);
        std::vector<TriangleTriple> triangles;
        std::uint32_t vertices = 0;
        if (!weightedTin(model->set, model->weights, triangles, vertices, error)) return false;
        // The TIN's own vertices, numbered in order of first use.
        std::vector<std::uint32_t> number(model->set.points.size(), UINT32_MAX);
        mesh = engine::BenchMesh{};
        mesh.originX = model->all.originX;
        mesh.originY = model->all.originY;
        for (const TriangleTriple& t : triangles)
            for (PointId v : t.v) {
                if (number[v] == UINT32_MAX) {
                    number[v] = std::uint32_t(mesh.vertices.size());
                    mesh.vertices.push_back(model->all.vertices[v]);
                }
                mesh.indices.push_back(number[v]);
            }
        return true;
    };
}

int run(BenchCli& c) {
    if (!c.engine.apply(c.o.scene, c.o.device, c.o.width, c.o.height, "bench")) return 2;
    c.o.runsGiven = c.runsOption != nullptr && c.runsOption->count() > 0;
    c.o.runs = splitList(c.runs);  // checked while parsing
    std::string error;
    if (std::find(c.o.runs.begin(), c.o.runs.end(), "tin") != c.o.runs.end()) setBaseline(c.o);
    // Where the JSON goes: -o FILE, or the old spelling --json FILE; "-" is stdout (instead of
    // the table).
    if (!c.output.path.empty() && c.json.requested() && !c.json.toStdout()) {
        std::fprintf(stderr, "unilod bench: error: give -o FILE or --json FILE, not both\n");
        return 2;
    }
    std::string jsonFile =
        c.output.path.empty() && !c.json.toStdout() ? c.json.target : c.output.path;
    const bool jsonStdout = c.json.toStdout() || jsonFile == "-";
    if (jsonFile == "-") jsonFile.clear();
    // The JSON file replaces an earlier result only with --overwrite, never the model or the
    // camera path; checked now so that a bad path fails before the runs.
    format::OutputOptions output = outputOptions(c.output, {c.o.path});
    if (!c.cameraPath.empty()) output.inputs.push_back(c.cameraPath);
    if (!jsonFile.empty() && !format::checkOutputPath(jsonFile, output, false, error)) {
        std::fprintf(stderr, "unilod bench: error: %s\n", error.c_str());
        return 1;
    }
    engine::CameraPath path;
    if (!c.cameraPath.empty()) {
        if (!engine::loadCameraPath(c.cameraPath, path, error)) {
            std::fprintf(stderr, "unilod bench: error: %s\n", error.c_str());
            return 1;
        }
    } else {
        format::Reader reader;
        if (!reader.open(c.o.path, error)) {
            std::fprintf(stderr, "unilod bench: error: %s\n", error.c_str());
            return 1;
        }
        path = engine::defaultFlyOver(reader.header());
    }
    c.o.cameras = engine::sampleCameraPath(path, c.frames);
    nlohmann::json out;
    bool ok = false;
    {
        Progress progress("bench", !c.quiet, "opening the device");
        c.o.progress = [&progress](const std::string& run, std::size_t done, std::size_t total) {
            if (!run.empty())
                progress.stage(run, total);
            else
                progress.update(done, total);
        };
        ok = engine::runBench(c.o, out, error);
    }
    if (!ok) {
        std::fprintf(stderr, "unilod bench: error: %s\n", errorForFile(c.o.path, error).c_str());
        return 1;
    }
    out["path"] = c.cameraPath.empty() ? "default fly-over" : c.cameraPath;
    if (jsonStdout) {
        std::printf("%s\n", jsonText(out, 2).c_str());
        return 0;
    }
    std::printf("%-9s %9s %9s %9s %9s %9s %12s %9s %12s\n", "run", "fps", "median", "p95", "p99",
                "gpu ms", "triangles", "resident", "uploaded MB");
    for (const char* name : {"lod", "resident", "bare", "full", "tin"}) {
        if (!out["runs"].contains(name)) continue;
        const nlohmann::json& r = out["runs"][name];
        auto num = [](const nlohmann::json& j) { return j.is_null() ? -1.0 : j.get<double>(); };
        std::printf("%-9s %9.1f %9.2f %9.2f %9.2f %9.2f %12.0f %9.1f %12.1f\n", name, num(r["fps"]),
                    num(r["frame_ms"]["median"]), num(r["frame_ms"]["p95"]),
                    num(r["frame_ms"]["p99"]),
                    r["gpu_ms"].is_null() ? -1.0 : num(r["gpu_ms"]["median"]),
                    num(r["triangles"]["mean"]), num(r["resident_blocks"]["mean"]),
                    double(r["bytes_uploaded"].get<std::uint64_t>()) / 1e6);
    }
    for (const char* name : {"resident", "bare", "full"})
        if (out["skipped"].contains(name))
            std::printf("%-9s skipped: %s\n", name, out["skipped"][name].get<std::string>().c_str());
    for (auto& [k, v] : out["ratios_of_median_frame_ms"].items()) {
        std::printf("%s = %.3f", k.c_str(), v.get<double>());
        for (auto& [goal, met] : out["goals_met"].items()) {
            // "lod_over_bare_at_most" is the goal of the ratio "lod_over_bare".
            if (goal.rfind(k, 0) != 0) continue;
            const bool atMost = goal.find("at_most") != std::string::npos;
            std::printf(" (goal %s %.1f: %s)",
                        atMost ? "<=" : ">=", out["goals"][goal].get<double>(),
                        met.get<bool>() ? "met" : "not met");
        }
        std::printf("\n");
    }
    std::printf("device: %s, %ux%u, %zu frames", out["device"].get<std::string>().c_str(),
                c.o.width, c.o.height, c.o.cameras.size());
    if (c.o.rounds > 1) {
        std::printf(" x %u rounds (full/lod by round:", c.o.rounds);
        for (const auto& r : out["round_ratios"])
            if (r.contains("full_over_lod")) std::printf(" %.2f", r["full_over_lod"].get<double>());
        std::printf(")");
    }
    if (c.o.paceMs > 0)
        std::printf(", paced every %g ms (frame time: each frame's own)", c.o.paceMs);
    std::printf("\n");
    if (!jsonFile.empty()) {
        if (!format::writeFileAtomically(jsonFile, jsonText(out, 2) + "\n", output, error)) {
            std::fprintf(stderr, "unilod bench: error: %s\n", error.c_str());
            return 1;
        }
        std::printf("json: %s\n", jsonFile.c_str());
    }
    return 0;
}

}  // namespace

void addBenchCommand(CLI::App& app, int& exitCode) {
    auto c = std::make_shared<BenchCli>();
    CLI::App* sub = app.add_subcommand(
        "bench",
        "Frame-time benchmark along a camera path (paper §4.2.3): streamed LOD vs "
        "everything resident, a bare pipeline and full resolution; prints a table, or "
        "JSON with --json; -o writes the JSON to a file");
    sub->add_option("FILE", c->o.path, ".ulod file")->required();
    sub->add_option("--path", c->cameraPath,
                    "camera path JSON (as for capture; default: a fly-over of the data)");
    sub->add_option("--frames", c->frames, "measured frames per run (default 200)")
        ->transform(integerIn(1, 100000));
    sub->add_option("--warmup", c->o.warmup,
                    "unmeasured frames on the first camera before each run, at least (default 5)")
        ->transform(integerIn(0, 100000));
    sub->add_option("--warmup-ms", c->o.warmupMs,
                    "and at least this wall time of warm-up frames, so that a GPU idle before "
                    "the run (a preload) reaches its working clock (default 500)")
        ->check(numberIn(0, 60000));
    sub->add_option("--pace-ms", c->o.paceMs,
                    "start frame i no earlier than i * MS into each run and wait for each frame: "
                    "the loader streams between frames as under a display's refresh (16.7 for "
                    "60 Hz), and a frame's time is its own cost (default 0: unpaced, frames back "
                    "to back)")
        ->check(numberIn(0, 10000));
    c->engine.add(*sub, "1920x1080");
    // Every item one of the four: an empty list or item ("", "lod,") is refused, not skipped.
    c->runsOption =
        sub->add_option("--runs", c->runs,
                        "comma-separated runs: lod, resident, bare, full (default: these four), "
                        "tin (the best known method's frames: each frame's view-dependent "
                        "greedy TIN of the whole model, every point on screen within its own "
                        "P-pixel bound; built before the run: about 0.1 s a frame at 144k "
                        "points, 20 s and 3.5 GB at 16M)")
            ->check(listOf(CLI::Validator(
                [](std::string& run) -> std::string {
                    if (run == "lod" || run == "resident" || run == "bare" || run == "full" ||
                        run == "tin")
                        return {};
                    return "unknown run '" + run + "' (lod, resident, bare, full, tin)";
                },
                "RUN")));
    sub->add_option("--rounds", c->o.rounds,
                    "repeat the runs in order this many times and pool each run's frames, so "
                    "that a slow phase of the machine falls on every run alike; the JSON keeps "
                    "each round's ratios (default 1)")
        ->transform(integerIn(1, 100));
    sub->add_flag("--per-frame", c->o.perFrame, "include every frame's numbers in the JSON");
    addOutputOptions(sub, c->output, "write the JSON to this file ('-': stdout)", false, true);
    addJsonOption(sub, c->json,
                  "print the JSON on stdout instead of the table ('-', the default; "
                  "--json FILE: the old spelling of -o FILE)",
                  true);
    addQuietFlag(sub, c->quiet);
    sub->callback([c, &exitCode] { exitCode = run(*c); });
}

}  // namespace unilod::cli
