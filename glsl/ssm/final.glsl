// Final pass of ssm and ssm2 (Atty et al. Sec. 3.1: "project the soft shadow map onto the
// scene"). Per texel of the 2x2 footprint at the point's light uv: the nearest-receiver
// layer when the point is that receiver (depth within a tolerance), the pure-receiver
// layer when the point lies behind it (e.g. the ground under a caster), no data when the
// texel's receiver lies behind the point (weight 0, weights renormalised). The occlusion
// is clamped to [0,1] per texel (overlapping back-projections can sum above 1, Sec. 5.1.2);
// visibility = 1 - occlusion. ssm2 (TWO_SIDED) merges front and back maps with max (Sec. 3.5).
#include "common/frame.glsl"
#include "ssm/ssm.glsl"
#include "ssm/constants.glsl"

layout(set = 0, binding = 1) uniform sampler2D receiver_front;   // R32F nearest receiver depth
layout(set = 0, binding = 2) uniform sampler2D ssm_front;        // accumulated occlusion, layer 0
layout(set = 0, binding = 3) uniform sampler2D ssm_pure;         // accumulated occlusion, layer 1
#ifdef TWO_SIDED
layout(set = 0, binding = 4) uniform sampler2D ssm_back_front;   // back-face occluder map's SSM, layer 0
layout(set = 0, binding = 5) uniform sampler2D ssm_back_pure;    // back-face occluder map's SSM, layer 1
#endif

// A point matches its texel's nearest receiver when their depths differ by less than this
// many texels of depth slope (the normal offset moves the point by up to 1.5 texels).
const float MATCH_TEXELS = 3.0;

float visibility(vec3 p, vec3 n) {
    float res = SSM_RES;
    float texel = 2.0 * frame.light_frustum.x / res;   // world texel size per unit depth
    // Normal offset as common/shadow.glsl, in occluder-map texels.
    float d0 = -(frame.light_view * vec4(p, 1.0)).z;
    vec3 l = normalize(frame.light_pos_radius.xyz - p);
    float slope = clamp(sqrt(max(1.0 - dot(n, l) * dot(n, l), 0.0)), 0.2, 1.0);
    vec3 po = p + n * (d0 * texel * frame.light_frustum.z * slope);
    vec4 c = frame.light_view_proj * vec4(po, 1.0);
    if (c.w <= frame.light_params.x) return 1.0;
    vec2 uv = (c.xy / c.w) * 0.5 + 0.5;
    if (any(lessThan(uv, vec2(0.0))) || any(greaterThan(uv, vec2(1.0)))) return 1.0;
    float depth = c.w;

    vec4 z1 = textureGather(receiver_front, uv, 0);
    vec4 o1 = textureGather(ssm_front, uv, 0);
    vec4 o2 = textureGather(ssm_pure, uv, 0);
#ifdef TWO_SIDED
    o1 = max(o1, textureGather(ssm_back_front, uv, 0));
    o2 = max(o2, textureGather(ssm_back_pure, uv, 0));
#endif
    vec4 tol = z1 * (frame.light_frustum.w + MATCH_TEXELS * texel);
    vec4 behind = vec4(greaterThan(vec4(depth), z1 + tol));
    vec4 known = vec4(greaterThanEqual(vec4(depth), z1 - tol));
    vec4 occl = clamp(mix(o1, o2, behind), 0.0, 1.0);
    // textureGather order (i0,j1), (i1,j1), (i1,j0), (i0,j0).
    vec2 f = fract(uv * res - 0.5);
    vec4 w = vec4((1.0 - f.x) * f.y, f.x * f.y, f.x * (1.0 - f.y), (1.0 - f.x) * (1.0 - f.y));
    vec4 wk = w * known;
    float sw = wk.x + wk.y + wk.z + wk.w;
    float o = sw > 1e-4 ? dot(wk, occl) / sw : dot(w, clamp(o1, 0.0, 1.0));
    return 1.0 - clamp(o, 0.0, 1.0);
}
