// Offscreen rendering of the per-block LOD: terrain triangles with a hypsometric tint and flat
// lambert shading, rivers as lines on their constraint edges (DESIGN.md "Engine").
#include "renderer.h"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iterator>
#include <string>

#include "../shaders/shared.h"
#include "vkcheck.h"

#ifndef UNILOD_SPIRV_DIR
#define UNILOD_SPIRV_DIR "spirv"
#endif

namespace unilod::engine {

VkDeviceSize largestAllocation(const Device& device, VkMemoryPropertyFlags properties) {
    VkDeviceSize largest = 0;
    for (std::uint32_t i = 0; i < device.memory.memoryTypeCount; ++i) {
        const VkMemoryType& t = device.memory.memoryTypes[i];
        if ((t.propertyFlags & properties) == properties)
            largest = std::max(largest, device.memory.memoryHeaps[t.heapIndex].size);
    }
    if (device.maxAllocation > 0) largest = std::min(largest, device.maxAllocation);
    return largest;
}

bool tryCreateBuffer(const Device& device, VkDeviceSize size, VkBufferUsageFlags usage,
                     VkMemoryPropertyFlags properties, Buffer& buffer, std::string& error) {
    assert(size > 0);
    const auto mib = [](VkDeviceSize b) { return std::to_string((b + (1u << 20) - 1) >> 20); };
    const VkDeviceSize limit = largestAllocation(device, properties);
    if (size > limit) {
        error = "a buffer of " + mib(size) + " MiB exceeds what the Vulkan device '" +
                device.properties.deviceName + "' can allocate at once (" + mib(limit) + " MiB)";
        return false;
    }
    VkBufferCreateInfo info{};
    info.sType = VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO;
    info.size = size;
    info.usage = usage;
    info.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
    VK_CHECK(vkCreateBuffer(device.device, &info, nullptr, &buffer.buffer));
    VkMemoryRequirements req;
    vkGetBufferMemoryRequirements(device.device, buffer.buffer, &req);
    VkMemoryAllocateInfo alloc{};
    alloc.sType = VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO;
    alloc.allocationSize = req.size;
    alloc.memoryTypeIndex = findMemoryType(device, req.memoryTypeBits, properties);
    const VkResult r = vkAllocateMemory(device.device, &alloc, nullptr, &buffer.memory);
    if (r == VK_ERROR_OUT_OF_DEVICE_MEMORY || r == VK_ERROR_OUT_OF_HOST_MEMORY) {
        vkDestroyBuffer(device.device, buffer.buffer, nullptr);
        buffer = Buffer{};
        error = "the Vulkan device '" + std::string(device.properties.deviceName) +
                "' could not allocate " + mib(req.size) + " MiB (" +
                (r == VK_ERROR_OUT_OF_DEVICE_MEMORY ? "out of device memory"
                                                    : "out of host memory") +
                ")";
        return false;
    }
    VK_CHECK(r);
    VK_CHECK(vkBindBufferMemory(device.device, buffer.buffer, buffer.memory, 0));
    buffer.size = size;
    if (properties & VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT)
        VK_CHECK(vkMapMemory(device.device, buffer.memory, 0, VK_WHOLE_SIZE, 0, &buffer.mapped));
    return true;
}

void createBuffer(const Device& device, VkDeviceSize size, VkBufferUsageFlags usage,
                  VkMemoryPropertyFlags properties, Buffer& buffer) {
    std::string error;
    if (!tryCreateBuffer(device, size, usage, properties, buffer, error)) {
        std::fprintf(stderr, "unilod: %s\n", error.c_str());
        std::abort();
    }
}

void destroyBuffer(const Device& device, Buffer& buffer) {
    if (buffer.mapped) vkUnmapMemory(device.device, buffer.memory);
    if (buffer.buffer) vkDestroyBuffer(device.device, buffer.buffer, nullptr);
    if (buffer.memory) vkFreeMemory(device.device, buffer.memory, nullptr);
    buffer = Buffer{};
}

void createImage(const Device& device, std::uint32_t width, std::uint32_t height, VkFormat format,
                 VkImageUsageFlags usage, VkImageAspectFlags aspect, Image& image) {
    VkImageCreateInfo info{};
    info.sType = VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO;
    info.imageType = VK_IMAGE_TYPE_2D;
    info.format = format;
    info.extent = {width, height, 1};
    info.mipLevels = 1;
    info.arrayLayers = 1;
    info.samples = VK_SAMPLE_COUNT_1_BIT;
    info.tiling = VK_IMAGE_TILING_OPTIMAL;
    info.usage = usage;
    info.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
    info.initialLayout = VK_IMAGE_LAYOUT_UNDEFINED;
    VK_CHECK(vkCreateImage(device.device, &info, nullptr, &image.image));
    VkMemoryRequirements req;
    vkGetImageMemoryRequirements(device.device, image.image, &req);
    VkMemoryAllocateInfo alloc{};
    alloc.sType = VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO;
    alloc.allocationSize = req.size;
    alloc.memoryTypeIndex =
        findMemoryType(device, req.memoryTypeBits, VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT);
    VK_CHECK(vkAllocateMemory(device.device, &alloc, nullptr, &image.memory));
    VK_CHECK(vkBindImageMemory(device.device, image.image, image.memory, 0));
    VkImageViewCreateInfo view{};
    view.sType = VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO;
    view.image = image.image;
    view.viewType = VK_IMAGE_VIEW_TYPE_2D;
    view.format = format;
    view.subresourceRange = {aspect, 0, 1, 0, 1};
    VK_CHECK(vkCreateImageView(device.device, &view, nullptr, &image.view));
}

void destroyImage(const Device& device, Image& image) {
    if (image.view) vkDestroyImageView(device.device, image.view, nullptr);
    if (image.image) vkDestroyImage(device.device, image.image, nullptr);
    if (image.memory) vkFreeMemory(device.device, image.memory, nullptr);
    image = Image{};
}

void submitAndWait(const Device& device, const std::function<void(VkCommandBuffer)>& record) {
    VkCommandPoolCreateInfo poolInfo{};
    poolInfo.sType = VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO;
    poolInfo.flags = VK_COMMAND_POOL_CREATE_TRANSIENT_BIT;
    poolInfo.queueFamilyIndex = device.queueFamily;
    VkCommandPool pool;
    VK_CHECK(vkCreateCommandPool(device.device, &poolInfo, nullptr, &pool));
    VkCommandBufferAllocateInfo alloc{};
    alloc.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO;
    alloc.commandPool = pool;
    alloc.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
    alloc.commandBufferCount = 1;
    VkCommandBuffer cmd;
    VK_CHECK(vkAllocateCommandBuffers(device.device, &alloc, &cmd));
    VkCommandBufferBeginInfo begin{};
    begin.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO;
    begin.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
    VK_CHECK(vkBeginCommandBuffer(cmd, &begin));
    record(cmd);
    VK_CHECK(vkEndCommandBuffer(cmd));
    VkFenceCreateInfo fenceInfo{};
    fenceInfo.sType = VK_STRUCTURE_TYPE_FENCE_CREATE_INFO;
    VkFence fence;
    VK_CHECK(vkCreateFence(device.device, &fenceInfo, nullptr, &fence));
    VkSubmitInfo submit{};
    submit.sType = VK_STRUCTURE_TYPE_SUBMIT_INFO;
    submit.commandBufferCount = 1;
    submit.pCommandBuffers = &cmd;
    VK_CHECK(vkQueueSubmit(device.queue, 1, &submit, fence));
    VK_CHECK(vkWaitForFences(device.device, 1, &fence, VK_TRUE, UINT64_MAX));
    vkDestroyFence(device.device, fence, nullptr);
    vkDestroyCommandPool(device.device, pool, nullptr);
}

namespace {

bool readFile(const std::string& path, std::vector<char>& bytes) {
    std::ifstream in(path, std::ios::binary);
    if (!in) return false;
    bytes.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
    return !bytes.empty() && bytes.size() % 4 == 0;
}

bool createShader(const Device& device, const std::string& path, VkShaderModule& module,
                  std::string& error) {
    std::vector<char> code;
    if (!readFile(path, code)) {
        error = path + ": cannot read SPIR-V (not built? set UNILOD_SPIRV_DIR)";
        return false;
    }
    VkShaderModuleCreateInfo info{};
    info.sType = VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO;
    info.codeSize = code.size();
    // std::vector storage comes from operator new: aligned for uint32_t.
    info.pCode = reinterpret_cast<const std::uint32_t*>(static_cast<const void*>(code.data()));
    VK_CHECK(vkCreateShaderModule(device.device, &info, nullptr, &module));
    return true;
}

enum class PipelineKind { Terrain, River, Wire };

VkPipeline createPipeline(const Device& device, VkRenderPass renderPass, VkPipelineLayout layout,
                          VkShaderModule vert, VkShaderModule frag, PipelineKind kind) {
    const bool river = kind == PipelineKind::River;
    VkPipelineShaderStageCreateInfo stages[2]{};
    stages[0].sType = VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO;
    stages[0].stage = VK_SHADER_STAGE_VERTEX_BIT;
    stages[0].module = vert;
    stages[0].pName = "main";
    stages[1].sType = VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO;
    stages[1].stage = VK_SHADER_STAGE_FRAGMENT_BIT;
    stages[1].module = frag;
    stages[1].pName = "main";

    const VkVertexInputBindingDescription binding{0, sizeof(format::Vertex),
                                                  VK_VERTEX_INPUT_RATE_VERTEX};
    const VkVertexInputAttributeDescription position{0, 0, VK_FORMAT_R32G32B32_SFLOAT, 0};
    VkPipelineVertexInputStateCreateInfo input{};
    input.sType = VK_STRUCTURE_TYPE_PIPELINE_VERTEX_INPUT_STATE_CREATE_INFO;
    input.vertexBindingDescriptionCount = 1;
    input.pVertexBindingDescriptions = &binding;
    input.vertexAttributeDescriptionCount = 1;
    input.pVertexAttributeDescriptions = &position;

    VkPipelineInputAssemblyStateCreateInfo assembly{};

    assembly.sType = VK_STRUCTURE_TYPE_PIPELINE_INPUT_ASSEMBLY_STATE_CREATE_INFO;
    assembly.topology =
        river ? VK_PRIMITIVE_TOPOLOGY_LINE_LIST : VK_PRIMITIVE_TOPOLOGY_TRIANGLE_LIST;

    VkPipelineViewportStateCreateInfo viewportState{};
    viewportState.sType = VK_STRUCTURE_TYPE_PIPELINE_VIEWPORT_STATE_CREATE_INFO;
    viewportState.viewportCount = 1;
    viewportState.scissorCount = 1;
    const VkDynamicState dynamicStates[2] = {VK_DYNAMIC_STATE_VIEWPORT, VK_DYNAMIC_STATE_SCISSOR};
    VkPipelineDynamicStateCreateInfo dynamic{};
    dynamic.sType = VK_STRUCTURE_TYPE_PIPELINE_DYNAMIC_STATE_CREATE_INFO;
    dynamic.dynamicStateCount = 2;
    dynamic.pDynamicStates = dynamicStates;

    VkPipelineRasterizationStateCreateInfo raster{};

    raster.sType = VK_STRUCTURE_TYPE_PIPELINE_RASTERIZATION_STATE_CREATE_INFO;
    raster.polygonMode = kind == PipelineKind::Wire ? VK_POLYGON_MODE_LINE : VK_POLYGON_MODE_FILL;
    raster.cullMode = VK_CULL_MODE_NONE;  // a terrain seen from below is still a terrain
    raster.frontFace = VK_FRONT_FACE_COUNTER_CLOCKWISE;
    raster.lineWidth = 1.0f;

    VkPipelineMultisampleStateCreateInfo multisample{};

    multisample.sType = VK_STRUCTURE_TYPE_PIPELINE_MULTISAMPLE_STATE_CREATE_INFO;
    multisample.rasterizationSamples = VK_SAMPLE_COUNT_1_BIT;

    // Reversed Z (near = 1, infinite far = 0): float depth keeps precision over 100 km views.
    VkPipelineDepthStencilStateCreateInfo depth{};
    depth.sType = VK_STRUCTURE_TYPE_PIPELINE_DEPTH_STENCIL_STATE_CREATE_INFO;
    depth.depthTestEnable = VK_TRUE;
    depth.depthWriteEnable = river ? VK_FALSE : VK_TRUE;
    depth.depthCompareOp = VK_COMPARE_OP_GREATER_OR_EQUAL;

    VkPipelineColorBlendAttachmentState blendAttachment{};
    blendAttachment.colorWriteMask = VK_COLOR_COMPONENT_R_BIT | VK_COLOR_COMPONENT_G_BIT |
                                     VK_COLOR_COMPONENT_B_BIT | VK_COLOR_COMPONENT_A_BIT;
    VkPipelineColorBlendStateCreateInfo blend{};
    blend.sType = VK_STRUCTURE_TYPE_PIPELINE_COLOR_BLEND_STATE_CREATE_INFO;
    blend.attachmentCount = 1;
    blend.pAttachments = &blendAttachment;

    VkGraphicsPipelineCreateInfo info{};

    info.sType = VK_STRUCTURE_TYPE_GRAPHICS_PIPELINE_CREATE_INFO;
    info.stageCount = 2;
    info.pStages = stages;
    info.pVertexInputState = &input;
    info.pInputAssemblyState = &assembly;
    info.pViewportState = &viewportState;
    info.pRasterizationState = &raster;
    info.pMultisampleState = &multisample;
    info.pDepthStencilState = &depth;
    info.pColorBlendState = &blend;
    info.pDynamicState = &dynamic;
    info.layout = layout;
    info.renderPass = renderPass;
    info.subpass = 0;
    VkPipeline pipeline;
    VK_CHECK(
        vkCreateGraphicsPipelines(device.device, VK_NULL_HANDLE, 1, &info, nullptr, &pipeline));
    return pipeline;
}

}  // namespace

VkRenderPass createRenderPass(const Device& device, VkFormat colourFormat,
                              VkImageLayout colourFinalLayout) {
    VkAttachmentDescription attachments[2]{};
    attachments[0].format = colourFormat;
    attachments[0].samples = VK_SAMPLE_COUNT_1_BIT;
    attachments[0].loadOp = VK_ATTACHMENT_LOAD_OP_CLEAR;
    attachments[0].storeOp = VK_ATTACHMENT_STORE_OP_STORE;
    attachments[0].stencilLoadOp = VK_ATTACHMENT_LOAD_OP_DONT_CARE;
    attachments[0].stencilStoreOp = VK_ATTACHMENT_STORE_OP_DONT_CARE;
    attachments[0].initialLayout = VK_IMAGE_LAYOUT_UNDEFINED;
    attachments[0].finalLayout = colourFinalLayout;
    attachments[1].format = kDepthFormat;
    attachments[1].samples = VK_SAMPLE_COUNT_1_BIT;
    attachments[1].loadOp = VK_ATTACHMENT_LOAD_OP_CLEAR;
    attachments[1].storeOp = VK_ATTACHMENT_STORE_OP_DONT_CARE;
    attachments[1].stencilLoadOp = VK_ATTACHMENT_LOAD_OP_DONT_CARE;
    attachments[1].stencilStoreOp = VK_ATTACHMENT_STORE_OP_DONT_CARE;
    attachments[1].initialLayout = VK_IMAGE_LAYOUT_UNDEFINED;
    attachments[1].finalLayout = VK_IMAGE_LAYOUT_DEPTH_STENCIL_ATTACHMENT_OPTIMAL;
    const VkAttachmentReference colourRef{0, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL};
    const VkAttachmentReference depthRef{1, VK_IMAGE_LAYOUT_DEPTH_STENCIL_ATTACHMENT_OPTIMAL};
    VkSubpassDescription subpass{};
    subpass.pipelineBindPoint = VK_PIPELINE_BIND_POINT_GRAPHICS;
    subpass.colorAttachmentCount = 1;
    subpass.pColorAttachments = &colourRef;
    subpass.pDepthStencilAttachment = &depthRef;
    // In: the previous frame's readback copy (offscreen) or the swapchain acquire, and the
    // previous frame's depth writes, finish before this pass writes. Out: the colour is copied
    // to the readback buffer (offscreen) or presented.
    VkSubpassDependency dependencies[2]{};
    dependencies[0].srcSubpass = VK_SUBPASS_EXTERNAL;
    dependencies[0].dstSubpass = 0;
    dependencies[0].srcStageMask = VK_PIPELINE_STAGE_TRANSFER_BIT |
                                   VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT |
                                   VK_PIPELINE_STAGE_LATE_FRAGMENT_TESTS_BIT;
    dependencies[0].dstStageMask = VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT |
                                   VK_PIPELINE_STAGE_EARLY_FRAGMENT_TESTS_BIT |
                                   VK_PIPELINE_STAGE_LATE_FRAGMENT_TESTS_BIT;
    dependencies[0].srcAccessMask = VK_ACCESS_TRANSFER_READ_BIT |
                                    VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT |
                                    VK_ACCESS_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT;
    dependencies[0].dstAccessMask = VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT |
                                    VK_ACCESS_DEPTH_STENCIL_ATTACHMENT_READ_BIT |
                                    VK_ACCESS_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT;
    dependencies[1].srcSubpass = 0;
    dependencies[1].dstSubpass = VK_SUBPASS_EXTERNAL;
    dependencies[1].srcStageMask = VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT;
    dependencies[1].dstStageMask =
        VK_PIPELINE_STAGE_TRANSFER_BIT | VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT;
    dependencies[1].srcAccessMask = VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT;
    dependencies[1].dstAccessMask = VK_ACCESS_TRANSFER_READ_BIT;
    VkRenderPassCreateInfo passInfo{};
    passInfo.sType = VK_STRUCTURE_TYPE_RENDER_PASS_CREATE_INFO;
    passInfo.attachmentCount = 2;
    passInfo.pAttachments = attachments;
    passInfo.subpassCount = 1;
    passInfo.pSubpasses = &subpass;
    passInfo.dependencyCount = 2;
    passInfo.pDependencies = dependencies;
    VkRenderPass renderPass;
    VK_CHECK(vkCreateRenderPass(device.device, &passInfo, nullptr, &renderPass));
    return renderPass;

}

void createOffscreen(const Device& device, std::uint32_t width, std::uint32_t height,
                     Offscreen& offscreen) {
    assert(width > 0 && height > 0);
    offscreen.width = width;
    offscreen.height = height;
    createImage(device, width, height, kColourFormat,
                VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT,
                VK_IMAGE_ASPECT_COLOR_BIT, offscreen.colour);
    createImage(device, width, height, kDepthFormat, VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT,
                VK_IMAGE_ASPECT_DEPTH_BIT, offscreen.depth);

    offscreen.renderPass =
        createRenderPass(device, kColourFormat, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL);

    const VkImageView views[2] = {offscreen.colour.view, offscreen.depth.view};
    VkFramebufferCreateInfo fbInfo{};
    fbInfo.sType = VK_STRUCTURE_TYPE_FRAMEBUFFER_CREATE_INFO;
    fbInfo.renderPass = offscreen.renderPass;
    fbInfo.attachmentCount = 2;
    fbInfo.pAttachments = views;
    fbInfo.width = width;
    fbInfo.height = height;
    fbInfo.layers = 1;
    VK_CHECK(vkCreateFramebuffer(device.device, &fbInfo, nullptr, &offscreen.framebuffer));

    createBuffer(device, VkDeviceSize(width) * height * 4, VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                 VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT,
                 offscreen.readback);
}

void destroyOffscreen(const Device& device, Offscreen& offscreen) {
    destroyBuffer(device, offscreen.readback);
    if (offscreen.framebuffer) vkDestroyFramebuffer(device.device, offscreen.framebuffer, nullptr);
    if (offscreen.renderPass) vkDestroyRenderPass(device.device, offscreen.renderPass, nullptr);
    destroyImage(device, offscreen.depth);
    destroyImage(device, offscreen.colour);
    offscreen = Offscreen{};
}

std::string spirvDirectory(const std::string& configured) {
    if (!configured.empty()) return configured;
    const char* env = std::getenv("UNILOD_SPIRV_DIR");
    return env && *env ? env : UNILOD_SPIRV_DIR;
}

bool createPipelines(const Device& device, VkRenderPass renderPass, const std::string& spirvDir,
                     Pipelines& pipelines, std::string& error) {
    const char* names[4] = {"terrain.vert.spv", "terrain.frag.spv", "river.vert.spv",
                            "river.frag.spv"};
    VkShaderModule modules[4] = {};
    bool ok = true;
    for (int i = 0; i < 4 && ok; ++i)
        ok = createShader(device, spirvDir + "/" + names[i], modules[i], error);
    if (ok) {
        const VkPushConstantRange range{VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT,
                                        0, sizeof(shader::DrawConstants)};
        VkPipelineLayoutCreateInfo layoutInfo{};
        layoutInfo.sType = VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO;
        layoutInfo.pushConstantRangeCount = 1;
        layoutInfo.pPushConstantRanges = &range;
        VK_CHECK(vkCreatePipelineLayout(device.device, &layoutInfo, nullptr, &pipelines.layout));
        pipelines.terrain = createPipeline(device, renderPass, pipelines.layout, modules[0],
                                           modules[1], PipelineKind::Terrain);
        pipelines.river = createPipeline(device, renderPass, pipelines.layout, modules[2],
                                         modules[3], PipelineKind::River);
        if (device.fillModeNonSolid)
            pipelines.wire = createPipeline(device, renderPass, pipelines.layout, modules[0],
                                            modules[1], PipelineKind::Wire);
    }
    for (VkShaderModule m : modules)
        if (m) vkDestroyShaderModule(device.device, m, nullptr);
    return ok;
}

void destroyPipelines(const Device& device, Pipelines& pipelines) {
    if (pipelines.wire) vkDestroyPipeline(device.device, pipelines.wire, nullptr);
    if (pipelines.river) vkDestroyPipeline(device.device, pipelines.river, nullptr);
    if (pipelines.terrain) vkDestroyPipeline(device.device, pipelines.terrain, nullptr);
    if (pipelines.layout) vkDestroyPipelineLayout(device.device, pipelines.layout, nullptr);
    pipelines = Pipelines{};
}

void recordDraws(VkCommandBuffer cmd, const Pipelines& pipelines, VkBuffer geometry,
                 const FrameView& view, const std::vector<DrawBlock>& blocks,
                 VkBuffer dynamicIndices) {
    const VkViewport viewport{0, 0, float(view.width), float(view.height), 0, 1};
    const VkRect2D scissor{{0, 0}, {view.width, view.height}};
    vkCmdSetViewport(cmd, 0, 1, &viewport);
    vkCmdSetScissor(cmd, 0, 1, &scissor);
    if (blocks.empty()) return;
    const Camera& camera = view.camera;
    const double aspect = double(view.width) / view.height;
    const bool grid = view.grid && pipelines.wire;
    shader::DrawConstants constants{};
    constants.viewProj = grid ? gridViewProjection(view.gridHalfHeight, aspect)
                              : perspectiveViewProjection(camera, aspect);
    constants.zRange = shader::vec4(float(view.minZ), float(view.maxZ), grid ? 1.0f : 0.0f,
                                    grid ? 0.0f : shader::kRiverDepthBias);
    for (int pass = 0; pass < (view.rivers ? 2 : 1); ++pass) {
        vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS,
                          pass == 1 ? pipelines.river : grid ? pipelines.wire : pipelines.terrain);
        VkBuffer bound = VK_NULL_HANDLE;
        for (const DrawBlock& b : blocks) {
            const std::uint32_t count = pass == 0 ? b.terrainCount : b.riverCount;
            if (count == 0) continue;
            const VkBuffer indices = b.dynamic ? dynamicIndices : geometry;
            assert(indices != VK_NULL_HANDLE);
            if (indices != bound) {
                vkCmdBindIndexBuffer(cmd, indices, 0, VK_INDEX_TYPE_UINT32);
                bound = indices;
            }
            vkCmdBindVertexBuffers(cmd, 0, 1, &geometry, &b.vertexOffset);
            // Offsets in double, then float: block-relative floats stay precise.
            constants.blockOffset =
                shader::vec4(float(b.originX - camera.eye[0]), float(b.originY - camera.eye[1]),
                             float(-camera.eye[2]), 0.0f);
            vkCmdPushConstants(cmd, pipelines.layout,
                               VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT, 0,
                               sizeof constants, &constants);
            vkCmdDrawIndexed(cmd, count, 1, pass == 0 ? b.terrainFirst : b.riverFirst, 0, 0);
        }
    }
}

void DynamicIndices::write(const Device& device, const std::vector<std::uint32_t>& words) {
    const VkDeviceSize bytes = words.size() * sizeof(std::uint32_t);
    if (bytes == 0) return;
    if (buffer.size < bytes) {
        destroyBuffer(device, buffer);
        // Room to grow: a view that refines a little more next frame does not reallocate.
        createBuffer(device, std::max<VkDeviceSize>(bytes + bytes / 2, 1 << 16),
                     VK_BUFFER_USAGE_INDEX_BUFFER_BIT,
                     VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT,
                     buffer);
    }
    std::memcpy(buffer.mapped, words.data(), bytes);
}

void recordReadback(VkCommandBuffer cmd, const Offscreen& offscreen) {
    VkBufferImageCopy copy{};
    copy.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
    copy.imageExtent = {offscreen.width, offscreen.height, 1};
    vkCmdCopyImageToBuffer(cmd, offscreen.colour.image, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL,
                           offscreen.readback.buffer, 1, &copy);
    VkMemoryBarrier barrier{};
    barrier.sType = VK_STRUCTURE_TYPE_MEMORY_BARRIER;
    barrier.srcAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
    barrier.dstAccessMask = VK_ACCESS_HOST_READ_BIT;
    vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_HOST_BIT, 0, 1,
                         &barrier, 0, nullptr, 0, nullptr);
}

}  // namespace unilod::engine
