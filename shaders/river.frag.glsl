#version 450
#extension GL_GOOGLE_include_directive : require
#include "shared.h"

layout(location = 0) out vec4 outColour;

void main() {
    outColour = vec4(kRiverColour, 1.0);
}
