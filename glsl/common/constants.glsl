// Numbers that several shaders, or a shader and the Rust side, must agree on, written once:
// build.rs turns each `const float` here into `shaders::constants::NAME`, which the Rust
// side and the tests read instead of a copy.
#ifndef COMMON_CONSTANTS_GLSL
#define COMMON_CONSTANTS_GLSL

// Below this 1 - b/r a smoothie's remap alpha / (1 - b/r) is not trusted (Volokh Sec. 3.5:
// b ~ r): the smoothie touches what it shadows, so it casts nothing. Above the relative
// rounding of two R32F depths, so no speckles where b and r agree. Both smoothie forms'
// fragments (smoothies/alpha.glsl, smoothies_centred/inner.frag).
const float REMAP_EPS = 1e-4;

// The centred final passes' receiver window (smoothies_centred/final.frag,
// penumbra_map_centred/final.frag): a point more than this (relative) beyond the receiver
// an inner value was made for is behind something else. The inner passes extrapolate that
// receiver's plane, so 5 % is several texels' worth of slope and far below the gap between
// a caster and the ground it stands over.
const float RECEIVER_EPS = 0.05;

// The inner passes' receiver plane (common/inner_receiver.glsl): the largest relative depth
// change between its two samples, and of the extrapolation, that still counts as one
// plane. The Rust side bounds the inner smoothies' reach with it (regions::INNER_PLANE_LIMIT).
const float PLANE_LIMIT = 0.05;

// The centred forms' packed light values (common/packed.glsl): an R32F key holds a value
// in its high part, as one of STEPS + 1 levels, and a depth code in its low part, as one of
// LEVELS. (STEPS + 1) x LEVELS = 2^24, the integers a float holds exactly. The outer key:
// the outer share in [-1, 0] over 512 levels, the smoothie's (or foremost surface's)
// depth over 32768 codes; the inner key: the inner share in [-1, 1] over 1024 levels,
// its receiver's depth over 16384 codes.
const float OUTER_KEY_STEPS = 511.0;
const float OUTER_KEY_LEVELS = 32768.0;
const float INNER_KEY_STEPS = 1023.0;
const float INNER_KEY_LEVELS = 16384.0;

#endif
