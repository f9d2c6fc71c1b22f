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
// The first texel outside an edge that is not the edge's own caster's: a point this far out
// lies in a texel whose centre is at least 1 - sqrt(2)/2 texel beyond the edge's line.
const float FIRST_OUT_TEXELS = 1.0;
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
// foremost surface FIRST_OUT_TEXELS outside the edge and PLANE_TEXELS farther. 1/depth is
// affine across the map over a plane, so the plane through both samples is extrapolated to
// here; samples of two different surfaces, or a curved receiver, keep the nearer sample
// within PLANE_LIMIT. False when nothing lies beyond the edge, or when a caster more than
// HIDE_EPS in front of `edge_depth` covers its outside (the edge is hidden): at the first
// texel out and still at OUT_TEXELS, so that a neighbour which only borders the edge does
// not hide it (where it does not reach that far, the receiver is read at OUT_TEXELS). A
// caster at or behind the edge's depth at the first texel out is taken as the receiver: the
// lip between a bumpy blocker's outline and a fold just inside it, which hides the fold
// from the surface beyond, gives the fold no penumbra there (its receiver lies at its own
// depth).
bool receiver_beyond(vec2 here, vec2 dir, float inside, float edge_depth, out float z_r) {
    z_r = 0.0;
    float d1 = inside + FIRST_OUT_TEXELS;
    vec2 out_rg = vec2(0.0);
    // One read in the loop: a CPU driver pays each read written in the shader at every
    // fragment, and the second trip is rare.
    for (int trip = 0; trip < 2; ++trip) {
        vec2 outside = here - dir * d1;
        if (!inside_map(outside)) return false;
        out_rg = texelFetch(shadow_map, texel_at(outside), 0).rg;
        if (!(out_rg.r < edge_depth * (1.0 - HIDE_EPS))) break;
        if (trip == 1) return false;
        d1 = inside + OUT_TEXELS;
    }
    if (out_rg.g >= 0.5 * FAR_DEPTH) return false;
    z_r = out_rg.g;
    vec2 far_pos = here - dir * (d1 + PLANE_TEXELS);
    if (inside_map(far_pos)) {
        float far_g = texelFetch(shadow_map, texel_at(far_pos), 0).g;
        float inv = 1.0 / z_r + (1.0 / z_r - 1.0 / far_g) * (d1 / PLANE_TEXELS);
        if (abs(far_g - z_r) <= PLANE_LIMIT * z_r && inv > 0.0) {
            z_r = clamp(1.0 / inv, z_r / (1.0 + PLANE_LIMIT), z_r * (1.0 + PLANE_LIMIT));
        }
    }
    return true;
}

#endif
