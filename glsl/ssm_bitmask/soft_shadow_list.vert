#version 450
#extension GL_GOOGLE_include_directive : require
#include "common/count.glsl"  // by name: build.rs also builds it counted (-DCOUNT_LIGHT)
// ssm-bitmask/soft_shadow, the quad list's draw (speed layer, src/technique/speed/ssm.rs):
// instance k draws the k-th quad micro_quads.comp listed, as soft_shadow.vert draws it.
#define FRAME_NO_DRAW_PUSH
#include "ssm_bitmask/quad_vertex.glsl"

// Per quad 3 vec4, as micro_quads.comp writes them.
layout(set = 0, binding = 8, std430) readonly buffer Quads { vec4 quads[]; } list;

void main() {
    uint at = 3u * uint(gl_InstanceIndex);
    vec4 a = list.quads[at];
    vec4 c = list.quads[at + 2u];
    emit_quad(a.xyz, list.quads[at + 1u], a.w, c.xy, c.z);
}
