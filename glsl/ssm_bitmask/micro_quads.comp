#version 450
#extension GL_GOOGLE_include_directive : require
#include "common/count.glsl"  // by name: build.rs also builds it counted (-DCOUNT_LIGHT)
// ssm-bitmask/micro_quads (speed layer, src/technique/speed/ssm.rs): the micro-quad of each
// instance (`micro_quad`, micro_quad.glsl) computed once instead of once per vertex, and
// listed only when it reaches a receiver; the quads' draw (soft_shadow_list.vert) is an
// indirect draw of the listed quads. One invocation per instance of the plain draw, a
// workgroup per tile of the occluder map that holds a drawn texel (an indirect dispatch).
#define FRAME_NO_DRAW_PUSH
#include "ssm_bitmask/micro_quad.glsl"

layout(local_size_x = SSM_TILE, local_size_y = SSM_TILE) in;

// The two indirect draws' VkDrawIndirectCommand, cleared to 0 before the dispatch: the
// listed quads as points, then as triangle strips (each vertex shader places the other
// draw's quads outside clip space: quad_vertex.glsl).
layout(set = 0, binding = 7, std430) buffer Command {
    uint vertex_count;
    uint instance_count;
    uint first_vertex;
    uint first_instance;
    uint strip_vertex_count;
    uint strip_instance_count;
    uint strip_first_vertex;
    uint strip_first_instance;
} command;
// Per listed quad 3 vec4: (first, reach), corner depths, (size, grow, 0).
layout(set = 0, binding = 8, std430) writeonly buffer Quads { vec4 quads[]; } list;
#define DRAWN_TILES_BINDING 11
#define DRAWN_TILES_ACCESS readonly
#include "ssm/drawn_tiles.glsl"

void main() {
    int n = int(SSM_RES);
    // One workgroup per tile that holds a drawn texel (every tile, in order, when the
    // micro-patch step is above 1): the other tiles' texels draw no quad.
    ivec2 texel = workgroup_tile(true, bound.step, n) + ivec2(gl_LocalInvocationID.xy);
    // No workgroup at all where no texel is drawn: then no quad and no vertices either.
    if (gl_WorkGroupID.x == 0u && gl_LocalInvocationIndex == 0u) {
        command.vertex_count = 1u;
        command.strip_vertex_count = 4u;
    }
    // Instance k = y n + x of the plain draw: texel (x, y), or block k of the micro-patch
    // step (`micro_quad` draws none past the last block).
    if (any(greaterThanEqual(texel, ivec2(n)))) return;
    int k = texel.y * n + texel.x;
    MicroQuad q = micro_quad(k);
    if (q.grow < 0.0) return;
    uint at = 3u * atomicAdd(command.instance_count, 1u);
    atomicAdd(command.strip_instance_count, 1u);
    list.quads[at] = vec4(q.first, q.reach);
    list.quads[at + 1u] = q.corner_depth;
    list.quads[at + 2u] = vec4(q.size, q.grow, 0.0);
}
