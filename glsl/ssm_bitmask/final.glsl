// Final pass of ssm-bitmask. As ssm's (glsl/ssm/final.glsl) in its 2x2 footprint of the
// receiver map: layer 0 where the point is its texel's nearest receiver, layer 1 behind it,
// no data where the texel's receiver is behind the point. Unlike ssm's, the footprint is
// read at the point itself, not at the normal-offset point: only the depth that picks each
// texel's layer is the offset point's (see `visibility`). Each texel holds, per layer, the
// offset d of the straight edge whose disc segment hides the share of the light samples
// that some micro-quad hides (ssm_bitmask/resolve.frag); the footprint interpolates d, and
// the occlusion is that edge's share, disc_chord(d) (common/penumbra.glsl). Behind a
// straight edge d is linear across the receiver where the share bends at both ends of the
// penumbra: interpolated as shares, a penumbra would start a texel early and end a texel
// late; visibility = 1 - occlusion.
#include "common/frame.glsl"
#include "common/penumbra.glsl"
#include "ssm/ssm.glsl"
#include "ssm_bitmask/constants.glsl"
#include "ssm/footprint.glsl"

layout(set = 0, binding = 1) uniform sampler2D receiver_front;   // R32F nearest receiver depth
// R32F, ssm-bitmask/resolve: both layers' edge offsets, 4096 * front + pure (0 ..= 4095
// each over [-1, 1]).
layout(set = 0, binding = 2) uniform sampler2D edge_offsets;

float visibility(vec3 p, vec3 n) {
    float res = SSM_RES;
    // World texel size per unit depth; a sun's world texel (ssm/footprint.glsl).
    float texel = light_is_sun() ? ssm_sun_texel() : 2.0 * frame.light_frustum.x / res;
    // The masks hold the visibility of the receiver at each texel's centre: the point is
    // looked up where it is (ssm looks up a normal-offset point, which reads the receivers
    // beside it and shifts every penumbra by a fraction of a texel). Only the depth that
    // picks the layer is the offset point's (ssm's offset, in occluder-map texels), so that
    // a caster's own steep surface is not taken for something behind its texel's receiver.
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
    // The same four texels, in the same order: each one's edge offsets of both layers.
    vec4 packed = textureGather(edge_offsets, uv, 0);
    vec4 front_q = floor(packed * (1.0 / (SSMB_OFFSET_LEVELS + 1.0)));
    vec4 pure_q = packed - (SSMB_OFFSET_LEVELS + 1.0) * front_q;
    // 0 ..= 4095 back to [-1, 1]: a full umbra texel at -1, a lit one at 1 (within the
    // rounding the ends below take up).
    vec4 front = front_q * (1.0 / (0.5 * SSMB_OFFSET_LEVELS)) - 1.0;
    vec4 pure = pure_q * (1.0 / (0.5 * SSMB_OFFSET_LEVELS)) - 1.0;
    vec4 offset = mix(front, pure, vec4(behind));
    float d = ssm_footprint(uv, res, known, offset, front);
    // The offset d hides disc_chord(d): it lets through the share -d's profile, exactly 1
    // and 0 at the ends, as the hidden shares gave.
    return share_visibility(-d);
}
