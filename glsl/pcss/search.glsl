// pcss's three steps (Fernando 2005) for one point. Equation numbers as in
// src/technique/pcss.rs.
#ifndef PCSS_SEARCH_GLSL
#define PCSS_SEARCH_GLSL
#include "pcf/filter.glsl"
#include "pcss/constants.glsl"
#include "pcss/radii.glsl"

// R32F, casters only, MIN-blended, no depth attachment (gpu::passes::ShadowMap::casters):
// the nearest caster's linear depth, the one searched and compared here.
layout(set = 0, binding = 1) uniform sampler2D shadow_map;

// Blocker-search radius in texels (Eq. 3): the light's projection through the receiver onto
// the near plane, clamped to the largest radius.
float pcss_search_radius(LightSample s) {
    // A sun: the widest penumbra a blocker at the near plane throws (Eq. 3s).
    if (light_is_sun())
        return min(penumbra_half_uv(s.depth, frame.light_params.x) * frame.light_params.z,
                   PCSS_MAX_RADIUS_TEXELS);
    return pcss_search_texels(PCSS_LIGHT_UV_NEAR, s.depth, frame.light_params.x,
                              frame.light_params.z, PCSS_MAX_RADIUS_TEXELS);
}

// Steps 2 and 3 for a point whose blocker search found blockers at mean linear depth d_b
// (the blocker search below); `rp` as for the search.
float pcss_filter(LightSample s, ReceiverPlane rp, float d_b) {
    float res = frame.light_params.z;
    float d_r = s.depth;

    // Step 2, penumbra estimate (Eq. 1) in world units at the receiver, as uv (Eq. 4).
    // A sun: parallel projection, (d_r - d_b) tan(theta) at every depth (Eq. 4s).
    float radius = light_is_sun()
        ? min(penumbra_half_uv(d_r, d_b) * res, PCSS_MAX_RADIUS_TEXELS)
        : pcss_filter_texels(PCSS_PENUMBRA_SCALE, d_r, d_b, res, PCSS_MAX_RADIUS_TEXELS);

    // Step 3, PCF over a Poisson disc of that radius; each tap is a 2x2 bilinear footprint.
    // A point light (R = 0) leaves one 2x2 footprint: the `hard` result, one tap.
    int samples = radius < 0.01 ? 1 : int(PCSS_FILTER_SAMPLES);
    rp.max_shift = light_is_sun() ? 8.0 * (radius + 1.0) * frame.sun.z
                                  : 8.0 * (radius + 1.0) * d_r * frame.light_frustum.y;
    return pcf_poisson(shadow_map, s.uv, rp, samples, radius);
}

// Steps 1 to 3 for a point inside the light frustum; `rp` is its receiver plane over the
// search disc (`receiver_plane(s, n, search + 1.0)`).
float pcss_visibility(LightSample s, ReceiverPlane rp, float search) {
    float res = frame.light_params.z;

    // Step 1, blocker search over the disc of Eq. 3, 4 texels per gather.
    // Under half a texel every tap reads the same 2x2 footprint: one is enough (R = 0).
    int taps = search < 0.5 ? 1 : int(PCSS_SEARCH_SAMPLES);
    float depth_sum = 0.0;
    float blockers = 0.0;
    for (int i = 0; i < taps; ++i) {
        COUNT_LOOP(COUNT_SEARCH);
        vec2 duv = POISSON[i] * (search / res);
        vec4 g = textureGather(shadow_map, s.uv + duv, 0);
        // The receiver's own surface inside the search disc is no blocker (filter.glsl).
        vec4 blocked = vec4(1.0) - lit_test(g, plane_depth(rp, duv));
        depth_sum += dot(blocked, g);
        blockers += dot(blocked, vec4(1.0));
    }
    if (blockers == 0.0) return 1.0;              // nothing in front: fully lit, no filter
    if (blockers == float(4 * taps)) return 0.0;  // every texel blocked: umbra
    return pcss_filter(s, rp, depth_sum / blockers);
}

#endif
