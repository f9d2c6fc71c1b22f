// The smoothie pass's per-fragment decision (smoothie.frag): which fragments are written
// and the remapped alpha they write. An include of its own so that tests/shader_guards.rs
// runs these very lines (glsl/tests/smoothie_alpha.comp).
#ifndef SMOOTHIES_ALPHA_GLSL
#define SMOOTHIES_ALPHA_GLSL

#include "common/far_depth.glsl"
// REMAP_EPS: below it 1 - b/r is not trusted (Volokh Sec. 3.5), the smoothie casts nothing.
#include "common/constants.glsl"

// Eq. 1's denominator, the share of the smoothie's width t a receiver at depth r behind a
// smoothie at depth b is shadowed over: a spotlight's (span 0) 1 - b/r; a sun's (span > 0,
// its map's depth range far - near, smoothies/light.glsl) (r - b) / span, as its penumbra
// grows with r - b, not with 1 - b/r (src/technique/smoothies.rs, "Under a sun").
float remap_denom(float b, float r, float span) {
    return span > 0.0 ? (r - b) / span : 1.0 - b / r;
}

// Eq. 1's alpha' = alpha / remap_denom (1 - b/r for a spotlight) for a fragment of a
// smoothie at depth `b`, over the surface at depth `r` (the shadow map's g at its texel), at
// `dist` from the silhouette (along the outward normal, or radially at a corner), of width
// `t`, under a light of remap `span`; false where the fragment is discarded. A fragment is written only where it darkens a surface:
// alpha' < 1. A fully lit fragment casts nothing, and its b must not MIN-blend into a
// texel that another smoothie shades (that b made the receivers between the two
// smoothies' depths take the farther one's alpha).
bool smoothie_alpha(float b, float r, float dist, float t, float span, out float alpha_out) {
    // No surface at this texel (g holds the clear value): nothing to shade, and the shadow
    // map's r there is lit too.
    if (!(r < 0.5 * FAR_DEPTH)) return false;
    float denom = remap_denom(b, r, span);
    // Smoothie behind the surface seen at this texel (b > r: it shadows nothing there,
    // paper: discard), or touching it (Volokh Sec. 3.5, b ~ r: the remap is not trusted,
    // for a sun within REMAP_EPS of its depth range,
    // the smoothie casts nothing); also a NaN b / r.
    if (!(denom > REMAP_EPS)) return false;
    // Eq. 1 reaches alpha' = 1 at dist = t denom: from there on, including past the
    // smoothie's outer side (dist >= t), the fragment adds no shadow. A corner's polygon
    // overshoots its disc of radius t (chords at t / cos(phi / 2)); discarding there makes
    // the image independent of how a corner is split into fans, and of how far short of t
    // the CPU path stops its quads (`records::Extent`).
    float reach = t * denom;
    if (!(dist < reach)) return false;
    alpha_out = max(dist, 0.0) / reach;
    return true;
}

#endif
