#version 450
#extension GL_GOOGLE_include_directive : require
// One thread per edge of one caster: is it a silhouette edge for this light (`classify` of
// silhouette.glsl: the facing test and classification of src/silhouette/mod.rs), and if so
// its smoothie quad (build_edge of src/silhouette/smoothie.rs), appended to the vertex buffer; the edge is then listed at
// both of its welded ends for corners.comp.
#include "silhouette/silhouette.glsl"

layout(local_size_x = 64) in;

// Which side of s0 -> s1 the valid faces' third vertices lie on (third_vertex_side).
float third_vertex_side(uvec4 e, uint a, uint b, vec2 s0, vec2 s1) {
    float side = 0.0;
    uint nf = face_count(e);
    for (uint i = 0u; i < nf; ++i) {
        uint f = face_entry(e, i) >> 1;
        if (degenerate(f)) {
            continue;
        }
        uvec4 t = triangles[f];
        uint c = (t.x != a && t.x != b) ? t.x : ((t.y != a && t.y != b) ? t.y : t.z);
        if (c == a || c == b) {
            continue;
        }
        vec2 sc;
        float zc;
        if (project(world(c), sc, zc)) {
            float cr = perp_dot(s1 - s0, sc - s0);
            if (abs(cr) > 1e-12) {
                side += sign(cr);
            }
        }
    }
    return side;
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
    uint nf = face_count(e);
    uint a, b, front_face;
    uint flags = classify(e, a, b, front_face);
    if (flags == 0u) {
        sil[ei] = 0u;
        return;
    }
    bool boundary = (flags >> SIL_KIND_SHIFT) == 1u;

    // build_edge: the quad from the edge outward by t.
    vec3 pa = world(a);
    vec3 pb = world(b);
    vec2 s0, s1;
    float z0, z1;
    bool ok = project(pa, s0, z0) && project(pb, s1, z1);
    vec2 along_s = s1 - s0;
    float len = length(along_s);
    if (!ok || !(len > 1e-9)) {
        sil[ei] = flags;
        return;
    }
    vec2 d = perp(along_s) / len;
    bool decided = false;
    if (!boundary) {
        vec3 m = (pa + pb) * 0.5;
        vec2 sm;
        float zm;
        if (project(m, sm, zm)) {
            vec2 avg = vec2(0.0);
            vec3 normals = vec3(0.0);
            for (uint i = 0u; i < nf; ++i) {
                uint f = face_entry(e, i) >> 1;
                if (!degenerate(f)) {
                    avg += project_normal(m, zm, sm, face_planes[f].xyz);
                    normals += face_planes[f].xyz;
                }
            }
            float dt = dot(d, avg);
            // Only trust the normals when they clearly pick a side (> ~0.5 degree), and not
            // at all when they cancel (NORMALS_CANCEL).
            if (abs(dt) > 1e-2 * length(avg) && length(normals) >= NORMALS_CANCEL) {
                if (dt < 0.0) {
                    d = -d;
                }
                decided = true;
            }
        }
    }
    if (!decided) {
        float side = third_vertex_side(e, a, b, s0, s1);
        if (side > 0.0) {
            d = -d;
        } else if (side == 0.0) {
            // No usable evidence: the orientation convention puts the outside on the right.
            d = -d;
            if (boundary) {
                vec3 m = (pa + pb) * 0.5;
                vec2 sm;
                float zm;
                if (project(m, sm, zm)) {
                    vec2 n = project_normal(m, zm, sm, face_planes[front_face].xyz);
                    if (dot(d, n) < 0.0) {
                        d = -d;
                    }
                }
            }
        }
    }
    float i0 = 1.0 / z0;
    float i1 = 1.0 / z1;
    float t0 = width_at(z0);
    float t1 = width_at(z1);
    // The nearer end's factor at both ends: linear along the edge, at least the bound.
    float nearer = max(i0, i1);
    vec2 o0 = s0 + reach_at(t0, nearer) * d;
    vec2 o1 = s1 + reach_at(t1, nearer) * d;
    uint base;
    if (reserve(6u, base)) {
        put_vertex(base + 0u, s0, i0, 0.0, s0, d, t0);
        put_vertex(base + 1u, s1, i1, 0.0, s0, d, t1);
        put_vertex(base + 2u, o1, i1, 0.0, s0, d, t1);
        put_vertex(base + 3u, s0, i0, 0.0, s0, d, t0);
        put_vertex(base + 4u, o1, i1, 0.0, s0, d, t1);
        put_vertex(base + 5u, o0, i0, 0.0, s0, d, t0);
    }
    sil[ei] = flags | SIL_QUAD;
    edge_dir[ei] = d;
    // List the edge at both ends for the corner fans (slots beyond MAX_INCIDENT are counted
    // but not stored; corners.comp then falls back to the special case).
    uint k = atomicAdd(incident_count[a], 1u);
    if (k < MAX_INCIDENT) {
        incident[a * MAX_INCIDENT + k] = ei;
    }
    k = atomicAdd(incident_count[b], 1u);
    if (k < MAX_INCIDENT) {
        incident[b * MAX_INCIDENT + k] = ei;
    }
}
