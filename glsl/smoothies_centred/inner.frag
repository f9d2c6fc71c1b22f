#version 450
#extension GL_GOOGLE_include_directive : require
#include "common/count.glsl"  // by name: build.rs also builds it counted (-DCOUNT_LIGHT)
// smoothies-centred/smoothie, inner smoothies (src/silhouette/smoothie.rs, `Side::Inner`):
// the inner half of the centred penumbra, inside the hard shadow, where the shadow map's
// foremost surface is the blocker and the receiver is hidden behind it. The same rules as
// penumbra-map-centred's inner.frag, with the smoothie's own geometry for the distance:
//   - x = the fragment's distance inside its hard-edge line (or from its silhouette vertex),
//     `dir` the inward direction;
//   - the receiver depth Z_R: the shadow map's g 1.0 texel outside the edge along -dir (1.5
//     past a caster in front there: common/inner_receiver.glsl), and 4 texels farther, the
//     plane through both (1/depth is affine across the map over a plane) extrapolated to
//     this texel, within 5 % of the nearer sample;
//   - nothing when the edge is hidden (a caster more than 1 % in front of b just outside
//     it: no inner penumbra through another caster), when this texel is not behind a caster
//     1 % nearer than Z_R, or when s = x / (t (1 - b/Z_R)) >= 1 (umbra);
//   - v = disc_chord(s) in [0, 0.5], plus, for a blocker thinner than its penumbra, the
//     share beyond its far edge: the shadow map searched from this texel along `dir` over
//     the half-width (bisections, where the blocker no longer covers the texel one
//     half-width in), the far edge d beyond this texel adds disc_chord(d / w)
//     (exact for a parallel strip: through it a point sees the disc's segment beyond each
//     edge);
//   - written as v's share (s at an edge alone), which the final pass interpolates.
#include "smoothies_centred/smoothie.glsl"

// `smoothie_inner` (R32F, MIN): the inner key (common/packed.glsl) of v's share and Z_R,
// so that MIN keeps the lightest inner estimate with its receiver.
layout(location = 0) out float o_inner;

#include "common/packed.glsl"

#include "common/inner_receiver.glsl"

void main() {
    float t = v_width;
    float texel = frame.light_params.w;   // uv per texel
    vec2 here = gl_FragCoord.xy;
    float b = smoothie_b(v_inv_depth);
    vec2 dir;
    float x = max(smoothie_distance(here * texel, dir), 0.0);
    if (x >= t || dir == vec2(0.0)) discard;
    float x_tex = x / texel;
    float zr;
    if (!receiver_beyond(here, dir, x_tex, b, zr)) discard;
    float denom = remap_denom(b, zr, remap_span());
    if (!(denom > REMAP_EPS)) discard;
    if (!blocked_at(here, zr)) discard;
    float w = t * denom;   // penumbra half-width at Z_R, uv
    float w_tex = w / texel;
    float s = x_tex / w_tex;
    if (!(s < 1.0)) discard;
    // Thin blocker: the far edge within w of this texel adds its segment; the share the
    // final pass interpolates is then the sum's.
    float far_edge = far_edge_texels(here, dir, w_tex, zr);
    float far = far_edge > 0.0 ? disc_chord(far_edge / w_tex) : 0.0;
    o_inner = inner_key(summed_share(s, far), zr);
}
