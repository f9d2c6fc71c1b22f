#version 450
#extension GL_GOOGLE_include_directive : require
// Test harness (tests/shader_guards.rs): pcss's radii from the production
// glsl/pcss/radii.glsl at each input, with pcss_visibility's rule that the blocker depth is
// formed only when a blocker was found. Input: (d_r, near, depth sum, blockers); the other
// parameters fixed below. Output: (search texels, filter texels or -1 without a blocker, 0, 0).
#include "pcss/radii.glsl"

layout(local_size_x = 1) in;
layout(set = 0, binding = 0, std430) readonly buffer Inputs { vec4 inputs[]; };
layout(set = 0, binding = 1, std430) writeonly buffer Outputs { vec4 outputs[]; };

const float LIGHT_UV_NEAR = 0.2;
const float PENUMBRA_SCALE = 0.05;
const float RES = 256.0;
const float MAX_TEXELS = 32.0;

void main() {
    uint i = gl_GlobalInvocationID.x;
    vec4 x = inputs[i];
    float search = pcss_search_texels(LIGHT_UV_NEAR, x.x, x.y, RES, MAX_TEXELS);
    float filter_r = -1.0;
    if (x.w > 0.0) filter_r = pcss_filter_texels(PENUMBRA_SCALE, x.x, x.z / x.w, RES, MAX_TEXELS);
    outputs[i] = vec4(search, filter_r, 0.0, 0.0);
}
