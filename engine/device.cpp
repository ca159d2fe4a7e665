// Instance, validation, physical device choice and logical device. niagara's picker skips CPU
// devices; this one ranks them last but accepts them, so the engine runs on lavapipe without a GPU.
#include "device.h"

#include <cassert>
#include <climits>
#include <cstdio>
#include <cstdlib>
#include <cstring>

#include "vkcheck.h"

#if defined(__GLIBC__)
#include <malloc.h>
#endif

namespace unilod::engine {

const char* resultName(VkResult result) {
    switch (result) {
#define UNILOD_RESULT_CASE(r) \
    case r:                   \
        return #r;
        UNILOD_RESULT_CASE(VK_SUCCESS)
        UNILOD_RESULT_CASE(VK_NOT_READY)
        UNILOD_RESULT_CASE(VK_TIMEOUT)
        UNILOD_RESULT_CASE(VK_EVENT_SET)
        UNILOD_RESULT_CASE(VK_EVENT_RESET)
        UNILOD_RESULT_CASE(VK_INCOMPLETE)
        UNILOD_RESULT_CASE(VK_ERROR_OUT_OF_HOST_MEMORY)
        UNILOD_RESULT_CASE(VK_ERROR_OUT_OF_DEVICE_MEMORY)
        UNILOD_RESULT_CASE(VK_ERROR_INITIALIZATION_FAILED)
        UNILOD_RESULT_CASE(VK_ERROR_DEVICE_LOST)
        UNILOD_RESULT_CASE(VK_ERROR_MEMORY_MAP_FAILED)
        UNILOD_RESULT_CASE(VK_ERROR_LAYER_NOT_PRESENT)
        UNILOD_RESULT_CASE(VK_ERROR_EXTENSION_NOT_PRESENT)
        UNILOD_RESULT_CASE(VK_ERROR_FEATURE_NOT_PRESENT)
        UNILOD_RESULT_CASE(VK_ERROR_INCOMPATIBLE_DRIVER)
        UNILOD_RESULT_CASE(VK_ERROR_TOO_MANY_OBJECTS)
        UNILOD_RESULT_CASE(VK_ERROR_FORMAT_NOT_SUPPORTED)
        UNILOD_RESULT_CASE(VK_ERROR_FRAGMENTED_POOL)
        UNILOD_RESULT_CASE(VK_ERROR_UNKNOWN)
        UNILOD_RESULT_CASE(VK_ERROR_OUT_OF_POOL_MEMORY)
        UNILOD_RESULT_CASE(VK_ERROR_SURFACE_LOST_KHR)
        UNILOD_RESULT_CASE(VK_SUBOPTIMAL_KHR)
        UNILOD_RESULT_CASE(VK_ERROR_OUT_OF_DATE_KHR)
#undef UNILOD_RESULT_CASE
        default:
            return "VK_RESULT_UNKNOWN";
    }
}

namespace {

constexpr const char* kValidationLayer = "VK_LAYER_KHRONOS_validation";

VKAPI_ATTR VkBool32 VKAPI_CALL onDebugMessage(VkDebugUtilsMessageSeverityFlagBitsEXT severity,
                                              VkDebugUtilsMessageTypeFlagsEXT,
                                              const VkDebugUtilsMessengerCallbackDataEXT* data,
                                              void* user) {
    auto* log = static_cast<ValidationLog*>(user);
    const char* level =
        (severity & VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT) ? "error" : "warning";
    std::string text = std::string("validation ") + level + ": " +
                       (data && data->pMessage ? data->pMessage : "(no message)");
    std::fprintf(stderr, "%s\n", text.c_str());
    std::lock_guard<std::mutex> lock(log->mutex);
    log->messages.push_back(std::move(text));
    return VK_FALSE;
}

bool hasLayer(const char* name) {
    std::uint32_t count = 0;
    VK_CHECK(vkEnumerateInstanceLayerProperties(&count, nullptr));
    std::vector<VkLayerProperties> layers(count);
    VK_CHECK(vkEnumerateInstanceLayerProperties(&count, layers.data()));
    for (const VkLayerProperties& l : layers)
        if (std::strcmp(l.layerName, name) == 0) return true;
    return false;
}

// Discrete before integrated before virtual before CPU: the CPU device is the fallback.
int rank(VkPhysicalDeviceType type) {
    switch (type) {
        case VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU:
            return 4;
        case VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU:
            return 3;
        case VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU:
            return 2;
        case VK_PHYSICAL_DEVICE_TYPE_CPU:
            return 1;
        default:
            return 0;
    }
}

bool hasDeviceExtension(VkPhysicalDevice physical, const char* name) {
    std::uint32_t count = 0;
    VK_CHECK(vkEnumerateDeviceExtensionProperties(physical, nullptr, &count, nullptr));
    std::vector<VkExtensionProperties> extensions(count);
    VK_CHECK(vkEnumerateDeviceExtensionProperties(physical, nullptr, &count, extensions.data()));
    for (const VkExtensionProperties& e : extensions)
        if (std::strcmp(e.extensionName, name) == 0) return true;
    return false;
}

// A graphics queue family; with a surface, one that also presents to it (one queue does both:
// no ownership transfers) on a device with VK_KHR_swapchain.
bool graphicsFamily(VkPhysicalDevice physical, VkSurfaceKHR surface, std::uint32_t& family) {
    if (surface && !hasDeviceExtension(physical, VK_KHR_SWAPCHAIN_EXTENSION_NAME)) return false;
    std::uint32_t count = 0;
    vkGetPhysicalDeviceQueueFamilyProperties(physical, &count, nullptr);
    std::vector<VkQueueFamilyProperties> families(count);
    vkGetPhysicalDeviceQueueFamilyProperties(physical, &count, families.data());
    for (std::uint32_t i = 0; i < count; ++i) {
        if (!(families[i].queueFlags & VK_QUEUE_GRAPHICS_BIT)) continue;
        if (surface) {
            VkBool32 present = VK_FALSE;
            VK_CHECK(vkGetPhysicalDeviceSurfaceSupportKHR(physical, i, surface, &present));
            if (!present) continue;
        }
        family = i;
        return true;
    }
    return false;
}

}  // namespace

bool createDevice(const DeviceOptions& requested, Device& device, std::string& error) {
    DeviceOptions options = requested;
    if (options.validation && options.validationOptional && !hasLayer(kValidationLayer)) {
        std::fprintf(stderr, "unilod: %s not installed: running without validation\n",
                     kValidationLayer);
        options.validation = false;
    }
    if (options.validation && !hasLayer(kValidationLayer)) {
        error = std::string("validation requested but ") + kValidationLayer +
                " is not installed (Debian: vulkan-validationlayers)";
        return false;
    }
    VkApplicationInfo app{};
    app.sType = VK_STRUCTURE_TYPE_APPLICATION_INFO;
    app.pApplicationName = "unilod";
    app.apiVersion = VK_API_VERSION_1_2;
    VkInstanceCreateInfo instanceInfo{};
    instanceInfo.sType = VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO;
    instanceInfo.pApplicationInfo = &app;
    std::vector<const char*> extensions = options.instanceExtensions;
    VkDebugUtilsMessengerCreateInfoEXT messengerInfo{};
    messengerInfo.sType = VK_STRUCTURE_TYPE_DEBUG_UTILS_MESSENGER_CREATE_INFO_EXT;
    if (options.validation) {
        device.log = std::make_unique<ValidationLog>();
        instanceInfo.enabledLayerCount = 1;
        instanceInfo.ppEnabledLayerNames = &kValidationLayer;
        extensions.push_back(VK_EXT_DEBUG_UTILS_EXTENSION_NAME);
        messengerInfo.messageSeverity = VK_DEBUG_UTILS_MESSAGE_SEVERITY_WARNING_BIT_EXT |
                                        VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT;
        messengerInfo.messageType = VK_DEBUG_UTILS_MESSAGE_TYPE_GENERAL_BIT_EXT |
                                    VK_DEBUG_UTILS_MESSAGE_TYPE_VALIDATION_BIT_EXT |
                                    VK_DEBUG_UTILS_MESSAGE_TYPE_PERFORMANCE_BIT_EXT;
        messengerInfo.pfnUserCallback = onDebugMessage;
        messengerInfo.pUserData = device.log.get();
        // Chained so that instance creation and destruction are validated too.
        instanceInfo.pNext = &messengerInfo;
    }
    instanceInfo.enabledExtensionCount = std::uint32_t(extensions.size());
    instanceInfo.ppEnabledExtensionNames = extensions.empty() ? nullptr : extensions.data();
    const VkResult created = vkCreateInstance(&instanceInfo, nullptr, &device.instance);
    if (created != VK_SUCCESS) {
        error = std::string("cannot create a Vulkan 1.2 instance: ") + resultName(created) +
                " (no Vulkan driver installed? Debian: mesa-vulkan-drivers)";
        device.instance = VK_NULL_HANDLE;
        return false;
    }
    if (options.validation) {
        auto create = reinterpret_cast<PFN_vkCreateDebugUtilsMessengerEXT>(
            vkGetInstanceProcAddr(device.instance, "vkCreateDebugUtilsMessengerEXT"));
        assert(create);
        VK_CHECK(create(device.instance, &messengerInfo, nullptr, &device.messenger));
    }
    if (options.createSurface && !options.createSurface(device.instance, device.surface, error)) {
        device.surface = VK_NULL_HANDLE;
        destroyDevice(device);
        return false;
    }

    // A driver that cannot enumerate its devices (VK_ERROR_INITIALIZATION_FAILED: a broken
    // installation, or no memory to start) is an error of the machine, not of the code.
    std::uint32_t count = 0;
    VkResult listed = vkEnumeratePhysicalDevices(device.instance, &count, nullptr);
    std::vector<VkPhysicalDevice> physicals(count);
    if (listed == VK_SUCCESS)
        listed = vkEnumeratePhysicalDevices(device.instance, &count, physicals.data());
    if (listed != VK_SUCCESS && listed != VK_INCOMPLETE) {
        destroyDevice(device);
        throwIfOutOfMemory(listed, "vkEnumeratePhysicalDevices");
        error = std::string("cannot list the Vulkan devices: vkEnumeratePhysicalDevices failed: ") +
                resultName(listed);
        return false;
    }
    physicals.resize(count);

    int index = options.deviceIndex;
    if (index < 0) {
        if (const char* env = std::getenv("UNILOD_DEVICE"); env && *env) {
            char* end = nullptr;
            const long v = std::strtol(env, &end, 10);
            if (*end != '\0' || v < 0) {
                error = std::string("UNILOD_DEVICE='") + env + "' is not a device index";
                destroyDevice(device);
                return false;
            }
            index = int(v);
        }
    }
    int best = -1, bestRank = -1;
    for (std::uint32_t i = 0; i < count; ++i) {
        VkPhysicalDeviceProperties p;
        vkGetPhysicalDeviceProperties(physicals[i], &p);
        std::uint32_t family;
        const bool usable =
            p.apiVersion >= VK_API_VERSION_1_2 && graphicsFamily(physicals[i], device.surface, family);
        if (index >= 0) {
            if (std::uint32_t(index) == i && !usable) {
                error = "Vulkan device " + std::to_string(i) + " (" + p.deviceName +
                        ") has no Vulkan 1.2 graphics queue" +
                        (device.surface ? " that presents to the window" : "");
                destroyDevice(device);
                return false;
            }
            if (std::uint32_t(index) == i) best = int(i);
            continue;
        }
        if (usable && rank(p.deviceType) > bestRank) {
            best = int(i);
            bestRank = rank(p.deviceType);
        }
    }
    if (best < 0) {
        error = index >= 0 ? "Vulkan device index " + std::to_string(index) + " out of range (" +
                                 std::to_string(count) + " devices)"
                           : std::string("no Vulkan 1.2 device with a graphics queue") +
                                 (device.surface ? " that presents to the window" : "") + " (" +
                                 std::to_string(count) + " devices found)";
        destroyDevice(device);
        return false;
    }
    device.physical = physicals[std::size_t(best)];
    vkGetPhysicalDeviceProperties(device.physical, &device.properties);
    if (device.properties.deviceType == VK_PHYSICAL_DEVICE_TYPE_CPU) keepFreedHostMemory();
    vkGetPhysicalDeviceMemoryProperties(device.physical, &device.memory);
    {
        VkPhysicalDeviceMaintenance3Properties m3{};
        m3.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_MAINTENANCE_3_PROPERTIES;
        VkPhysicalDeviceProperties2 p2{};
        p2.sType = VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2;
        p2.pNext = &m3;
        vkGetPhysicalDeviceProperties2(device.physical, &p2);
        device.maxAllocation = m3.maxMemoryAllocationSize;
        if (options.allocationCap > 0)
            device.maxAllocation = device.maxAllocation > 0
                                       ? std::min<VkDeviceSize>(device.maxAllocation,
                                                                options.allocationCap)
                                       : options.allocationCap;
    }
    graphicsFamily(device.physical, device.surface, device.queueFamily);

    const float priority = 1.0f;
    VkDeviceQueueCreateInfo queueInfo{};
    queueInfo.sType = VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO;
    queueInfo.queueFamilyIndex = device.queueFamily;
    queueInfo.queueCount = 1;
    queueInfo.pQueuePriorities = &priority;
    VkPhysicalDeviceFeatures supported{}, enabled{};
    vkGetPhysicalDeviceFeatures(device.physical, &supported);
    enabled.fillModeNonSolid = supported.fillModeNonSolid;
    device.fillModeNonSolid = supported.fillModeNonSolid == VK_TRUE;
    {
        std::uint32_t familyCount = 0;
        vkGetPhysicalDeviceQueueFamilyProperties(device.physical, &familyCount, nullptr);
        std::vector<VkQueueFamilyProperties> families(familyCount);
        vkGetPhysicalDeviceQueueFamilyProperties(device.physical, &familyCount, families.data());
        device.timestamps = families[device.queueFamily].timestampValidBits > 0 &&
                            device.properties.limits.timestampPeriod > 0;
        device.timestampPeriodNs = device.properties.limits.timestampPeriod;
    }
    VkDeviceCreateInfo deviceInfo{};
    deviceInfo.sType = VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO;
    deviceInfo.queueCreateInfoCount = 1;
    deviceInfo.pQueueCreateInfos = &queueInfo;
    deviceInfo.pEnabledFeatures = &enabled;
    const char* swapchainExtension = VK_KHR_SWAPCHAIN_EXTENSION_NAME;
    if (device.surface) {
        deviceInfo.enabledExtensionCount = 1;
        deviceInfo.ppEnabledExtensionNames = &swapchainExtension;
    }
    // As for the device list: a driver that cannot create the device (VK_ERROR_UNKNOWN,
    // _INITIALIZATION_FAILED, also under a memory limit) is reported, not a programmer error.
    const VkResult made = vkCreateDevice(device.physical, &deviceInfo, nullptr, &device.device);
    if (made != VK_SUCCESS) {
        device.device = VK_NULL_HANDLE;
        destroyDevice(device);
        throwIfOutOfMemory(made, "vkCreateDevice");
        error = std::string("cannot create the Vulkan device: vkCreateDevice failed: ") +
                resultName(made);
        return false;
    }
    vkGetDeviceQueue(device.device, device.queueFamily, 0, &device.queue);
    return true;
}

bool keepFreedHostMemory() {
#if defined(__GLIBC__)
    // 32 MiB: the largest mmap threshold glibc accepts on 64-bit; larger blocks are still
    // mmap'ed. The trim threshold keeps the heap top. (Under AddressSanitizer mallopt is a
    // no-op that returns 0: its own allocator is in charge.)
    const bool mmap = mallopt(M_MMAP_THRESHOLD, 32 << 20) == 1;
    const bool trim = mallopt(M_TRIM_THRESHOLD, INT_MAX) == 1;
    return mmap && trim;
#else
    return false;
#endif
}

void destroyDevice(Device& device) {
    if (device.device) vkDestroyDevice(device.device, nullptr);
    if (device.surface) vkDestroySurfaceKHR(device.instance, device.surface, nullptr);
    if (device.messenger) {
        auto destroy = reinterpret_cast<PFN_vkDestroyDebugUtilsMessengerEXT>(
            vkGetInstanceProcAddr(device.instance, "vkDestroyDebugUtilsMessengerEXT"));
        destroy(device.instance, device.messenger, nullptr);
    }
    if (device.instance) vkDestroyInstance(device.instance, nullptr);
    device.device = VK_NULL_HANDLE;
    device.messenger = VK_NULL_HANDLE;
    device.surface = VK_NULL_HANDLE;
    device.instance = VK_NULL_HANDLE;
}

std::vector<std::string> validationMessages(const Device& device) {
    if (!device.log) return {};
    std::lock_guard<std::mutex> lock(device.log->mutex);
    return device.log->messages;
}

std::uint32_t findMemoryType(const Device& device, std::uint32_t typeBits,
                             VkMemoryPropertyFlags properties) {
    for (std::uint32_t i = 0; i < device.memory.memoryTypeCount; ++i)
        if ((typeBits & (1u << i)) &&
            (device.memory.memoryTypes[i].propertyFlags & properties) == properties)
            return i;
    std::fprintf(stderr, "no Vulkan memory type with properties 0x%x\n", properties);
    std::abort();
}

}  // namespace unilod::engine
