// The centred smoothies' remap guard, an include of its own so that tests/shader_guards.rs
// runs these very lines (glsl/tests/centred_remap.comp).
#ifndef SMOOTHIES_CENTRED_REMAP_GLSL
#define SMOOTHIES_CENTRED_REMAP_GLSL

// Below this 1 - b/r the smoothie touches what it shadows (Volokh Sec. 3.5: b ~ r): no
// penumbra, and no division by a rounding-sized denominator.
const float REMAP_EPS = 1e-4;

// s of outer.frag: the distance `x` outside the hard edge over the penumbra's half-width
// t (1 - b/r) (`denom` = 1 - b/r), clamped to [0, 1]; 1 (the outer rim: lit) within
// REMAP_EPS of contact.
float outer_fraction(float x, float t, float denom) {
    return denom > REMAP_EPS ? min(max(x, 0.0) / (t * denom), 1.0) : 1.0;
}

#endif
