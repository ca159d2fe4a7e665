#include "engineopts.h"

#include <cstdio>

#include "campath.h"
#include "numbers.h"
#include "ulod.h"
#include "workers.h"

namespace unilod::cli {

namespace {
// Debug builds validate by default (when the layer is installed); optimised builds on request.
#ifdef NDEBUG
constexpr bool kValidateByDefault = false;
#else
constexpr bool kValidateByDefault = true;
#endif
}  // namespace

bool parseSize(const std::string& s, std::uint32_t& w, std::uint32_t& h) {
    // Decimal digits on both sides of one 'x' (sscanf's %lu took spaces, signs and "640x480junk"
    // was caught only by the tail check).
    const std::size_t x = s.find('x');
    if (x == std::string::npos) return false;
    std::uint32_t side[2] = {0, 0};
    const std::string parts[2] = {s.substr(0, x), s.substr(x + 1)};
    for (int i = 0; i < 2; ++i) {
        if (parts[i].empty() || parts[i].size() > 5) return false;
        for (const char ch : parts[i]) {
            if (ch < '0' || ch > '9') return false;
            side[i] = side[i] * 10 + std::uint32_t(ch - '0');
        }
        if (side[i] == 0 || side[i] > 16384) return false;
    }
    w = side[0];
    h = side[1];
    return true;
}

bool parseCamera(const std::string& text, bool positionOnly, engine::Camera& camera,
                 bool& hasDirection, std::string& error) {
    static const char* const names[] = {"x", "y", "z", "yaw", "pitch"};
    const std::vector<std::string> items = splitList(text);
    if (items.size() != 5 && !(positionOnly && items.size() == 3)) {
        error = "'" + text + "' is not " + (positionOnly ? "X,Y,Z or " : "") + "X,Y,Z,YAW,PITCH (" +
                std::to_string(items.size()) + " values)";
        return false;
    }
    double v[5] = {};
    for (std::size_t i = 0; i < items.size(); ++i) {
        if (!parseFinite(items[i], v[i])) {
            error = std::string(names[i]) + " '" + items[i] + "' is not a finite number";
            return false;
        }
    }
    hasDirection = items.size() == 5;
    if (hasDirection && !(v[4] >= -90 && v[4] <= 90)) {
        error = "pitch '" + items[4] + "' must be in [-90, 90]";
        return false;
    }
    for (int i = 0; i < 3; ++i)
        camera.eye[i] = v[i];
    camera.yawDegrees = v[3];
    camera.pitchDegrees = v[4];
    return true;
}

CLI::Option* addCameraOption(CLI::App& sub, std::string& text, const std::string& help,
                             bool positionOnly) {
    return sub.add_option("--camera", text, help)
        ->check(CLI::Validator(
            [positionOnly](std::string& value) -> std::string {
                engine::Camera camera;
                bool direction = false;
                std::string error;
                return parseCamera(value, positionOnly, camera, direction, error) ? "" : error;
            },
            positionOnly ? "X,Y,Z[,YAW,PITCH]" : "X,Y,Z,YAW,PITCH"));
}

CLI::Option* addMetricOption(CLI::App& sub, std::string& metric) {
    return sub
        .add_option("--metric", metric,
                    "error metric: max (a bound of the distance to every original point) or "
                    "paper (the paper's mean nearest-point error); default: the file's, as "
                    "built (`build --metric`)")
        ->check(CLI::IsMember({"max", "paper"}));
}

std::uint32_t metricOf(const std::string& metric) {
    std::uint32_t code = 0;
    format::metricOfName(metric, code);
    return code;
}

CLI::Validator fovRange() {
    return numberIn(0, 180, Bound::Open, Bound::Open);
}

bool defaultCamera(const std::string& path, engine::Camera& camera, std::string& error) {
    format::Reader reader;
    if (!reader.open(path, error)) {
        error = errorForFile(path, error);
        return false;
    }
    camera = engine::defaultOverview(reader.header());
    if (!engine::validCamera(camera)) {
        error = path + ": the model's extent (header) gives no valid default view; give --camera";
        return false;
    }
    return true;
}

void EngineCli::add(CLI::App& sub, const std::string& defaultSize) {
    size = defaultSize;
    sub.add_option("--size", size, "image size WxH (default " + defaultSize + ")");
    sub.add_option("--pixels", pixels, "screen-space error tolerance P in pixels (default 1)")
        ->check(positive());
    addMetricOption(sub, metric);
    sub.add_option("--distance", distance,
                   "S for h_lim: nearest (nearest point of the block's box, made safe for the "
                   "whole view so that the P-pixel bound holds; default) or centre (the paper's "
                   "block centre)")
        ->check(CLI::IsMember({"nearest", "centre"}));
    sub.add_flag("--no-refine", noRefine,
                 "draw every block at a stored level (the paper's per-block levels) instead of "
                 "refining the leaves for the view from their deletion records");
    sub.add_option("--threads", threads,
                   "CPU threads that read the model's entries and refine a frame's entries "
                   "(default 0: every core, at most 16; the image is the same for any count)")
        ->transform(integerIn(0, engine::WorkerPool::kMaxThreads));
    sub.add_option("--gpu-budget", gpuBudgetMiB,
                   "device memory for block geometry in MiB (default " +
                       std::to_string(engine::kDefaultGpuBudget >> 20) +
                       "); must hold every block's coarsest level")
        ->check(numberIn(0, double(engine::kMaxGpuBudget >> 20), Bound::Open));
    CLI::Option* on = sub.add_flag(
        "--validation", validation,
        std::string("enable the Vulkan validation layer; any warning or error fails the command "
                    "(default: ") +
            (kValidateByDefault ? "on in this debug build when the layer is installed)"
                                : "off in this optimised build)"));
    CLI::Option* off = sub.add_flag("--no-validation", noValidation, "disable validation");
    on->excludes(off);
    off->excludes(on);
    sub.add_option("--device", device,
                   "Vulkan physical device index (default: $UNILOD_DEVICE, else the best)")
        ->transform(integerIn(0, 1 << 20));
}

bool EngineCli::apply(engine::SceneOptions& scene, engine::DeviceOptions& dev, std::uint32_t& width,
                      std::uint32_t& height, const char* command) const {
    if (!parseSize(size, width, height)) {
        std::fprintf(stderr, "unilod %s: error: --size '%s' is not WxH (1..16384)\n", command,
                     size.c_str());
        return false;
    }
    scene.pixels = pixels;
    scene.refine = !noRefine;
    scene.threads = threads;
    scene.metric = metric;
    scene.distance =
        distance == "centre" ? engine::DistanceMode::Centre : engine::DistanceMode::Nearest;
    scene.gpuBudget = std::uint64_t(gpuBudgetMiB * 1048576.0);
    dev.validation = validation || (kValidateByDefault && !noValidation);
    dev.validationOptional = !validation;
    dev.deviceIndex = device;
    return true;
}

}  // namespace unilod::cli
