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
#include "ssm/footprint.glsl"

layout(set = 0, binding = 1) uniform sampler2D receiver_front;   // R32F nearest receiver depth
layout(set = 0, binding = 2) uniform sampler2D ssm_front;        // accumulated occlusion, layer 0
layout(set = 0, binding = 3) uniform sampler2D ssm_pure;         // accumulated occlusion, layer 1
#ifdef TWO_SIDED
layout(set = 0, binding = 4) uniform sampler2D ssm_back_front;   // back-face occluder map's SSM, layer 0
layout(set = 0, binding = 5) uniform sampler2D ssm_back_pure;    // back-face occluder map's SSM, layer 1
#endif

float visibility(vec3 p, vec3 n) {
    float res = SSM_RES;
    // World texel size per unit depth; a sun's world texel (footprint.glsl).
    float texel = light_is_sun() ? ssm_sun_texel() : 2.0 * frame.light_frustum.x / res;
    vec3 po = ssm_offset_point(p, n, texel);
    vec4 c = frame.light_view_proj * vec4(po, 1.0);
    // A sun's clip w is 1: in front of its near plane is clip z >= 0.
    if (light_is_sun() ? c.z < 0.0 : c.w <= frame.light_params.x) return 1.0;
    vec2 uv = (c.xy / c.w) * 0.5 + 0.5;
    if (any(lessThan(uv, vec2(0.0))) || any(greaterThan(uv, vec2(1.0)))) return 1.0;
    float depth = clip_linear_depth(c);

    vec4 z1 = textureGather(receiver_front, uv, 0);
    vec4 o1 = textureGather(ssm_front, uv, 0);
    vec4 o2 = textureGather(ssm_pure, uv, 0);
#ifdef TWO_SIDED
    o1 = max(o1, textureGather(ssm_back_front, uv, 0));
    o2 = max(o2, textureGather(ssm_back_pure, uv, 0));
#endif
    bvec4 behind;
    vec4 known;
    ssm_layers(depth, z1, texel, behind, known);
    vec4 occl = clamp(mix(o1, o2, vec4(behind)), 0.0, 1.0);
    float o = ssm_footprint(uv, res, known, occl, clamp(o1, 0.0, 1.0));
    return 1.0 - clamp(o, 0.0, 1.0);
}
