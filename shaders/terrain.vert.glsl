#version 450
#extension GL_GOOGLE_include_directive : require
#include "shared.h"

layout(push_constant) uniform Push { DrawConstants pc; };
layout(location = 0) in vec3 inPosition;  // x, y block-relative; z absolute
layout(location = 0) out vec3 outRelative;
layout(location = 1) out float outZ;

void main() {
    vec3 p = inPosition + pc.blockOffset.xyz;
    outRelative = p;
    outZ = inPosition.z;
    gl_Position = pc.viewProj * vec4(p, 1.0);
}
