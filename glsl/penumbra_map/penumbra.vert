#version 450
#extension GL_GOOGLE_include_directive : require
// penumbra-map/penumbra: cones and sheets (world space, built on the CPU) seen from the light.
#include "common/frame.glsl"

layout(location = 0) in vec3 in_pos;
layout(location = 1) in vec2 in_zv_h;
layout(location = 2) in float in_reach;

// Both perspective-correct: linear depth is affine in world space, and so are Zv * k and k
// (src/silhouette/penumbra.rs), so their interpolation over a planar triangle is exact (a
// sun's clip w is 1: plain linear interpolation, its depth from clip z).
layout(location = 0) out float v_depth;
layout(location = 1) out vec2 v_zv_h;
// The caster's angular radius from the light centre (one value per object).
layout(location = 2) flat out float v_reach;

void main() {
    gl_Position = frame.light_view_proj * vec4(in_pos, 1.0);
    v_depth = clip_linear_depth(gl_Position);
    v_zv_h = in_zv_h;
    v_reach = in_reach;
}
