#version 450
#extension GL_GOOGLE_include_directive : require
// Test harness (tests/shader_guards.rs): the centred forms' profile, its inverse and the
// final passes' visibility of an interpolated share, from the production
// glsl/common/penumbra.glsl at each input, so that a change to the inverse's fit or to the
// ends' snap fails the test. Input: (visibility v, share s, 0, 0); output:
// (chord_share(v), disc_chord(chord_share(v)), share_visibility(s), disc_chord(s)).
#include "common/penumbra.glsl"

layout(local_size_x = 1) in;
layout(set = 0, binding = 0, std430) readonly buffer Inputs { vec4 inputs[]; };
layout(set = 0, binding = 1, std430) writeonly buffer Outputs { vec4 outputs[]; };

void main() {
    uint i = gl_GlobalInvocationID.x;
    vec4 x = inputs[i];
    float s = chord_share(x.x);
    outputs[i] = vec4(s, disc_chord(s), share_visibility(x.y), disc_chord(x.y));
}
