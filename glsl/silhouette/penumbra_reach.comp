#version 450
#extension GL_GOOGLE_include_directive : require
// penumbra-map, dispatch 2 of 4: one thread per welded vertex on a silhouette (listed by
// penumbra_edges.comp): its distance from the centre of its caster's bounding box, folded
// into the caster's bounding-circle radius (`blocker_reach`) with an atomicMax on the bits
// of a non-negative float.
#include "silhouette/penumbra.glsl"

layout(local_size_x = 64) in;

void main() {
    uint v = thread_index();
    if (v >= pc.counts.y) {
        return;
    }
    g_caster = vertex_caster[v];
    if (casters[g_caster].info.w == 0u || incident_count[v] == 0u) {
        return;
    }
    Cone c;
    if (!cone_data(v, c)) {
        return;
    }
    float r = length(reach_point(c) - reach_mid());
    uint o = g_caster * REACH_WORDS;
    if (!finite1(r)) {
        atomicOr(reach_state[o + 5u], 1u);
        return;
    }
    atomicMax(reach_state[o + 4u], floatBitsToUint(r));
}
