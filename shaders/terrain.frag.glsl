#version 450
#extension GL_GOOGLE_include_directive : require
#include "shared.h"

layout(push_constant) uniform Push { DrawConstants pc; };
layout(location = 0) in vec3 inRelative;
layout(location = 1) in float inZ;
layout(location = 0) out vec4 outColour;

void main() {
    if (pc.zRange.z > 0.5) {  // grid mode: wireframe lines in one colour
        outColour = vec4(kGridColour, 1.0);
        return;
    }
    // Flat normal from screen-space derivatives: no normals stored, exact per face.
    vec3 n = normalize(cross(dFdx(inRelative), dFdy(inRelative)));
    if (n.z < 0.0) n = -n;  // terrain faces up whatever the screen orientation
    vec3 light = normalize(vec3(-0.5, 0.5, 0.7));
    float lambert = 0.35 + 0.65 * max(dot(n, light), 0.0);
    float range = max(pc.zRange.y - pc.zRange.x, 1e-3);
    float t = clamp((inZ - pc.zRange.x) / range, 0.0, 1.0);
    // Hypsometric tint: lowland green, brown slopes, pale summits. Never river blue.
    vec3 low = vec3(0.25, 0.55, 0.25), mid = vec3(0.70, 0.60, 0.38), high = vec3(0.95, 0.93, 0.90);
    vec3 tint = t < 0.5 ? mix(low, mid, t * 2.0) : mix(mid, high, t * 2.0 - 1.0);
    outColour = vec4(tint * lambert, 1.0);
}
