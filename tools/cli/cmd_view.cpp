// `unilod view FILE [--camera x,y,z,yaw,pitch] [--size WxH] [--pixels P] [--metric M]
// [--distance nearest|centre] [--gpu-budget MiB] [--validation] [--device N] [--frames N]
// [--screenshot PATH] [--resize WxH] [--grid]`: roams a .ulod file in a window (engine/view.h). Malformed
// options are usage errors (exit 2); no display, no device, an unreadable file, a validation
// message or a failed screenshot are errors (exit 1).
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "commands.h"
#include "engineopts.h"
#include "numbers.h"
#include "outputopts.h"
#include "progress.h"
#include "view.h"

namespace unilod::cli {

namespace {

struct ViewCli {
    engine::ViewOptions o;
    EngineCli engine;
    std::string camera;  // --camera X,Y,Z,YAW,PITCH (checked while parsing)
    std::string resize;
    bool quiet = false;
    bool overwrite = false;  // --screenshot onto an existing file
};

int run(ViewCli& c) {
    if (!c.engine.apply(c.o.scene, c.o.device, c.o.width, c.o.height, "view")) return 2;
    if (!c.o.screenshotPath.empty() && c.o.frames == 0) {
        std::fprintf(stderr, "unilod view: error: --screenshot needs --frames N\n");
        return 2;
    }
    // The rules the screenshot is written under (existing file only with --overwrite, never the
    // input, an existing writable folder), checked before a window opens.
    std::string error;
    if (!c.o.screenshotPath.empty() &&
        !format::checkOutputPath(c.o.screenshotPath,
                                 outputOptions({c.o.screenshotPath, c.overwrite}, {c.o.path}),
                                 false, error)) {
        std::fprintf(stderr, "unilod view: error: %s\n", error.c_str());
        return 1;
    }
    if (!c.resize.empty() &&
        (c.o.frames == 0 || !parseSize(c.resize, c.o.resizeWidth, c.o.resizeHeight))) {
        std::fprintf(stderr, "unilod view: error: --resize '%s' needs --frames and WxH\n",
                     c.resize.c_str());
        return 2;
    }
    if (!c.camera.empty()) {
        bool direction = false;
        c.o.hasCamera = parseCamera(c.camera, false, c.o.camera, direction, error);
    }
    engine::ViewResult result;
    // The model's entries are read and validated before the first frame (seconds for a large
    // model): that, and nothing else, has a progress line.
    Progress progress("view", !c.quiet, "opening the model");
    c.o.scene.openProgress = [&](std::size_t done, std::size_t total) {
        progress.update(done, total);
        if (done == total) progress.finish();
    };
    const bool ok = engine::runView(c.o, result, error);
    progress.finish();
    if (!ok) {
        std::fprintf(stderr, "unilod view: error: %s\n",
                     errorForFile(c.o.path, error).c_str());
        return 1;
    }
    std::printf("%s: %llu frames on %s\n", c.o.path.c_str(),
                static_cast<unsigned long long>(result.frames), result.deviceName.c_str());
    return 0;
}

}  // namespace

void addViewCommand(CLI::App& app, int& exitCode) {
    auto c = std::make_shared<ViewCli>();
    CLI::App* sub = app.add_subcommand(
        "view",
        "Roam a .ulod file in a window: WASD + drag to look, wheel/Shift speed, +/- pixel "
        "tolerance, G grid, L rivers, P/F12 screenshot, Esc quit");
    sub->add_option("FILE", c->o.path, ".ulod file")->required();
    addCameraOption(*sub, c->camera,
                    "start eye x,y,z (file CRS, metres), yaw (0 = north, 90 = east), pitch "
                    "(< 0 down) in degrees (default: above the data, looking at its centre)");
    c->engine.add(*sub, "1280x720");
    sub->add_option("--frames", c->o.frames, "render N frames, then exit (default: until Esc)")
        ->transform(integerIn(1, 1000000000));
    sub->add_option("--screenshot", c->o.screenshotPath,
                    "with --frames: write the last frame to this PNG (rendering goes on, at most "
                    "30 s, until every block the view selects is loaded)")
        ->check(notStdout("view"));
    sub->add_flag("--overwrite", c->overwrite, "--screenshot: replace an existing PNG");
    sub->add_flag("--force", c->overwrite, "old spelling of --overwrite")->group("");
    sub->add_option("--resize", c->resize,
                    "with --frames: resize the window to WxH after half the frames (tests the "
                    "swapchain recreation)");
    sub->add_flag("--grid", c->o.grid, "start in the 2D grid mode (top-down wireframe)");
    sub->add_flag("--annotate", c->o.annotate,
                  "screenshots get a colour key (height, m), a scale bar and a north arrow");
    addQuietFlag(sub, c->quiet);  // drops the progress of opening the model
    sub->callback([c, &exitCode] { exitCode = run(*c); });
}

}  // namespace unilod::cli
