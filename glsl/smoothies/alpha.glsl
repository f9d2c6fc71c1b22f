// The smoothie pass's per-fragment decision (smoothie.frag): which fragments are written
// and the remapped alpha they write. An include of its own so that tests/shader_guards.rs
// runs these very lines (glsl/tests/smoothie_alpha.comp).
#ifndef SMOOTHIES_ALPHA_GLSL
#define SMOOTHIES_ALPHA_GLSL

// Below this 1 - b/r the remap alpha / (1 - b/r) is not trusted (Volokh Sec. 3.5: b ~ r):
// the smoothie touches what it shadows, so it casts nothing (alpha' = 1). 1e-4 is above
// the relative rounding of the two R32F depths, so no speckles where b and r agree.
const float REMAP_EPS = 1e-4;

// Eq. 1's alpha' = alpha / (1 - b/r), clamped to [0, 1], for a fragment at `dist` from the
// silhouette (along the outward normal, or radially at a corner) of a smoothie of width
// `t`, with f = b / r; false where the fragment is discarded.
bool smoothie_alpha(float f, float dist, float t, out float alpha_out) {
    // Smoothie behind the surface seen at this texel: it shadows nothing there (paper: discard).
    if (f > 1.0) return false;
    // At or past the smoothie's outer side (alpha >= 1) it adds no shadow: not written, so
    // that its b does not MIN-blend into a texel that another smoothie shades. A corner's
    // polygon overshoots its disc of radius t (chords at t / cos(phi / 2)); without this the
    // overshoot's depths showed, and the image depended on how a corner is split into fans.
    if (dist >= t) return false;
    float alpha = clamp(dist / t, 0.0, 1.0);
    float denom = 1.0 - f;
    alpha_out = denom > REMAP_EPS ? min(alpha / denom, 1.0) : 1.0;
    return true;
}

#endif
