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

// How S is measured (DESIGN.md "Screen-space error"): `Nearest` = distance to the nearest point
// of the block's bounding box (the safe default), `Centre` = distance to the box centre (the
// paper's choice; no guarantee for points nearer than the centre).
enum class DistanceMode { Nearest, Centre };
double blockDistance(DistanceMode mode, const double eye[3], const double boxMin[3],
                     const double boxMax[3]);

// cos^2 of the angle between the view axis and a corner ray of the frustum, for a vertical
// field of view `fovRadians` and width / height `aspect`. A world segment of length h whose end
// points are inside the frustum at Euclidean distances >= S projects to at most
// f * h / (S * cos^2(theta_c)) pixels (f = H / (2 tan(fov / 2))): the depth of a point is at
// least its distance times cos(theta_c), and the projection's magnification is d / (z1 * z2)
// (Cauchy-Schwarz on the perspective division). So in `Nearest` mode the level is chosen with
// S * frustumEdgeFactor: the P-pixel bound then holds anywhere on screen, not only at the centre.
double frustumEdgeFactor(double fovRadians, double aspect);

// The tolerance a block's level is chosen with: Eq. 11 with S in `Centre` mode (the paper),
// with S * frustumEdgeFactor in `Nearest` mode (a guarantee: see above).
struct ViewTolerance {
    double pixels = 1;        // P
    double fovRadians = 0;    // vertical field of view
    double width = 0, height = 0;  // viewport in pixels
    DistanceMode mode = DistanceMode::Nearest;
};
double blockTolerance(const ViewTolerance& view, double distance);

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

// The same choice from the stored levels' own errors (format::Level::errorMax / errorPaper,
// equal to the error table at their steps): the level with the largest step whose error is
// <= hLim, or level 0 (full resolution) when none is. This is all the streaming engine keeps
// in memory per block.
LevelChoice chooseStoredLevel(const std::vector<format::Level>& levels, std::uint32_t metric,
                              double hLim);

}  // namespace unilod::engine
