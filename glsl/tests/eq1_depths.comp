#version 450
#extension GL_GOOGLE_include_directive : require
// Test harness (tests/shader_guards.rs): penumbra-map's `eq1_depths` from the production
// wedge.glsl at each input, so that a change to its discards (CONTACT_EPS, far texels,
// fragments behind the surface) fails the test. Input: (Z_P, Z_F, Zv k, k); output:
// (1 where kept else 0, Z_P - Z_v, 0, 0).
// No draw push constants: a compute pipeline has no draws.
#define FRAME_NO_DRAW_PUSH
#include "penumbra_map/wedge.glsl"

layout(local_size_x = 1) in;
layout(set = 0, binding = 1, std430) readonly buffer Inputs { vec4 inputs[]; };
layout(set = 0, binding = 2, std430) writeonly buffer Outputs { vec4 outputs[]; };

void main() {
    uint i = gl_GlobalInvocationID.x;
    vec4 x = inputs[i];
    Eq1 e;
    bool kept = eq1_depths(x.x, x.y, x.zw, e);
    outputs[i] = vec4(kept ? 1.0 : 0.0, e.denom, 0.0, 0.0);
}
