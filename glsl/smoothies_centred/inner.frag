#version 450
#extension GL_GOOGLE_include_directive : require
// smoothies-centred/smoothie, inner smoothies (src/silhouette/smoothie.rs, `Side::Inner`):
// the inner half of the centred penumbra, inside the hard shadow, where the shadow map's
// foremost surface is the blocker and the receiver is hidden behind it. The same rules as
// penumbra-map-centred's inner.frag, with the smoothie's own geometry for the distance:
//   - x = the fragment's distance inside its hard-edge line (or from its silhouette vertex),
//     `dir` the inward direction;
//   - the receiver depth Z_R: the shadow map's g 1.5 texels outside the edge along -dir, and
//     4 texels farther, the plane through both (1/depth is affine across the map over a
//     plane) extrapolated to this texel, within 5 % of the nearer sample;
//   - nothing when the edge is hidden (a caster more than 1 % in front of b just outside
//     it: no inner penumbra through another caster), when this texel is not behind a caster
//     1 % nearer than Z_R, or when s = x / (t (1 - b/Z_R)) >= 1 (umbra);
//   - v = disc_chord(s) in [0, 0.5], plus, for a blocker thinner than its penumbra, the
//     share beyond its far edge: the shadow map marched from this texel along `dir` for
//     the half-width (8 steps, then 3 bisections), the far edge d beyond this texel adds
//     disc_chord(d / w) (exact for a parallel strip: through it a point sees the disc's
//     segment beyond each edge).
// Writes depth FAR_DEPTH (neutral: inner smoothies do not take part in the outer depth
// test) and (1, 1 - v, 1 - Z_R / far, 1): MIN keeps the lightest inner estimate and the
// farthest receiver an inner value was made for.
#include "smoothies_centred/smoothie.glsl"

// How far outside the edge (texels) the receiver is read: past the texel the edge crosses.
const float OUT_TEXELS = 1.5;
// A caster this much (relative) in front of the smoothie's depth hides the edge.
const float HIDE_EPS = 0.01;
// A caster counts as in front of the receiver when nearer than this (relative).
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
    float t = v_width;
    float texel = frame.light_params.w;   // uv per texel
    vec2 here = gl_FragCoord.xy;
    float b = 1.0 / v_inv_depth;
    vec2 dir;
    float x = max(smoothie_distance(here * texel, dir), 0.0);
    if (x >= t || dir == vec2(0.0)) discard;
    float x_tex = x / texel;
    vec2 outside = here - dir * (x_tex + OUT_TEXELS);
    if (!inside_map(outside)) discard;
    vec2 out_rg = texelFetch(shadow_map, texel_at(outside), 0).rg;
    // Nothing beyond the edge to receive a penumbra, or the edge is hidden.
    if (out_rg.g >= 0.5 * FAR_DEPTH || out_rg.r < b * (1.0 - HIDE_EPS)) discard;
    float zr = out_rg.g;
    vec2 far_pos = outside - dir * PLANE_TEXELS;
    if (inside_map(far_pos)) {
        float far_g = texelFetch(shadow_map, texel_at(far_pos), 0).g;
        float d1 = x_tex + OUT_TEXELS;
        float inv = 1.0 / zr + (1.0 / zr - 1.0 / far_g) * (d1 / PLANE_TEXELS);
        if (abs(far_g - zr) <= PLANE_LIMIT * zr && inv > 0.0) {
            zr = clamp(1.0 / inv, zr / (1.0 + PLANE_LIMIT), zr * (1.0 + PLANE_LIMIT));
        }
    }
    float denom = 1.0 - b / zr;
    if (!(denom > REMAP_EPS)) discard;
    if (!covered(here, zr)) discard;
    float w = t * denom;   // penumbra half-width at Z_R, uv
    float s = x / w;
    if (!(s < 1.0)) discard;
    float v = disc_chord(s);
    // Thin blocker: the far edge within w of this texel.
    float w_tex = w / texel;
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
        v += disc_chord(0.5 * (lo + hi) / w_tex);
    }
    o_depth = FAR_DEPTH;
    o_penumbra = vec4(1.0, 1.0 - clamp(v, 0.0, 1.0), 1.0 - zr / frame.light_params.y, 1.0);
}
