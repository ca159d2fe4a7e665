#version 450
#extension GL_GOOGLE_include_directive : require
#include "shared.h"

layout(push_constant) uniform Push { DrawConstants pc; };
layout(location = 0) in vec3 inPosition;

void main() {
    // The eye is the origin of the relative frame: scaling pulls the point towards it.
    vec3 p = (inPosition + pc.blockOffset.xyz) * (1.0 - pc.zRange.w);
    gl_Position = pc.viewProj * vec4(p, 1.0);
}
