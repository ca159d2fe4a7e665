// A small synthetic world with rivers (tools/synthetic.h) written under a test folder, and the
// build options that cut it into 2 x 2 blocks: the model the format tests start from.
#pragma once

#include <algorithm>
#include <cstdint>
#include <string>

#include "build.h"
#include "synthetic.h"
#include "testutil.h"

namespace unilod::test {

// Writes dir/synth/dem.tif and dir/synth/rivers.geojson (about `points` points, `seed`) and
// fills `o` with their paths and a block size of half the grid (2 x 2 blocks); the caller sets
// the output and any other option. False with `error` when writing fails or the world has no
// river.
inline bool writeTwoByTwoWorld(const TempDir& dir, std::size_t points, std::uint64_t seed,
                               BuildOptions& o, std::string& error) {
    SyntheticOptions so;
    so.targetPoints = points;
    so.seed = seed;
    const SyntheticData data = generateSyntheticData(so);
    if (data.rivers.empty()) {
        error = "the synthetic world has no river";
        return false;
    }
    if (!writeSyntheticData(data, dir.file("synth"), error)) return false;
    o.demPath = dir.file("synth/dem.tif");
    o.riversPath = dir.file("synth/rivers.geojson");
    o.blockSize = (std::max(data.dem.width, data.dem.height) - 1) / 2;
    return true;
}

}  // namespace unilod::test
