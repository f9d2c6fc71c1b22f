#version 450
#extension GL_GOOGLE_include_directive : require
// reference: the ray-cast visibility (src/reference.rs), computed on the CPU at this
// very pixel's surface point and uploaded as an R32F image of the camera's size; the pass
// only looks it up at its own pixel, so the AOV and the PNG show the exact reference.
#include "common/frame.glsl"

layout(set = 0, binding = 1) uniform sampler2D reference_visibility;   // R32F, camera-sized

float visibility(vec3 p, vec3 n) {
    return texelFetch(reference_visibility, ivec2(gl_FragCoord.xy), 0).r;
}

#include "common/final.glsl"
