#version 450
#extension GL_GOOGLE_include_directive : require
// penumbra-map, dispatch 3 of 4: one thread per edge, then one per welded vertex, of every
// caster rebuilt this frame. An edge thread writes its silhouette edge's sheet (`sheet` of
// src/silhouette/penumbra.rs: the quad (a, b, tb) (a, tb, ta)); a vertex thread writes the
// cone of a silhouette vertex (`cone_arc` + `emit_cone`), recomputing the sheet normals of
// its edges rather than waiting for the edge threads (one dispatch instead of two).
#include "silhouette/penumbra.glsl"

layout(local_size_x = 64) in;

void emit_sheet(uint ei) {
    uint flags = sil[ei];
    if (flags == 0u) {
        return;
    }
    uint a, b;
    oriented_ends(edges[ei], flags, a, b);
    Cone ca, cb;
    vec2 n;
    if (!cone_data(a, ca) || !cone_data(b, cb) || !sheet_normal(ca, cb, n)) {
        return;
    }
    float reach = caster_reach();
    vec3 ta = base_world(ca.centre + ca.radius * n);
    vec3 tb = base_world(cb.centre + cb.radius * n);
    vec2 ha = base_zv_h(ca);
    vec2 hb = base_zv_h(cb);
    uint at;
    if (reserve(6u, at)) {
        put_penumbra(at + 0u, ca.world, vec2(ca.zv, 1.0), reach);
        put_penumbra(at + 1u, cb.world, vec2(cb.zv, 1.0), reach);
        put_penumbra(at + 2u, tb, hb, reach);
        put_penumbra(at + 3u, ca.world, vec2(ca.zv, 1.0), reach);
        put_penumbra(at + 4u, tb, hb, reach);
        put_penumbra(at + 5u, ta, ha, reach);
    }
}

// Cone triangles around `c` over the base-plane arc from angle `from` over `sweep`
// (`emit_cone` of penumbra.rs).
void emit_arc(Cone c, float from, float sweep) {
    float max_step = 2.0 * PI / float(CONE_SEGMENTS);
    uint k = uint(clamp(ceil(abs(sweep) / max_step), 1.0, float(CONE_SEGMENTS)));
    float step = sweep / float(k);
    // Circumscribed: the polygon's edges touch the round base circle.
    float r = c.radius / cos(step * 0.5);
    float reach = caster_reach();
    vec2 zv_h = vec2(c.zv, 1.0);
    uint at;
    if (!reserve(3u * k, at)) {
        return;
    }
    vec3 prev = base_world(c.centre + r * vec2(cos(from), sin(from)));
    for (uint i = 0u; i < k; ++i) {
        float a = from + step * float(i + 1u);
        vec3 next = base_world(c.centre + r * vec2(cos(a), sin(a)));
        put_penumbra(at + 0u, c.world, zv_h, reach);
        put_penumbra(at + 1u, prev, zv_h, reach);
        put_penumbra(at + 2u, next, zv_h, reach);
        at += 3u;
        prev = next;
    }
}

void emit_cone(uint v) {
    uint count = incident_count[v];
    if (count == 0u) {
        return;
    }
    Cone c;
    if (!cone_data(v, c)) {
        return;
    }
    // cone_arc: the arc between exactly two sheet normals, taken in silhouette (= edge
    // index) order like the CPU, reaching ARC_OVERLAP past each; an even number of four and
    // more: an arc per pair (paired_arcs, pair_corner_edges); else (or past MAX_INCIDENT
    // edges, or at a hairpin pair) the whole cone.
    float froms[MAX_INCIDENT / 2u];
    float sweeps[MAX_INCIDENT / 2u];
    uint arcs = 0u;
    if (count <= MAX_INCIDENT) {
        uint ids[MAX_INCIDENT];
        vec2 normals[MAX_INCIDENT];
        uint sheets = 0u;
        for (uint i = 0u; i < count; ++i) {
            uint ei = incident[v * MAX_INCIDENT + i];
            vec2 n;
            if (!edge_sheet_normal(ei, n)) {
                continue;
            }
            uint j = sheets++;
            while (j > 0u && ids[j - 1u] > ei) {
                ids[j] = ids[j - 1u];
                normals[j] = normals[j - 1u];
                --j;
            }
            ids[j] = ei;
            normals[j] = n;
        }
        // The pairs (pair_corner_edges; two sheets: already one pair).
        uint order[MAX_INCIDENT];
        uint shift = 0u;
        if (sheets == 2u) {
            order[0] = 0u;
            order[1] = 1u;
            arcs = 1u;
        } else if (sheets >= 4u && sheets % 2u == 0u) {
            shift = pair_corner_edges(normals, sheets, order);
            arcs = sheets / 2u;
        }
        for (uint j = 0u; j < arcs; ++j) {
            uint a = order[(2u * j + shift) % sheets];
            uint b = order[(2u * j + shift + 1u) % sheets];
            float s = angle_to(normals[min(a, b)], normals[max(a, b)]);
            // Hairpin: which side is outside is ambiguous; draw the whole cone.
            if (isnan(s) || isinf(s) || abs(s) > PI - HAIRPIN) {
                arcs = 0u;
                break;
            }
            float e = s < 0.0 ? -ARC_OVERLAP : ARC_OVERLAP;
            vec2 n = normals[min(a, b)];
            froms[j] = atan(n.y, n.x) - e;
            sweeps[j] = s + 2.0 * e;
        }
    }
    if (arcs == 0u) {
        froms[0] = 0.0;
        sweeps[0] = 2.0 * PI;
        arcs = 1u;
    }
    for (uint j = 0u; j < arcs; ++j) {
        emit_arc(c, froms[j], sweeps[j]);
    }
}

void main() {
    uint t = thread_index();
    if (t < pc.counts.x) {
        g_caster = edge_caster[t];
        if (casters[g_caster].info.w != 0u) {
            emit_sheet(t);
        }
        return;
    }
    uint v = t - pc.counts.x;
    if (v >= pc.counts.y) {
        return;
    }
    g_caster = vertex_caster[v];
    if (casters[g_caster].info.w != 0u) {
        emit_cone(v);
    }
}
