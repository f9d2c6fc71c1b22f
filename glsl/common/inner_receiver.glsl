// The receiver hidden behind a caster, for the inner passes that read the shared shadow map
// (penumbra_map_centred and smoothies_centred inner.frag). The includer declares
// `uniform sampler2D shadow_map` (RG32F: r nearest caster, g foremost surface) first.
#ifndef INNER_RECEIVER_GLSL
#define INNER_RECEIVER_GLSL
#include "common/far_depth.glsl"

#define INNER_MAP shadow_map
#include "common/inner_march.glsl"

// A caster this much (relative) in front of the edge's own depth hides the edge.
const float HIDE_EPS = 0.01;
// A caster counts as in front of the receiver when nearer than this (relative): the same
// margin as the final passes' own-surface window, so the receiver never shadows itself.
const float COVER_EPS = 0.01;
// The second receiver sample lies this many texels beyond the first.
const float PLANE_TEXELS = 4.0;
// PLANE_LIMIT: the largest relative depth change between the two samples, and of the
// extrapolation, that still counts as one plane.
#include "common/constants.glsl"

// A caster nearer than the receiver depth z_r at `pos` (texels).
bool blocked_at(vec2 pos, float z_r) {
    return texelFetch(shadow_map, texel_at(pos), 0).r < z_r * (1.0 - COVER_EPS);
}

// The receiver depth at `here`, whose edge lies `inside` texels away against `dir`: the
// foremost surface OUT_TEXELS outside the edge and PLANE_TEXELS farther. 1/depth is affine
// across the map over a plane, so the plane through both samples is extrapolated to here;
// samples of two different surfaces, or a curved receiver, keep the nearer sample within
// PLANE_LIMIT. False when nothing lies beyond the edge or a caster more than HIDE_EPS in
// front of `edge_depth` covers its outside (the edge is hidden).
bool receiver_beyond(vec2 here, vec2 dir, float inside, float edge_depth, out float z_r) {
    vec2 outside = here - dir * (inside + OUT_TEXELS);
    z_r = 0.0;
    if (!inside_map(outside)) return false;
    vec2 out_rg = texelFetch(shadow_map, texel_at(outside), 0).rg;
    if (out_rg.g >= 0.5 * FAR_DEPTH || out_rg.r < edge_depth * (1.0 - HIDE_EPS)) return false;
    z_r = out_rg.g;
    vec2 far_pos = outside - dir * PLANE_TEXELS;
    if (inside_map(far_pos)) {
        float far_g = texelFetch(shadow_map, texel_at(far_pos), 0).g;
        float d1 = inside + OUT_TEXELS;
        float inv = 1.0 / z_r + (1.0 / z_r - 1.0 / far_g) * (d1 / PLANE_TEXELS);
        if (abs(far_g - z_r) <= PLANE_LIMIT * z_r && inv > 0.0) {
            z_r = clamp(1.0 / inv, z_r / (1.0 + PLANE_LIMIT), z_r * (1.0 + PLANE_LIMIT));
        }
    }
    return true;
}

#endif
