#include "headless.h"

#include <chrono>
#include <cstring>

#include "vkcheck.h"

namespace unilod::engine {

struct HeadlessRenderer::Impl {
    HeadlessOptions options;
    Device device;
    bool deviceOpen = false;
    StreamingScene scene;
    bool sceneOpen = false;
    Offscreen offscreen;
    Pipelines pipelines;
    VkCommandPool pool = VK_NULL_HANDLE;
    VkQueryPool queries = VK_NULL_HANDLE;
    struct Slot {
        VkCommandBuffer cmd = VK_NULL_HANDLE;
        VkFence fence = VK_NULL_HANDLE;
        bool pending = false;
        FrameTiming timing;
        DynamicIndices bareIndices;  // renderBareFrame's refined index data
    } slots[kFramesInFlight];
    std::uint64_t nextFrame = 0;
    std::int64_t completed = -1;
    std::vector<FrameTiming> done;

    // Waits for a slot's frame and collects its timing.
    void retire(std::uint32_t index) {
        Slot& slot = slots[index];
        if (!slot.pending) return;
        VK_CHECK(vkWaitForFences(device.device, 1, &slot.fence, VK_TRUE, UINT64_MAX));
        slot.pending = false;
        if (queries) {
            std::uint64_t ticks[2] = {};
            const VkResult r =
                vkGetQueryPoolResults(device.device, queries, index * 2, 2, sizeof ticks, ticks,
                                      sizeof ticks[0], VK_QUERY_RESULT_64_BIT);
            if (r == VK_SUCCESS)
                slot.timing.gpuMs = double(ticks[1] - ticks[0]) * device.timestampPeriodNs * 1e-6;
        }
        completed = std::max(completed, std::int64_t(slot.timing.frame));
        done.push_back(slot.timing);
    }
};

HeadlessRenderer::HeadlessRenderer() : impl_(std::make_unique<Impl>()) {}
HeadlessRenderer::~HeadlessRenderer() { close(); }

bool HeadlessRenderer::open(const HeadlessOptions& options, std::string& error) {
    Impl& h = *impl_;
    h.options = options;
    if (!createDevice(options.device, h.device, error)) return false;
    h.deviceOpen = true;
    if (!h.scene.open(h.device, options.path, options.scene, error)) return false;
    h.sceneOpen = true;
    createOffscreen(h.device, options.width, options.height, h.offscreen);
    if (!createPipelines(h.device, h.offscreen.renderPass, spirvDirectory(options.spirvDir),
                         h.pipelines, error))
        return false;
    VkCommandPoolCreateInfo poolInfo{};
    poolInfo.sType = VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO;
    poolInfo.flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT;
    poolInfo.queueFamilyIndex = h.device.queueFamily;
    VK_CHECK(vkCreateCommandPool(h.device.device, &poolInfo, nullptr, &h.pool));
    for (auto& slot : h.slots) {
        VkCommandBufferAllocateInfo alloc{};
        alloc.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO;
        alloc.commandPool = h.pool;
        alloc.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
        alloc.commandBufferCount = 1;
        VK_CHECK(vkAllocateCommandBuffers(h.device.device, &alloc, &slot.cmd));
        VkFenceCreateInfo fenceInfo{};
        fenceInfo.sType = VK_STRUCTURE_TYPE_FENCE_CREATE_INFO;
        VK_CHECK(vkCreateFence(h.device.device, &fenceInfo, nullptr, &slot.fence));
    }
    if (h.device.timestamps) {
        VkQueryPoolCreateInfo q{};
        q.sType = VK_STRUCTURE_TYPE_QUERY_POOL_CREATE_INFO;
        q.queryType = VK_QUERY_TYPE_TIMESTAMP;
        q.queryCount = 2 * kFramesInFlight;
        VK_CHECK(vkCreateQueryPool(h.device.device, &q, nullptr, &h.queries));
    }
    return true;
}

std::vector<std::string> HeadlessRenderer::close() {
    Impl& h = *impl_;
    if (!h.deviceOpen) return {};
    VK_CHECK(vkDeviceWaitIdle(h.device.device));
    if (h.queries) vkDestroyQueryPool(h.device.device, h.queries, nullptr);
    for (auto& slot : h.slots) {
        if (slot.fence) vkDestroyFence(h.device.device, slot.fence, nullptr);
        slot.bareIndices.destroy(h.device);
    }
    if (h.pool) vkDestroyCommandPool(h.device.device, h.pool, nullptr);
    destroyPipelines(h.device, h.pipelines);
    destroyOffscreen(h.device, h.offscreen);
    if (h.sceneOpen) h.scene.close();
    h.sceneOpen = false;
    std::vector<std::string> messages = validationMessages(h.device);
    destroyDevice(h.device);
    h.deviceOpen = false;
    h.queries = VK_NULL_HANDLE;
    h.pool = VK_NULL_HANDLE;
    for (auto& slot : h.slots) slot = Impl::Slot{};
    return messages;
}

bool HeadlessRenderer::renderFrame(const FrameView& view, bool draw,
                                   std::vector<std::uint8_t>* rgba, std::string& error) {
    return record(view, draw, nullptr, nullptr, VK_NULL_HANDLE, rgba, error);
}

void HeadlessRenderer::renderBareFrame(const FrameView& view, const std::vector<DrawBlock>& draws,
                                       const std::vector<std::uint32_t>& indices) {
    std::string error;
    record(view, true, &draws, &indices, VK_NULL_HANDLE, nullptr, error);
}

void HeadlessRenderer::renderMeshFrame(const FrameView& view, VkBuffer geometry,
                                       const std::vector<DrawBlock>& draws,
                                       std::vector<std::uint8_t>* rgba) {
    static const std::vector<std::uint32_t> kNoIndices;
    std::string error;
    record(view, true, &draws, &kNoIndices, geometry, rgba, error);
}

bool HeadlessRenderer::record(const FrameView& view, bool draw, const std::vector<DrawBlock>* bare,
                              const std::vector<std::uint32_t>* bareIndices, VkBuffer bareGeometry,
                              std::vector<std::uint8_t>* rgba, std::string& error) {
    Impl& h = *impl_;
    const std::uint64_t frame = h.nextFrame++;
    const std::uint32_t index = std::uint32_t(frame % kFramesInFlight);
    Impl::Slot& slot = h.slots[index];
    h.retire(index);  // frame - kFramesInFlight
    // CPU time is the frame's own work: waiting for frame - kFramesInFlight is not counted.
    const auto start = std::chrono::steady_clock::now();
    VK_CHECK(vkResetFences(h.device.device, 1, &slot.fence));
    VK_CHECK(vkResetCommandBuffer(slot.cmd, 0));
    VkCommandBufferBeginInfo begin{};
    begin.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO;
    begin.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
    VK_CHECK(vkBeginCommandBuffer(slot.cmd, &begin));
    if (h.queries) {
        vkCmdResetQueryPool(slot.cmd, h.queries, index * 2, 2);
        vkCmdWriteTimestamp(slot.cmd, VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, h.queries, index * 2);
    }
    const bool ok = bare || h.scene.prepare(slot.cmd, frame, h.completed, view, error);
    if (draw) {
        VkClearValue clears[2]{};
        clears[0].color = {{0.0f, 0.0f, 0.0f, 1.0f}};
        clears[1].depthStencil = {0.0f, 0};  // reversed Z: far is 0
        VkRenderPassBeginInfo pass{};
        pass.sType = VK_STRUCTURE_TYPE_RENDER_PASS_BEGIN_INFO;
        pass.renderPass = h.offscreen.renderPass;
        pass.framebuffer = h.offscreen.framebuffer;
        pass.renderArea = {{0, 0}, {h.offscreen.width, h.offscreen.height}};
        pass.clearValueCount = 2;
        pass.pClearValues = clears;
        vkCmdBeginRenderPass(slot.cmd, &pass, VK_SUBPASS_CONTENTS_INLINE);
        if (bare) {
            slot.bareIndices.write(h.device, *bareIndices);
            recordDraws(slot.cmd, h.pipelines,
                        bareGeometry != VK_NULL_HANDLE ? bareGeometry : h.scene.geometryBuffer(),
                        view, *bare, slot.bareIndices.buffer.buffer);
        } else
            h.scene.draw(slot.cmd, h.pipelines, view);
        vkCmdEndRenderPass(slot.cmd);
        if (rgba) recordReadback(slot.cmd, h.offscreen);
    }
    if (h.queries)
        vkCmdWriteTimestamp(slot.cmd, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, h.queries,
                            index * 2 + 1);
    VK_CHECK(vkEndCommandBuffer(slot.cmd));
    VkSubmitInfo submit{};
    submit.sType = VK_STRUCTURE_TYPE_SUBMIT_INFO;
    submit.commandBufferCount = 1;
    submit.pCommandBuffers = &slot.cmd;
    VK_CHECK(vkQueueSubmit(h.device.queue, 1, &submit, slot.fence));
    slot.pending = true;
    slot.timing = FrameTiming{};
    slot.timing.frame = frame;
    if (!bare) slot.timing.stats = h.scene.stats();
    slot.timing.cpuMs =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    if (rgba && draw) {
        h.retire(index);
        const auto* bytes = static_cast<const std::uint8_t*>(h.offscreen.readback.mapped);
        rgba->assign(bytes, bytes + h.offscreen.readback.size);
    }
    return ok;
}

std::vector<FrameTiming> HeadlessRenderer::finish() {
    Impl& h = *impl_;
    // Oldest first.
    const std::uint64_t next = h.nextFrame;
    for (std::uint64_t f = next >= kFramesInFlight ? next - kFramesInFlight : 0; f < next; ++f)
        h.retire(std::uint32_t(f % kFramesInFlight));
    std::vector<FrameTiming> out;
    out.swap(h.done);
    return out;
}

StreamingScene& HeadlessRenderer::scene() { return impl_->scene; }
const Device& HeadlessRenderer::device() const { return impl_->device; }
const Pipelines& HeadlessRenderer::pipelines() const { return impl_->pipelines; }

FrameView HeadlessRenderer::view(const Camera& camera) const {
    FrameView v;
    v.camera = camera;
    v.width = impl_->options.width;
    v.height = impl_->options.height;
    v.minZ = impl_->scene.header().minZ;
    v.maxZ = impl_->scene.header().maxZ;
    return v;
}

}  // namespace unilod::engine
