// `unilod capture FILE --camera x,y,z,yaw,pitch [--size WxH] [--pixels P] [--fov DEG] --out DIR`:
// one headless frame of a .ulod file with per-block LOD (engine/capture.h), written as
// DIR/frame_0000.png and DIR/frame_0000.json. Malformed options are usage errors (exit 2);
// an unreadable file, a camera out of range or no Vulkan device are data errors (exit 1).
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "capture.h"
#include "commands.h"

namespace unilod::cli {

namespace {

struct CaptureCli {
    engine::CaptureOptions o;
    std::vector<double> camera;
    std::string size = "1024x768";
    std::string distance = "nearest";
};

bool parseSize(const std::string& s, std::uint32_t& w, std::uint32_t& h) {
    unsigned long a = 0, b = 0;
    char tail = 0;
    if (std::sscanf(s.c_str(), "%lux%lu%c", &a, &b, &tail) != 2) return false;
    if (a == 0 || b == 0 || a > 16384 || b > 16384) return false;
    w = std::uint32_t(a);
    h = std::uint32_t(b);
    return true;
}

int run(CaptureCli& c) {
    if (!parseSize(c.size, c.o.width, c.o.height)) {
        std::fprintf(stderr, "unilod capture: error: --size '%s' is not WxH (1..16384)\n",
                     c.size.c_str());
        return 2;
    }
    c.o.distance =
        c.distance == "centre" ? engine::DistanceMode::Centre : engine::DistanceMode::Nearest;
    for (int i = 0; i < 3; ++i)
        c.o.camera.eye[i] = c.camera[std::size_t(i)];
    c.o.camera.yawDegrees = c.camera[3];
    c.o.camera.pitchDegrees = c.camera[4];
    engine::CaptureResult result;
    std::string error;
    if (!engine::runCapture(c.o, result, error)) {
        std::fprintf(stderr, "unilod capture: error: %s: %s\n", c.o.path.c_str(), error.c_str());
        return 1;
    }
    std::printf("%s: %zu blocks, %llu triangles, %llu river edges on %s -> %s\n", c.o.path.c_str(),
                result.blocks.size(), static_cast<unsigned long long>(result.triangles),
                static_cast<unsigned long long>(result.riverEdges), result.deviceName.c_str(),
                result.pngPath.c_str());
    return 0;
}

}  // namespace

void addCaptureCommand(CLI::App& app, int& exitCode) {
    auto c = std::make_shared<CaptureCli>();
    CLI::App* sub = app.add_subcommand(
        "capture", "render one frame of a .ulod file headless (Vulkan) to PNG + JSON");
    sub->add_option("FILE", c->o.path, ".ulod file")->required();
    sub->add_option("--camera", c->camera,
                    "eye x,y,z (file CRS, metres), yaw (0 = north, 90 = east), pitch (< 0 down) "
                    "in degrees")
        ->required()
        ->delimiter(',')
        ->expected(5);
    sub->add_option("--size", c->size, "image size WxH (default 1024x768)");
    sub->add_option("--pixels", c->o.pixels, "screen-space error tolerance P in pixels (default 1)")
        ->check(CLI::PositiveNumber);
    sub->add_option("--fov", c->o.camera.fovDegrees,
                    "vertical field of view in degrees (default 60)")
        ->check(CLI::Range(1.0, 179.0));
    sub->add_option("--metric", c->o.metric, "error metric (default: the file's)")
        ->check(CLI::IsMember({"max", "paper"}));
    sub->add_option("--distance", c->distance,
                    "S for h_lim: nearest (nearest point of the block's box, scaled so the P-pixel "
                    "bound holds over the whole view; default) or centre (the paper's block centre)")
        ->check(CLI::IsMember({"nearest", "centre"}));
    sub->add_option("--out", c->o.outDir, "output folder (frame_0000.png, frame_0000.json)")
        ->required();
    sub->add_flag("--validation", c->o.device.validation,
                  "enable the Vulkan validation layer; any warning or error fails the capture");
    sub->add_option("--device", c->o.device.deviceIndex,
                    "Vulkan physical device index (default: $UNILOD_DEVICE, else the best)")
        ->check(CLI::NonNegativeNumber);
    sub->callback([c, &exitCode] { exitCode = run(*c); });
}

}  // namespace unilod::cli
