#version 450
#extension GL_GOOGLE_include_directive : require
// plateaus final pass: points on the plane read the plateau texture (bilinear over its 4
// nearest texels, then the sine falloff, Haines Sec. 3 / Fig. 5); every other receiver gets
// the shadow map's 2x2 bilinear comparison (the filter `hard` gets from its comparison
// sampler).
#include "common/shadow.glsl"
#include "plateaus/plane.glsl"

layout(set = 0, binding = 2) uniform sampler2D plateau_tex;   // R32F penumbra fraction, 1 = lit
// R32F, casters only, MIN-blended, no depth attachment (gpu::passes::ShadowMap::casters):
// the nearest caster's linear depth.
layout(set = 0, binding = 3) uniform sampler2D shadow_map;
layout(set = 0, binding = 4) uniform sampler1D falloff;       // R32F 0.5 - 0.5 cos(pi x)

float visibility(vec3 p, vec3 n) {
    LightSample s = light_sample(p, n);
    if (!s.inside) return 1.0;
    vec4 q = plane.to_texture * vec4(p, 1.0);
    bool on_plane = abs(q.z) <= plane.params.x && abs(dot(n, plane.normal.xyz)) >= plane.params.y;
    // The texture covers the chosen plane's footprint in the light; anything else (other
    // receivers, a coplanar object beyond that footprint) gets the hard shadow map.
    bool in_texture = all(greaterThanEqual(q.xy, vec2(0.0))) && all(lessThanEqual(q.xy, vec2(1.0)));
    if (!on_plane || !in_texture) {
        return bilinear(lit_test(textureGather(shadow_map, s.uv, 0), s.depth), s.uv);
    }
    // Same side as the shadow map, so `bilinear` (which uses frame.light_params.z) applies.
    float f = clamp(bilinear(textureGather(plateau_tex, q.xy, 0), q.xy), 0.0, 1.0);
    float size = float(textureSize(falloff, 0));
    return texture(falloff, (f * (size - 1.0) + 0.5) / size).r;
}

#include "common/final.glsl"
