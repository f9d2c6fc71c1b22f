#version 450
#extension GL_GOOGLE_include_directive : require
// hard/shadow_map: every caster from the light into a D32 depth buffer; no fragment shader
// (depth-only: the rasterizer writes z/w, early depth test LESS).
#include "common/frame.glsl"

layout(location = 0) in vec3 in_pos;

void main() {
    gl_Position = frame.light_view_proj * (draw.model * vec4(in_pos, 1.0));
}
