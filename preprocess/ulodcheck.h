// `unilod check FILE`: every block's checksum and structure (format::Reader), then the topology
// invariants (checker.h) at EVERY stored level of every block, on the exact grid coordinates
// stored in the file; the records replayed from full resolution must reproduce every stored
// level's triangles and river edges.
#pragma once

#include <cstddef>
#include <functional>
#include <string>

namespace unilod {

struct UlodCheckSummary {
    std::size_t blocks = 0, levels = 0, steps = 0;
};

// Returns false with a precise message (file, block, level, the violation) on the first failure.
bool checkUlod(const std::string& path, UlodCheckSummary& summary, std::string& error,
               const std::function<void(std::size_t, std::size_t)>& progress = {});

}  // namespace unilod
