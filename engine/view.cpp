// The roaming viewer: input -> camera, one StreamingScene frame per window frame, stats once per
// second. Keys (README "unilod view"): WASD move, Q/E or Ctrl/Space down/up, hold a mouse button
// and drag to look, wheel = speed (Shift: x4 while held), +/- pixel tolerance P (x2 / /2),
// G grid mode, L river lines, P or F12 screenshot, Esc quits.
#include "view.h"

#define GLFW_INCLUDE_VULKAN
#include <GLFW/glfw3.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <optional>

#include "annotate.h"
#include "pngwrite.h"
#include "vkcheck.h"
#include "window.h"

namespace unilod::engine {

namespace {

constexpr double kDegree = 3.14159265358979323846 / 180.0;
constexpr double kLookDegreesPerPixel = 0.15;
constexpr double kMinPixels = 0.125, kMaxPixels = 64.0;

using Clock = std::chrono::steady_clock;

std::string formatStats(const FrameStats& s, double fps, double frameMs, double pixels,
                        bool grid) {
    char line[320];
    std::snprintf(line, sizeof line,
                  "%.1f fps, %.2f ms/frame, %llu triangles, blocks %u visible / %u resident / "
                  "%u fallback, GPU %.1f / %.1f MiB, P = %g px%s",
                  fps, frameMs, static_cast<unsigned long long>(s.triangles), s.visibleBlocks,
                  s.residentBlocks, s.fallbackBlocks, double(s.gpuBytesUsed) / (1 << 20),
                  double(s.gpuBudget) / (1 << 20), pixels, grid ? ", grid" : "");
    return line;
}

// Numbered screenshot in the current folder that does not exist yet.
std::string nextScreenshotPath() {
    for (int i = 0;; ++i) {
        char name[64];
        std::snprintf(name, sizeof name, "unilod_view_%04d.png", i);
        if (!std::filesystem::exists(name)) return name;
    }
}

// `annotate`: the frame's view, for the annotation (annotate.h); null: the plain image.
bool saveScreenshot(const Device& device, WindowTarget& target, const std::string& path,
                    const format::OutputOptions& output, const FrameView* annotate,
                    std::string& error) {
    std::uint32_t width = 0, height = 0;
    std::vector<std::uint8_t> rgba;
    if (!readWindowScreenshot(device, target, width, height, rgba, error)) {
        error = path + ": " + error;
        return false;
    }
    if (annotate) annotateImage(rgba, width, height, annotationFor(*annotate));
    return format::writePng(path, width, height, rgba, output, error);
}

// Metres from the view centre to the top edge in grid mode: what the perspective camera sees
// of the ground straight below it.
double gridHalfHeight(const Camera& camera, const format::Header& header) {
    const double height = std::max(camera.eye[2] - header.minZ, 1.0);
    return height * std::tan(camera.fovDegrees * kDegree / 2);
}

// Applies the held keys and mouse drags of `seconds` to the camera.
void moveCamera(GLFWwindow* w, double seconds, double speed, bool grid, Camera& camera,
                double cursor[2], bool& dragging) {
    double x = 0, y = 0;
    glfwGetCursorPos(w, &x, &y);
    const bool held = glfwGetMouseButton(w, GLFW_MOUSE_BUTTON_LEFT) == GLFW_PRESS ||
                      glfwGetMouseButton(w, GLFW_MOUSE_BUTTON_RIGHT) == GLFW_PRESS;
    if (held && dragging && !grid) {
        camera.yawDegrees = std::fmod(camera.yawDegrees + (x - cursor[0]) * kLookDegreesPerPixel,
                                      360.0);
        camera.pitchDegrees = std::clamp(
            camera.pitchDegrees - (y - cursor[1]) * kLookDegreesPerPixel, -89.0, 89.0);
    }
    dragging = held;
    cursor[0] = x;
    cursor[1] = y;

    auto down = [w](int key) { return glfwGetKey(w, key) == GLFW_PRESS; };
    if (down(GLFW_KEY_LEFT_SHIFT) || down(GLFW_KEY_RIGHT_SHIFT)) speed *= 4;
    const double step = speed * seconds;
    double forward[3], right[3];
    if (grid) {  // the grid view is north up: W is north, D is east
        forward[0] = 0, forward[1] = 1, forward[2] = 0;
        right[0] = 1, right[1] = 0, right[2] = 0;
    } else {
        const CameraBasis b = cameraBasis(camera);
        std::copy(b.forward, b.forward + 3, forward);
        std::copy(b.right, b.right + 3, right);
    }
    const double f = (down(GLFW_KEY_W) ? 1 : 0) - (down(GLFW_KEY_S) ? 1 : 0);
    const double r = (down(GLFW_KEY_D) ? 1 : 0) - (down(GLFW_KEY_A) ? 1 : 0);
    const double u = (down(GLFW_KEY_E) || down(GLFW_KEY_SPACE) ? 1 : 0) -
                     (down(GLFW_KEY_Q) || down(GLFW_KEY_LEFT_CONTROL) ? 1 : 0);
    for (int i = 0; i < 3; ++i)
        camera.eye[i] += step * (f * forward[i] + r * right[i]);
    camera.eye[2] += step * u;
}

}  // namespace

Camera defaultViewCamera(const format::Header& header, double fovDegrees) {
    const double cx = (header.minX + header.maxX) / 2, cy = (header.minY + header.maxY) / 2;
    const double dy = header.maxY - header.minY;
    const double extent = std::max(header.maxX - header.minX, dy);
    Camera camera;
    camera.fovDegrees = fovDegrees;
    camera.eye[0] = cx;
    camera.eye[1] = cy - 0.6 * dy;
    camera.eye[2] = header.maxZ + 0.4 * extent;
    camera.yawDegrees = 0;
    const double midZ = (header.minZ + header.maxZ) / 2;
    camera.pitchDegrees = -std::atan2(camera.eye[2] - midZ, 0.6 * dy) / kDegree;
    return camera;
}

bool runView(const ViewOptions& options, ViewResult& result, std::string& error) {
    Window window;
    if (!createWindow(options.width, options.height, "unilod view - " + options.path, window,
                      error))
        return false;
    DeviceOptions deviceOptions = options.device;
    addPresentation(window, deviceOptions);
    Device device;
    if (!createDevice(deviceOptions, device, error)) {
        destroyWindow(window);
        return false;
    }
    result.deviceName = device.properties.deviceName;

    SceneOptions sceneOptions = options.scene;
    StreamingScene scene;
    WindowTarget target;
    Pipelines pipelines;
    const bool opened = scene.open(device, options.path, sceneOptions, error);
    bool ok = opened && createWindowTarget(device, window, target, error) &&
              createPipelines(device, target.renderPass, spirvDirectory(""), pipelines, error);

    const format::Header header = opened ? scene.header() : format::Header{};
    Camera camera = options.hasCamera ? options.camera : defaultViewCamera(header, 60.0);
    bool grid = options.grid, rivers = true;
    if (grid && !options.hasCamera) {
        // Starting in grid mode: the map of the whole data set, centred.
        camera.eye[0] = (header.minX + header.maxX) / 2;
        camera.eye[1] = (header.minY + header.maxY) / 2;
        const double half = 0.55 * std::max(header.maxY - header.minY,
                                            (header.maxX - header.minX) * options.height /
                                                std::max(options.width, 1u));
        camera.eye[2] = header.minZ + half / std::tan(camera.fovDegrees * kDegree / 2);
    }
    double speed = std::max(header.maxX - header.minX, header.maxY - header.minY) / 10;
    if (!(speed > 0)) speed = 100;
    double cursor[2] = {0, 0};
    bool dragging = false;

    std::uint64_t frame = 0;
    std::optional<Clock::time_point> waitStart;  // when the frame count was reached
    bool resizeRequested = false;
    double lastPixels = sceneOptions.pixels;
    std::uint64_t secondFrames = 0;
    Clock::time_point secondStart = Clock::now(), last = secondStart;
    const Clock::time_point runStart = secondStart;
    std::string lastStats;
    auto report = [&](double seconds, std::uint64_t frames) {
        const double fps = seconds > 0 ? double(frames) / seconds : 0;
        lastStats = formatStats(scene.stats(), fps, frames ? 1000 * seconds / double(frames) : 0,
                                sceneOptions.pixels, grid);
        std::printf("%s\n", lastStats.c_str());
        std::fflush(stdout);
        glfwSetWindowTitle(window.window, ("unilod view - " + options.path + " - " + lastStats).c_str());
    };

    while (ok && !glfwWindowShouldClose(window.window)) {
        glfwPollEvents();
        const Clock::time_point now = Clock::now();
        const double seconds = std::chrono::duration<double>(now - last).count();
        last = now;

        bool screenshot = false;
        for (int key : window.keyPresses) {
            switch (key) {
                case GLFW_KEY_ESCAPE:
                    glfwSetWindowShouldClose(window.window, GLFW_TRUE);
                    break;
                case GLFW_KEY_G:
                    grid = !grid;
                    break;
                case GLFW_KEY_L:
                    rivers = !rivers;
                    break;
                case GLFW_KEY_EQUAL:  // '+' is Shift + '=' on most layouts
                case GLFW_KEY_KP_ADD:
                    if (sceneOptions.pixels * 2 <= kMaxPixels) {
                        sceneOptions.pixels *= 2;
                        scene.setPixels(sceneOptions.pixels);
                    }
                    break;
                case GLFW_KEY_MINUS:
                case GLFW_KEY_KP_SUBTRACT:
                    if (sceneOptions.pixels / 2 >= kMinPixels) {
                        sceneOptions.pixels /= 2;
                        scene.setPixels(sceneOptions.pixels);
                    }
                    break;
                case GLFW_KEY_P:
                case GLFW_KEY_F12:
                    screenshot = true;
                    break;
                default:
                    break;
            }
        }
        if (window.keyPresses.size() && sceneOptions.pixels != lastPixels) {
            std::printf("pixel tolerance P = %g px\n", sceneOptions.pixels);
            lastPixels = sceneOptions.pixels;
        }
        window.keyPresses.clear();
        speed *= std::pow(1.25, window.scroll);
        window.scroll = 0;
        if (options.resizeWidth > 0 && options.frames > 0 && frame == options.frames / 2 &&
            !resizeRequested) {
            glfwSetWindowSize(window.window, int(options.resizeWidth), int(options.resizeHeight));
            resizeRequested = true;
        }
        moveCamera(window.window, seconds, speed, grid, camera, cursor, dragging);

        int fbWidth = 0, fbHeight = 0;
        glfwGetFramebufferSize(window.window, &fbWidth, &fbHeight);
        if (fbWidth == 0 || fbHeight == 0) {  // minimised: draw nothing until restored
            glfwWaitEvents();
            continue;
        }
        VkCommandBuffer cmd = VK_NULL_HANDLE;
        if (!beginWindowFrame(device, target, frame, cmd)) continue;  // swapchain recreated

        FrameView view;
        view.camera = camera;
        view.width = target.swapchain.extent.width;
        view.height = target.swapchain.extent.height;
        view.grid = grid;
        view.gridHalfHeight = gridHalfHeight(camera, header);
        view.rivers = rivers;
        view.minZ = header.minZ;
        view.maxZ = header.maxZ;
        std::string prepareError;
        if (!scene.prepare(cmd, frame, completedWindowFrame(device, target), view, prepareError))
            std::fprintf(stderr, "unilod view: warning: %s: %s\n", options.path.c_str(),
                         prepareError.c_str());
        const bool settled = scene.settled();  // this frame draws the view's final selection
        beginWindowPass(target, cmd);
        scene.draw(cmd, pipelines, view);
        vkCmdEndRenderPass(cmd);

        ++frame;
        // With --screenshot the last frame is the first from the frame count on that draws the
        // view settled (every block it selects resident, as capture waits for), for at most 30 s
        // more: the picture then does not depend on how fast the blocks streamed in.
        const bool counted = options.frames > 0 && frame >= options.frames;
        if (counted && !waitStart) waitStart = Clock::now();
        const bool lastFrame =
            counted && (options.screenshotPath.empty() || settled ||
                        std::chrono::duration<double>(Clock::now() - *waitStart).count() > 30);
        const bool finalShot = lastFrame && !options.screenshotPath.empty();
        endWindowFrame(device, target, screenshot || finalShot);
        if (screenshot || finalShot) {
            const std::string path = finalShot ? options.screenshotPath : nextScreenshotPath();
            std::string shotError;
            // --screenshot replaces its file; a numbered one never replaces another view's.
            format::OutputOptions output;
            output.replace = finalShot;
            output.inputs = {options.path};
            if (saveScreenshot(device, target, path, output,
                               options.annotate ? &view : nullptr, shotError)) {
                std::printf("screenshot %s (%ux%u)\n", path.c_str(),
                            target.swapchain.extent.width, target.swapchain.extent.height);
            } else if (finalShot) {
                error = shotError;
                ok = false;
            } else {
                std::fprintf(stderr, "unilod view: screenshot failed: %s\n", shotError.c_str());
            }
        }

        ++secondFrames;
        const double secondElapsed = std::chrono::duration<double>(Clock::now() - secondStart).count();
        if (secondElapsed >= 1.0) {
            report(secondElapsed, secondFrames);
            secondFrames = 0;
            secondStart = Clock::now();
        }
        if (lastFrame) break;
    }

    VK_CHECK(vkDeviceWaitIdle(device.device));
    result.frames = frame;
    if (ok && frame > 0) {  // the whole run, so short runs (--frames) report too
        report(std::chrono::duration<double>(Clock::now() - runStart).count(), frame);
    }
    destroyPipelines(device, pipelines);
    destroyWindowTarget(device, target);
    scene.close();
    const std::vector<std::string> messages = validationMessages(device);
    destroyDevice(device);
    destroyWindow(window);
    if (ok && !messages.empty()) {
        error = std::to_string(messages.size()) + " validation message(s), the first: " +
                messages.front();
        ok = false;
    }
    return ok;
}

}  // namespace unilod::engine
