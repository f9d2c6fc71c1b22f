#version 450
#extension GL_GOOGLE_include_directive : require
#include "common/count.glsl"  // by name: build.rs also builds it counted (-DCOUNT_LIGHT)
// smoothies-centred/smoothie, outer smoothies: the paper's smoothie fragment, with the
// paper form's own decision (smoothies/alpha.glsl `smoothie_alpha`: receiver r = the shadow
// map's g at this texel; written only where the smoothie darkens a surface) and the
// penumbra centred on the hard edge. With the calibrated width t (R / (2 b tan(fov/2)),
// src/silhouette/smoothie.rs `Width`) the half-width of a disc light's penumbra at receiver
// depth r is t (1 - b/r) uv, so the paper's remapped alpha' = alpha / (1 - b/r) (Eq. 1) is
// exactly s, the fragment's distance outside the hard edge over that half-width, and the
// visibility is disc_chord(-s): 0.5 on the hard edge, 1 at the outer rim, plus the disc's
// segment beyond the far edge of a blocker narrower than its penumbra (`outer_far_share`,
// common/inner_march.glsl: the inner side adds it too, so the two meet at the hard edge
// without a step). Writes the visibility's share (-s at an edge alone) and b to
// `smoothie_outer` (MIN: the darkest outer value, the paper's rule).
//
// Discarded, as in the paper form: no surface at the texel, b/r > 1, 1 - b/r < REMAP_EPS,
// and s >= 1 (fully lit, v = 1). A lit fragment darkens nothing, but its b would still
// MIN-blend into a texel that another caster's smoothie darkens: the final pass then
// counts a point between the two smoothies' depths as behind the nearest smoothie and
// gives it the farther smoothie's v (dark speckles along casters' edges under another
// caster's smoothie; tests/centred_penumbra.rs, `outer_smoothies_write_only_what_darkens`).
#include "smoothies_centred/smoothie.glsl"

// `smoothie_outer` (R32F, MIN): the outer key (common/packed.glsl) of the share and b.
layout(location = 0) out float o_outer;

#include "common/packed.glsl"

#include "common/inner_receiver.glsl"

void main() {
    float t = v_width;
    float texel = frame.light_params.w;   // uv per texel
    vec2 uv = gl_FragCoord.xy * texel;
    float b = smoothie_b(v_inv_depth);
    float r = texelFetch(shadow_map, ivec2(gl_FragCoord.xy), 0).g;
    vec2 dir;
    float x = smoothie_distance(uv, dir);
    float s;
    if (!smoothie_alpha(b, r, x, t, remap_span(), s)) discard;
    float w_tex = t * remap_denom(b, r, remap_span()) / texel;
    // The share the final pass interpolates: -s at the edge alone, with a thin blocker's
    // far segment the sum's.
    float far = outer_far_share(gl_FragCoord.xy, dir, s * w_tex, w_tex, r);
    o_outer = outer_key(summed_share(-s, far), b);
}
