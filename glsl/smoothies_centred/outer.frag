#version 450
#extension GL_GOOGLE_include_directive : require
#include "common/count.glsl"  // by name: build.rs also builds it counted (-DCOUNT_LIGHT)
// smoothies-centred/smoothie, outer smoothies: the paper's smoothie fragment
// (smoothies/smoothie.frag: receiver r = the shadow map's g at this texel, discard when
// b/r > 1 or past the smoothie's outer side) with the penumbra centred on the hard edge.
// With the calibrated width t (R / (2 b tan(fov/2)), src/silhouette/smoothie.rs `Width`) the
// half-width of a disc light's penumbra at receiver depth r is t (1 - b/r) uv, so the
// paper's remapped alpha' = alpha / (1 - b/r) (Eq. 1) is exactly s, the fragment's distance
// outside the hard edge over that half-width, and the visibility is disc_chord(-s): 0.5
// on the hard edge, 1 at the outer rim. Writes b (MIN: the nearest smoothie) and
// (v, 1, 1, 1) (MIN on v: the darkest outer value wins, the paper's rule).
#include "smoothies_centred/smoothie.glsl"

void main() {
    float t = v_width;
    vec2 uv = gl_FragCoord.xy * frame.light_params.w;
    float b = 1.0 / v_inv_depth;
    float r = texelFetch(shadow_map, ivec2(gl_FragCoord.xy), 0).g;
    float f = b / r;
    if (f > 1.0) discard;
    vec2 dir;
    float x = smoothie_distance(uv, dir);
    if (x >= t) discard;
    float denom = 1.0 - f;
    float s = outer_fraction(x, t, denom);
    o_depth = b;
    o_penumbra = vec4(disc_chord(-s), 1.0, 1.0, 1.0);
}
