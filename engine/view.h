// `unilod view`: roams a .ulod file in a window (engine/window.h) with the streamed scene
// (engine/scene.h). Interactive by default; with `frames` > 0 it renders that many frames and
// returns (tests, scripted screenshots).
#pragma once

#include <cstdint>
#include <string>

#include "camera.h"
#include "device.h"
#include "scene.h"

namespace unilod::engine {

struct ViewOptions {
    std::string path;  // .ulod file
    bool hasCamera = false;
    Camera camera;  // with hasCamera; else above the data looking at its centre, oblique
    std::uint32_t width = 1280, height = 720;
    SceneOptions scene;
    DeviceOptions device;
    std::uint64_t frames = 0;    // 0: until the window closes
    std::string screenshotPath;  // with frames: the last frame as PNG (view.cpp: the first
                                 // settled frame from the count on, at most 30 s later)
    bool annotate = false;       // screenshots get a colour key, scale bar, north arrow (annotate.h)
    bool grid = false;           // start in grid mode
    // With frames: resize the window to this size after half of them (as a window manager
    // would; exercises swapchain recreation). 0: no resize.
    std::uint32_t resizeWidth = 0, resizeHeight = 0;
};

struct ViewResult {
    std::uint64_t frames = 0;  // rendered
    std::string deviceName;
};

// The default camera: south of the data's centre, above its top, looking north and down at the
// centre.
Camera defaultViewCamera(const format::Header& header, double fovDegrees);

// Opens the window and runs until it closes (Esc) or `frames` frames are rendered. False with a
// message (no display, no device, unreadable file, a validation message, a failed screenshot).
// Prints a stats line once per second and at the end on stdout.
bool runView(const ViewOptions& options, ViewResult& result, std::string& error);

}  // namespace unilod::engine
