// Small helpers shared by the tests: a portable fixed-seed PRNG and random point sets.
#pragma once

#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include "points.h"

namespace unilod::test {

// True in an AddressSanitizer build (GCC's __SANITIZE_ADDRESS__, Clang's __has_feature): tests
// of resident memory or of address-space limits skip there (it reserves terabytes of address
// space and keeps freed memory in quarantine).
#if defined(__SANITIZE_ADDRESS__)
inline constexpr bool kAddressSanitizer = true;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
inline constexpr bool kAddressSanitizer = true;
#else
inline constexpr bool kAddressSanitizer = false;
#endif
#else
inline constexpr bool kAddressSanitizer = false;
#endif

// The pid of a process that has exited (and been reaped): no process has it now (pids are
// reused only after the range wraps). For stale-temporary tests (atomicfile.h).
inline pid_t deadPid() {
    const pid_t child = fork();
    if (child == 0) _exit(0);
    int status = 0;
    waitpid(child, &status, 0);
    return child;
}

// A fresh folder under the system temp folder, removed with everything in it at scope exit. The
// test program's name and the process id keep parallel test programs apart.
struct TempDir {
    std::filesystem::path path;
    explicit TempDir(const std::string& name)
        : path(std::filesystem::temp_directory_path() /
               ("unilod_" + std::string(program_invocation_short_name) + "_" + name + "_" +
                std::to_string(getpid()))) {
        std::filesystem::remove_all(path);
        std::filesystem::create_directories(path);
    }
    ~TempDir() {
        std::error_code ec;
        std::filesystem::remove_all(path, ec);
    }
    TempDir(const TempDir&) = delete;
    TempDir& operator=(const TempDir&) = delete;
    std::string file(const std::string& name) const { return (path / name).string(); }
    // Writes `text` to a file in the folder and returns its path.
    std::string write(const std::string& name, const std::string& text) const {
        const std::string p = file(name);
        std::ofstream(p) << text;
        return p;
    }
    std::size_t entries() const {
        return static_cast<std::size_t>(
            std::distance(std::filesystem::directory_iterator(path), {}));
    }
};

// splitmix64: identical sequences on every platform (std distributions are not).
struct Rng {
    std::uint64_t s;
    explicit Rng(std::uint64_t seed) : s(seed) {}
    std::uint64_t next() {
        std::uint64_t z = (s += 0x9e3779b97f4a7c15ULL);
        z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
        z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
        return z ^ (z >> 31);
    }
    double uniform() { return double(next() >> 11) * 0x1.0p-53; }  // [0, 1)
    double uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }
    std::uint32_t below(std::uint32_t n) { return static_cast<std::uint32_t>(next() % n); }
};

// n random terrain points in a 10 km square (smooth relief + noise) and, when `rivers` > 0,
// that many meandering polylines of `riverLen` vertices whose endpoints are locked.
inline PointSet randomPointSet(std::uint64_t seed, int n, int rivers = 0, int riverLen = 60) {
    Rng rng(seed);
    PointSet set;
    auto height = [](double x, double y) {
        return 300 + 200 * std::sin(x / 1700) * std::cos(y / 2300) + 0.02 * x;
    };
    for (int i = 0; i < n; ++i) {
        const double x = rng.uniform(0, 10000), y = rng.uniform(0, 10000);
        set.points.push_back({x, y, height(x, y) + rng.uniform(-15, 15), PointKind::Dem, false});
    }
    for (int r = 0; r < rivers; ++r) {
        Polyline line;
        double x = rng.uniform(1000, 9000), y = rng.uniform(1000, 3000);
        double heading = rng.uniform(1.2, 1.9), turn = rng.uniform(-0.4, 0.4);
        for (int k = 0; k < riverLen; ++k) {
            set.points.push_back({x, y, height(x, y) - 5, PointKind::River, false});
            line.push_back(static_cast<PointId>(set.points.size() - 1));
            if (k % 7 == 6) turn = -turn + rng.uniform(-0.1, 0.1);
            heading += turn;
            const double step = rng.uniform(40, 120);
            x += step * std::cos(heading);
            y += step * std::sin(heading);
        }
        set.points[line.front()].locked = true;
        set.points[line.back()].locked = true;
        set.rivers.push_back(std::move(line));
    }
    return set;
}

}  // namespace unilod::test
