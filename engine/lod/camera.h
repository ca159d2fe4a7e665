// The camera: world coordinates of the file's CRS (x east, y north, z up, metres). Shared by
// the renderer (projection matrices), the per-block LOD choice (frustum culling) and the tools.
#pragma once

#include "shared.h"  // shaders/shared.h: the matrix type the renderer pushes

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
// The same with the camera's basis already computed (cameraBasis(camera)): per-frame loops.
double boxMinDepth(const Camera& camera, const CameraBasis& basis, const double boxMin[3],
                   const double boxMax[3]);

// How a box lies in the view: what the nearest-distance tolerance needs (lod.h
// effectiveDistance). Every value is exact for the box (not only its corners): each is an
// extreme of a function over the box that a convex set decides, so the 8 corners decide it.
struct BoxView {
    // boxMinDepth (depth is linear).
    double minDepth = 0;
    // cos of the largest angle between the view axis and a ray from the eye to a point of the
    // box; 0 (no information) unless every corner makes an angle < 90 degrees with the axis
    // ({x : angle(x, axis) <= t} is a convex cone for t < 90 degrees, so the box is inside it
    // exactly when its corners are).
    double axisCos = 0;
    // The largest sin of the angle between world up (+z) and a ray from the eye to a point of
    // the box: the factor by which a vertical segment at that point shortens in projection. 1
    // when the eye's height is within the box's z range; otherwise the largest over the corners
    // (the box is then entirely below or above the eye, and {x : angle(x, down) <= t} is a
    // convex cone).
    double verticalSin = 1;
    // The block's `max` error also bounds horizontal displacements: the 3D deviation of its
    // rivers (preprocess/deletion.h), which a view from above does not shrink. Set by the
    // caller for a block with river edges; lod.h effectiveDistance then uses 1 for verticalSin.
    bool horizontal = false;
};
BoxView boxView(const Camera& camera, const double boxMin[3], const double boxMax[3]);
BoxView boxView(const Camera& camera, const CameraBasis& basis, const double boxMin[3],
                const double boxMax[3]);

// False when the axis-aligned box lies entirely outside the perspective frustum (conservative:
// a box is kept unless one frustum plane has all 8 corners outside).
bool boxInFrustum(const Camera& camera, double aspect, const double boxMin[3],
                  const double boxMax[3]);
bool boxInFrustum(const Camera& camera, const CameraBasis& basis, double aspect,
                  const double boxMin[3], const double boxMax[3]);
// The same test with the frustum's planes computed once (many boxes of one view: refine.h).
struct Frustum {
    double eye[3] = {}, forward[3] = {};
    double planes[4][3] = {};  // inward normals of the side planes, through the eye
};
Frustum viewFrustum(const Camera& camera, const CameraBasis& basis, double aspect);
bool boxInFrustum(const Frustum& frustum, const double boxMin[3], const double boxMax[3]);

// The grid view's culling: false when the box's x/y extent misses the viewport rectangle.
bool boxInGridView(const Camera& camera, double halfHeight, double aspect, const double boxMin[3],
                   const double boxMax[3]);

}  // namespace unilod::engine
