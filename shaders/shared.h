// Layout shared by C++ and GLSL (STYLE.md "Shaders in CMake"): one definition of the push
// constants and of the constants both sides must agree on. Included by the *.glsl files through
// GL_GOOGLE_include_directive and by engine/renderer.cpp.
#ifndef UNILOD_SHADERS_SHARED_H
#define UNILOD_SHADERS_SHARED_H

#ifdef __cplusplus
#include <glm/glm.hpp>
namespace unilod::engine::shader {
using mat4 = glm::mat4;
using vec4 = glm::vec4;
using vec3 = glm::vec3;
using glm::mix;
#endif

// Per draw (one block). Positions reach the GPU relative to the eye: blockOffset = block origin
// minus eye (computed in double on the CPU), so float vertices stay precise far from the CRS
// origin.
struct DrawConstants {
    mat4 viewProj;     // eye-relative world -> clip (reversed Z, infinite far plane)
    vec4 blockOffset;  // xyz: (originX - eyeX, originY - eyeY, -eyeZ); w unused
    vec4 zRange;       // x: file min z, y: file max z (hypsometric tint); z: 1 in grid mode
                       // (flat line colour); w: river pull towards the eye (kRiverDepthBias)
};

// Rivers are pulled towards the eye by this fraction of their distance so that a river lying on
// the surface wins the depth test against the triangles it is an edge of (a depth bias that also
// works for lines, which the pipeline's polygon depth bias does not offset).
const float kRiverDepthBias = 0.002;
const vec3 kRiverColour = vec3(0.0, 0.2, 1.0);
const vec3 kGridColour = vec3(0.35, 0.35, 0.35);  // grid mode: triangle edges

// Hypsometric tint of the terrain before shading: t = (z - zRange.x) / (zRange.y - zRange.x)
// clamped to [0, 1]; lowland green, brown slopes, pale summits, never river blue. The fragment
// shader and the colour key of annotated images (engine/annotate.h) both call this.
const vec3 kTintLow = vec3(0.25, 0.55, 0.25);
const vec3 kTintMid = vec3(0.70, 0.60, 0.38);
const vec3 kTintHigh = vec3(0.95, 0.93, 0.90);
#ifdef __cplusplus
inline
#endif
vec3 hypsometricTint(float t) {
    return t < 0.5 ? mix(kTintLow, kTintMid, t * 2.0f) : mix(kTintMid, kTintHigh, t * 2.0f - 1.0f);
}

#ifdef __cplusplus
static_assert(sizeof(DrawConstants) == 96);
}  // namespace unilod::engine::shader
#endif

#endif
