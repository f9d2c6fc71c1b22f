#version 450
#extension GL_GOOGLE_include_directive : require
// Test harness (tests/shader_guards.rs): smoothies-centred's `outer_fraction` from the
// production glsl/smoothies_centred/remap.glsl at each input, so that a change to its
// REMAP_EPS guard fails the test. Input: (x, t, 1 - b/r, unused); output: (s, 0, 0, 0).
#include "smoothies_centred/remap.glsl"

layout(local_size_x = 1) in;
layout(set = 0, binding = 0, std430) readonly buffer Inputs { vec4 inputs[]; };
layout(set = 0, binding = 1, std430) writeonly buffer Outputs { vec4 outputs[]; };

void main() {
    uint i = gl_GlobalInvocationID.x;
    vec4 x = inputs[i];
    outputs[i] = vec4(outer_fraction(x.x, x.y, x.z), 0.0, 0.0, 0.0);
}
