// Shadow-map filters shared by `pcf` and `pcss`: a box of bilinear taps built from
// textureGather footprints, and a fixed Poisson disc of bilinear taps.
#ifndef PCF_FILTER_GLSL
#define PCF_FILTER_GLSL
#include "common/shadow.glsl"

// 64 points in the unit disc, Mitchell's best-candidate order (seed 20050731, generated
// once offline and frozen): every prefix of N points is itself a well-spread disc, so a
// kernel of N samples takes the first N. Points keep half a spacing from the rim, as
// cells of equal area would. Fixed, no per-pixel rotation: results are deterministic.
const int POISSON_MAX = 64;
const vec2 POISSON[POISSON_MAX] = vec2[](
    vec2(-0.0877, 0.0815), vec2(0.6179, -0.2075), vec2(-0.3423, -0.5583), vec2(0.2104, 0.6654),
    vec2(-0.6687, 0.0261), vec2(-0.3156, 0.5641), vec2(0.1472, -0.6865), vec2(0.5965, 0.3038),
    vec2(0.2065, -0.1916), vec2(-0.6873, -0.3641), vec2(0.5533, -0.5583), vec2(-0.6434, 0.3954),
    vec2(-0.3645, -0.1889), vec2(0.2430, 0.1501), vec2(-0.0273, 0.4098), vec2(-0.0497, -0.4038),
    vec2(0.8262, 0.0763), vec2(0.5511, 0.6366), vec2(-0.1291, 0.8294), vec2(-0.1396, -0.8386),
    vec2(-0.3729, 0.2341), vec2(0.5103, 0.0585), vec2(0.3053, -0.4494), vec2(0.3638, 0.4618),
    vec2(-0.5789, 0.6298), vec2(-0.8625, -0.1404), vec2(-0.0523, -0.1625), vec2(-0.5808, -0.6558),
    vec2(0.7667, -0.4278), vec2(0.3825, -0.7540), vec2(0.8579, -0.1834), vec2(-0.8390, 0.2515),
    vec2(-0.0102, 0.6257), vec2(-0.3736, -0.7843), vec2(0.1020, 0.8709), vec2(0.8234, 0.3215),
    vec2(-0.3746, 0.7904), vec2(0.4018, 0.7934), vec2(-0.4663, -0.3743), vec2(-0.4502, 0.0114),
    vec2(-0.0696, -0.6193), vec2(0.7026, 0.4967), vec2(-0.5958, -0.1710), vec2(0.1741, 0.3494),
    vec2(0.0996, -0.8864), vec2(0.4260, -0.1336), vec2(-0.2358, -0.3375), vec2(-0.2312, 0.3657),
    vec2(-0.8989, 0.0594), vec2(-0.5732, 0.2085), vec2(0.1233, -0.0180), vec2(0.4663, -0.3366),
    vec2(-0.4384, 0.4160), vec2(-0.2188, -0.0611), vec2(0.4146, 0.2249), vec2(0.1242, -0.3691),
    vec2(0.0344, 0.2143), vec2(0.7091, -0.0580), vec2(-0.7203, -0.5274), vec2(0.6666, 0.1447),
    vec2(0.3083, -0.0161), vec2(-0.7290, 0.5437), vec2(0.5479, -0.7240), vec2(-0.8504, -0.3399)
);

// Receiver plane (after Isidoro 2006, "receiver plane depth bias"): a wide kernel reads
// texels of the receiver's own surface at other depths, and a surface sloping away from the
// light would shadow itself. Each tap instead compares with the depth of the point's tangent
// plane along the tap's light ray, only where that plane is closer than the point (a convex
// or flat caster never self-shadows; a blocker in front of the plane still blocks).
// Along the light ray through uv (view space direction ((2u-1)tan, (2v-1)tan, -1)) the
// plane's depth is d0 / (1 + g . (uv - uv0)) with g = 2 tan (Nx, Ny) / (N . D(uv0)).
struct ReceiverPlane {
    vec2 g;
    float depth;
    float max_shift;  // a guard for planes edge-on to the light
};

// Under a sun's parallel rays (x = (2u - 1) h, h the map's half width) the plane's depth is
// linear in uv instead: d0 (1 - g . (uv - uv0)) with g = 2 h (Nx, Ny) / (d0 (N . D)).
ReceiverPlane receiver_plane(LightSample s, vec3 n, float radius_texels) {
    float t = frame.light_frustum.x;
    vec3 nv = mat3(frame.light_view) * n;
    ReceiverPlane rp;
    rp.depth = s.depth;
    if (light_is_sun()) {
        float h = 0.5 * frame.sun.z * frame.light_params.z;
        float den = -nv.z;
        rp.g = abs(den) > 1e-6 ? 2.0 * h * nv.xy / (den * s.depth) : vec2(0.0);
        rp.max_shift = 8.0 * radius_texels * frame.sun.z;
        return rp;
    }
    float den = dot(nv, vec3((2.0 * s.uv - 1.0) * t, -1.0));
    rp.g = abs(den) > 1e-6 ? 2.0 * t * nv.xy / den : vec2(0.0);
    // At most a slope of 8 over the kernel radius.
    rp.max_shift = 8.0 * radius_texels * s.depth * frame.light_frustum.y;
    return rp;
}

// Comparison depth of a tap offset by duv from the point.
float plane_depth(ReceiverPlane rp, vec2 duv) {
    float q = 1.0 + dot(rp.g, duv);
    float shift = q > 1.0 ? (light_is_sun() ? rp.depth * (1.0 - q) : rp.depth * (1.0 / q - 1.0)) : 0.0;
    return rp.depth + max(shift, -rp.max_shift);
}

// Box-filtered bilinear PCF: n x n (n odd) bilinear taps one texel apart around uv.
// Summed, their weights per texel are 1 inside the (n+1) x (n+1) footprint and the
// bilinear fractions (1 - f, f) on its first and last row/column, so the footprint is read
// with ((n+1)/2)^2 gathers of 2x2 texels and weighted once. n = 1 is exactly `hard`.
// Each gather compares with the receiver plane at its offset from the point's own 2x2
// footprint (whole texels; the normal offset covers the half texel), so box1 is `hard`.
float pcf_box(sampler2D sm, vec2 uv, ReceiverPlane rp, int n) {
    float res = frame.light_params.z;
    vec2 t = uv * res - 0.5;
    vec2 i0 = floor(t);
    vec2 f = t - i0;
    int h = (n - 1) / 2;
    float sum = 0.0;
    bool every_lit = true;
    for (int b = 0; b <= n; b += 2) {
        // Texel rows b and b + 1 of the footprint (relative to i0 - h).
        float wy0 = (b < n ? 1.0 - f.y : 0.0) + (b > 0 ? f.y : 0.0);
        float wy1 = (b + 1 < n ? 1.0 - f.y : 0.0) + f.y;
        for (int a = 0; a <= n; a += 2) {
            COUNT_LOOP(COUNT_FILTER);
            float wx0 = (a < n ? 1.0 - f.x : 0.0) + (a > 0 ? f.x : 0.0);
            float wx1 = (a + 1 < n ? 1.0 - f.x : 0.0) + f.x;
            // The midpoint between texels k and k + 1 gathers exactly those two.
            vec2 k = i0 - float(h) + vec2(a, b);
            float d = plane_depth(rp, (vec2(a, b) - float(h)) / res);
            vec4 lit = lit_test(textureGather(sm, (k + 1.0) / res, 0), d);
            // Gather order: (k, l+1), (k+1, l+1), (k+1, l), (k, l).
            sum += dot(lit, vec4(wx0 * wy1, wx1 * wy1, wx1 * wy0, wx0 * wy0));
            every_lit = every_lit && all(equal(lit, vec4(1.0)));
        }
    }
    // The weights sum to n^2 only up to rounding; visibility must stay in [0,1], and be
    // exactly 1 where every texel is lit, as the lookup-free shader of a split final pass
    // (FinalPass::split) gives.
    return every_lit ? 1.0 : clamp(sum / float(n * n), 0.0, 1.0);
}

// Poisson-disc PCF: the first n points of POISSON scaled to `radius` texels, each a 2x2
// bilinear tap, equally weighted. radius = 0 is exactly `hard`.
float pcf_poisson(sampler2D sm, vec2 uv, ReceiverPlane rp, int n, float radius) {
    vec2 scale = vec2(radius * frame.light_params.w);
    float sum = 0.0;
    for (int i = 0; i < n; ++i) {
        COUNT_LOOP(COUNT_FILTER);
        vec2 q = uv + POISSON[i] * scale;
        // bilinear_lit: n lit taps sum to exactly n, so the result is exactly 1.
        sum += bilinear_lit(lit_test(textureGather(sm, q, 0), plane_depth(rp, q - uv)), q);
    }
    return clamp(sum / float(n), 0.0, 1.0);
}

#endif
