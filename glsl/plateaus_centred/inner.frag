#version 450
#extension GL_GOOGLE_include_directive : require
#include "common/count.glsl"  // by name: build.rs also builds it counted (-DCOUNT_LIGHT)
// plateaus-centred/inner: the cones and the INNER sheets (src/technique/plateaus_common.rs
// `PlateauBuilder` with `Side::Inner`: (P3) with p -> -p, opening into the drop shadow), in
// the texture's clip space with depth t = 0 at the hard edge and 1 at the inner rim. The
// receiver is the plane itself, so t is s, the fragment's share of the penumbra half-width
// inside the hard edge, and the edge alone lets v = disc_chord(t) of the light through.
//   - nothing outside the drop shadow, or when the edge is hidden: the plane 1.5 texels
//     outside the edge is under a drop shadow too. A caster nearer the light there covers
//     the edge's outside (no light through it); a farther one blocks the light this edge
//     lets through before it reaches the plane, and one MAX image cannot take the minimum
//     over casters, so that edge draws nothing either (the union's outline draws it);
//   - thin blocker: the coverage image is searched from this texel along the inward
//     direction (the gradient of t) over the half-width w (bisections, where the drop
//     shadow no longer covers the texel w in); the first texel out of the drop shadow is
//     the blocker's far edge, d beyond this texel, and adds disc_chord(d / w)
//     (through a strip between parallel edges a point sees the disc's segment beyond each
//     edge).
// Written as (1 - s) / 2 of v's share s (t at an edge alone), which the final pass
// interpolates, with MAX blending into the R16F inner image (clear 0: the umbra's s = 1):
// the lightest estimate, the smallest share, wins.
#include "common/penumbra.glsl"

layout(set = 0, binding = 0) uniform sampler2D coverage;   // R16F: 0 under a drop shadow, 1 elsewhere
// Clip-space step from this fragment's edge point along its cone's spoke or sheet's ruling.
layout(location = 0) noperspective in vec2 v_from_edge;
layout(location = 0) out float o_inner;

#define INNER_MAP coverage
#include "common/inner_march.glsl"

// Under a drop shadow (the receiver is the plane itself: z_r plays no part).
bool blocked_at(vec2 pos, float z_r) {
    return texelFetch(coverage, texel_at(pos), 0).r < 0.5;
}

void main() {
    float t = gl_FragCoord.z;
    // Derivatives first (uniform control flow): t grows inward, over w texels.
    vec2 grad = vec2(dFdx(t), dFdy(t));
    float g = length(grad);
    if (!(g > 0.0) || isinf(g)) discard;
    vec2 dir = grad / g;
    float w_tex = 1.0 / g;
    vec2 here = gl_FragCoord.xy;
    if (!(t < 1.0) || !blocked_at(here, 0.0)) discard;
    // The hidden-edge test reads OUT_TEXELS beyond the fragment's own edge point, back along
    // its ruling: t's gradient crosses the edge at a slant where a sheet's rim is not
    // parallel to it, and a point found along the gradient can land on the coverage image's
    // staircase beside the edge (single umbra texels in the penumbra).
    vec2 from_edge = v_from_edge * (0.5 * vec2(textureSize(coverage, 0)));
    float reach = length(from_edge);
    vec2 out_dir = reach > 1e-3 ? from_edge / reach : dir;
    vec2 outside = here - from_edge - out_dir * OUT_TEXELS;
    if (inside_map(outside) && blocked_at(outside, 0.0)) discard;
    // Thin blocker: the far edge within w of this texel adds its segment; the share the
    // final pass interpolates is then the sum's.
    float far_edge = far_edge_texels(here, dir, w_tex, 0.0);
    float far = far_edge > 0.0 ? disc_chord(far_edge / w_tex) : 0.0;
    o_inner = 0.5 - 0.5 * summed_share(t, far);
}
