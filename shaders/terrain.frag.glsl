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
    outColour = vec4(hypsometricTint(t) * lambert, 1.0);  // shared.h
}
