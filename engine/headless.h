// The offscreen target with frames in flight: a StreamingScene drawn into an Offscreen image,
// one command buffer, fence and timestamp pair per frame slot. Captures and the benchmark use
// it; the window target (window.h) runs the same scene and pipelines on a swapchain.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "device.h"
#include "renderer.h"
#include "scene.h"

namespace unilod::engine {

struct HeadlessOptions {
    std::string path;  // the .ulod file
    std::uint32_t width = 1024, height = 768;
    SceneOptions scene;
    DeviceOptions device;
    std::string spirvDir;  // empty: spirvDirectory("")
};

// One submitted frame's measurements, known once it has completed.
struct FrameTiming {
    std::uint64_t frame = 0;
    double cpuMs = 0;  // prepare + record + submit on the CPU
    double gpuMs = -1; // between the frame's first and last command (timestamps); -1: unknown
    FrameStats stats;  // the scene's statistics for this frame
};

class HeadlessRenderer {
public:
    HeadlessRenderer();
    ~HeadlessRenderer();
    HeadlessRenderer(const HeadlessRenderer&) = delete;
    HeadlessRenderer& operator=(const HeadlessRenderer&) = delete;

    // Device, scene (coarse set uploaded), target and pipelines. False with a message.
    bool open(const HeadlessOptions& options, std::string& error);
    // Waits for the device and destroys everything; returns the validation messages recorded.
    std::vector<std::string> close();

    // Records and submits one frame of `view` (its width / height must be the target's). With
    // `draw` false only the uploads are recorded (a capture settling its residency). With `rgba`
    // it waits for the frame and copies the image (rows top to bottom). Returns false with a
    // message on a scene data error.
    bool renderFrame(const FrameView& view, bool draw, std::vector<std::uint8_t>* rgba,
                     std::string& error);
    // A bare frame: `draws` (in the scene's geometry buffer; the `dynamic` ones in `indices`,
    // as StreamingScene::refinedIndices gave them) recorded as they are, with no level
    // selection and no streaming (the benchmark's baseline).
    void renderBareFrame(const FrameView& view, const std::vector<DrawBlock>& draws,
                         const std::vector<std::uint32_t>& indices);
    // A frame of `draws` from the caller's `geometry` buffer (vertices and, for draws that are
    // not `dynamic`, indices: DrawBlock), with no level selection and no streaming (the
    // benchmark's baseline meshes, bench.h BenchOptions::baseline). With `rgba` it waits for
    // the frame and copies the image, as renderFrame.
    void renderMeshFrame(const FrameView& view, VkBuffer geometry,
                         const std::vector<DrawBlock>& draws,
                         std::vector<std::uint8_t>* rgba = nullptr);
    // Waits for every submitted frame; their timings in submission order since the last call.
    std::vector<FrameTiming> finish();

    StreamingScene& scene();
    const Device& device() const;
    const Pipelines& pipelines() const;

    // A FrameView of the target's size for `camera` with the file's z range.
    FrameView view(const Camera& camera) const;

private:
    // `bare`: draws recorded as they are, from `bareGeometry` (null: the scene's buffer).
    bool record(const FrameView& view, bool draw, const std::vector<DrawBlock>* bare,
                const std::vector<std::uint32_t>* bareIndices, VkBuffer bareGeometry,
                std::vector<std::uint8_t>* rgba, std::string& error);
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

}  // namespace unilod::engine
