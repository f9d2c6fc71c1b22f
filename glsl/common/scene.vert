#version 450
#extension GL_GOOGLE_include_directive : require
// Camera pass vertex shader shared by every technique's final pass: world position and
// normal for the fragment shader (which computes visibility at exactly that point).
#include "common/frame.glsl"

layout(location = 0) in vec3 in_pos;
layout(location = 1) in vec3 in_normal;
layout(location = 0) out vec3 v_world;
layout(location = 1) out vec3 v_normal;

void main() {
    vec4 world = draw.model * vec4(in_pos, 1.0);
    v_world = world.xyz;
    // Models carry rotation and uniform or axis scale: the inverse-transpose keeps normals right.
    v_normal = transpose(inverse(mat3(draw.model))) * in_normal;
    gl_Position = frame.cam_view_proj * world;
}
