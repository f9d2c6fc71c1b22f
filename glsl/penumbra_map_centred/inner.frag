#version 450
#extension GL_GOOGLE_include_directive : require
// penumbra-map-centred/penumbra, inner cones and sheets (src/silhouette/penumbra.rs,
// `Side::Inner`): the inner half of the centred penumbra, inside the hard shadow, where the
// shadow map's foremost surface is the caster and the receiver is hidden behind it.
//
// The fragment F lies u = Lr (1/Zv - 1/Z_F) (tangent units) inside the hard-edge line of its
// edge (or cone tip); the gradient of u across the map points inward along the edge's
// normal. The receiver is estimated from the foremost surface just outside the edge (the
// foot of the normal through this texel, 1.5 and 5.5 texels out: the plane through the two
// samples, extrapolated to this texel): Z_R. Then, at P = the receiver behind this texel,
//   - the edge is hidden (another caster in front of it covers its outside): nothing;
//   - this texel is not in the hard shadow at Z_R (a caster nearer than Z_R): nothing;
//   - the penumbra's half-width is w = Lr (1/Zv - 1/Z_R), s = u / w (nothing when s >= 1:
//     umbra), and the edge alone lets v_a = disc_chord(s) of the light through;
//   - thin blocker: the shadow map is marched from this texel inward along the normal for w;
//     the first texel not in the hard shadow at Z_R is the blocker's far edge, d beyond this
//     texel. Through a strip between two parallel edges P sees the disc's segment beyond
//     each edge, so the visibility is v_a + disc_chord(d / w): per-edge shares add (a
//     narrower blocker than its penumbra is never a full umbra). Exact for a parallel strip
//     and a single straight edge; at a corner it counts the segment beyond the other edge in
//     full (too light inside sharp corners of thin blockers).
// Written to the RGBA16F penumbra map with MIN blending: g (inner occlusion) gets 1 - v, so
// the lightest estimate wins; b the receiver depth it was made for as 1 - Z_R / far (the
// farthest wins), which the final pass checks its own depth against; r (outer visibility)
// and a the neutral 1.
#include "common/frame.glsl"
#include "common/penumbra.glsl"
#include "penumbra_map/wedge.glsl"

layout(set = 0, binding = 1) uniform sampler2D shadow_map;   // RG32F: r nearest caster, g foremost surface

layout(location = 0) in float v_depth;
layout(location = 1) in vec2 v_zv_h;
layout(location = 2) flat in float v_reach;
layout(location = 0) out vec4 o_penumbra;   // outer visibility, inner occlusion, 1 - receiver depth / far, unused

// How far outside the edge (texels) the receiver is read: past the texel the edge crosses.
const float OUT_TEXELS = 1.5;
// A caster this much (relative) in front of the edge's own depth hides the edge.
const float HIDE_EPS = 0.01;
// A caster counts as in front of the receiver when nearer than this (relative): the same
// margin as the final pass's own-surface window, so the receiver never shadows itself.
const float COVER_EPS = 0.01;
// The second receiver sample lies this many texels beyond the first.
const float PLANE_TEXELS = 4.0;
// Largest relative depth change between the two samples, and of the extrapolation, that
// still counts as one plane.
const float PLANE_LIMIT = 0.05;
// Coarse steps of the thin-blocker march, then bisection steps between the last two.
const int MARCH_STEPS = 8;
const int BISECT_STEPS = 3;

ivec2 texel_at(vec2 pos) {
    ivec2 size = textureSize(shadow_map, 0);
    return clamp(ivec2(floor(pos)), ivec2(0), size - 1);
}

bool inside_map(vec2 pos) {
    vec2 size = vec2(textureSize(shadow_map, 0));
    return all(greaterThanEqual(pos, vec2(0.0))) && all(lessThan(pos, size));
}

// A caster nearer than the receiver depth z_r at `pos` (texels).
bool covered(vec2 pos, float z_r) {
    return texelFetch(shadow_map, texel_at(pos), 0).r < z_r * (1.0 - COVER_EPS);
}

void main() {
    float zv = fragment_zv(v_zv_h);
    float lr = frame.light_pos_radius.w;
    float u = max(lr * (1.0 / zv - 1.0 / v_depth), 0.0);
    // Derivatives first (uniform control flow): u grows inward along the edge's normal.
    vec2 grad = vec2(dFdx(u), dFdy(u));
    float g = length(grad);
    if (!(g > 0.0) || isinf(g)) discard;
    vec2 dir = grad / g;
    float per_texel = frame.light_frustum.y;   // tangent units per texel
    vec2 here = gl_FragCoord.xy;
    vec2 outside = here - dir * (u / per_texel + OUT_TEXELS);
    if (!inside_map(outside)) discard;
    vec2 out_rg = texelFetch(shadow_map, texel_at(outside), 0).rg;
    // Nothing beyond the edge to receive a penumbra, or the edge is hidden.
    if (out_rg.g >= 0.5 * FAR_DEPTH || out_rg.r < zv * (1.0 - HIDE_EPS)) discard;
    // The receiver at this texel: 1/depth is affine across the map over a plane, so the
    // receiver's plane through two samples outside the edge (OUT_TEXELS and PLANE_TEXELS
    // farther) is extrapolated to here. Samples of two different surfaces, or a curved
    // receiver, keep the nearer sample within PLANE_LIMIT.
    float zr = out_rg.g;
    vec2 far_pos = outside - dir * PLANE_TEXELS;
    if (inside_map(far_pos)) {
        vec2 far_rg = texelFetch(shadow_map, texel_at(far_pos), 0).rg;
        float d1 = u / per_texel + OUT_TEXELS;
        float inv = 1.0 / zr + (1.0 / zr - 1.0 / far_rg.g) * (d1 / PLANE_TEXELS);
        float same = abs(far_rg.g - zr) <= PLANE_LIMIT * zr ? 1.0 : 0.0;
        if (same > 0.0 && inv > 0.0) {
            zr = clamp(1.0 / inv, zr / (1.0 + PLANE_LIMIT), zr * (1.0 + PLANE_LIMIT));
        }
    }
    float denom = zr - zv;
    if (!clear_of_contact(zr, denom)) discard;
    if (!covered(here, zr)) discard;
    float w = lr * (1.0 / zv - 1.0 / zr);
    float s = u / w;
    if (!(s < 1.0)) discard;
    float v = disc_chord(s);
    // Thin blocker: the far edge within w of this texel.
    float w_tex = w / per_texel;
    int steps = int(min(float(MARCH_STEPS), ceil(w_tex)));
    float step_len = w_tex / float(max(steps, 1));
    float lo = 0.0;
    float hi = -1.0;
    for (int k = 1; k <= steps; ++k) {
        vec2 pos = here + dir * (step_len * float(k));
        if (!inside_map(pos)) break;
        if (!covered(pos, zr)) {
            hi = step_len * float(k);
            break;
        }
        lo = step_len * float(k);
    }
    if (hi > 0.0) {
        for (int k = 0; k < BISECT_STEPS; ++k) {
            float mid = 0.5 * (lo + hi);
            if (covered(here + dir * mid, zr)) {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        // The far edge lies between the last covered and the first open sample.
        v += disc_chord(0.5 * (lo + hi) * per_texel / w);
    }
    float v_in = clamp(max(v, blocker_floor(v_reach, zv, zr, denom)), 0.0, 1.0);
    o_penumbra = vec4(1.0, 1.0 - v_in, 1.0 - zr / frame.light_params.y, 1.0);
}
