// Always-on Vulkan result check (STYLE.md "Errors in three tiers"): a failing call is a
// programmer or driver error, so it prints file, line, call and result name and aborts, in every
// build type. Data errors (no device, bad file) are returned instead, never checked here.
#pragma once

#include <vulkan/vulkan.h>

#include <cstdio>
#include <cstdlib>

namespace unilod::engine {

const char* resultName(VkResult result);

}  // namespace unilod::engine

#define VK_CHECK(call)                                                                \
    do {                                                                              \
        const VkResult vkCheckResult_ = (call);                                       \
        if (vkCheckResult_ != VK_SUCCESS) {                                           \
            std::fprintf(stderr, "%s:%d: %s failed: %s\n", __FILE__, __LINE__, #call, \
                         ::unilod::engine::resultName(vkCheckResult_));               \
            std::abort();                                                             \
        }                                                                             \
    } while (0)
