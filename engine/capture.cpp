#include "capture.h"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "pngwrite.h"
#include "vkcheck.h"

#ifndef UNILOD_SPIRV_DIR
#define UNILOD_SPIRV_DIR "spirv"
#endif

namespace unilod::engine {

namespace {

constexpr double kDegree = 3.14159265358979323846 / 180.0;

bool writeText(const std::string& path, const std::string& text, std::string& error) {
    const std::string temp = path + ".tmp";
    {
        std::ofstream out(temp, std::ios::binary | std::ios::trunc);
        out << text;
        out.flush();
        if (!out) {
            std::error_code ec;
            std::filesystem::remove(temp, ec);
            error = path + ": cannot write";
            return false;
        }
    }
    std::error_code ec;
    std::filesystem::rename(temp, path, ec);
    if (ec) {
        std::filesystem::remove(temp, ec);
        error = path + ": cannot move into place";
        return false;
    }
    return true;
}

bool validCamera(const Camera& c) {
    for (double v : c.eye)
        if (!std::isfinite(v)) return false;
    return std::isfinite(c.yawDegrees) && std::isfinite(c.pitchDegrees) && c.pitchDegrees >= -90 &&
           c.pitchDegrees <= 90 && c.fovDegrees > 0 && c.fovDegrees < 180;
}

}  // namespace

std::vector<CaptureBlock> chooseLevels(const Scene& scene, const CaptureOptions& options,
                                       std::uint32_t metric) {
    std::vector<CaptureBlock> out;
    for (const SceneBlock& b : scene.blocks) {
        CaptureBlock c;
        c.col = b.col;
        c.row = b.row;
        c.distance = blockDistance(options.distance, options.camera.eye, b.boxMin, b.boxMax);
        c.hLim = blockTolerance({options.pixels, options.camera.fovDegrees * kDegree,
                                 double(options.width), double(options.height), options.distance},
                                c.distance);
        const std::vector<float>& errors =
            metric == format::kMetricPaper ? b.errorPaper : b.errorMax;
        c.choice = chooseLevel(b.levels, errors, c.hLim);
        c.triangles = b.levels[c.choice.level].triangleCount;
        c.riverEdges = b.levels[c.choice.level].riverCount;
        out.push_back(c);
    }
    return out;
}

bool runCapture(const CaptureOptions& options, CaptureResult& result, std::string& error) {
    if (!validCamera(options.camera)) {
        error = "invalid camera (finite x, y, z, yaw; pitch in [-90, 90]; fov in (0, 180))";
        return false;
    }
    if (options.width == 0 || options.height == 0 || options.width > 16384 ||
        options.height > 16384 || !(options.pixels > 0)) {
        error = "invalid size or pixel tolerance";
        return false;
    }
    format::Reader reader;
    if (!reader.open(options.path, error)) return false;
    std::uint32_t metric = reader.header().defaultMetric;
    if (options.metric == "max")
        metric = format::kMetricMax;
    else if (options.metric == "paper")
        metric = format::kMetricPaper;
    else if (!options.metric.empty()) {
        error = "unknown metric '" + options.metric + "' (max or paper)";
        return false;
    }
    if (!(reader.header().metrics & metric)) {
        error = options.path + ": the file has no '" +
                (metric == format::kMetricPaper ? "paper" : "max") + "' error metric";
        return false;
    }

    std::string spirvDir = options.spirvDir;
    if (spirvDir.empty()) {
        const char* env = std::getenv("UNILOD_SPIRV_DIR");
        spirvDir = env && *env ? env : UNILOD_SPIRV_DIR;
    }

    Device device;
    if (!createDevice(options.device, device, error)) return false;
    result.deviceName = device.properties.deviceName;
    Scene scene;
    Offscreen offscreen;
    Pipelines pipelines;
    std::vector<std::uint8_t> rgba;
    bool ok = createScene(device, reader, scene, error);
    if (ok) {
        createOffscreen(device, options.width, options.height, offscreen);
        ok = createPipelines(device, offscreen, spirvDir, pipelines, error);
    }
    if (ok) {
        result.blocks = chooseLevels(scene, options, metric);
        std::vector<DrawItem> items;
        for (std::size_t i = 0; i < result.blocks.size(); ++i) {
            items.push_back({i, &scene.blocks[i].levels[result.blocks[i].choice.level]});
            result.triangles += result.blocks[i].triangles;
            result.riverEdges += result.blocks[i].riverEdges;
        }
        renderFrame(device, offscreen, pipelines, scene, options.camera, items, rgba);
    }
    VK_CHECK(vkDeviceWaitIdle(device.device));
    destroyPipelines(device, pipelines);
    destroyOffscreen(device, offscreen);
    destroyScene(device, scene);
    const std::vector<std::string> messages = validationMessages(device);
    destroyDevice(device);
    if (!ok) return false;
    if (!messages.empty()) {
        error = std::to_string(messages.size()) +
                " Vulkan validation message(s) (first: " + messages.front() + ")";
        return false;
    }

    std::error_code ec;
    std::filesystem::create_directories(options.outDir, ec);
    if (ec) {
        error = options.outDir + ": cannot create the output folder: " + ec.message();
        return false;
    }
    nlohmann::json blocks = nlohmann::json::array();
    for (const CaptureBlock& b : result.blocks) {
        blocks.push_back(
            {{"col", b.col},
             {"row", b.row},
             {"level", b.choice.level},
             {"step", b.choice.step},
             {"S", b.distance},
             {"h_lim", b.hLim},
             {"h_s", b.choice.error},
             {"next_level_error",
              b.choice.nextError < 0 ? nlohmann::json() : nlohmann::json(b.choice.nextError)},
             {"triangles", b.triangles},
             {"river_edges", b.riverEdges}});
    }
    const Camera& c = options.camera;
    const nlohmann::json json = {
        {"file", options.path},
        {"device", result.deviceName},
        {"size", {options.width, options.height}},
        {"camera",
         {{"eye", {c.eye[0], c.eye[1], c.eye[2]}},
          {"yaw", c.yawDegrees},
          {"pitch", c.pitchDegrees},
          {"fov", c.fovDegrees}}},
        {"pixels", options.pixels},
        {"metric", metric == format::kMetricPaper ? "paper" : "max"},
        {"distance", options.distance == DistanceMode::Nearest ? "nearest" : "centre"},
        {"edge_factor", options.distance == DistanceMode::Nearest
                            ? frustumEdgeFactor(c.fovDegrees * kDegree,
                                                double(options.width) / options.height)
                            : 1.0},
        {"blocks", blocks},
        {"totals",
         {{"blocks_drawn", result.blocks.size()},
          {"triangles", result.triangles},
          {"river_edges", result.riverEdges}}},
    };
    const std::filesystem::path dir(options.outDir);
    result.pngPath = (dir / "frame_0000.png").string();
    result.jsonPath = (dir / "frame_0000.json").string();
    if (!writePng(result.pngPath, options.width, options.height, rgba, error)) return false;
    if (!writeText(result.jsonPath, json.dump(2) + "\n", error)) {
        std::filesystem::remove(result.pngPath, ec);
        return false;
    }
    return true;
}

}  // namespace unilod::engine
