#version 450
#extension GL_GOOGLE_include_directive : require
// Test harness (tests/shader_guards.rs): smoothies' `smoothie_alpha` from the production
// glsl/smoothies/alpha.glsl at each input, so that a change to its discards or to the
// REMAP_EPS guard fails the test. Input: (smoothie depth b, surface depth r, distance,
// width t); output: (1 where kept else 0, alpha', 0, 0).
#include "smoothies/alpha.glsl"

layout(local_size_x = 1) in;
layout(set = 0, binding = 0, std430) readonly buffer Inputs { vec4 inputs[]; };
layout(set = 0, binding = 1, std430) writeonly buffer Outputs { vec4 outputs[]; };

void main() {
    uint i = gl_GlobalInvocationID.x;
    vec4 x = inputs[i];
    float alpha = -1.0;
    // Span 0: the spotlight's remap 1 - b/r.
    bool kept = smoothie_alpha(x.x, x.y, x.z, x.w, 0.0, alpha);
    outputs[i] = vec4(kept ? 1.0 : 0.0, alpha, 0.0, 0.0);
}
