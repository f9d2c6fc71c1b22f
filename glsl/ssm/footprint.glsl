// The final passes' lookup shared by ssm, ssm2 and the bitmask forms (glsl/ssm/final.glsl,
// glsl/ssm_bitmask/final.glsl): the normal-offset point, and the 2x2 footprint of the
// receiver map that picks each texel's layer and weight. Texels in textureGather order
// (i0,j1), (i1,j1), (i1,j0), (i0,j0).
#ifndef SSM_FOOTPRINT_GLSL
#define SSM_FOOTPRINT_GLSL
#include "common/frame.glsl"

// A point matches its texel's nearest receiver when their depths differ by less than this
// many texels of depth slope (the normal offset moves the point by up to 1.5 texels).
const float MATCH_TEXELS = 3.0;

// Normal offset as common/shadow.glsl, in occluder-map texels (`texel`: world texel size
// per unit depth).
// A sun: `texel` is the world texel (its map's texels have one size).
vec3 ssm_offset_point(vec3 p, vec3 n, float texel) {
    if (light_is_sun()) {
        vec3 d = light_direction(p);
        float sun_slope = clamp(sqrt(max(1.0 - dot(n, d) * dot(n, d), 0.0)), 0.2, 1.0);
        return p + n * (texel * frame.light_frustum.z * sun_slope);
    }
    float d0 = -(frame.light_view * vec4(p, 1.0)).z;
    vec3 l = normalize(frame.light_pos_radius.xyz - p);
    float slope = clamp(sqrt(max(1.0 - dot(n, l) * dot(n, l), 0.0)), 0.2, 1.0);
    return p + n * (d0 * texel * frame.light_frustum.z * slope);
}

// Per footprint texel, from its nearest receiver's depth z1: whether the point lies behind
// that receiver (it reads layer 1, the pure receivers, e.g. the ground under a caster), and
// whether the texel knows the point at all (its receiver is not behind the point).
void ssm_layers(float depth, vec4 z1, float texel, out bvec4 behind, out vec4 known) {
    vec4 tol = light_is_sun() ? z1 * frame.light_frustum.w + MATCH_TEXELS * texel
                              : z1 * (frame.light_frustum.w + MATCH_TEXELS * texel);
    behind = greaterThan(vec4(depth), z1 + tol);
    known = vec4(greaterThanEqual(vec4(depth), z1 - tol));
}

// The footprint's occlusion: bilinear over the texels that know the point, weights
// renormalised; where none does, the front layer's plain bilinear (`front`).
float ssm_footprint(vec2 uv, float res, vec4 known, vec4 occl, vec4 front) {
    vec2 f = fract(uv * res - 0.5);
    vec4 w = vec4((1.0 - f.x) * f.y, f.x * f.y, f.x * (1.0 - f.y), (1.0 - f.x) * (1.0 - f.y));
    vec4 wk = w * known;
    float sw = wk.x + wk.y + wk.z + wk.w;
    return sw > 1e-4 ? dot(wk, occl) / sw : dot(w, front);
}

#endif
