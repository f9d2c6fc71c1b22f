#version 450
#extension GL_GOOGLE_include_directive : require
// ssm/maps, objects that only cast (role caster): a caster and a surface in the occluder
// map, no receiver (both layers keep the far clear value). Every attachment MIN-blended,
// clear FAR_DEPTH.
#include "common/far_depth.glsl"

layout(location = 0) in float v_depth;
layout(location = 0) out float o_front;
layout(location = 1) out float o_pure;
layout(location = 2) out vec2 o_occluder;   // r: nearest caster, g: nearest surface

void main() {
    o_occluder = vec2(v_depth);
    o_front = FAR_DEPTH;
    o_pure = FAR_DEPTH;
}
