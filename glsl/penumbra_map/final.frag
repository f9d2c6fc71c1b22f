#version 450
#extension GL_GOOGLE_include_directive : require
// penumbra-map/final (Wyman & Hansen Sec. 3, last paragraph): two lookups. At each texel of
// the 2x2 footprint: behind a caster in the shadow map -> 0 (umbra); else the penumbra map's
// intensity (1 where no cone or sheet reached). Bilinear weights, as `hard`.
#include "common/shadow.glsl"

layout(set = 0, binding = 1) uniform sampler2D shadow_map;     // R32F caster depth
layout(set = 0, binding = 2) uniform sampler2D penumbra_map;   // R16F intensity (MIN)

float visibility(vec3 p, vec3 n) {
    LightSample s = light_sample(p, n);
    if (!s.inside) return 1.0;
    vec4 lit = lit_test(textureGather(shadow_map, s.uv, 0), s.depth);
    vec4 intensity = textureGather(penumbra_map, s.uv, 0);
    return clamp(bilinear(lit * intensity, s.uv), 0.0, 1.0);
}

#include "common/final.glsl"
