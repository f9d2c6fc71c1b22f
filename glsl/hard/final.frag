#version 450
#extension GL_GOOGLE_include_directive : require
// hard: one depth comparison per texel of the 2x2 footprint, bilinearly weighted
// (the smoothie paper's Fig. 7 shadow-map baseline).
#include "common/shadow.glsl"

layout(set = 0, binding = 1) uniform sampler2D shadow_map;   // R32F linear depth

float visibility(vec3 p, vec3 n) {
    LightSample s = light_sample(p, n);
    if (!s.inside) return 1.0;
    return bilinear(lit_test(textureGather(shadow_map, s.uv, 0), s.depth), s.uv);
}

#include "common/final.glsl"
