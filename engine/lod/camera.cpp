#include "camera.h"

#include <cmath>

namespace unilod::engine {

namespace {
constexpr double kDegree = 3.14159265358979323846 / 180.0;

double dot(const double a[3], const double b[3]) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
}  // namespace

double boxMinDepth(const Camera& camera, const double boxMin[3], const double boxMax[3]) {
    return boxMinDepth(camera, cameraBasis(camera), boxMin, boxMax);
}

double boxMinDepth(const Camera& camera, const CameraBasis& b, const double boxMin[3],
                   const double boxMax[3]) {
    // Per axis the corner coordinate that minimises the dot product with the forward vector.
    double depth = 0;
    for (int k = 0; k < 3; ++k)
        depth += b.forward[k] * ((b.forward[k] >= 0 ? boxMin[k] : boxMax[k]) - camera.eye[k]);
    return depth;
}

BoxView boxView(const Camera& camera, const double boxMin[3], const double boxMax[3]) {
    return boxView(camera, cameraBasis(camera), boxMin, boxMax);
}

BoxView boxView(const Camera& camera, const CameraBasis& b, const double boxMin[3],
                const double boxMax[3]) {
    BoxView v;
    v.minDepth = boxMinDepth(camera, b, boxMin, boxMax);
    const bool beside = camera.eye[2] >= boxMin[2] && camera.eye[2] <= boxMax[2];
    double axisCos = 1, verticalSin = beside ? 1.0 : 0.0;
    for (int c = 0; c < 8; ++c) {
        double p[3];
        for (int j = 0; j < 3; ++j) p[j] = ((c >> j) & 1 ? boxMax[j] : boxMin[j]) - camera.eye[j];
        // sqrt, not hypot: no overflow at these magnitudes, and several times faster (refine.h
        // evaluates thousands of boxes a frame).
        const double horizontal2 = p[0] * p[0] + p[1] * p[1];
        const double horizontal = std::sqrt(horizontal2);
        const double length = std::sqrt(horizontal2 + p[2] * p[2]);
        if (!(length > 0)) return BoxView{v.minDepth, 0.0, 1.0};  // the eye is a corner
        axisCos = std::min(axisCos, dot(b.forward, p) / length);
        if (!beside) verticalSin = std::max(verticalSin, horizontal / length);
    }
    v.axisCos = std::max(axisCos, 0.0);
    v.verticalSin = verticalSin;
    return v;
}

CameraBasis cameraBasis(const Camera& camera) {
    const double yaw = camera.yawDegrees * kDegree, pitch = camera.pitchDegrees * kDegree;
    CameraBasis b{};
    b.forward[0] = std::sin(yaw) * std::cos(pitch);
    b.forward[1] = std::cos(yaw) * std::cos(pitch);
    b.forward[2] = std::sin(pitch);
    b.right[0] = std::cos(yaw);
    b.right[1] = -std::sin(yaw);
    b.right[2] = 0.0;
    const double* r = b.right;
    const double* f = b.forward;
    b.up[0] = r[1] * f[2] - r[2] * f[1];
    b.up[1] = r[2] * f[0] - r[0] * f[2];
    b.up[2] = r[0] * f[1] - r[1] * f[0];
    return b;
}

shader::mat4 perspectiveViewProjection(const Camera& camera, double aspect) {
    const CameraBasis b = cameraBasis(camera);
    const double focal = 1.0 / std::tan(camera.fovDegrees * kDegree / 2.0);
    shader::mat4 m(0.0f);
    for (int j = 0; j < 3; ++j) {
        m[j][0] = float(focal / aspect * b.right[j]);
        m[j][1] = float(-focal * b.up[j]);
        m[j][3] = float(b.forward[j]);
    }
    m[3][2] = float(kNearPlane);
    return m;
}

shader::mat4 gridViewProjection(double halfHeight, double aspect) {
    shader::mat4 m(0.0f);
    m[0][0] = float(1.0 / (halfHeight * aspect));
    m[1][1] = float(-1.0 / halfHeight);  // north up on screen (Vulkan y points down)
    m[3][2] = 0.5f;                      // constant depth
    m[3][3] = 1.0f;
    return m;
}

bool boxInFrustum(const Camera& camera, double aspect, const double boxMin[3],
                  const double boxMax[3]) {
    return boxInFrustum(camera, cameraBasis(camera), aspect, boxMin, boxMax);
}

bool boxInFrustum(const Camera& camera, const CameraBasis& b, double aspect,
                  const double boxMin[3], const double boxMax[3]) {
    return boxInFrustum(viewFrustum(camera, b, aspect), boxMin, boxMax);
}

Frustum viewFrustum(const Camera& camera, const CameraBasis& b, double aspect) {
    const double ty = std::tan(camera.fovDegrees * kDegree / 2.0), tx = ty * aspect;
    Frustum f;
    for (int j = 0; j < 3; ++j) {
        f.eye[j] = camera.eye[j];
        f.forward[j] = b.forward[j];
        f.planes[0][j] = b.forward[j] * tx + b.right[j];  // left: x / z >= -tx
        f.planes[1][j] = b.forward[j] * tx - b.right[j];  // right
        f.planes[2][j] = b.forward[j] * ty + b.up[j];     // bottom
        f.planes[3][j] = b.forward[j] * ty - b.up[j];     // top
    }
    return f;
}

bool boxInFrustum(const Frustum& f, const double boxMin[3], const double boxMax[3]) {
    // The corner farthest along a normal (per axis the box's end on the normal's side): the
    // largest of the 8 corners' dot products, computed as they would be (each product and sum
    // is monotone), so the test is exactly "all 8 corners outside" with 1 corner per plane.
    auto farthest = [&](const double n[3]) {
        double sum = 0;
        for (int j = 0; j < 3; ++j)
            sum += n[j] * ((n[j] >= 0 ? boxMax[j] : boxMin[j]) - f.eye[j]);
        return sum;
    };
    for (const auto& plane : f.planes)
        if (farthest(plane) < 0) return false;
    return farthest(f.forward) >= kNearPlane;  // else entirely behind the near plane
}

bool boxInGridView(const Camera& camera, double halfHeight, double aspect, const double boxMin[3],
                   const double boxMax[3]) {
    const double hx = halfHeight * aspect;
    return boxMax[0] >= camera.eye[0] - hx && boxMin[0] <= camera.eye[0] + hx &&
           boxMax[1] >= camera.eye[1] - halfHeight && boxMin[1] <= camera.eye[1] + halfHeight;
}

}  // namespace unilod::engine
