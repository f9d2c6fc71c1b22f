// Shared light-space lookups of the final passes: where a surface point falls in the
// shadow map, and the bilinear weights of the 2x2 texel footprint that textureGather returns.
#ifndef SHADOW_GLSL
#define SHADOW_GLSL
#include "common/frame.glsl"

struct LightSample {
    vec2 uv;        // light-screen uv in [0,1]^2
    float depth;    // linear light depth of the (offset) point
    bool inside;    // inside the light frustum
};

// The light clip coordinates of the point p and of the unit normal n that visibility(p, n)
// gets: light_view_proj * (p, 1) and light_view_proj * (n, 0). common/final.glsl sets them
// from the camera pass's varyings (common/scene.vert) before it calls visibility(): the
// product is affine in p and linear in the unnormalised normal, so interpolating it gives
// the per-pixel product up to float rounding, and light_sample() below needs no 4x4
// product of its own (nor the light_view one for the depth: for a perspective light,
// clip w = -view z). On a CPU driver every pixel pays each product.
vec4 surface_light_clip;
vec4 surface_light_normal;

// Normal offset: moves the lookup point along the normal by a fixed number of shadow-map
// texels at its depth, so a lit surface never compares against its own texel (acne)
// without the large constant bias that detaches contact shadows.
LightSample light_sample(vec3 p, vec3 n) {
    float d0 = surface_light_clip.w;
    vec3 l = light_direction(p);
    // Grazing light needs more offset; clamp so the offset never leaves the texel scale.
    float slope = clamp(sqrt(max(1.0 - dot(n, l) * dot(n, l), 0.0)), 0.2, 1.0);
    // light_view_proj * (p + n k, 1), k the offset length; a sun's texels have one size.
    float k = light_is_sun() ? frame.sun.z * frame.light_frustum.z * slope
                             : d0 * frame.light_frustum.y * frame.light_frustum.z * slope;
    vec4 c = surface_light_clip + surface_light_normal * k;
    LightSample s;
    s.depth = clip_linear_depth(c);
    s.uv = (c.xy / max(c.w, 1e-30)) * 0.5 + 0.5;
    s.inside = s.depth > frame.light_params.x && all(greaterThanEqual(s.uv, vec2(0.0))) && all(lessThanEqual(s.uv, vec2(1.0)));
    return s;
}

// textureGather returns (i0,j1), (i1,j1), (i1,j0), (i0,j0) of the footprint around uv.
float bilinear(vec4 g, vec2 uv) {
    vec2 f = fract(uv * frame.light_params.z - 0.5);
    vec4 w = vec4((1.0 - f.x) * f.y, f.x * f.y, f.x * (1.0 - f.y), (1.0 - f.x) * (1.0 - f.y));
    return dot(g, w);
}

// `bilinear`, but exactly 1 where all four texels are 1: the weights sum to 1 only up to
// rounding, and a final pass drawn in parts (`FinalPass::split`) must give there what its
// lookup-free shader (common/unshadowed.frag) gives elsewhere.
float bilinear_lit(vec4 g, vec2 uv) {
    return all(equal(g, vec4(1.0))) ? 1.0 : bilinear(g, uv);
}

// 1 where the point is in front of (or on) the stored depth, else 0. The relative bias
// absorbs float rounding of the linear depths, which grows with depth.
vec4 lit_test(vec4 stored, float depth) {
    return step(depth, stored * (1.0 + frame.light_frustum.w));
}

#endif
