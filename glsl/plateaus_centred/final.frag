#version 450
#extension GL_GOOGLE_include_directive : require
// plateaus-centred/final: points on the plane read, at each of the 4 nearest texels of the
// plateau textures, outside every drop shadow the outer visibility disc_chord(-f) (f = the
// outer plateaus' fraction, 1 where none: lit), under a drop shadow min(inner, outer) (the
// inner visibility, 0 where no inner cone or sheet reached: the umbra; never lighter than a
// second caster's outer plateau over it); bilinear weights, no falloff lookup (the profile
// is in the values). Every other receiver, and every point at R = 0 (a sun's theta = 0),
// gets the shadow map's 2x2 bilinear comparison (`hard`'s filter: R = 0 is `hard`'s image
// exactly).
#include "common/shadow.glsl"
#include "common/penumbra.glsl"
#include "plateaus/plane.glsl"

layout(set = 0, binding = 2) uniform sampler2D plateau_tex;   // R32F outer fraction, 1 = lit
// R32F, casters only, MIN-blended, no depth attachment (gpu::passes::ShadowMap::casters):
// the nearest caster's linear depth.
layout(set = 0, binding = 3) uniform sampler2D shadow_map;
layout(set = 0, binding = 4) uniform sampler2D coverage;      // R16F: 0 under a drop shadow, 1 elsewhere
layout(set = 0, binding = 5) uniform sampler2D inner_tex;     // R16F lightest inner visibility (MAX)

float visibility(vec3 p, vec3 n) {
    LightSample s = light_sample(p, n);
    if (!s.inside) return 1.0;
    vec4 q = plane.to_texture * vec4(p, 1.0);
    bool on_plane = abs(q.z) <= plane.params.x && abs(dot(n, plane.normal.xyz)) >= plane.params.y;
    bool in_texture = all(greaterThanEqual(q.xy, vec2(0.0))) && all(lessThanEqual(q.xy, vec2(1.0)));
    // The light's spread: a spotlight's R, a sun's tan(theta).
    float spread = light_is_sun() ? frame.sun.y : frame.light_pos_radius.w;
    if (!on_plane || !in_texture || spread <= 0.0) {
        return bilinear(lit_test(textureGather(shadow_map, s.uv, 0), s.depth), s.uv);
    }
    vec4 lit = step(0.5, textureGather(coverage, q.xy, 0));
    // The inner values, read first where a texel is under a drop shadow: under every one,
    // none with an inner value (the umbra's inside), v is 0 from two lookups, whatever the
    // outer values (the min below takes the inner 0).
    vec4 inner = vec4(0.0);
    if (any(equal(lit, vec4(0.0)))) {
        inner = textureGather(inner_tex, q.xy, 0);
        if (all(equal(lit, vec4(0.0))) && all(equal(inner, vec4(0.0)))) return 0.0;
    }
    vec4 f = textureGather(plateau_tex, q.xy, 0);
    vec4 outer = vec4(disc_chord(-f.x), disc_chord(-f.y), disc_chord(-f.z), disc_chord(-f.w));
    // Outside every drop shadow: the outer values alone (the inner ones are never read).
    if (all(equal(lit, vec4(1.0)))) return clamp(bilinear(outer, q.xy), 0.0, 1.0);
    return clamp(bilinear(mix(min(inner, outer), outer, lit), q.xy), 0.0, 1.0);
}

#include "common/final.glsl"
