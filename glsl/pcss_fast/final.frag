#version 450
#extension GL_GOOGLE_include_directive : require
// pcss-fast final pass: pcss (pcss/search.glsl) after one look at the min/max hierarchy,
// which settles "no blocker" (1) and "every texel blocked" (0) for most points with at most
// nine reads. Equation numbers as in src/technique/pcss.rs and pcss_fast.rs.
#include "pcss/search.glsl"
#include "pcss_fast/constants.glsl"
#include "pcss_fast/hierarchy.glsl"

layout(std430, set = 0, binding = 2) readonly buffer MinMax { vec2 cells[]; } minmax;

// (min, max) of the caster depths over the cells of the lowest level at which the texels
// [lo, hi] span at most 3 x 3 cells; (0, 3e38), deciding nothing, if none does.
vec2 depth_bounds(ivec2 lo, ivec2 hi) {
    int last = int(PCSS_FAST_LAST_LEVEL);
    int res = int(frame.light_params.z);
    int offset = 0;
    for (int k = 2; k <= last; ++k) {
        int size = level_size(res, k);
        ivec2 a = lo >> k;
        ivec2 b = hi >> k;
        if (all(lessThanEqual(b - a, ivec2(2)))) {
            vec2 r = vec2(3.0e38, 0.0);
            for (int y = a.y; y <= b.y; ++y) {
                for (int x = a.x; x <= b.x; ++x) {
                    vec2 c = minmax.cells[offset + y * size + x];
                    r = vec2(min(r.x, c.x), max(r.y, c.y));
                }
            }
            return r;
        }
        offset += size * size;
    }
    return vec2(0.0, 3.0e38);
}

float visibility(vec3 p, vec3 n) {
    LightSample s = light_sample(p, n);
    if (!s.inside) return 1.0;
    float res = frame.light_params.z;
    float search = pcss_search_radius(s);
    ReceiverPlane rp = receiver_plane(s, n, search + 1.0);

    // Every texel a search tap's 2x2 gather can read: within search + 1 texels of the point
    // (the Poisson points lie inside the unit disc), clamped as the sampler clamps.
    vec2 c = s.uv * res;
    ivec2 top = ivec2(res) - 1;
    ivec2 lo = clamp(ivec2(floor(c - search - 1.5)), ivec2(0), top);
    ivec2 hi = clamp(ivec2(floor(c + search + 1.5)), ivec2(0), top);
    vec2 bounds = depth_bounds(lo, hi);
    float bias = 1.0 + frame.light_frustum.w;

    // pcss's lit test compares each tap with the receiver plane, never deeper than the point
    // itself (plane_depth only moves it closer): no texel in front of the point, no blocker.
    if (bounds.x * bias >= rp.depth) return 1.0;
    // The plane is closest at the tap that raises q = 1 + g . duv most, |duv| <= search
    // texels on each axis; every texel in front of that depth (with a margin for rounding)
    // blocks every tap: pcss's umbra.
    float q = 1.0 + (abs(rp.g.x) + abs(rp.g.y)) * (search / res);
    float nearest = rp.depth + max(rp.depth * (1.0 / q - 1.0), -rp.max_shift);
    if (bounds.y * bias < nearest * (1.0 - 1e-5)) return 0.0;

    return pcss_visibility(s, rp, search);
}

#include "common/final.glsl"
