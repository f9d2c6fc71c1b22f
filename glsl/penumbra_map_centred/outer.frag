#version 450
#extension GL_GOOGLE_include_directive : require
#include "common/count.glsl"  // by name: build.rs also builds it counted (-DCOUNT_LIGHT)
// penumbra-map-centred/penumbra, outer cones and sheets: the paper's fragment program
// (penumbra_map/penumbra.frag) with the penumbra centred on the hard edge. Eq. 1's depths
// give the exact share of the outer penumbra half-width at P: the fragment F lies
// Lr (1/Zv - 1/Z_F) (tangent units) outside the hard-edge line, the half-width at P is
// Lr (1/Zv - 1/Z_P), so
//     s = (1/Zv - 1/Z_F) / (1/Zv - 1/Z_P) = I Z_P / Z_F,   I = Eq. 1,
// (a sun: F lies (Z_F - Zv) tan theta outside, the half-width is (Z_P - Zv) tan theta, so
// s = I; `outer_share`)
// and the visibility is the disc-chord profile v = disc_chord(-s): 0.5 on the hard edge, 1
// at the outer rim, plus the disc's segment beyond the far edge of a blocker narrower than
// its penumbra (`outer_far_share`, common/inner_march.glsl, marched along the gradient of
// Z_F, which points away from the edge: the inner side adds the same segment, so the two
// meet at the hard edge without a step). Written to the penumbra map as v's share (-s at
// an edge alone), which the final pass interpolates, with MIN blending (darkest wins, as in
// the paper).
#include "common/frame.glsl"
#include "common/penumbra.glsl"
#include "penumbra_map/wedge.glsl"

layout(set = 0, binding = 1) uniform sampler2D shadow_map;   // RG32F: r nearest caster, g foremost surface

layout(location = 0) in float v_depth;
layout(location = 1) in vec2 v_zv_h;
layout(location = 2) flat in float v_reach;
// `penumbra_map` (R32F, MIN): the outer key (common/packed.glsl) of the outer share and
// the texel's foremost surface depth, which the final pass's own-surface test reads.
layout(location = 0) out float o_outer;

#include "common/packed.glsl"

#include "common/inner_receiver.glsl"

void main() {
    // Derivatives first (uniform control flow): F's offset from the hard-edge line grows
    // outward along the edge's normal.
    vec2 grad = vec2(dFdx(v_depth), dFdy(v_depth));
    Eq1 e;
    float surface = texelFetch(shadow_map, ivec2(gl_FragCoord.xy), 0).g;
    if (!eq1_depths(surface, v_depth, v_zv_h, e)) {
        discard;
    }
    // Rasterised F can fall a rounding error in front of the tip.
    float s = clamp(outer_share((e.zf - e.zv) / e.denom, e.zp, e.zf), 0.0, 1.0);
    if (!(s < 1.0)) discard;
    float w_tex = wedge_offset(e.zv, e.zp) / wedge_unit_per_texel();
    float g = length(grad);
    float far = g > 0.0 && !isinf(g)
        ? outer_far_share(gl_FragCoord.xy, grad / g, s * w_tex, w_tex, e.zp)
        : 0.0;
    // The share the final pass interpolates: -s at the edge alone, raised by a thin
    // blocker's far segment or to the blocker-size bound, whichever lets more through.
    float to_floor = blocker_floor(v_reach, e.zv, e.zp, e.denom) - disc_chord(-s);
    o_outer = outer_key(summed_share(-s, max(far, to_floor)), surface);
}
