// Headless capture: one frame of a .ulod file from a camera, per-block LOD chosen by the
// screen-space error (paper §3.4), written as DIR/frame_0000.png + DIR/frame_0000.json.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "device.h"
#include "renderer.h"

namespace unilod::engine {

struct CaptureOptions {
    std::string path;    // the .ulod file
    std::string outDir;  // created if missing
    Camera camera;
    std::uint32_t width = 1024, height = 768;
    double pixels = 1.0;  // P: the screen-space error tolerance in pixels
    std::string metric;   // "max", "paper"; empty: the file's default
    DistanceMode distance = DistanceMode::Nearest;  // how S is measured (lod.h)
    DeviceOptions device;
    std::string spirvDir;  // empty: $UNILOD_SPIRV_DIR, else the build's spirv folder
};

struct CaptureBlock {
    std::uint32_t col = 0, row = 0;
    LevelChoice choice;
    double distance = 0;  // S
    double hLim = 0;
    std::uint32_t triangles = 0, riverEdges = 0;
};

struct CaptureResult {
    std::string deviceName;
    std::vector<CaptureBlock> blocks;
    std::uint64_t triangles = 0, riverEdges = 0;
    std::string pngPath, jsonPath;
};

// The level choice of every block for a camera (no Vulkan): also what the capture draws.
std::vector<CaptureBlock> chooseLevels(const Scene& scene, const CaptureOptions& options,
                                       std::uint32_t metric);

// Returns false with a message naming the file on a data error (unreadable file, bad camera,
// no Vulkan device, validation messages when validation is on); no output is left behind then.
bool runCapture(const CaptureOptions& options, CaptureResult& result, std::string& error);

}  // namespace unilod::engine
