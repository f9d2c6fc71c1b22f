// Two light values in one R32F texel, so that a final pass reads both with one gather (a
// gather returns one channel of four texels; two values in two channels cost two). The
// centred forms' light passes write them (smoothies_centred, penumbra_map_centred: outer
// and inner), their final passes unpack them; src/technique/packed.rs unpacks them the same
// way for `--buffers`.
//
// A key is an integer below 2^24, which a float holds exactly: the high part is the value
// MIN blending must pick as one of STEPS + 1 levels, the low part a linear light depth as
// one of LEVELS codes. A MIN over keys is a MIN over the high parts, and among equal high
// parts over the low ones: the depth that travels with the value is that of the value kept,
// not the nearest or farthest of all. The value is a penumbra share s
// (common/penumbra.glsl: -1 lit, 1 umbra), which the final passes interpolate before they
// take the profile. The profile falls as s grows, so the darkest outer value is the largest
// s and the lightest inner value the smallest: the outer key's high part is -s (an outer
// share lies in [-1, 0], the hard edge's 0 or lighter: a step of 1/511), the inner key's
// (1 + s) / 2 (an inner share lies in [-1, 1], lighter than the hard edge where a thin
// blocker lets light through: a step of 2/1023). The depth code is logarithmic over the
// light's range, so that its relative step is the same at every depth: ln(far / near) /
// LEVELS, which frustum.rs's far <= 1e5 near bounds by 3.5e-4 for the outer keys' 32768
// codes (rounded to the nearest: within 1.8e-4, below the relative depth bias of the tests
// against them) and by 7e-4 for the inner keys' 16384 (far below their 5 % window).
#ifndef COMMON_PACKED_GLSL
#define COMMON_PACKED_GLSL
#include "common/frame.glsl"
#include "common/constants.glsl"

// The code in [0, 1] of linear light depth d: 0 at the near plane, 1 at the far plane and
// beyond (the 1e30 of "nothing drawn" included).
float depth_code(float d) {
    float near = frame.light_params.x;
    return clamp(log2(max(d, near) / near) / log2(frame.light_params.y / near), 0.0, 1.0);
}

// The linear light depths of codes c (depth_code's inverse).
vec4 code_depth(vec4 c) {
    float near = frame.light_params.x;
    return near * exp2(c * log2(frame.light_params.y / near));
}

// The key of `high` and `low` (both in [0, 1]), each rounded to the nearest of its levels.
float pack_key(float high, float steps, float low, float levels) {
    return round(clamp(high, 0.0, 1.0) * steps) * levels
        + round(clamp(low, 0.0, 1.0) * (levels - 1.0));
}

// The high and low parts of four keys, each in [0, 1]: pack_key's inverse up to rounding.
void unpack_keys(vec4 keys, float steps, float levels, out vec4 high, out vec4 low) {
    vec4 q = floor(keys / levels);   // exact: levels is a power of two
    high = q / steps;
    low = (keys - q * levels) / (levels - 1.0);
}

// Outer key: the outer share s in [-1, 0] (darkest, largest s, first) with the depth
// `depth` of what made it (smoothies-centred: the smoothie's b; penumbra-map-centred: the
// texel's foremost surface). Cleared to 2^24 - 1: lit (s = -1), with the far plane's code.
float outer_key(float s, float depth) {
    return pack_key(-s, OUTER_KEY_STEPS, depth_code(depth), OUTER_KEY_LEVELS);
}

// Inner key: the inner share s in [-1, 1] (lightest, smallest s, first) with the depth of
// the receiver it was made for (of equal shares the farthest first, so the code is
// 1 - depth_code). Cleared to 2^24 - 1: umbra (s = 1), with the near plane's code.
float inner_key(float s, float receiver) {
    return pack_key(0.5 + 0.5 * s, INNER_KEY_STEPS, 1.0 - depth_code(receiver), INNER_KEY_LEVELS);
}

// Four gathered outer keys: their shares and depth codes (compare the codes with a point's
// depth_code; code_depth gives the depths).
void unpack_outer(vec4 keys, out vec4 s, out vec4 depth_codes) {
    vec4 high;
    unpack_keys(keys, OUTER_KEY_STEPS, OUTER_KEY_LEVELS, high, depth_codes);
    s = -high;
}

// 1 where a point at linear depth `depth` is in front of (or on) the depths of `codes`,
// else 0: `lit_test` (common/shadow.glsl) on depth codes, so that the keys' depths need no
// decoding (the code is monotonic in the depth).
vec4 in_front_of_codes(vec4 codes, float depth) {
    return step(depth_code(depth / (1.0 + frame.light_frustum.w)), codes);
}

// Four gathered inner keys: their shares and their receivers' codes (receiver_depths gives
// the depths).
void unpack_inner(vec4 keys, out vec4 s, out vec4 receiver_codes) {
    vec4 high;
    unpack_keys(keys, INNER_KEY_STEPS, INNER_KEY_LEVELS, high, receiver_codes);
    s = 2.0 * high - 1.0;
}

// The receiver depths of unpack_inner's codes.
vec4 receiver_depths(vec4 receiver_codes) {
    return code_depth(1.0 - receiver_codes);
}

#endif
