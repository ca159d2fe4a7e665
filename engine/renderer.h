// Offscreen target, the block geometry on the GPU, the terrain and river pipelines, one frame.
// Plain structs with create/destroy pairs (STYLE.md "Vulkan lifetimes"); destroy in reverse order
// after the device is idle.
#pragma once

#include <vulkan/vulkan.h>

#include <cstdint>
#include <string>
#include <vector>

#include "device.h"
#include "lod.h"
#include "ulod.h"

namespace unilod::engine {

struct Buffer {
    VkBuffer buffer = VK_NULL_HANDLE;
    VkDeviceMemory memory = VK_NULL_HANDLE;
    VkDeviceSize size = 0;
    void* mapped = nullptr;  // host-visible buffers stay mapped
};
void createBuffer(const Device& device, VkDeviceSize size, VkBufferUsageFlags usage,
                  VkMemoryPropertyFlags properties, Buffer& buffer);
void destroyBuffer(const Device& device, Buffer& buffer);

struct Image {
    VkImage image = VK_NULL_HANDLE;
    VkDeviceMemory memory = VK_NULL_HANDLE;
    VkImageView view = VK_NULL_HANDLE;
};

inline constexpr VkFormat kColourFormat = VK_FORMAT_R8G8B8A8_UNORM;
inline constexpr VkFormat kDepthFormat = VK_FORMAT_D32_SFLOAT;

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

// A block's share of the scene buffers (niagara-style sub-allocation by offset/count).
struct SceneBlock {
    std::uint32_t col = 0, row = 0;
    double originX = 0, originY = 0;
    double boxMin[3] = {}, boxMax[3] = {};
    std::int32_t vertexBase = 0;    // first vertex in the vertex buffer
    std::uint32_t terrainBase = 0;  // first terrain index in the index buffer
    std::uint32_t riverBase = 0;    // first river index in the index buffer
    std::vector<format::Level> levels;
    std::vector<float> errorMax, errorPaper;
};

// Every block of a file, resident (this slice has no streaming yet).
struct Scene {
    Buffer vertices, indices;  // device-local; format::Vertex and uint32 indices
    std::vector<SceneBlock> blocks;
    double minZ = 0, maxZ = 0;
};
// Reads and uploads every block (staging buffer + one transfer). Returns false with a message
// naming the file when a block cannot be read.
bool createScene(const Device& device, const format::Reader& reader, Scene& scene,
                 std::string& error);
void destroyScene(const Device& device, Scene& scene);

struct Pipelines {
    VkPipelineLayout layout = VK_NULL_HANDLE;
    VkPipeline terrain = VK_NULL_HANDLE;
    VkPipeline river = VK_NULL_HANDLE;
};
// Loads <spirvDir>/{terrain,river}.{vert,frag}.spv. False with a message if one is missing.
bool createPipelines(const Device& device, const Offscreen& offscreen, const std::string& spirvDir,
                     Pipelines& pipelines, std::string& error);
void destroyPipelines(const Device& device, Pipelines& pipelines);

// World coordinates of the file's CRS; yaw 0 looks north (+y), 90 east; pitch < 0 looks down.
struct Camera {
    double eye[3] = {};
    double yawDegrees = 0, pitchDegrees = 0;
    double fovDegrees = 60;  // vertical
};

struct DrawItem {
    std::size_t block = 0;
    const format::Level* level = nullptr;
};

// Records, submits and waits for one frame: clear, terrain then rivers of every item, copy of
// the colour image to `rgba` (width * height * 4 bytes, rows top to bottom).
void renderFrame(const Device& device, const Offscreen& offscreen, const Pipelines& pipelines,
                 const Scene& scene, const Camera& camera, const std::vector<DrawItem>& items,
                 std::vector<std::uint8_t>& rgba);

}  // namespace unilod::engine
