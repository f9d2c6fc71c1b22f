// Final pass of ssm-bitmask. As ssm's (glsl/ssm/final.glsl) in its 2x2
// footprint of the receiver map: layer 0 where the point is its texel's nearest receiver,
// layer 1 behind it, no data where the texel's receiver is behind the point. Unlike ssm's,
// the footprint is read at the point itself, not at the normal-offset point: only the depth
// that picks each texel's layer is the offset point's (see `visibility`). Each texel's
// occlusion = popcount(mask) / SAMPLES (SSMB_INV_SAMPLES), the fraction of the light samples that some
// micro-quad hides (a union: never above 1, no clamp needed); visibility = 1 - occlusion.
#include "common/frame.glsl"
#include "ssm/ssm.glsl"
#include "ssm_bitmask/constants.glsl"
#include "ssm/footprint.glsl"

layout(set = 0, binding = 1) uniform sampler2D receiver_front;   // R32F nearest receiver depth
layout(set = 0, binding = 2) uniform usampler2D mask_front;      // RGBA32UI hidden samples, layer 0
layout(set = 0, binding = 3) uniform usampler2D mask_pure;       // RGBA32UI hidden samples, layer 1

float hidden_fraction(uvec4 m) {
    ivec4 c = bitCount(m);
    return float(c.x + c.y + c.z + c.w) * SSMB_INV_SAMPLES;
}

float visibility(vec3 p, vec3 n) {
    float res = SSM_RES;
    // World texel size per unit depth; a sun's world texel (ssm/footprint.glsl).
    float texel = light_is_sun() ? ssm_sun_texel() : 2.0 * frame.light_frustum.x / res;
    // The masks hold the visibility of the receiver at each texel's centre: the point is
    // looked up where it is (ssm looks up a normal-offset point, which reads the receivers
    // beside it and shifts every penumbra by a fraction of a texel). Only the depth that
    // picks the layer is the offset point's (ssm's offset, in occluder-map texels), so that a
    // caster's own steep surface is not taken for something behind its texel's receiver.
    vec3 po = ssm_offset_point(p, n, texel);
    vec4 c = frame.light_view_proj * vec4(p, 1.0);
    // A sun's clip w is 1: in front of its near plane is clip z >= 0.
    if (light_is_sun() ? c.z < 0.0 : c.w <= frame.light_params.x) return 1.0;
    vec2 uv = (c.xy / c.w) * 0.5 + 0.5;
    if (any(lessThan(uv, vec2(0.0))) || any(greaterThan(uv, vec2(1.0)))) return 1.0;
    float depth = clip_linear_depth(frame.light_view_proj * vec4(po, 1.0));

    vec4 z1 = textureGather(receiver_front, uv, 0);
    bvec4 behind;
    vec4 known;
    ssm_layers(depth, z1, texel, behind, known);
    // The texels textureGather read, in its order (i0,j1), (i1,j1), (i1,j0), (i0,j0).
    ivec2 i0 = ivec2(floor(uv * res - 0.5));
    ivec2 last = ivec2(int(res) - 1);
    const ivec2 offsets[4] = ivec2[4](ivec2(0, 1), ivec2(1, 1), ivec2(1, 0), ivec2(0, 0));
    vec4 occl, front;
    for (int k = 0; k < 4; ++k) {
        COUNT_LOOP(COUNT_FILTER);
        ivec2 t = clamp(i0 + offsets[k], ivec2(0), last);
        front[k] = hidden_fraction(texelFetch(mask_front, t, 0));
        occl[k] = behind[k] ? hidden_fraction(texelFetch(mask_pure, t, 0)) : front[k];
    }
    float o = ssm_footprint(uv, res, known, occl, front);
    return 1.0 - clamp(o, 0.0, 1.0);
}
