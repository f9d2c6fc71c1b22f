#version 450
#extension GL_GOOGLE_include_directive : require
// smoothies-centred/final: at each texel of the 2x2 footprint, in front of the shadow map's
// nearest caster -> the outer visibility if the point is behind the smoothie that made it,
// else 1 (the paper's step 5 with the centred outer value); behind it -> 1 - the inner
// occlusion (0 where no inner smoothie reached: the umbra) if the point is at most 5 %
// beyond the receiver that inner value was made for (a point behind a second caster stays
// in the umbra), never lighter than the outer visibility there (a second
// caster's outer smoothie over this one's shadow). Bilinear weights as `hard`; no falloff
// lookup (the disc-chord profile is in the values).
#include "common/shadow.glsl"
#include "common/nearer_receiver.glsl"
#include "smoothies/constants.glsl"
#include "common/packed.glsl"

layout(set = 0, binding = 1) uniform sampler2D shadow_map;          // RG32F: r = nearest caster depth
// R32F, MIN: the outer key (common/packed.glsl): the darkest outer visibility (1 = lit)
// with the depth of the smoothie that made it.
layout(set = 0, binding = 2) uniform sampler2D smoothie_outer;
// R32F, MIN: the inner key: the least inner occlusion (1 = umbra) with the depth of the
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
    // The inner occlusions, read first where a texel is behind a caster: behind every one,
    // none with an inner value (the umbra's inside), v is 0 from two lookups, whatever the
    // outer values (the min below takes the inner 0). Read in one place: a CPU driver pays
    // each lookup written in the shader at every pixel.
    vec4 occlusion = vec4(1.0);
    vec4 receiver_codes = vec4(1.0);
    if (any(equal(lit, vec4(0.0)))) {
        unpack_inner(textureGather(smoothie_inner, s.uv, 0), occlusion, receiver_codes);
        if (all(equal(lit, vec4(0.0))) && all(equal(occlusion, vec4(1.0)))) return 0.0;
    }
    vec4 outer, smoothie;
    unpack_outer(textureGather(smoothie_outer, s.uv, 0), outer, smoothie);
    vec4 in_front = in_front_of_codes(smoothie, s.depth);
    // Lit and in front of every smoothie (the bulk of the image): no penumbra value.
    if (all(equal(lit * in_front, vec4(1.0)))) return 1.0;
    outer = mix(outer, vec4(1.0), in_front);
    // In front of every caster: the outer values alone (the inner ones are never read).
    if (all(equal(lit, vec4(1.0)))) return clamp(bilinear_lit(outer, s.uv), 0.0, 1.0);
    vec4 receiver = receiver_depths(receiver_codes);
    vec4 inner = (1.0 - occlusion) * step(s.depth, receiver * (1.0 + RECEIVER_EPS));
    inner = inner_at_depth(inner, receiver, casters, s.depth);
    vec4 behind = min(inner, outer);
    return clamp(bilinear_lit(mix(behind, outer, lit), s.uv), 0.0, 1.0);
}

#include "common/final.glsl"
