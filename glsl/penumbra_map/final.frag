#version 450
#extension GL_GOOGLE_include_directive : require
// penumbra-map/final (Wyman & Hansen Sec. 3, last paragraph): two lookups. At each texel of
// the 2x2 footprint: behind a caster in the shadow map -> 0 (umbra); else the penumbra map's
// intensity (1 where no cone or sheet reached) if the texel's foremost surface is this point's
// surface, else 1. Bilinear weights, as `hard`.
#include "common/shadow.glsl"

layout(set = 0, binding = 1) uniform sampler2D shadow_map;     // RG32F: r caster depth, g foremost surface
layout(set = 0, binding = 2) uniform sampler2D penumbra_map;   // R16F intensity (MIN)

// A texel whose foremost surface is more than this (relative) beyond the point stores the
// intensity of a background surface (e.g. the ground just outside a caster's silhouette,
// deep in its penumbra): without this test, grazing caster faces a texel or two wide would
// take that darkness through the bilinear footprint. 1 % is far above the normal offset
// (~0.2 %) and below the depth steps at silhouettes.
const float SAME_SURFACE = 0.01;

float visibility(vec3 p, vec3 n) {
    LightSample s = light_sample(p, n);
    if (!s.inside) return 1.0;
    vec4 lit = lit_test(textureGather(shadow_map, s.uv, 0), s.depth);
    // Component 1: the foremost surface of any role.
    vec4 own = step(textureGather(shadow_map, s.uv, 1), vec4(s.depth * (1.0 + SAME_SURFACE)));
    vec4 intensity = mix(vec4(1.0), textureGather(penumbra_map, s.uv, 0), own);
    return clamp(bilinear(lit * intensity, s.uv), 0.0, 1.0);
}

#include "common/final.glsl"
