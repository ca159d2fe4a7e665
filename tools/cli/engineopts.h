// Options every engine command shares (capture, view, bench): image size, LOD tolerance and
// metric, S, GPU budget, Vulkan device and validation. One definition so that the commands
// agree on names, defaults and ranges.
#pragma once

#include <CLI/CLI.hpp>
#include <cstdint>
#include <string>

#include "camera.h"
#include "device.h"
#include "scene.h"
#include "ulod.h"

namespace unilod::cli {

struct EngineCli {
    std::string size;
    std::string distance = "nearest";
    double gpuBudgetMiB = double(engine::kDefaultGpuBudget >> 20);
    double pixels = 1.0;
    std::string metric;
    bool validation = false, noValidation = false;
    bool noRefine = false;
    unsigned threads = 0;
    int device = -1;

    void add(CLI::App& sub, const std::string& defaultSize);
    // Parses the size and fills the scene / device options. False (usage error, message on
    // stderr naming `command`) on a malformed size.
    bool apply(engine::SceneOptions& scene, engine::DeviceOptions& dev, std::uint32_t& width,
               std::uint32_t& height, const char* command) const;
};

bool parseSize(const std::string& s, std::uint32_t& w, std::uint32_t& h);

// --camera of capture, view and export: X,Y,Z,YAW,PITCH, or (export: `positionOnly` allowed) also
// X,Y,Z. One definition of the option and of its check, so that the three commands accept and
// refuse the same values: each component the whole text of a finite number (numbers.h), pitch
// in [-90, 90], no empty item. A bad value is a usage error (exit 2) while parsing, before any
// file, window or device is opened: "--camera: pitch '-95' must be in [-90, 90]".
CLI::Option* addCameraOption(CLI::App& sub, std::string& text, const std::string& help,
                             bool positionOnly = false);
// The camera of a --camera text (fov untouched); `hasDirection`: yaw and pitch were given. False
// with `error` (without the option name) when the text fails the check above.
bool parseCamera(const std::string& text, bool positionOnly, engine::Camera& camera,
                 bool& hasDirection, std::string& error);

// --metric max|paper of the commands that choose levels (capture, view, bench, stats, export,
// report): the error metric h_s is read in; without it, the file's default (`build --metric`).
// One definition (capture, view and bench called max the default, which it is only for files
// built with it).
CLI::Option* addMetricOption(CLI::App& sub, std::string& metric);
// The format::Metric of a value the option accepted; 0 (the file's default) when not given.
std::uint32_t metricOf(const std::string& metric);

// --fov of capture, export, stats and report: degrees in (0, 180), the range engine::validCamera
// accepts. One definition so that the commands agree.
CLI::Validator fovRange();

// The camera of capture and export without --camera: engine::defaultOverview of the file's
// header. False with `error` naming the file when it cannot be read or when its extent gives no
// valid view (a damaged header whose extents are finite but huge).
bool defaultCamera(const std::string& path, engine::Camera& camera, std::string& error);

// "PATH: ERROR" for an engine error, unless the message already names the file first (the
// reader's and the scene's do; the device's do not): format::errorForFile.
using format::errorForFile;

}  // namespace unilod::cli
