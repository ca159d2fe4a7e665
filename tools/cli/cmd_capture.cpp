// `unilod capture FILE [--camera x,y,z,yaw,pitch | --path PATH.json] [--frames N] [--size WxH]
// [--pixels P] ... -o DIR`: headless frames of a .ulod file with the streamed per-block LOD
// (engine/capture.h), written as DIR/frame_NNNN.png + .json. Malformed options (a --camera value
// out of range too) are usage errors (exit 2); an unreadable file, a camera path out of range or
// no Vulkan device are data errors (1), and
// so is a DIR that is not empty without --overwrite (outputopts.h; with it the frames replace
// those of the same names, other files stay).
#include <cstdio>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "capture.h"
#include "commands.h"
#include "engineopts.h"
#include "numbers.h"
#include "outputopts.h"
#include "progress.h"

namespace unilod::cli {

namespace {

struct CaptureCli {
    engine::CaptureOptions o;
    OutputFlags output;
    EngineCli engine;
    std::string camera;  // --camera X,Y,Z,YAW,PITCH (checked while parsing)
    std::string cameraPath;
    std::uint32_t frames = 0;
    double fov = 60;
    bool noSettle = false;
    bool quiet = false;
};

int run(CaptureCli& c) {
    if (!c.engine.apply(c.o.scene, c.o.device, c.o.width, c.o.height, "capture")) return 2;
    if (!c.camera.empty() && !c.cameraPath.empty()) {
        std::fprintf(stderr, "unilod capture: error: give one of --camera and --path, not both\n");
        return 2;
    }
    std::string error;
    c.o.outDir = c.output.path;
    if (!checkOutput(c.output, OutputKind::Folder, error)) {
        std::fprintf(stderr, "unilod capture: error: %s\n", error.c_str());
        return 1;
    }
    engine::CameraPath path;
    if (!c.camera.empty()) {
        engine::Camera cam;
        bool direction = false;
        parseCamera(c.camera, false, cam, direction, error);  // checked while parsing
        cam.fovDegrees = c.fov;
        path.keyframes.push_back(cam);
    } else if (c.cameraPath.empty()) {
        // Neither: an overview of the whole model (engine::defaultOverview).
        engine::Camera overview;
        if (!defaultCamera(c.o.path, overview, error)) {
            std::fprintf(stderr, "unilod capture: error: %s\n", error.c_str());
            return 1;
        }
        path.keyframes.push_back(overview);
    } else if (!engine::loadCameraPath(c.cameraPath, path, error)) {
        std::fprintf(stderr, "unilod capture: error: %s\n", error.c_str());
        return 1;
    } else {
        c.o.inputs.push_back(c.cameraPath);
    }
    const std::uint32_t frames =
        c.frames ? c.frames : std::uint32_t(path.keyframes.size());
    c.o.cameras = engine::sampleCameraPath(path, frames);
    c.o.settle = !c.noSettle;
    engine::CaptureResult result;
    // Opening the model (entries read of all), then rendering: the engine renders all frames,
    // then writes them, no count to report.
    const std::string rendering = "rendering " + std::to_string(c.o.cameras.size()) + " frame" +
                                  (c.o.cameras.size() == 1 ? "" : "s");
    Progress progress("capture", !c.quiet, "opening the model");
    c.o.scene.openProgress = [&](std::size_t done, std::size_t total) {
        if (done < total)
            progress.update(done, total);
        else
            progress.stage(rendering);
    };
    const bool ok = engine::runCapture(c.o, result, error);
    progress.finish();
    if (!ok) {
        std::fprintf(stderr, "unilod capture: error: %s\n",
                     errorForFile(c.o.path, error).c_str());
        return 1;
    }
    for (const engine::CaptureFrame& f : result.frames) {
        std::printf("%s: %u of %u blocks drawn (%u not yet resident), %llu triangles, %llu river "
                    "edges, GPU %.1f / %.1f MiB -> %s\n",
                    c.o.path.c_str(), f.stats.visibleBlocks, f.stats.blocks, f.stats.fallbackBlocks,
                    static_cast<unsigned long long>(f.stats.triangles),
                    static_cast<unsigned long long>(f.stats.riverEdges),
                    double(f.stats.gpuBytesUsed) / 1048576.0,
                    double(f.stats.gpuBudget) / 1048576.0, f.pngPath.c_str());
    }
    std::printf("device: %s\n", result.deviceName.c_str());
    return 0;
}

}  // namespace

void addCaptureCommand(CLI::App& app, int& exitCode) {
    auto c = std::make_shared<CaptureCli>();
    CLI::App* sub = app.add_subcommand(
        "capture", "Render frames of a .ulod file headless (Vulkan) to PNG + JSON");
    sub->add_option("FILE", c->o.path, ".ulod file")->required();
    CLI::Option* camera = addCameraOption(
        *sub, c->camera,
        "eye x,y,z (file CRS, metres), yaw (0 = north, 90 = east), pitch (< 0 down) "
        "in degrees (default, without --path: the whole model seen from the south)");
    sub->add_option("--path", c->cameraPath,
                    "camera path JSON: {\"fov\": 60, \"keyframes\": [{\"eye\": [x, y, z], "
                    "\"yaw\": d, \"pitch\": d}, ...]}");
    sub->add_option("--frames", c->frames,
                    "frames to render (default: one per keyframe; sampled evenly along the path)")
        ->transform(integerIn(1, 100000));
    // Only with --camera: a --path has its own "fov", the default view its 60 degrees.
    sub->add_option("--fov", c->fov, "vertical field of view in degrees with --camera (default 60)")
        ->check(fovRange())
        ->needs(camera);
    c->engine.add(*sub, "1024x768");
    sub->add_flag("--grid", c->o.grid,
                  "2D grid mode: top-down orthographic wireframe, river edges highlighted");
    sub->add_flag("--annotate", c->o.annotate,
                  "draw a colour key (height, m), a scale bar and a north arrow on each frame; the "
                  "JSON records where");
    sub->add_flag("--no-settle", c->noSettle,
                  "draw each frame with what is resident (default: wait until the blocks the "
                  "view wants are loaded, so the output is deterministic)");
    addOutputOptions(sub, c->output,
                     "output folder (frame_NNNN.png, frame_NNNN.json; created when missing)");
    addQuietFlag(sub, c->quiet);
    sub->callback([c, &exitCode] { exitCode = run(*c); });
}

}  // namespace unilod::cli
