#version 450
#extension GL_GOOGLE_include_directive : require
// penumbra-map-centred/final: the paper's two lookups (penumbra_map/final.frag) plus the
// inner side. At each texel of the 2x2 footprint: in front of the shadow map's nearest
// caster -> the outer share if the texel's foremost surface is this point's surface, else
// -1 (lit, as the paper form); behind it -> the inner share (1 where no inner cone or sheet
// reached: the umbra) if this point is not beyond the receiver that inner value was made
// for (a point behind a second caster, e.g. the ground under two stacked boxes, stays in
// the umbra), never lighter than the outer share there (a second caster's outer penumbra
// over this one's shadow). The shares are interpolated with `hard`'s bilinear weights and
// the visibility is their profile, disc_chord (common/penumbra.glsl: `share_visibility`).
#include "common/shadow.glsl"
#include "common/nearer_receiver.glsl"
#include "common/penumbra.glsl"
#include "penumbra_map/surface.glsl"
#include "common/packed.glsl"

layout(set = 0, binding = 1) uniform sampler2D shadow_map;   // RG32F: r caster depth, g foremost surface
// R32F, MIN: the outer key (common/packed.glsl): the outer share (-1 = lit), the paper
// form's penumbra map as a share, with the depth of the texel's foremost surface.
layout(set = 0, binding = 2) uniform sampler2D penumbra_map;
// R32F, MIN: the inner key: the lightest inner share (1 = umbra) with the depth of the
// receiver it was made for.
layout(set = 0, binding = 3) uniform sampler2D penumbra_inner;

// RECEIVER_EPS: a point more than this (relative) beyond the inner value's receiver is
// behind something else.
#include "common/constants.glsl"

float visibility(vec3 p, vec3 n) {
    LightSample s = light_sample(p, n);
    if (!s.inside) return 1.0;
    vec4 casters = textureGather(shadow_map, s.uv, 0);
    vec4 lit = lit_test(casters, s.depth);
    // R = 0 (a sun's theta = 0): no cone or sheet was drawn, exactly `hard` (interpolated
    // as shares, the hard edge's step would take the profile's S across a texel).
    if (light_spread() <= 0.0) return bilinear_lit(lit, s.uv);
    // The inner shares, read first where a texel is behind a caster: behind every one, none
    // with an inner value (the umbra's inside), v is 0 from two lookups, whatever the outer
    // values (the max below takes the inner umbra). Read in one place: a CPU driver pays
    // each lookup written in the shader at every pixel.
    vec4 inner = vec4(1.0);
    vec4 receiver_codes = vec4(1.0);
    if (any(equal(lit, vec4(0.0)))) {
        unpack_inner(textureGather(penumbra_inner, s.uv, 0), inner, receiver_codes);
        if (all(equal(lit, vec4(0.0))) && all(equal(inner, vec4(1.0)))) return 0.0;
    }
    vec4 outer, surface_codes;
    unpack_outer(textureGather(penumbra_map, s.uv, 0), outer, surface_codes);
    // In front of every caster and outside every outer penumbra: lit, no further lookup.
    if (all(equal(lit, vec4(1.0))) && all(equal(outer, vec4(-1.0)))) return 1.0;
    // The foremost surfaces the outer values were made for travel in their keys: no read of
    // the shadow map's g (where a texel holds no outer value, -1, it does not matter).
    vec4 own = own_surface(code_depth(surface_codes), s, p, n);
    vec4 in_front = mix(vec4(-1.0), outer, own);
    // In front of every caster: the outer shares alone (the inner ones are never read).
    if (all(equal(lit, vec4(1.0)))) return share_visibility(bilinear(in_front, s.uv));
    vec4 receiver = receiver_depths(receiver_codes);
    inner = mix(vec4(1.0), inner, step(s.depth, receiver * (1.0 + RECEIVER_EPS)));
    inner = inner_at_depth(inner, receiver, casters, s.depth);
    // The darker of the two: the larger share.
    vec4 behind = max(inner, outer);
    return share_visibility(bilinear(mix(behind, in_front, lit), s.uv));
}

#include "common/final.glsl"
