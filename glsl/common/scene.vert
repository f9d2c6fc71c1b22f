#version 450
#extension GL_GOOGLE_include_directive : require
// Camera pass vertex shader shared by every technique's final pass: world position and
// normal for the fragment shader (which computes visibility at exactly that point), and
// their light clip coordinates (common/shadow.glsl says why they are interpolated).
#include "common/frame.glsl"

layout(location = 0) in vec3 in_pos;
layout(location = 1) in vec3 in_normal;
layout(location = 0) out vec3 v_world;
layout(location = 1) out vec3 v_normal;
layout(location = 2) out vec4 v_light_clip;     // light_view_proj * (world, 1)
layout(location = 3) out vec4 v_light_normal;   // light_view_proj * (v_normal, 0)

void main() {
    vec4 world = draw.model * vec4(in_pos, 1.0);
    v_world = world.xyz;
    // Models carry rotation and uniform or axis scale: the inverse-transpose keeps normals right.
    v_normal = transpose(inverse(mat3(draw.model))) * in_normal;
    v_light_clip = frame.light_view_proj * world;
    v_light_normal = frame.light_view_proj * vec4(v_normal, 0.0);
    gl_Position = frame.cam_view_proj * world;
}
