// pcss's two radii (src/technique/pcss.rs, Equations 1, 3 and 4) as functions of plain
// numbers, so that tests/shader_guards.rs runs them at the edges of their domain.
#ifndef PCSS_RADII_GLSL
#define PCSS_RADII_GLSL

// Blocker-search radius in texels (Eq. 3), clamped to max_texels. The caller guarantees
// d_r > near (light_sample's inside test); max() keeps it >= 0 regardless.
float pcss_search_texels(float light_uv_near, float d_r, float near, float res, float max_texels) {
    return min(light_uv_near * max(d_r - near, 0.0) / d_r * res, max_texels);
}

// Filter radius in texels (Eq. 1 as uv, Eq. 4), clamped to max_texels. d_b is the mean
// blocker depth, formed only when a blocker was found, so d_b > 0; a blocker is closer
// than the receiver (lit_test), so the radius is >= 0 without a guard.
float pcss_filter_texels(float penumbra_scale, float d_r, float d_b, float res, float max_texels) {
    return min(penumbra_scale * (d_r - d_b) / (d_b * d_r) * res, max_texels);
}

#endif
