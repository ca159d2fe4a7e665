// Always-on Vulkan result check (STYLE.md "Errors in three tiers"): a failing call is a
// programmer or driver error, so it prints file, line, call and result name and aborts, in every
// build type. Data errors (no device, bad file) are returned instead, never checked here.
// Exception: running out of memory (VK_ERROR_OUT_OF_HOST_MEMORY / _DEVICE_MEMORY) is neither; it
// happens to correct code under a memory limit or on a small GPU, so it throws OutOfMemory (a
// std::runtime_error naming the call and the result), which the command reports as an error with
// exit status 1 (tools/cli/main.cpp) instead of dumping core.
#pragma once

#include <vulkan/vulkan.h>

#include <cstdio>
#include <cstdlib>
#include <stdexcept>
#include <string>

namespace unilod::engine {

const char* resultName(VkResult result);

class OutOfMemory : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

// Throws OutOfMemory for the two out-of-memory results; returns for any other.
inline void throwIfOutOfMemory(VkResult result, const char* call) {
    if (result == VK_ERROR_OUT_OF_HOST_MEMORY || result == VK_ERROR_OUT_OF_DEVICE_MEMORY)
        throw OutOfMemory(std::string(call) + " failed: " + resultName(result) + " (out of " +
                          (result == VK_ERROR_OUT_OF_HOST_MEMORY ? "memory" : "GPU memory") + ")");
}

}  // namespace unilod::engine

#define VK_CHECK(call)                                                                \
    do {                                                                              \
        const VkResult vkCheckResult_ = (call);                                       \
        if (vkCheckResult_ != VK_SUCCESS) {                                           \
            ::unilod::engine::throwIfOutOfMemory(vkCheckResult_, #call);              \
            std::fprintf(stderr, "%s:%d: %s failed: %s\n", __FILE__, __LINE__, #call, \
                         ::unilod::engine::resultName(vkCheckResult_));               \
            std::abort();                                                             \
        }                                                                             \
    } while (0)
