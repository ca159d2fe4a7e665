// The camera: world coordinates of the file's CRS (x east, y north, z up, metres). Shared by
// the renderer (projection matrices), the per-block LOD choice (frustum culling) and the tools.
#pragma once

#include "../shaders/shared.h"

namespace unilod::engine {

// yaw 0 looks north (+y), 90 east; pitch < 0 looks down; vertical field of view in degrees.
struct Camera {
    double eye[3] = {};
    double yawDegrees = 0, pitchDegrees = 0;
    double fovDegrees = 60;
};

// Near plane of the perspective projection, metres (reversed Z, infinite far plane).
inline constexpr double kNearPlane = 1.0;

// Orthonormal view basis: forward f, right r, up u = r x f.
struct CameraBasis {
    double forward[3], right[3], up[3];
};
CameraBasis cameraBasis(const Camera& camera);

// Eye-relative world -> clip: the view rows right / up / -forward, then a reversed-Z infinite
// perspective with Vulkan's downward y. Positions reach the GPU relative to the eye.
shader::mat4 perspectiveViewProjection(const Camera& camera, double aspect);

// The 2D grid mode (paper Figures 7-12): top-down orthographic view centred below the eye,
// `halfHeight` metres from the centre to the top edge of the viewport, north up. Eye-relative
// like the perspective; depth is constant (every line is visible).
shader::mat4 gridViewProjection(double halfHeight, double aspect);

// The smallest depth along the view axis (eye-relative, metres) of the box's 8 corners: the
// smallest depth of any point of the box (depth is linear). Negative when part of the box is
// behind the eye.
double boxMinDepth(const Camera& camera, const double boxMin[3], const double boxMax[3]);

// False when the axis-aligned box lies entirely outside the perspective frustum (conservative:
// a box is kept unless one frustum plane has all 8 corners outside).
bool boxInFrustum(const Camera& camera, double aspect, const double boxMin[3],
                  const double boxMax[3]);

// The grid view's culling: false when the box's x/y extent misses the viewport rectangle.
bool boxInGridView(const Camera& camera, double halfHeight, double aspect, const double boxMin[3],
                   const double boxMax[3]);

}  // namespace unilod::engine
