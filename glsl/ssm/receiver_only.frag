#version 450
#extension GL_GOOGLE_include_directive : require
// ssm/maps, objects that only receive (the paper's receivers, e.g. the ground): both
// layers, and a surface but no caster in the occluder map. Every attachment MIN-blended,
// clear FAR_DEPTH.
#include "common/far_depth.glsl"

layout(location = 0) in float v_depth;
layout(location = 0) out float o_front;
layout(location = 1) out float o_pure;
layout(location = 2) out vec2 o_occluder;   // r: nearest caster, g: nearest surface

void main() {
    o_occluder = vec2(FAR_DEPTH, v_depth);
    o_front = v_depth;
    o_pure = v_depth;
}
