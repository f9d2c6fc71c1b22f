#version 450
#extension GL_GOOGLE_include_directive : require
// plateaus-centred/inner: the cones and the INNER sheets (src/technique/plateaus.rs
// `PlateauBuilder` with `Side::Inner`: (P3) with p -> -p, opening into the drop shadow), in
// the texture's clip space with depth t = 0 at the hard edge and 1 at the inner rim. The
// receiver is the plane itself, so t is s, the fragment's share of the penumbra half-width
// inside the hard edge, and the edge alone lets v = disc_chord(t) of the light through.
//   - nothing outside the drop shadow, or when the edge is hidden: the plane 1.5 texels
//     outside the edge is under a drop shadow too. A caster nearer the light there covers
//     the edge's outside (no light through it); a farther one blocks the light this edge
//     lets through before it reaches the plane, and one MAX image cannot take the minimum
//     over casters, so that edge draws nothing either (the union's outline draws it);
//   - thin blocker: the coverage image is marched from this texel along the inward
//     direction (the gradient of t) for the half-width w (8 steps, then 3 bisections); the
//     first texel out of the drop shadow is the blocker's far edge, d beyond this texel,
//     and adds disc_chord(d / w) (through a strip between parallel edges a point sees the
//     disc's segment beyond each edge).
// Written with MAX blending into the R16F inner image (clear 0): the lightest estimate wins.
#include "common/penumbra.glsl"

layout(set = 0, binding = 0) uniform sampler2D coverage;   // R16F: 0 under a drop shadow, 1 elsewhere
layout(location = 0) out float o_inner;

// How far outside the edge (texels) the hidden-edge test looks: past the texel the edge crosses.
const float OUT_TEXELS = 1.5;
// Coarse steps of the thin-blocker march, then bisection steps between the last two.
const int MARCH_STEPS = 8;
const int BISECT_STEPS = 3;

ivec2 texel_at(vec2 pos) {
    ivec2 size = textureSize(coverage, 0);
    return clamp(ivec2(floor(pos)), ivec2(0), size - 1);
}

bool inside_map(vec2 pos) {
    vec2 size = vec2(textureSize(coverage, 0));
    return all(greaterThanEqual(pos, vec2(0.0))) && all(lessThan(pos, size));
}

bool shadowed(vec2 pos) {
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
    if (!(t < 1.0) || !shadowed(here)) discard;
    vec2 outside = here - dir * (t * w_tex + OUT_TEXELS);
    if (inside_map(outside) && shadowed(outside)) discard;
    float v = disc_chord(t);
    int steps = int(min(float(MARCH_STEPS), ceil(w_tex)));
    float step_len = w_tex / float(max(steps, 1));
    float lo = 0.0;
    float hi = -1.0;
    for (int k = 1; k <= steps; ++k) {
        vec2 pos = here + dir * (step_len * float(k));
        if (!inside_map(pos)) break;
        if (!shadowed(pos)) {
            hi = step_len * float(k);
            break;
        }
        lo = step_len * float(k);
    }
    if (hi > 0.0) {
        for (int k = 0; k < BISECT_STEPS; ++k) {
            float mid = 0.5 * (lo + hi);
            if (shadowed(here + dir * mid)) {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        v += disc_chord(0.5 * (lo + hi) / w_tex);
    }
    o_inner = clamp(v, 0.0, 1.0);
}
