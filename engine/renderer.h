// Offscreen target, the block geometry on the GPU, the terrain and river pipelines, one frame.
// Plain structs with create/destroy pairs (STYLE.md "Vulkan lifetimes"); destroy in reverse order
// after the device is idle.
#pragma once

#include <vulkan/vulkan.h>

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "camera.h"
#include "device.h"
#include "ulod.h"

namespace unilod::engine {

struct Buffer {
    VkBuffer buffer = VK_NULL_HANDLE;
    VkDeviceMemory memory = VK_NULL_HANDLE;
    VkDeviceSize size = 0;
    void* mapped = nullptr;  // host-visible buffers stay mapped
};
// A buffer with its own memory (host-visible buffers stay mapped). Running out of memory here is
// not expected (small, fixed-size buffers): it aborts with a message.
void createBuffer(const Device& device, VkDeviceSize size, VkBufferUsageFlags usage,
                  VkMemoryPropertyFlags properties, Buffer& buffer);
// The same for a buffer whose size comes from the user or the data (the GPU budget, staging for
// the largest block): false with a message when it exceeds what the device can allocate (the
// memory heap of its type, maxMemoryAllocationSize) or the allocation fails; nothing is left.
bool tryCreateBuffer(const Device& device, VkDeviceSize size, VkBufferUsageFlags usage,
                     VkMemoryPropertyFlags properties, Buffer& buffer, std::string& error);
// The largest buffer of memory with `properties` the device can allocate at once: the largest
// heap among the matching memory types, capped by maxMemoryAllocationSize. 0 when none matches.
VkDeviceSize largestAllocation(const Device& device, VkMemoryPropertyFlags properties);
void destroyBuffer(const Device& device, Buffer& buffer);

struct Image {
    VkImage image = VK_NULL_HANDLE;
    VkDeviceMemory memory = VK_NULL_HANDLE;
    VkImageView view = VK_NULL_HANDLE;
};

inline constexpr VkFormat kColourFormat = VK_FORMAT_R8G8B8A8_UNORM;
inline constexpr VkFormat kDepthFormat = VK_FORMAT_D32_SFLOAT;

void createImage(const Device& device, std::uint32_t width, std::uint32_t height, VkFormat format,
                 VkImageUsageFlags usage, VkImageAspectFlags aspect, Image& image);
void destroyImage(const Device& device, Image& image);

// A render pass with one colour attachment (cleared, stored, left in `colourFinalLayout`) and a
// D32 depth attachment (cleared to 0: reversed Z). Offscreen and swapchain targets both use it.
VkRenderPass createRenderPass(const Device& device, VkFormat colourFormat,
                              VkImageLayout colourFinalLayout);

// Colour + depth of a fixed size, the render pass and framebuffer drawing into them, and a
// host-visible buffer the colour image is copied into after the frame.
struct Offscreen {
    std::uint32_t width = 0, height = 0;
    Image colour, depth;
    VkRenderPass renderPass = VK_NULL_HANDLE;
    VkFramebuffer framebuffer = VK_NULL_HANDLE;
    Buffer readback;
};
void createOffscreen(const Device& device, std::uint32_t width, std::uint32_t height,
                     Offscreen& offscreen);
void destroyOffscreen(const Device& device, Offscreen& offscreen);
// Records the copy of the colour image (left in TRANSFER_SRC by the pass) into the readback
// buffer, with the barrier that makes it visible to the host after the fence.
void recordReadback(VkCommandBuffer cmd, const Offscreen& offscreen);

struct Pipelines {
    VkPipelineLayout layout = VK_NULL_HANDLE;
    VkPipeline terrain = VK_NULL_HANDLE;
    VkPipeline river = VK_NULL_HANDLE;
    VkPipeline wire = VK_NULL_HANDLE;  // grid mode: triangle edges (null without fillModeNonSolid)
};
// Loads <spirvDir>/{terrain,river}.{vert,frag}.spv and builds the pipelines for `renderPass`
// (viewport and scissor are dynamic: one set of pipelines serves any size). False with a message
// if a shader is missing.
bool createPipelines(const Device& device, VkRenderPass renderPass, const std::string& spirvDir,
                     Pipelines& pipelines, std::string& error);
void destroyPipelines(const Device& device, Pipelines& pipelines);

// The folder of the compiled shaders: `configured` if not empty, else $UNILOD_SPIRV_DIR, else
// the build's spirv folder.
std::string spirvDirectory(const std::string& configured);

// What a frame looks at and how.
struct FrameView {
    Camera camera;
    std::uint32_t width = 0, height = 0;  // viewport in pixels
    bool grid = false;          // 2D grid mode: top-down orthographic wireframe (Figures 7-12)
    double gridHalfHeight = 0;  // grid mode: metres from the view centre to the top edge
    bool rivers = true;         // draw the river lines
    double minZ = 0, maxZ = 0;  // hypsometric tint range
};

// One block's draw: vertices at byte `vertexOffset` of the geometry buffer, index ranges in
// units of uint32 from the start of the same buffer (terrain: triangle lists, rivers: lines).
// `dynamic`: the index ranges are in the frame's dynamic index buffer instead (a block refined
// for the view, scene.h SceneOptions::refine), from its start.
struct DrawBlock {
    VkDeviceSize vertexOffset = 0;
    std::uint32_t terrainFirst = 0, terrainCount = 0;  // indices
    std::uint32_t riverFirst = 0, riverCount = 0;      // indices
    double originX = 0, originY = 0;                   // block origin (world)
    bool dynamic = false;
};

// Records, inside a render pass of the pipelines' kind, the terrain of every block, then the
// rivers (their depth test needs the terrain's depth). Sets viewport and scissor to the view.
// `dynamicIndices`: the buffer of the `dynamic` draws' indices (needed when one is).
void recordDraws(VkCommandBuffer cmd, const Pipelines& pipelines, VkBuffer geometry,
                 const FrameView& view, const std::vector<DrawBlock>& blocks,
                 VkBuffer dynamicIndices = VK_NULL_HANDLE);

// A host-visible index buffer rewritten every frame (one per frame in flight): the refined
// blocks' indices, which the GPU reads once (a few hundred KB a frame). write() grows it as
// needed (the caller has waited for the frame that last used it) and copies the words.
struct DynamicIndices {
    Buffer buffer;
    void write(const Device& device, const std::vector<std::uint32_t>& words);
    void destroy(const Device& device) { destroyBuffer(device, buffer); }
};

// Records into a one-shot command buffer, submits it and waits (startup uploads).
void submitAndWait(const Device& device, const std::function<void(VkCommandBuffer)>& record);

}  // namespace unilod::engine
