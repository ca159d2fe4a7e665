// The windowed target: GLFW window, surface, swapchain with recreation, frames in flight.
// Synchronisation follows the usual swapchain pattern (vkguide, Khronos "swapchain semaphore
// reuse"): one acquire semaphore and one fence per frame slot, one render semaphore per swapchain
// image (present may still wait on an image's semaphore after the slot's fence has signalled).
#include "window.h"

#define GLFW_INCLUDE_VULKAN
#include <GLFW/glfw3.h>

#include <algorithm>
#include <cassert>
#include <cstdlib>

#include "vkcheck.h"

namespace unilod::engine {

namespace {

// The clear colour of the offscreen target (capture), so both targets look the same.
constexpr VkClearColorValue kClearColour = {{0.0f, 0.0f, 0.0f, 1.0f}};

std::string glfwErrorText() {
    const char* description = nullptr;
    const int code = glfwGetError(&description);
    if (code == GLFW_NO_ERROR) return "unknown GLFW error";
    return description ? description : "GLFW error " + std::to_string(code);
}

void onFramebufferSize(GLFWwindow* glfw, int, int) {
    auto* window = static_cast<Window*>(glfwGetWindowUserPointer(glfw));
    if (window) window->resized = true;
}

void onKey(GLFWwindow* glfw, int key, int, int action, int) {
    auto* window = static_cast<Window*>(glfwGetWindowUserPointer(glfw));
    if (window && action == GLFW_PRESS) window->keyPresses.push_back(key);
}

void onScroll(GLFWwindow* glfw, double, double y) {
    auto* window = static_cast<Window*>(glfwGetWindowUserPointer(glfw));
    if (window) window->scroll += y;
}

// The framebuffer size in pixels; 0 x 0 while minimised.
VkExtent2D framebufferExtent(GLFWwindow* window) {
    int w = 0, h = 0;
    glfwGetFramebufferSize(window, &w, &h);
    return {std::uint32_t(std::max(w, 0)), std::uint32_t(std::max(h, 0))};
}

bool chooseFormat(const Device& device, VkSurfaceFormatKHR& chosen, std::string& error) {
    std::uint32_t count = 0;
    VK_CHECK(vkGetPhysicalDeviceSurfaceFormatsKHR(device.physical, device.surface, &count, nullptr));
    std::vector<VkSurfaceFormatKHR> formats(count);
    VK_CHECK(
        vkGetPhysicalDeviceSurfaceFormatsKHR(device.physical, device.surface, &count, formats.data()));
    // UNORM first: the shaders write the colours the offscreen R8G8B8A8_UNORM target stores, so
    // screenshots and captures agree byte for byte.
    for (VkFormat wanted : {VK_FORMAT_B8G8R8A8_UNORM, VK_FORMAT_B8G8R8A8_SRGB}) {
        for (const VkSurfaceFormatKHR& f : formats) {
            if (f.format == wanted && f.colorSpace == VK_COLOR_SPACE_SRGB_NONLINEAR_KHR) {
                chosen = f;
                return true;
            }
        }
    }
    error = "the window surface offers neither B8G8R8A8_UNORM nor B8G8R8A8_SRGB";
    return false;
}

void destroySwapchainResources(const Device& device, Swapchain& swapchain) {
    for (VkSemaphore s : swapchain.rendered) vkDestroySemaphore(device.device, s, nullptr);
    for (VkFramebuffer f : swapchain.framebuffers) vkDestroyFramebuffer(device.device, f, nullptr);
    for (VkImageView v : swapchain.views) vkDestroyImageView(device.device, v, nullptr);
    destroyImage(device, swapchain.depth);
    swapchain.rendered.clear();
    swapchain.framebuffers.clear();
    swapchain.views.clear();
    swapchain.images.clear();
}

// (Re)creates the swapchain for the current framebuffer size, passing the old one to the driver.
// False while the window is minimised (nothing is created; the old swapchain stays).
bool createSwapchain(const Device& device, WindowTarget& target) {
    Swapchain& sc = target.swapchain;
    VkSurfaceCapabilitiesKHR caps;
    VK_CHECK(vkGetPhysicalDeviceSurfaceCapabilitiesKHR(device.physical, device.surface, &caps));
    VkExtent2D extent = caps.currentExtent;
    if (extent.width == 0xFFFFFFFFu) {  // the surface takes the swapchain's size
        extent = framebufferExtent(target.window->window);
        extent.width =
            std::clamp(extent.width, caps.minImageExtent.width, caps.maxImageExtent.width);
        extent.height =
            std::clamp(extent.height, caps.minImageExtent.height, caps.maxImageExtent.height);
    }
    if (extent.width == 0 || extent.height == 0) return false;

    VK_CHECK(vkDeviceWaitIdle(device.device));
    destroySwapchainResources(device, sc);

    std::uint32_t imageCount = caps.minImageCount + 1;
    if (caps.maxImageCount > 0) imageCount = std::min(imageCount, caps.maxImageCount);
    sc.transferSrc = (caps.supportedUsageFlags & VK_IMAGE_USAGE_TRANSFER_SRC_BIT) != 0;
    VkSwapchainCreateInfoKHR info{};
    info.sType = VK_STRUCTURE_TYPE_SWAPCHAIN_CREATE_INFO_KHR;
    info.surface = device.surface;
    info.minImageCount = imageCount;
    info.imageFormat = sc.format;
    info.imageColorSpace = VK_COLOR_SPACE_SRGB_NONLINEAR_KHR;
    info.imageExtent = extent;
    info.imageArrayLayers = 1;
    info.imageUsage = VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT |
                      (sc.transferSrc ? VK_IMAGE_USAGE_TRANSFER_SRC_BIT : 0);
    info.imageSharingMode = VK_SHARING_MODE_EXCLUSIVE;  // one queue draws and presents
    info.preTransform = (caps.supportedTransforms & VK_SURFACE_TRANSFORM_IDENTITY_BIT_KHR)
                            ? VK_SURFACE_TRANSFORM_IDENTITY_BIT_KHR
                            : caps.currentTransform;
    info.compositeAlpha = VK_COMPOSITE_ALPHA_OPAQUE_BIT_KHR;
    for (VkCompositeAlphaFlagBitsKHR a :
         {VK_COMPOSITE_ALPHA_OPAQUE_BIT_KHR, VK_COMPOSITE_ALPHA_INHERIT_BIT_KHR,
          VK_COMPOSITE_ALPHA_PRE_MULTIPLIED_BIT_KHR, VK_COMPOSITE_ALPHA_POST_MULTIPLIED_BIT_KHR}) {
        if (caps.supportedCompositeAlpha & a) {
            info.compositeAlpha = a;
            break;
        }
    }
    info.presentMode = VK_PRESENT_MODE_FIFO_KHR;  // always supported; vsync
    info.clipped = VK_TRUE;
    info.oldSwapchain = sc.swapchain;
    VkSwapchainKHR created;
    VK_CHECK(vkCreateSwapchainKHR(device.device, &info, nullptr, &created));
    if (sc.swapchain) vkDestroySwapchainKHR(device.device, sc.swapchain, nullptr);
    sc.swapchain = created;
    sc.extent = extent;

    std::uint32_t count = 0;
    VK_CHECK(vkGetSwapchainImagesKHR(device.device, sc.swapchain, &count, nullptr));
    sc.images.resize(count);
    VK_CHECK(vkGetSwapchainImagesKHR(device.device, sc.swapchain, &count, sc.images.data()));
    createImage(device, extent.width, extent.height, kDepthFormat,
                VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT, VK_IMAGE_ASPECT_DEPTH_BIT, sc.depth);
    for (VkImage image : sc.images) {
        VkImageViewCreateInfo viewInfo{};
        viewInfo.sType = VK_STRUCTURE_TYPE_IMAGE_VIEW_CREATE_INFO;
        viewInfo.image = image;
        viewInfo.viewType = VK_IMAGE_VIEW_TYPE_2D;
        viewInfo.format = sc.format;
        viewInfo.subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
        VkImageView view;
        VK_CHECK(vkCreateImageView(device.device, &viewInfo, nullptr, &view));
        sc.views.push_back(view);

        const VkImageView attachments[2] = {view, sc.depth.view};
        VkFramebufferCreateInfo fbInfo{};
        fbInfo.sType = VK_STRUCTURE_TYPE_FRAMEBUFFER_CREATE_INFO;
        fbInfo.renderPass = target.renderPass;
        fbInfo.attachmentCount = 2;
        fbInfo.pAttachments = attachments;
        fbInfo.width = extent.width;
        fbInfo.height = extent.height;
        fbInfo.layers = 1;
        VkFramebuffer framebuffer;
        VK_CHECK(vkCreateFramebuffer(device.device, &fbInfo, nullptr, &framebuffer));
        sc.framebuffers.push_back(framebuffer);

        VkSemaphoreCreateInfo semaphoreInfo{};
        semaphoreInfo.sType = VK_STRUCTURE_TYPE_SEMAPHORE_CREATE_INFO;
        VkSemaphore semaphore;
        VK_CHECK(vkCreateSemaphore(device.device, &semaphoreInfo, nullptr, &semaphore));
        sc.rendered.push_back(semaphore);
    }
    destroyBuffer(device, target.screenshot);  // sized for the old extent
    target.window->resized = false;
    return true;
}

// Barrier on one colour image of the swapchain.
void imageBarrier(VkCommandBuffer cmd, VkImage image, VkImageLayout from, VkImageLayout to,
                  VkAccessFlags srcAccess, VkAccessFlags dstAccess, VkPipelineStageFlags srcStage,
                  VkPipelineStageFlags dstStage) {
    VkImageMemoryBarrier barrier{};
    barrier.sType = VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER;
    barrier.srcAccessMask = srcAccess;
    barrier.dstAccessMask = dstAccess;
    barrier.oldLayout = from;
    barrier.newLayout = to;
    barrier.srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
    barrier.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
    barrier.image = image;
    barrier.subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
    vkCmdPipelineBarrier(cmd, srcStage, dstStage, 0, 0, nullptr, 0, nullptr, 1, &barrier);
}

}  // namespace

bool createWindow(std::uint32_t width, std::uint32_t height, const std::string& title,
                  Window& window, std::string& error) {
    if (!glfwInit()) {
        error = "cannot open a window: " + glfwErrorText() +
                " (no display? set DISPLAY, or run under xvfb-run)";
        return false;
    }
    if (!glfwVulkanSupported()) {
        error = "cannot open a window: GLFW found no Vulkan loader";
        glfwTerminate();
        return false;
    }
    glfwWindowHint(GLFW_CLIENT_API, GLFW_NO_API);
    window.window = glfwCreateWindow(int(width), int(height), title.c_str(), nullptr, nullptr);
    if (!window.window) {
        error = "cannot open a window: " + glfwErrorText();
        glfwTerminate();
        return false;
    }
    glfwSetWindowUserPointer(window.window, &window);
    glfwSetFramebufferSizeCallback(window.window, onFramebufferSize);
    glfwSetKeyCallback(window.window, onKey);
    glfwSetScrollCallback(window.window, onScroll);
    return true;
}

void destroyWindow(Window& window) {
    if (window.window) {
        glfwDestroyWindow(window.window);
        glfwTerminate();
    }
    window = Window{};
}

void addPresentation(Window& window, DeviceOptions& options) {
    std::uint32_t count = 0;
    const char** names = glfwGetRequiredInstanceExtensions(&count);
    for (std::uint32_t i = 0; i < count; ++i)
        options.instanceExtensions.push_back(names[i]);
    GLFWwindow* glfw = window.window;
    options.createSurface = [glfw](VkInstance instance, VkSurfaceKHR& surface,
                                   std::string& error) {
        const VkResult r = glfwCreateWindowSurface(instance, glfw, nullptr, &surface);
        if (r != VK_SUCCESS) {
            error = std::string("cannot create a Vulkan surface for the window: ") +
                    resultName(r) + " (" + glfwErrorText() + ")";
            return false;
        }
        return true;
    };
}

bool createWindowTarget(const Device& device, Window& window, WindowTarget& target,
                        std::string& error) {
    assert(device.surface && window.window);
    target.window = &window;
    VkSurfaceFormatKHR format;
    if (!chooseFormat(device, format, error)) return false;
    target.swapchain.format = format.format;
    target.renderPass =
        createRenderPass(device, format.format, VK_IMAGE_LAYOUT_PRESENT_SRC_KHR);

    VkCommandPoolCreateInfo poolInfo{};
    poolInfo.sType = VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO;
    poolInfo.flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT;
    poolInfo.queueFamilyIndex = device.queueFamily;
    VK_CHECK(vkCreateCommandPool(device.device, &poolInfo, nullptr, &target.pool));
    for (WindowFrameSlot& slot : target.slots) {
        VkCommandBufferAllocateInfo alloc{};
        alloc.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO;
        alloc.commandPool = target.pool;
        alloc.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
        alloc.commandBufferCount = 1;
        VK_CHECK(vkAllocateCommandBuffers(device.device, &alloc, &slot.cmd));
        VkFenceCreateInfo fenceInfo{};
        fenceInfo.sType = VK_STRUCTURE_TYPE_FENCE_CREATE_INFO;
        fenceInfo.flags = VK_FENCE_CREATE_SIGNALED_BIT;  // the first wait returns at once
        VK_CHECK(vkCreateFence(device.device, &fenceInfo, nullptr, &slot.fence));
        VkSemaphoreCreateInfo semaphoreInfo{};
        semaphoreInfo.sType = VK_STRUCTURE_TYPE_SEMAPHORE_CREATE_INFO;
        VK_CHECK(vkCreateSemaphore(device.device, &semaphoreInfo, nullptr, &slot.acquired));
    }
    // A window that opens minimised gets its swapchain at the first frame it can draw.
    createSwapchain(device, target);
    return true;
}

void destroyWindowTarget(const Device& device, WindowTarget& target) {
    destroyBuffer(device, target.screenshot);
    destroySwapchainResources(device, target.swapchain);
    if (target.swapchain.swapchain)
        vkDestroySwapchainKHR(device.device, target.swapchain.swapchain, nullptr);
    for (WindowFrameSlot& slot : target.slots) {
        if (slot.acquired) vkDestroySemaphore(device.device, slot.acquired, nullptr);
        if (slot.fence) vkDestroyFence(device.device, slot.fence, nullptr);
    }
    if (target.pool) vkDestroyCommandPool(device.device, target.pool, nullptr);
    if (target.renderPass) vkDestroyRenderPass(device.device, target.renderPass, nullptr);
    target = WindowTarget{};
}

bool beginWindowFrame(const Device& device, WindowTarget& target, std::uint64_t frame,
                      VkCommandBuffer& cmd) {
    Swapchain& sc = target.swapchain;
    const VkExtent2D fb = framebufferExtent(target.window->window);
    if (fb.width == 0 || fb.height == 0) return false;  // minimised
    // Resizes arrive as GLFW's framebuffer-size callback, or as OUT_OF_DATE / SUBOPTIMAL from
    // acquire and present (some platforms report only one of them).
    if (!sc.swapchain || target.window->resized) {
        if (!createSwapchain(device, target)) return false;
    }

    target.slot = std::uint32_t(frame % kFramesInFlight);
    WindowFrameSlot& slot = target.slots[target.slot];
    VK_CHECK(vkWaitForFences(device.device, 1, &slot.fence, VK_TRUE, UINT64_MAX));
    if (slot.frame > target.completedFrame) target.completedFrame = slot.frame;

    const VkResult acquired = vkAcquireNextImageKHR(device.device, sc.swapchain, UINT64_MAX,
                                                    slot.acquired, VK_NULL_HANDLE,
                                                    &target.imageIndex);
    if (acquired == VK_ERROR_OUT_OF_DATE_KHR) {
        // Nothing was signalled and the fence is untouched: recreate (now, or at a later call
        // while minimised) and let the caller retry.
        target.window->resized = true;
        createSwapchain(device, target);
        return false;
    }
    // SUBOPTIMAL: the image is acquired and the semaphore will signal; draw and present it,
    // the swapchain is recreated after the present.
    if (acquired != VK_SUBOPTIMAL_KHR) VK_CHECK(acquired);

    VK_CHECK(vkResetFences(device.device, 1, &slot.fence));
    slot.frame = std::int64_t(frame);
    cmd = slot.cmd;
    VK_CHECK(vkResetCommandBuffer(cmd, 0));
    VkCommandBufferBeginInfo begin{};
    begin.sType = VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO;
    begin.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
    VK_CHECK(vkBeginCommandBuffer(cmd, &begin));
    return true;
}

std::int64_t completedWindowFrame(const Device& device, WindowTarget& target) {
    for (const WindowFrameSlot& slot : target.slots)
        if (slot.frame > target.completedFrame &&
            vkGetFenceStatus(device.device, slot.fence) == VK_SUCCESS)
            target.completedFrame = slot.frame;
    return target.completedFrame;
}

void beginWindowPass(const WindowTarget& target, VkCommandBuffer cmd) {
    VkClearValue clears[2]{};
    clears[0].color = kClearColour;
    clears[1].depthStencil = {0.0f, 0};  // reversed Z: far is 0
    VkRenderPassBeginInfo begin{};
    begin.sType = VK_STRUCTURE_TYPE_RENDER_PASS_BEGIN_INFO;
    begin.renderPass = target.renderPass;
    begin.framebuffer = target.swapchain.framebuffers[target.imageIndex];
    begin.renderArea.extent = target.swapchain.extent;
    begin.clearValueCount = 2;
    begin.pClearValues = clears;
    vkCmdBeginRenderPass(cmd, &begin, VK_SUBPASS_CONTENTS_INLINE);
}

void endWindowFrame(const Device& device, WindowTarget& target, bool screenshot) {
    Swapchain& sc = target.swapchain;
    WindowFrameSlot& slot = target.slots[target.slot];
    const VkCommandBuffer cmd = slot.cmd;
    target.screenshotPending = screenshot && sc.transferSrc;
    if (target.screenshotPending) {
        const VkDeviceSize size = VkDeviceSize(sc.extent.width) * sc.extent.height * 4;
        if (target.screenshot.size != size) {
            // Only the previous screenshot frame used the buffer, and it was waited for.
            destroyBuffer(device, target.screenshot);
            createBuffer(device, size, VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                         VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT,
                         target.screenshot);
        }
        const VkImage image = sc.images[target.imageIndex];
        imageBarrier(cmd, image, VK_IMAGE_LAYOUT_PRESENT_SRC_KHR,
                     VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, VK_ACCESS_COLOR_ATTACHMENT_WRITE_BIT,
                     VK_ACCESS_TRANSFER_READ_BIT, VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT,
                     VK_PIPELINE_STAGE_TRANSFER_BIT);
        VkBufferImageCopy region{};
        region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
        region.imageExtent = {sc.extent.width, sc.extent.height, 1};
        vkCmdCopyImageToBuffer(cmd, image, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL,
                               target.screenshot.buffer, 1, &region);
        imageBarrier(cmd, image, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL,
                     VK_IMAGE_LAYOUT_PRESENT_SRC_KHR, VK_ACCESS_TRANSFER_READ_BIT, 0,
                     VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT);
        VkBufferMemoryBarrier host{};
        host.sType = VK_STRUCTURE_TYPE_BUFFER_MEMORY_BARRIER;
        host.srcAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
        host.dstAccessMask = VK_ACCESS_HOST_READ_BIT;
        host.srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
        host.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
        host.buffer = target.screenshot.buffer;
        host.size = VK_WHOLE_SIZE;
        vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_HOST_BIT, 0, 0,
                             nullptr, 1, &host, 0, nullptr);
    }
    VK_CHECK(vkEndCommandBuffer(cmd));

    const VkPipelineStageFlags waitStage = VK_PIPELINE_STAGE_COLOR_ATTACHMENT_OUTPUT_BIT;
    const VkSemaphore rendered = sc.rendered[target.imageIndex];
    VkSubmitInfo submit{};
    submit.sType = VK_STRUCTURE_TYPE_SUBMIT_INFO;
    submit.waitSemaphoreCount = 1;
    submit.pWaitSemaphores = &slot.acquired;
    submit.pWaitDstStageMask = &waitStage;
    submit.commandBufferCount = 1;
    submit.pCommandBuffers = &cmd;
    submit.signalSemaphoreCount = 1;
    submit.pSignalSemaphores = &rendered;
    VK_CHECK(vkQueueSubmit(device.queue, 1, &submit, slot.fence));

    VkPresentInfoKHR present{};
    present.sType = VK_STRUCTURE_TYPE_PRESENT_INFO_KHR;
    present.waitSemaphoreCount = 1;
    present.pWaitSemaphores = &rendered;
    present.swapchainCount = 1;
    present.pSwapchains = &sc.swapchain;
    present.pImageIndices = &target.imageIndex;
    const VkResult presented = vkQueuePresentKHR(device.queue, &present);
    if (presented == VK_ERROR_OUT_OF_DATE_KHR || presented == VK_SUBOPTIMAL_KHR) {
        target.window->resized = true;  // recreated at the next beginWindowFrame
    } else {
        VK_CHECK(presented);
    }
}

bool readWindowScreenshot(const Device& device, WindowTarget& target, std::uint32_t& width,
                          std::uint32_t& height, std::vector<std::uint8_t>& rgba,
                          std::string& error) {
    if (!target.screenshotPending) {
        error = target.swapchain.transferSrc
                    ? "no frame was rendered for the screenshot"
                    : "the window's swapchain images cannot be copied (no TRANSFER_SRC usage)";
        return false;
    }
    const WindowFrameSlot& slot = target.slots[target.slot];
    VK_CHECK(vkWaitForFences(device.device, 1, &slot.fence, VK_TRUE, UINT64_MAX));
    target.screenshotPending = false;
    width = target.swapchain.extent.width;
    height = target.swapchain.extent.height;
    const std::size_t pixels = std::size_t(width) * height;
    rgba.resize(pixels * 4);
    const auto* src = static_cast<const std::uint8_t*>(target.screenshot.mapped);
    for (std::size_t i = 0; i < pixels; ++i) {  // B8G8R8A8 -> RGBA, opaque
        rgba[4 * i + 0] = src[4 * i + 2];
        rgba[4 * i + 1] = src[4 * i + 1];
        rgba[4 * i + 2] = src[4 * i + 0];
        rgba[4 * i + 3] = 255;
    }
    return true;
}

}  // namespace unilod::engine
