// Camera paths (PATH.json) and the default fly-over of a model: what `capture`, `bench`, `report`
// and the benchmark programs fly along. CPU only (no Vulkan), beside the camera it moves.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "camera.h"
#include "ulod.h"

namespace unilod::engine {

// A camera path (PATH.json): {"fov": 60, "keyframes": [{"eye": [x, y, z], "yaw": d,
// "pitch": d}, ...]}. Frames are sampled at equal steps of the keyframe parameter.
struct CameraPath {
    std::vector<Camera> keyframes;
};
// False with a message naming the file (unreadable, not JSON, a missing or non-finite field,
// pitch outside [-90, 90], no keyframe).
bool loadCameraPath(const std::string& path, CameraPath& out, std::string& error);
// `frames` cameras along the path: keyframe parameter t = i * (K - 1) / (frames - 1), eye, yaw
// (the short way round) and pitch interpolated linearly. One keyframe: `frames` copies.
std::vector<Camera> sampleCameraPath(const CameraPath& path, std::uint32_t frames);

// Finite eye, yaw and pitch, pitch in [-90, 90], fov in (0, 180).
bool validCamera(const Camera& camera);

// `unilod bench`'s path without --path: a straight oblique fly-over of the data at a fifth of its
// width above its top, looking ahead and down 25 degrees, from 10 % to 90 % of the way from the
// south-west corner to the north-east one.
CameraPath defaultFlyOver(const format::Header& header);

// `unilod capture`'s camera without --camera or --path: the whole model in view, seen from the
// south 35 degrees above the horizon, looking at its centre (60 degree field of view).
Camera defaultOverview(const format::Header& header);

}  // namespace unilod::engine
