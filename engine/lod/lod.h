// Per-block level choice (paper §3.4, Eq. 11; DESIGN.md "Screen-space error"). Pure CPU, no
// Vulkan: the capture, the renderer and the tests share it.
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "camera.h"
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
// field of view `fovRadians` and width / height `aspect`.
double frustumEdgeFactor(double fovRadians, double aspect);

// The tolerance a block's level is chosen with (DESIGN.md "Screen-space error").
//
// `Centre` mode: Eq. 11 with S = the distance to the block's centre, as in the paper (no
// guarantee for points nearer than the centre).
//
// `Nearest` mode: Eq. 11 with an effective distance S' chosen so that, with the `max` metric,
// the drawn surface is within P pixels of every original point on screen. Let f = H / (2
// tan(fov / 2)) be the focal length in pixels and d = q - p a vertical world segment (|d| <=
// h_s) from an original point p on screen to the surface point q below or above it, both in the
// block's box, eye-relative with depths p_z, q_z > 0. Its projection has length
//   f |d_xy p_z - p_xy d_z| / (p_z q_z) <= f |d x p| / (p_z q_z) = f |d| sin(phi_p) / (q_z cos(theta_p))
// (the numerator is two components of d x p; phi_p = the angle between p and world up, theta_p
// = the angle between p and the view axis). For the block's box (camera.h BoxView):
//   cos(theta_p) >= c = max(cos(theta_c), axisCos)   (p is on screen and in the box; theta_c =
//                                                     the angle of the frustum's corner ray)
//   sin(phi_p)  <= verticalSin
//   q_z         >= max(zMin, S cos(theta_c))         (zMin: q is in the box; S cos(theta_c):
//                                                     q on screen too, at distance >= S)
// so S' = c max(zMin, S cos(theta_c)) / verticalSin bounds the error by P pixels. In a block with
// rivers or a moving outline (BoxView::horizontal) the `max` error also bounds the 3D distance
// from every original river vertex to the drawn river edge (preprocess/deletion.h); a
// displacement d in any direction projects to at most f |d| / (q_z cos(theta_p)) (|d x p| <=
// |d| |p|), so for it verticalSin is replaced by 1 (BoxView::horizontal true). Since format
// version 4 that river part is stored on its own (format::Level::errorRiver): the cut holds the
// `max` error to the tolerance with sin(phi) and the river part to the one without (cut.h
// NodeTolerance), and the drawn rivers are within P pixels of the original ones too. With no
// box information (BoxView{}: zMin 0, axisCos 0, verticalSin 1) S' = S cos^2(theta_c) <= S.
// The box terms only make S' larger where the bound allows it: blocks near the view axis (c up
// to 1 instead of cos(theta_c), about 0.65 at 60 degrees and 16:9) and blocks seen steeply from
// above (a vertical error shrinks on screen by sin(phi)). S' may exceed S.
struct ViewTolerance {
    double pixels = 1;        // P
    double fovRadians = 0;    // vertical field of view
    double width = 0, height = 0;  // viewport in pixels
    DistanceMode mode = DistanceMode::Nearest;
};
// `distance` = S of the mode; `box` = how the block's box lies in the view (Nearest mode only).
double effectiveDistance(const ViewTolerance& view, double distance, const BoxView& box = {});
double blockTolerance(const ViewTolerance& view, double distance, const BoxView& box = {});

struct LevelChoice {
    std::size_t level = 0;  // index into Block::levels
    std::uint32_t step = 0;
    double error = 0;       // h_s: the model error at that step
    double riverError = 0;  // its river part (`max` metric, stored levels; else 0)
    double nextError = -1;  // error of the next coarser stored level; -1 for the coarsest
};

// k* = the largest step k with errors[k] <= hLim (errors are non-decreasing, so the states within
// the tolerance are a prefix); 0 when even errors[0] exceeds it (nothing finer exists). The
// exact state the paper's Tables 2 and 3 count (`stats`).
std::size_t exactStep(const std::vector<float>& errors, double hLim);
// The same with the `max` metric's river part (format::Block::errorRiver) held to hRiver too:
// both tables are non-decreasing, so the steps within both bounds are the shorter prefix.
// `riverErrors` empty: the river part is not bounded apart.
std::size_t exactStep(const std::vector<float>& errors, double hLim,
                      const std::vector<float>& riverErrors, double hRiver);

// k* = the largest step with error[k] <= hLim (errors are non-decreasing, so a prefix
// qualifies); the chosen level is the stored level with the largest step <= k*. If even
// error[0] > hLim the full-resolution level is the best there is and is chosen.
LevelChoice chooseLevel(const std::vector<format::Level>& levels, const std::vector<float>& errors,
                        double hLim);

// The same choice from the stored levels' own errors (format::Level::errorMax / errorPaper,
// equal to the error table at their steps): the level with the largest step whose error is
// <= hLim and, for the `max` metric, whose river part (Level::errorRiver) is <= hRiver
// (format::storedLevelFor), or level 0 (full resolution) when none is. This is all the
// streaming engine keeps in memory per block.
LevelChoice chooseStoredLevel(const std::vector<format::Level>& levels, std::uint32_t metric,
                              double hLim, double hRiver = INFINITY);

}  // namespace unilod::engine
