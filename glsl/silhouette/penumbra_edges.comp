#version 450
#extension GL_GOOGLE_include_directive : require
// penumbra-map, dispatch 1 of 4: one thread per edge of every caster rebuilt this frame:
// `classify` (the smoothie path's classification, bit for bit the CPU's `extract`), the
// edge listed at both ends (incident, for the cones of penumbra_emit.comp), and both ends'
// points folded into the caster's bounding box of `blocker_reach` (or its skipped flag).
// Every end of every silhouette edge: a vertex is folded once per edge, which the atomics'
// min / max make harmless.
#include "silhouette/penumbra.glsl"

layout(local_size_x = 64) in;

void fold_end(uint v) {
    uint k = atomicAdd(incident_count[v], 1u);
    if (k < MAX_INCIDENT) {
        incident[v * MAX_INCIDENT + k] = thread_index();
    }
    uint o = g_caster * REACH_WORDS;
    Cone c;
    if (!cone_data(v, c)) {
        atomicOr(reach_state[o + 5u], 1u);
        return;
    }
    vec2 p = reach_point(c);
    atomicMax(reach_state[o + 0u], ~order_key(p.x));
    atomicMax(reach_state[o + 1u], ~order_key(p.y));
    atomicMax(reach_state[o + 2u], order_key(p.x));
    atomicMax(reach_state[o + 3u], order_key(p.y));
}

void main() {
    uint ei = thread_index();
    if (ei >= pc.counts.x) {
        return;
    }
    g_caster = edge_caster[ei];
    if (casters[g_caster].info.w == 0u) {
        return;
    }
    uvec4 e = edges[ei];
    uint a, b, front_face;
    uint flags = classify(e, a, b, front_face);
    sil[ei] = flags;
    if (flags == 0u) {
        return;
    }
    fold_end(a);
    fold_end(b);
}
