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
// The unit normal of the triangle itself (from the position's screen derivatives), on the
// side of n: the plane the shadow map stored, where the shading normal is interpolated.
vec3 surface_facet_normal;

// Receiver offset: the lookup point moves towards the light along its own ray until it
// stands k above the surface's tangent plane, k a fixed number of shadow-map texels at its
// depth (times the sine of the light's incidence, as grazing light spreads a texel's
// depths further). Its uv stays the point's own, so no shadow moves: a normal offset (the
// point moved by k along n) shifts every shadow on a tilted receiver by k sin(theta) across
// the light's rays, most of the error of every technique on `fence`. Only its depth
// changes, by k / cos(theta), so a lit surface still never compares against its own texel
// (acne) without the large constant bias that detaches contact shadows. Of the shading and
// the facet normal the one nearer to grazing sets theta; cos(theta) is clamped at 0.2, at
// most five times k, where mae_lit stops judging (terminators). A surface turned away from
// the light keeps the normal offset: moved across the rays away from its silhouette, its
// footprint reads its own caster's texels, not the lit ones beyond the outline.
LightSample light_sample(vec3 p, vec3 n) {
    float d0 = surface_light_clip.w;
    vec3 l = light_direction(p);
    float slope = clamp(sqrt(max(1.0 - dot(n, l) * dot(n, l), 0.0)), 0.2, 1.0);
    // k, the height above the tangent plane; a sun's texels have one size.
    float k = light_is_sun() ? frame.sun.z * frame.light_frustum.z * slope
                             : d0 * frame.light_frustum.y * frame.light_frustum.z * slope;
    bool away = dot(n, l) < 0.0;
    float along = away ? 0.0 : k / max(min(dot(n, l), dot(surface_facet_normal, l)), 0.2);
    vec4 c = surface_light_clip + surface_light_normal * (away ? k : 0.0);
    LightSample s;
    // A sun's rays run along the map's axis; a spotlight's depth scales along the ray.
    s.depth = light_is_sun() ? clip_linear_depth(c) - along
                             : c.w * (1.0 - along / length(frame.light_pos_radius.xyz - p));
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
