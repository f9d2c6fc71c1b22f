#version 450
#extension GL_GOOGLE_include_directive : require
// plateaus-centred/final: points on the plane read, at each of the 4 nearest texels of the
// plateau textures, outside every drop shadow the outer share -f (f = the outer plateaus'
// fraction, 1 where none: lit), under a drop shadow the darker of the inner share (1 where
// no inner cone or sheet reached: the umbra) and the outer one (a second caster's outer
// plateau over it); the shares are interpolated with bilinear weights and the visibility is
// their profile, disc_chord (common/penumbra.glsl: `share_visibility`), no falloff lookup.
// Every other receiver, and every point at R = 0 (a sun's theta = 0), gets the shadow map's
// 2x2 bilinear comparison (`hard`'s filter: R = 0 is `hard`'s image exactly).
#include "common/shadow.glsl"
#include "common/penumbra.glsl"
#include "plateaus/plane.glsl"

layout(set = 0, binding = 2) uniform sampler2D plateau_tex;   // R32F outer fraction, 1 = lit
// R32F, casters only, MIN-blended, no depth attachment (gpu::passes::ShadowMap::casters):
// the nearest caster's linear depth.
layout(set = 0, binding = 3) uniform sampler2D shadow_map;
layout(set = 0, binding = 4) uniform sampler2D coverage;      // R16F: 0 under a drop shadow, 1 elsewhere
// R16F, MAX: (1 - s) / 2 of the lightest inner share s (0 = umbra).
layout(set = 0, binding = 5) uniform sampler2D inner_tex;

float visibility(vec3 p, vec3 n) {
    LightSample s = light_sample(p, n);
    if (!s.inside) return 1.0;
    vec4 q = plane.to_texture * vec4(p, 1.0);
    bool on_plane = abs(q.z) <= plane.params.x && abs(dot(n, plane.normal.xyz)) >= plane.params.y;
    bool in_texture = all(greaterThanEqual(q.xy, vec2(0.0))) && all(lessThanEqual(q.xy, vec2(1.0)));
    if (!on_plane || !in_texture || light_spread() <= 0.0) {
        return bilinear(lit_test(textureGather(shadow_map, s.uv, 0), s.depth), s.uv);
    }
    vec4 lit = step(0.5, textureGather(coverage, q.xy, 0));
    // The inner shares, read first where a texel is under a drop shadow: under every one,
    // none with an inner value (the umbra's inside), v is 0 from two lookups, whatever the
    // outer values (the max below takes the inner umbra).
    vec4 inner = vec4(1.0);
    if (any(equal(lit, vec4(0.0)))) {
        inner = 1.0 - 2.0 * textureGather(inner_tex, q.xy, 0);
        if (all(equal(lit, vec4(0.0))) && all(equal(inner, vec4(1.0)))) return 0.0;
    }
    // The outer plateaus' fraction f is the outer share -f.
    vec4 outer = -textureGather(plateau_tex, q.xy, 0);
    // Outside every drop shadow: the outer shares alone (the inner ones are never read).
    if (all(equal(lit, vec4(1.0)))) return share_visibility(bilinear(outer, q.xy));
    // The darker of the two: the larger share.
    return share_visibility(bilinear(mix(max(inner, outer), outer, lit), q.xy));
}

#include "common/final.glsl"
