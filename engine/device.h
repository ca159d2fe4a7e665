// The Vulkan instance, optional validation with a message log, and the device (Vulkan 1.2+).
// Device selection accepts CPU devices (Mesa lavapipe in tests and CI) as well as GPUs.
#pragma once

#include <vulkan/vulkan.h>

#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

namespace unilod::engine {

struct DeviceOptions {
    bool validation = false;  // VK_LAYER_KHRONOS_validation + debug messenger
    // When the layer is not installed: false = an error, true = run without it (a debug
    // build's default, as opposed to an explicit --validation).
    bool validationOptional = false;
    int deviceIndex = -1;     // physical device index; -1: $UNILOD_DEVICE, else automatic
    // At most this many bytes in one allocation (0: the device's own limit): the tests rehearse
    // a device with less memory than the one they run on.
    std::uint64_t allocationCap = 0;
    // Presentation (engine/window.h); empty for the headless target. The instance gets these
    // extensions; `createSurface` runs right after the instance exists, so that device selection
    // can require a graphics queue family that presents to the surface and VK_KHR_swapchain.
    // False with a message: createDevice fails with it.
    std::vector<const char*> instanceExtensions;
    std::function<bool(VkInstance, VkSurfaceKHR&, std::string&)> createSurface;
};

// WARNING and ERROR messages of the validation layer, in arrival order (the callback may run
// on driver threads, hence the mutex).
struct ValidationLog {
    std::mutex mutex;
    std::vector<std::string> messages;
};

struct Device {
    VkInstance instance = VK_NULL_HANDLE;
    VkDebugUtilsMessengerEXT messenger = VK_NULL_HANDLE;
    VkSurfaceKHR surface = VK_NULL_HANDLE;  // presentation only; destroyed before the instance
    VkPhysicalDevice physical = VK_NULL_HANDLE;
    VkPhysicalDeviceProperties properties{};
    VkPhysicalDeviceMemoryProperties memory{};
    VkDevice device = VK_NULL_HANDLE;
    std::uint32_t queueFamily = 0;
    VkQueue queue = VK_NULL_HANDLE;
    std::unique_ptr<ValidationLog> log;  // non-null when validation is on
    bool fillModeNonSolid = false;       // wireframe (grid mode) available and enabled
    bool timestamps = false;             // the queue writes timestamps (GPU frame time)
    double timestampPeriodNs = 0;        // nanoseconds per timestamp tick
    VkDeviceSize maxAllocation = 0;      // maxMemoryAllocationSize (Vulkan 1.1 maintenance3)
};

// Returns false with a message when no usable Vulkan instance or device exists (an environment
// error, not a programmer error: the caller reports it and exits 1).
bool createDevice(const DeviceOptions& options, Device& device, std::string& error);
void destroyDevice(Device& device);

// Called by createDevice when it picks a CPU device (lavapipe): keep memory the process frees
// instead of handing it back to the kernel. llvmpipe mallocs and frees buffers of several MiB
// for every draw and frame; with glibc's defaults they are mmap'ed and unmapped (or trimmed off
// the heap top) each time, so every frame pays a page fault per fresh 4 KiB page. Measured on
// the 2-core machine (`unilod bench`, orbit path, 1080p, paper metric, 100 frames x 3 runs):
// page faults 147k -> 65k, the streamed run's median GPU time 10.7 -> 8.6 ms. A no-op outside
// glibc. Returns whether the settings took.
bool keepFreedHostMemory();

// Copies of the recorded validation messages.
std::vector<std::string> validationMessages(const Device& device);

// A memory type index with `properties` among `typeBits`; aborts if none (every conformant
// implementation has host-visible and device-local types for buffers and images).
std::uint32_t findMemoryType(const Device& device, std::uint32_t typeBits,
                             VkMemoryPropertyFlags properties);

}  // namespace unilod::engine
