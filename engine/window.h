// The windowed target (issue 5): a GLFW window, its surface and swapchain, and the per-frame
// synchronisation, drawing with the same render pass kind, pipelines and scene as the offscreen
// target (renderer.h). Plain structs with create/destroy pairs; destroy in reverse order after
// the device is idle (STYLE.md "Vulkan lifetimes").
//
// Frame protocol (kFramesInFlight slots, scene.h): beginWindowFrame(f) waits for slot f % 2's
// fence (frame f - 2), acquires an image and begins the slot's command buffer; the caller records
// scene.prepare(), then beginWindowPass() + scene.draw() + vkCmdEndRenderPass(), then
// endWindowFrame() submits (waiting on the acquire, signalling the image's render semaphore and
// the slot's fence) and presents. The swapchain is recreated when acquire or present report
// VK_ERROR_OUT_OF_DATE_KHR / VK_SUBOPTIMAL_KHR or GLFW reports a framebuffer resize; while the
// window is minimised (framebuffer 0 x 0) no frame begins.
#pragma once

#include <vulkan/vulkan.h>

#include <cstdint>
#include <string>
#include <vector>

#include "device.h"
#include "renderer.h"
#include "scene.h"

struct GLFWwindow;

namespace unilod::engine {

// The GLFW window alone (no Vulkan): created before the device, destroyed after it.
// Input arrives through GLFW callbacks during glfwPollEvents(); held keys and buttons are polled
// with glfwGetKey / glfwGetMouseButton.
struct Window {
    GLFWwindow* window = nullptr;
    bool resized = false;         // set by GLFW's framebuffer-size callback
    std::vector<int> keyPresses;  // GLFW key codes pressed since the consumer last cleared it
    double scroll = 0;            // vertical scroll accumulated since last cleared
};
// Initialises GLFW and opens a window of `width` x `height` without a client API. False with a
// message when there is no display (DISPLAY / WAYLAND_DISPLAY unset or unreachable) or GLFW has
// no Vulkan loader.
bool createWindow(std::uint32_t width, std::uint32_t height, const std::string& title,
                  Window& window, std::string& error);
void destroyWindow(Window& window);  // also terminates GLFW

// Adds to `options` what createDevice needs to present to `window`: GLFW's required instance
// extensions and the surface creation. `window` must outlive the device.
void addPresentation(Window& window, DeviceOptions& options);

struct Swapchain {
    VkSwapchainKHR swapchain = VK_NULL_HANDLE;
    VkFormat format = VK_FORMAT_UNDEFINED;
    VkExtent2D extent{};
    bool transferSrc = false;  // images can be copied from (screenshots)
    std::vector<VkImage> images;
    std::vector<VkImageView> views;
    std::vector<VkFramebuffer> framebuffers;
    std::vector<VkSemaphore> rendered;  // per image: the frame's commands done, present waits
    Image depth;
};

struct WindowFrameSlot {
    VkCommandBuffer cmd = VK_NULL_HANDLE;
    VkFence fence = VK_NULL_HANDLE;          // signalled: the slot's last frame completed
    VkSemaphore acquired = VK_NULL_HANDLE;   // the acquired image is ready for rendering
    std::int64_t frame = -1;                 // the frame last submitted from this slot
};

// Everything between the device and the scene for on-screen frames.
struct WindowTarget {
    Window* window = nullptr;
    VkRenderPass renderPass = VK_NULL_HANDLE;  // colour left in PRESENT_SRC
    Swapchain swapchain;
    VkCommandPool pool = VK_NULL_HANDLE;
    WindowFrameSlot slots[kFramesInFlight];
    std::uint32_t imageIndex = 0;    // the image of the frame being recorded
    std::uint32_t slot = 0;          // the slot of the frame being recorded
    Buffer screenshot;               // host-visible copy of one swapchain image
    bool screenshotPending = false;  // the frame being recorded copies its image
    std::int64_t completedFrame = -1;
};

// The device must have been created with addPresentation(window). False with a message when the
// surface offers no B8G8R8A8 format.
bool createWindowTarget(const Device& device, Window& window, WindowTarget& target,
                        std::string& error);
void destroyWindowTarget(const Device& device, WindowTarget& target);

// Begins frame `frame`: waits for the slot's previous frame, acquires an image (recreating the
// swapchain when it is out of date) and begins the slot's command buffer, returned in `cmd`.
// False when no frame can be rendered now (minimised, or the swapchain was just recreated):
// poll events and try again with the same frame number.
bool beginWindowFrame(const Device& device, WindowTarget& target, std::uint64_t frame,
                      VkCommandBuffer& cmd);
// The newest frame known complete (-1: none), for StreamingScene::prepare().
std::int64_t completedWindowFrame(const Device& device, WindowTarget& target);
// Begins the render pass on the acquired image (clear colour as the offscreen target).
void beginWindowPass(const WindowTarget& target, VkCommandBuffer cmd);
// Ends the command buffer (the caller has ended the render pass), submits and presents. With
// `screenshot` the image is also copied for readWindowScreenshot().
void endWindowFrame(const Device& device, WindowTarget& target, bool screenshot);
// Call right after endWindowFrame(..., true): waits for that frame and returns its image as RGBA8 rows, top to
// bottom. False with a message if the swapchain images cannot be copied from.
bool readWindowScreenshot(const Device& device, WindowTarget& target, std::uint32_t& width,
                          std::uint32_t& height, std::vector<std::uint8_t>& rgba,
                          std::string& error);

}  // namespace unilod::engine
