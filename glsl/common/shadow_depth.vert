#version 450
#extension GL_GOOGLE_include_directive : require
// Shadow map pass: casters from the light, linear light depth to the fragment shader.
#include "common/frame.glsl"

layout(location = 0) in vec3 in_pos;
layout(location = 0) out float v_depth;

void main() {
    vec4 world = draw.model * vec4(in_pos, 1.0);
    gl_Position = frame.light_view_proj * world;
    // Perspective projection: clip w is exactly the linear depth along the view axis (a
    // sun's orthographic one carries it in z).
    v_depth = clip_linear_depth(gl_Position);
}
