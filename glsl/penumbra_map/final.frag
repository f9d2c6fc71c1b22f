#version 450
#extension GL_GOOGLE_include_directive : require
// penumbra-map/final (Wyman & Hansen Sec. 3, last paragraph): two lookups. At each texel of
// the 2x2 footprint: behind a caster in the shadow map -> 0 (umbra); else the penumbra map's
// intensity (1 where no cone or sheet reached) if the texel's foremost surface is this point's
// surface, else 1. Bilinear weights, as `hard`.
#include "common/shadow.glsl"
#include "penumbra_map/surface.glsl"

layout(set = 0, binding = 1) uniform sampler2D shadow_map;     // RG32F: r caster depth, g foremost surface
layout(set = 0, binding = 2) uniform sampler2D penumbra_map;   // R16F intensity (MIN)

float visibility(vec3 p, vec3 n) {
    LightSample s = light_sample(p, n);
    if (!s.inside) return 1.0;
    vec4 lit = lit_test(textureGather(shadow_map, s.uv, 0), s.depth);
    // Component 1: the foremost surface of any role.
    vec4 own = own_surface(textureGather(shadow_map, s.uv, 1), s, p, n);
    vec4 intensity = mix(vec4(1.0), textureGather(penumbra_map, s.uv, 0), own);
    return clamp(bilinear_lit(lit * intensity, s.uv), 0.0, 1.0);
}

#include "common/final.glsl"
