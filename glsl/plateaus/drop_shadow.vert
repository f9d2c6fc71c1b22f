#version 450
#extension GL_GOOGLE_include_directive : require
// Hard drop shadow (Haines Sec. 2, Blinn 1988): every caster vertex projected from the point
// light onto the plane, viewed from straight above, at the near depth (clip z = 0).
#include "common/frame.glsl"
#include "plateaus/plane.glsl"

layout(location = 0) in vec3 in_pos;
// Height of the caster point above the plane. Perspective-correct interpolation (clip w =
// H - h) recovers the height of the caster surface point behind each texel.
layout(location = 0) out float v_height;

void main() {
    vec4 world = draw.model * vec4(in_pos, 1.0);
    gl_Position = plane.drop_shadow * world;
    v_height = (plane.to_texture * world).z;
}
