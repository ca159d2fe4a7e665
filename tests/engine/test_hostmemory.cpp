// engine::keepFreedHostMemory (engine/device.h): picking a CPU device (lavapipe) switches glibc
// to keeping freed memory, so llvmpipe's per-frame buffers stop costing fresh pages. Checked by
// behaviour with mallinfo2: a 30 MiB block is mmap'ed before (glibc's dynamic threshold is
// primed to 24 MiB first) and comes from the heap after the device is created.
#include <gtest/gtest.h>

#include <cstdlib>
#include <cstring>
#include <string>

#include "device.h"
#include "testutil.h"

#if defined(__GLIBC__)
#include <malloc.h>
#endif

namespace {

constexpr bool kAsan = unilod::test::kAddressSanitizer;

void* volatile sink = nullptr;  // keeps the compiler from eliding malloc / free pairs

// Allocates and touches `bytes`; returns how many mmap'ed blocks glibc holds meanwhile.
std::size_t mmappedBlocksDuring(std::size_t bytes) {
#if defined(__GLIBC__)
    void* p = std::malloc(bytes);
    EXPECT_NE(p, nullptr);
    std::memset(p, 1, bytes);
    sink = p;
    const std::size_t blocks = mallinfo2().hblks;
    std::free(sink);
    return blocks;
#else
    (void)bytes;
    return 0;
#endif
}

}  // namespace

TEST(HostMemory, CpuDeviceKeepsFreedMemory) {
#if !defined(__GLIBC__)
    GTEST_SKIP() << "not glibc: keepFreedHostMemory is a no-op";
#else
    if (kAsan) GTEST_SKIP() << "AddressSanitizer's allocator replaces glibc's malloc here";
    constexpr std::size_t kMiB = 1 << 20;
    const std::size_t before = mallinfo2().hblks;
    // Default glibc: a 24 MiB block is mmap'ed; freeing it raises the dynamic threshold to 24
    // MiB, so a 30 MiB block would still be mmap'ed without the engine's setting.
    EXPECT_EQ(mmappedBlocksDuring(24 * kMiB), before + 1);

    unilod::engine::DeviceOptions options;
    options.validation = true;
    unilod::engine::Device device;
    std::string error;
    ASSERT_TRUE(unilod::engine::createDevice(options, device, error)) << error;
    const bool cpu = device.properties.deviceType == VK_PHYSICAL_DEVICE_TYPE_CPU;
    const std::string name = device.properties.deviceName;
    unilod::engine::destroyDevice(device);
    if (!cpu) GTEST_SKIP() << "device " << name << " is not a CPU device: nothing to check";

    const std::size_t after = mallinfo2().hblks;
    EXPECT_EQ(mmappedBlocksDuring(30 * kMiB), after)
        << "a 30 MiB block was mmap'ed after a CPU device was created";
    // Larger than glibc's ceiling for the threshold (32 MiB): still mmap'ed.
    EXPECT_EQ(mmappedBlocksDuring(40 * kMiB), after + 1);
#endif
}
