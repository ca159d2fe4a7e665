// Headless capture (issue 5): frames of a .ulod file from a camera or along a camera path, with
// the streamed per-block LOD (paper §3.4), written as DIR/frame_NNNN.png + DIR/frame_NNNN.json.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "annotate.h"
#include "camera.h"
#include "campath.h"
#include "device.h"
#include "scene.h"

namespace unilod::engine {


struct CaptureOptions {
    std::string path;                 // the .ulod file
    std::string outDir;               // created if missing
    std::vector<std::string> inputs;  // other files read (the camera path): never overwritten
    std::vector<Camera> cameras;      // one frame each
    std::uint32_t width = 1024, height = 768;
    SceneOptions scene;
    bool settle = true;  // wait until each frame's wanted levels are resident (deterministic)
    bool grid = false;   // 2D grid mode (top-down wireframe)
    bool rivers = true;
    // Colour key, scale bar and north arrow on every frame (annotate.h); the JSON records where.
    bool annotate = false;
    DeviceOptions device;
    std::string spirvDir;  // empty: $UNILOD_SPIRV_DIR, else the build's spirv folder
};

struct CaptureFrame {
    std::vector<BlockSelection> blocks;
    FrameStats stats;
    bool annotated = false;
    Annotation annotation;         // with annotated: what was drawn ...
    AnnotationLayout annotationLayout;  // ... and where
    std::string pngPath, jsonPath;
};

struct CaptureResult {
    std::string deviceName;
    std::vector<CaptureFrame> frames;
};

// The grid mode's half height for a camera: the view covers what a perspective camera at the
// eye's height above the data's top would see straight down.
double gridHalfHeight(const Camera& camera, double maxZ);

// Returns false with a message naming the file on a data error (unreadable file, bad camera,
// no Vulkan device, validation messages when validation is on); no frame is left behind then.
bool runCapture(const CaptureOptions& options, CaptureResult& result, std::string& error);

}  // namespace unilod::engine
