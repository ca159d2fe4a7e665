// `unilod check FILE`: every block's checksum, structure and level geometry (format::Reader::
// readBlock, i.e. format::validateBlock and validateLevelGeometry: the same validation every other
// reader path runs, engine included), then the topology invariants (checker.h) at EVERY stored
// level of every block, on the exact grid coordinates
// stored in the file; the records replayed from full resolution must reproduce every stored
// level's triangles and river edges. Across blocks: neighbours of one tree level meet edge to edge
// (ulodcheck.cpp SharedBorders: the same border edges, heights and locked ends on both sides). With
// `errors` (`--errors`), also the TRUE `max` model error at every stored level, recomputed from the
// file's own data (errorcheck.h): a stored bound below it beyond the documented tolerance is a
// failure.
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>

namespace unilod {

struct UlodCheckOptions {
    bool errors = false;  // recompute the `max` error at every stored level (errorcheck.h)
    // Threads checking entries at once (0: every core, at most engine::WorkerPool::kMaxThreads);
    // the result does not depend on it.
    std::size_t threads = 0;
};

struct UlodCheckSummary {
    std::size_t blocks = 0, levels = 0, steps = 0;
    // With options.errors: how close the recomputed `max` error comes to the stored one. Ratio:
    // the largest recomputed / stored over levels with a stored error > 0, and where it is;
    // margin: the smallest stored - recomputed (metres; negative only within the tolerance).
    bool errorsChecked = false;
    double worstRatio = 0, worstStored = 0, worstRecomputed = 0;
    std::uint32_t worstCol = 0, worstRow = 0, worstTreeLevel = 0, worstLevel = 0;
    double smallestMargin = 0;
    // The largest recomputed river deviation of an original river point at a tree node's level
    // (errorcheck.h NodeOriginalError; 0 without nodes or rivers).
    double nodeRiverWorst = 0;
    // The smallest stored river part (format::Level::errorRiver) minus the recomputed river
    // deviation over the levels checked (metres; infinity when none has a river or outline).
    double riverMargin = INFINITY;
};

// Returns false with a precise message (file, block, level, the violation) on the first failure.
bool checkUlod(const std::string& path, const UlodCheckOptions& options, UlodCheckSummary& summary,
               std::string& error,
               const std::function<void(std::size_t, std::size_t)>& progress = {});

}  // namespace unilod
