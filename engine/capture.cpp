#include "capture.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <thread>
#include <nlohmann/json.hpp>

#include "headless.h"
#include "jsontext.h"
#include "pngwrite.h"

namespace unilod::engine {

namespace {

constexpr double kDegree = 3.14159265358979323846 / 180.0;

nlohmann::json rectJson(const PixelRect& r) { return {r.x, r.y, r.width, r.height}; }

// What annotate drew, where (pixels: [x, y, width, height], y down from the top row).
nlohmann::json annotationJson(const Annotation& a, const AnnotationLayout& l) {
    nlohmann::json regions = nlohmann::json::array();
    for (const PixelRect& r : l.regions)
        regions.push_back(rectJson(r));
    nlohmann::json j = {{"regions", regions}};
    if (a.colourKey) {
        j["colour_key"] = {{"bar", rectJson(l.keyBar)},
                           {"min_z", a.keyMinZ},
                           {"max_z", a.keyMaxZ},
                           {"ramp", "shaders/shared.h hypsometricTint, unshaded; top row max_z"}};
    }
    if (l.scalePixels > 0) {
        j["scale_bar"] = {{"metres", l.scaleMetres},
                          {"pixels", l.scalePixels},
                          {"metres_per_pixel", a.metresPerPixel},
                          {"exact", a.scaleExact},
                          {"where", a.scaleExact ? "everywhere (orthographic)" : "image centre"}};
    }
    if (a.northArrow) {
        j["north_arrow"] = {{"degrees_clockwise_from_up", l.northDegrees},
                            {"along_view", a.northAlongView}};
    }
    return j;
}

nlohmann::json frameJson(const CaptureOptions& options, const Camera& c, const CaptureFrame& f,
                         std::uint32_t metric, const std::string& deviceName) {
    nlohmann::json blocks = nlohmann::json::array();
    for (const BlockSelection& b : f.blocks) {
        blocks.push_back(
            {{"index", b.block},
             {"col", b.col},
             {"row", b.row},
             {"tree_level", b.treeLevel},
             {"level", b.drawnLevel},
             {"drawn_block", b.drawnBlock},
             {"wanted_level", b.wanted.level},
             {"fallback", b.fallback},
             {"step", b.wanted.step},
             {"S", b.distance},
             {"min_depth", b.box.minDepth},
             {"axis_cos", b.box.axisCos},
             {"vertical_sin", b.box.verticalSin},
             {"rivers", b.box.horizontal},
             {"h_lim", b.hLim},
             {"h_lim_river",
              std::isfinite(b.hLimRiver) ? nlohmann::json(b.hLimRiver) : nlohmann::json()},
             {"h_s", b.wanted.error},
             {"h_s_river", b.wanted.riverError},
             {"next_level_error",
              b.wanted.nextError < 0 ? nlohmann::json() : nlohmann::json(b.wanted.nextError)},
             {"refined", b.refined},
             {"steps_done", b.stepsDone},
             {"triangles", b.triangles},
             {"river_edges", b.riverEdges}});
    }
    nlohmann::json annotation;  // null: the image is the plain render
    if (f.annotated) annotation = annotationJson(f.annotation, f.annotationLayout);
    const bool nearest = options.scene.distance == DistanceMode::Nearest;
    return {
        {"file", options.path},
        {"device", deviceName},
        {"size", {options.width, options.height}},
        {"camera",
         {{"eye", {c.eye[0], c.eye[1], c.eye[2]}},
          {"yaw", c.yawDegrees},
          {"pitch", c.pitchDegrees},
          {"fov", c.fovDegrees}}},
        {"mode", options.grid ? "grid" : "perspective"},
        {"annotated", f.annotated},
        {"annotation", annotation},
        {"pixels", options.scene.pixels},
        {"metric", format::metricName(metric)},
        {"distance", nearest ? "nearest" : "centre"},
        {"edge_factor",
         nearest ? frustumEdgeFactor(c.fovDegrees * kDegree, double(options.width) / options.height)
                 : 1.0},
        {"blocks", blocks},
        {"totals",
         {{"blocks_in_file", f.stats.blocks},
          {"blocks_drawn", f.stats.visibleBlocks},
          {"fallback_blocks", f.stats.fallbackBlocks},
          {"resident_blocks", f.stats.residentBlocks},
          {"triangles", f.stats.triangles},
          {"river_edges", f.stats.riverEdges},
          {"gpu_bytes_used", f.stats.gpuBytesUsed},
          {"gpu_budget", f.stats.gpuBudget},
          {"coarse_bytes", f.stats.coarseBytes}}},
    };
}

}  // namespace

double gridHalfHeight(const Camera& camera, double maxZ) {
    const double height = std::max(camera.eye[2] - maxZ, 1.0);
    return height * std::tan(camera.fovDegrees * kDegree / 2.0);
}

bool runCapture(const CaptureOptions& options, CaptureResult& result, std::string& error) {
    if (options.cameras.empty()) {
        error = "no camera";
        return false;
    }
    for (const Camera& c : options.cameras) {
        if (!validCamera(c)) {
            error = "invalid camera (finite x, y, z, yaw; pitch in [-90, 90]; fov in (0, 180))";
            return false;
        }
    }
    if (options.width == 0 || options.height == 0 || options.width > 16384 ||
        options.height > 16384 || !(options.scene.pixels > 0)) {
        error = "invalid size or pixel tolerance";
        return false;
    }

    HeadlessOptions ho;
    ho.path = options.path;
    ho.width = options.width;
    ho.height = options.height;
    ho.scene = options.scene;
    ho.device = options.device;
    ho.spirvDir = options.spirvDir;
    HeadlessRenderer renderer;
    std::vector<std::vector<std::uint8_t>> images;
    bool ok = renderer.open(ho, error);
    if (ok) {
        result.deviceName = renderer.device().properties.deviceName;
        for (const Camera& camera : options.cameras) {
            FrameView view = renderer.view(camera);
            view.grid = options.grid;
            view.rivers = options.rivers;
            if (options.grid) view.gridHalfHeight = gridHalfHeight(camera, view.maxZ);
            // Settling: upload-only frames until the loads this view asks for are resident
            // (or refused by the budget). A bounded loop: each round either uploads, or the
            // loader is reading, or nothing is pending.
            if (options.settle) {
                for (int round = 0; round < 100000 && ok; ++round) {
                    ok = renderer.renderFrame(view, false, nullptr, error);
                    renderer.finish();
                    if (renderer.scene().settled()) break;
                    std::this_thread::yield();
                }
            }
            std::vector<std::uint8_t> rgba;
            if (ok) ok = renderer.renderFrame(view, true, &rgba, error);
            if (!ok) break;
            CaptureFrame frame;
            if (options.annotate) {
                frame.annotated = true;
                frame.annotation = annotationFor(view);
                annotateImage(rgba, options.width, options.height, frame.annotation,
                              &frame.annotationLayout);
            }
            frame.blocks = renderer.scene().selection();
            frame.stats = renderer.scene().stats();
            result.frames.push_back(std::move(frame));
            images.push_back(std::move(rgba));
        }
    }
    const std::uint32_t metric = ok ? renderer.scene().metric() : 0;
    const std::vector<std::string> messages = renderer.close();
    if (!ok) return false;
    if (!messages.empty()) {
        error = std::to_string(messages.size()) +
                " Vulkan validation message(s) (first: " + messages.front() + ")";
        return false;
    }

    std::error_code ec;
    const bool created = std::filesystem::create_directories(options.outDir, ec);
    if (ec) {
        error = options.outDir + ": cannot create the output folder: " + ec.message();
        return false;
    }
    // A folder this run created goes again when nothing could be written into it.
    struct RemoveCreated {
        std::string dir;
        bool keep = false;
        ~RemoveCreated() {
            std::error_code ignored;
            if (!keep && !dir.empty()) std::filesystem::remove(dir, ignored);  // only if empty
        }
    } removeCreated{created ? options.outDir : std::string()};
    const std::filesystem::path dir(options.outDir);
    // Frames replace those of an earlier capture, never a file this run read; all of them or
    // none (a failure leaves the old frames as they were: AtomicFileSet).
    format::OutputOptions output;
    output.replace = true;
    output.inputs = options.inputs;
    output.inputs.push_back(options.path);
    format::AtomicFileSet files;
    std::string png;
    for (std::size_t i = 0; i < result.frames.size(); ++i) {
        CaptureFrame& f = result.frames[i];
        char name[32];
        std::snprintf(name, sizeof name, "frame_%04zu", i);
        f.pngPath = (dir / (std::string(name) + ".png")).string();
        f.jsonPath = (dir / (std::string(name) + ".json")).string();
        if (!format::encodePng(options.width, options.height, images[i], png)) {
            error = f.pngPath + ": cannot encode the PNG";
            return false;
        }
        std::vector<std::uint8_t>().swap(images[i]);  // encoded: the pixels are not needed
        if (!files.add(f.pngPath, png, output, error)) return false;
        const nlohmann::json json =
            frameJson(options, options.cameras[i], f, metric, result.deviceName);
        if (!files.add(f.jsonPath, jsonText(json, 2) + "\n", output, error)) return false;
    }
    if (!files.commit(error)) return false;
    removeCreated.keep = true;
    return true;
}

}  // namespace unilod::engine
