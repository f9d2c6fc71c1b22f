#version 450
#extension GL_GOOGLE_include_directive : require
// ssm/maps, objects that cast AND receive (role both): they are the nearest receiver
// (layer 0) but not a pure receiver (layer 1 keeps the far clear value), and a caster and a
// surface in the occluder map. Every attachment MIN-blended, clear FAR_DEPTH: no z-buffer.
#include "common/far_depth.glsl"

layout(location = 0) in float v_depth;
layout(location = 0) out float o_front;
layout(location = 1) out float o_pure;
layout(location = 2) out vec2 o_occluder;   // r: nearest caster, g: nearest surface

void main() {
    o_occluder = vec2(v_depth);
    o_front = v_depth;
    o_pure = FAR_DEPTH;
}
