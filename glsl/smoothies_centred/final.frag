#version 450
#extension GL_GOOGLE_include_directive : require
// smoothies-centred/final: at each texel of the 2x2 footprint, in front of the shadow map's
// nearest caster -> the outer share if the point is behind the smoothie that made it, else
// -1 (lit; the paper's step 5 with the centred outer value); behind it -> the inner share
// (1 where no inner smoothie reached: the umbra) if the point is at most 5 % beyond the
// receiver that inner value was made for (a point behind a second caster stays in the
// umbra), never lighter than the outer share there (a second caster's outer smoothie over
// this one's shadow). The shares are interpolated with `hard`'s bilinear weights and the
// visibility is their profile, disc_chord (common/penumbra.glsl: `share_visibility`); no
// falloff lookup.
#include "common/shadow.glsl"
#include "common/nearer_receiver.glsl"
#include "common/penumbra.glsl"
#include "smoothies/constants.glsl"
#include "common/packed.glsl"

layout(set = 0, binding = 1) uniform sampler2D shadow_map;          // RG32F: r = nearest caster depth
// R32F, MIN: the outer key (common/packed.glsl): the darkest outer share (-1 = lit) with
// the depth of the smoothie that made it.
layout(set = 0, binding = 2) uniform sampler2D smoothie_outer;
// R32F, MIN: the inner key: the lightest inner share (1 = umbra) with the depth of the
// receiver it was made for.
layout(set = 0, binding = 3) uniform sampler2D smoothie_inner;

// RECEIVER_EPS: the inner value's receiver window.
#include "common/constants.glsl"

float visibility(vec3 p, vec3 n) {
    LightSample s = light_sample(p, n);
    if (!s.inside) return 1.0;
    vec4 casters = textureGather(shadow_map, s.uv, 0);
    vec4 lit = lit_test(casters, s.depth);
    // R = 0: no smoothie was drawn, exactly `hard`.
    if (SMOOTHIE_T <= 0.0) return bilinear_lit(lit, s.uv);
    // The inner shares, read first where a texel is behind a caster: behind every one, none
    // with an inner value (the umbra's inside), v is 0 from two lookups, whatever the outer
    // values (the max below takes the inner umbra). Read in one place: a CPU driver pays
    // each lookup written in the shader at every pixel.
    vec4 inner = vec4(1.0);
    vec4 receiver_codes = vec4(1.0);
    if (any(equal(lit, vec4(0.0)))) {
        unpack_inner(textureGather(smoothie_inner, s.uv, 0), inner, receiver_codes);
        if (all(equal(lit, vec4(0.0))) && all(equal(inner, vec4(1.0)))) return 0.0;
    }
    vec4 outer, smoothie;
    unpack_outer(textureGather(smoothie_outer, s.uv, 0), outer, smoothie);
    vec4 in_front = in_front_of_codes(smoothie, s.depth);
    // Lit and in front of every smoothie (the bulk of the image): no penumbra value.
    if (all(equal(lit * in_front, vec4(1.0)))) return 1.0;
    outer = mix(outer, vec4(-1.0), in_front);
    // In front of every caster: the outer shares alone (the inner ones are never read).
    if (all(equal(lit, vec4(1.0)))) return share_visibility(bilinear(outer, s.uv));
    vec4 receiver = receiver_depths(receiver_codes);
    inner = mix(vec4(1.0), inner, step(s.depth, receiver * (1.0 + RECEIVER_EPS)));
    inner = inner_at_depth(inner, receiver, casters, s.depth);
    // The darker of the two: the larger share.
    vec4 behind = max(inner, outer);
    return share_visibility(bilinear(mix(behind, outer, lit), s.uv));
}

#include "common/final.glsl"
