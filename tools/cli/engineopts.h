// Options every engine command shares (capture, view, bench): image size, LOD tolerance and
// metric, S, GPU budget, Vulkan device and validation. One definition so that the commands
// agree on names, defaults and ranges.
#pragma once

#include <CLI/CLI.hpp>
#include <cstdint>
#include <string>

#include "device.h"
#include "scene.h"

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

// "PATH: ERROR" for an engine error, unless the message already names the file first (the
// reader's and the scene's do; the device's do not).
std::string errorForFile(const std::string& path, const std::string& error);

}  // namespace unilod::cli
