#version 450
#extension GL_GOOGLE_include_directive : require
#include "common/count.glsl"  // by name: build.rs also builds it counted (-DCOUNT_LIGHT)
// penumbra-map-centred/penumbra, inner cones and sheets (src/silhouette/penumbra.rs,
// `Side::Inner`): the inner half of the centred penumbra, inside the hard shadow, where the
// shadow map's foremost surface is the caster and the receiver is hidden behind it.
//
// The fragment F lies u = Lr (1/Zv - 1/Z_F) (tangent units; a sun's (Z_F - Zv) tan theta
// world units, `wedge_offset`) inside the hard-edge line of its edge (or cone tip); the gradient of u across the map points inward along the edge's
// normal. The receiver is estimated from the foremost surface just outside the edge (the
// foot of the normal through this texel, 1.0 and 5.0 texels out, or 1.5 and 5.5 past a
// caster in front at 1.0 (common/inner_receiver.glsl): the plane through the two samples,
// extrapolated to this texel): Z_R. Then, at P = the receiver behind this texel,
//   - the edge is hidden (another caster in front of it covers its outside): nothing;
//   - this texel is not in the hard shadow at Z_R (a caster nearer than Z_R): nothing;
//   - the penumbra's half-width is w = Lr (1/Zv - 1/Z_R) (a sun's (Z_R - Zv) tan theta), s = u / w (nothing when s >= 1:
//     umbra), and the edge alone lets v_a = disc_chord(s) of the light through;
//   - thin blocker: the shadow map is marched from this texel inward along the normal for w;
//     the first texel not in the hard shadow at Z_R is the blocker's far edge, d beyond this
//     texel. Through a strip between two parallel edges P sees the disc's segment beyond
//     each edge, so the visibility is v_a + disc_chord(d / w): per-edge shares add (a
//     narrower blocker than its penumbra is never a full umbra). Exact for a parallel strip
//     and a single straight edge; at a corner it counts the segment beyond the other edge in
//     full (too light inside sharp corners of thin blockers).
// Written to the inner map with MIN blending as a key of v's share (s at an edge alone),
// which the final pass interpolates, so the lightest estimate wins, and the receiver depth
// it was made for (of equal shares the farthest), which the final pass checks its own
// depth against.
#include "common/frame.glsl"
#include "common/penumbra.glsl"
#include "penumbra_map/wedge.glsl"

layout(set = 0, binding = 1) uniform sampler2D shadow_map;   // RG32F: r nearest caster, g foremost surface

layout(location = 0) in float v_depth;
layout(location = 1) in vec2 v_zv_h;
layout(location = 2) flat in float v_reach;
// `penumbra_inner` (R32F, MIN): the inner key (common/packed.glsl) of (v's share, Z_R).
layout(location = 0) out float o_inner;

#include "common/packed.glsl"

#include "common/inner_receiver.glsl"

void main() {
    float zv = fragment_zv(v_zv_h);
    float u = max(wedge_offset(zv, v_depth), 0.0);
    // Derivatives first (uniform control flow): u grows inward along the edge's normal.
    vec2 grad = vec2(dFdx(u), dFdy(u));
    float g = length(grad);
    if (!(g > 0.0) || isinf(g)) discard;
    vec2 dir = grad / g;
    float per_texel = wedge_unit_per_texel();   // tangent units (a sun's world units) per texel
    vec2 here = gl_FragCoord.xy;
    float zr;
    if (!receiver_beyond(here, dir, u / per_texel, zv, zr)) discard;
    float denom = zr - zv;
    if (!clear_of_contact(zr, denom)) discard;
    if (!blocked_at(here, zr)) discard;
    float w = wedge_offset(zv, zr);
    float s = u / w;
    if (!(s < 1.0)) discard;
    float far_edge = far_edge_texels(here, dir, w / per_texel, zr);
    float far = far_edge > 0.0 ? disc_chord(far_edge * per_texel / w) : 0.0;
    // The share the final pass interpolates: s at the edge alone, raised by a thin
    // blocker's far segment or to the blocker-size bound, whichever lets more through.
    float to_floor = blocker_floor(v_reach, zv, zr, denom) - disc_chord(s);
    o_inner = inner_key(summed_share(s, max(far, to_floor)), zr);
}
