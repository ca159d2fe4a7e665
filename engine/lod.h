// Per-block level choice (paper §3.4, Eq. 11; DESIGN.md "Screen-space error"). Pure CPU, no
// Vulkan: the capture, the renderer and the tests share it.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "ulod.h"

namespace unilod::engine {

// Distance from the eye to the nearest point of an axis-aligned box (0 inside it): the safe S.
double nearestBoxDistance(const double eye[3], const double boxMin[3], const double boxMax[3]);

// h_lim = 2 P S tan(fov / 2) / H: the model-space error that projects to P pixels at distance S
// for a vertical field of view `fovRadians` over H pixels.
double toleranceFor(double pixels, double distance, double fovRadians, double viewportHeight);

struct LevelChoice {
    std::size_t level = 0;  // index into Block::levels
    std::uint32_t step = 0;
    double error = 0;       // h_s: the model error at that step
    double nextError = -1;  // error of the next coarser stored level; -1 for the coarsest
};

// k* = the largest step with error[k] <= hLim (errors are non-decreasing, so a prefix
// qualifies); the chosen level is the stored level with the largest step <= k*. If even
// error[0] > hLim the full-resolution level is the best there is and is chosen.
LevelChoice chooseLevel(const std::vector<format::Level>& levels, const std::vector<float>& errors,
                        double hLim);

}  // namespace unilod::engine
