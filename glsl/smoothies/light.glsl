// What the smoothie fragment shaders (smoothie.frag, smoothies_centred/) take from the
// light's kind (src/technique/smoothies.rs, "Under a sun"): the smoothie's linear depth b
// from its interpolated varying, and Eq. 1's span.
#ifndef SMOOTHIES_LIGHT_GLSL
#define SMOOTHIES_LIGHT_GLSL
#include "common/frame.glsl"

// smoothie.vert interpolates 1/b for a spotlight (1/depth is affine in a perspective map's
// screen space) and b itself for a sun (depth is affine in an orthographic map's).
float smoothie_b(float v) {
    return light_is_sun() ? v : 1.0 / v;
}

// Eq. 1's span (smoothies/alpha.glsl `remap_denom`): 0 for a spotlight, whose remap is
// 1 - b/r; a sun's map depth range far - near, its remap (r - b) / span.
float remap_span() {
    return light_is_sun() ? frame.light_params.y - frame.light_params.x : 0.0;
}

#endif
