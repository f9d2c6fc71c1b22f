#version 450
#extension GL_GOOGLE_include_directive : require
// One thread per welded vertex of one caster: where kept silhouette edges meet (listed by
// edges.comp), the corner fans of build_corner in src/silhouette/smoothie.rs. Two edges: a
// fan over the shorter arc between their outward directions (the far side at a hairpin);
// an even number of four and more: the same per pair (`pair_corner_edges`: directions
// sorted by angle, each paired with a neighbour, the pairing with the smaller summed arcs);
// one edge or another odd number: the paper's special case, a fan over the whole disc with
// spokes at every edge direction and at the projected vertex normal.
#include "silhouette/silhouette.glsl"

layout(local_size_x = 64) in;

// Spokes of the special case: every incident edge plus the vertex normal.
const uint MAX_SPOKES = MAX_INCIDENT + 1u;

uint ids[MAX_INCIDENT];
uint n_ids;

vec2 normalize_or_zero(vec2 v) {
    float rcp = 1.0 / length(v);
    return (rcp > 0.0 && !isinf(rcp)) ? v * rcp : vec2(0.0);
}

// The sum of the normals of silhouette edge `id`'s faces.
vec3 edge_face_normals(uint id) {
    uvec4 e = edges[id];
    uint nf = face_count(e);
    vec3 n = vec3(0.0);
    for (uint k = 0u; k < nf; ++k) {
        n += face_planes[face_entry(e, k) >> 1].xyz;
    }
    return n;
}

// vertex_normal_screen: a sum of face normals, normalised and projected.
vec2 projected_normal(vec3 p, vec2 s, float z, vec3 n) {
    float rcp = 1.0 / length(n);
    n = (rcp > 0.0 && !isinf(rcp)) ? n * rcp : vec3(0.0);
    return project_normal(p, z, s, n);
}

// Segments of a fan over `sweep` radians (plus the overlap on both sides).
uint fan_segments(float sweep) {
    float padded = abs(sweep) + 2.0 * FAN_OVERLAP;
    return max(uint(ceil(padded / MAX_SEGMENT)), 1u);
}

// `fan` of smoothie.rs: triangles (s, at(i), at(i + 1)) whose outer vertices sit at
// reach / cos(segment / 2), so the fan covers the disc sector of radius reach (t, or less
// where the extent cuts it).
void write_fan(inout uint at, vec2 s, float inv, float t, float from, float sweep) {
    float pad = sweep < 0.0 ? -FAN_OVERLAP : FAN_OVERLAP;
    from -= pad;
    sweep += 2.0 * pad;
    uint k = fan_segments(sweep - 2.0 * pad);
    float phi = sweep / float(k);
    float r = reach_at(t, inv) / cos(phi * 0.5);
    vec2 prev = s + r * vec2(cos(from), sin(from));
    for (uint i = 0u; i < k; ++i) {
        float a = from + phi * float(i + 1u);
        vec2 next = s + r * vec2(cos(a), sin(a));
        put_vertex(at + 0u, s, inv, 1.0, s, vec2(0.0), t);
        put_vertex(at + 1u, prev, inv, 1.0, s, vec2(0.0), t);
        put_vertex(at + 2u, next, inv, 1.0, s, vec2(0.0), t);
        at += 3u;
        prev = next;
    }
}

// A two-edge corner of silhouette edges id1 < id2 at vertex v: the shorter arc from d1 to
// d2, the hairpin's half turn away from the two edges, none when d1 == d2.
void two_edge(uint v, uint id1, uint id2, vec3 p, vec2 s, float z, float inv, float t) {
    vec2 d1 = edge_dir[id1];
    vec2 d2 = edge_dir[id2];
    float angle = acos(clamp(dot(d1, d2), -1.0, 1.0));
    if (angle < MIN_CORNER_ANGLE) {
        return;
    }
    float a1 = atan(d1.y, d1.x);
    float sweep = angle_to(d1, d2);
    if (angle > PI - MIN_CORNER_ANGLE) {
        // Hairpin: the outside is away from where the two edges go.
        vec2 away = vec2(0.0);
        uint pair[2] = uint[2](id1, id2);
        for (uint i = 0u; i < 2u; ++i) {
            uvec4 e = edges[pair[i]];
            uint other = e.x == v ? e.y : e.x;
            vec2 so;
            float zo;
            if (project(world(other), so, zo)) {
                away -= normalize_or_zero(so - s);
            }
        }
        if (length(away) < 1e-3) {
            vec3 faces = edge_face_normals(id1) + edge_face_normals(id2);
            away = projected_normal(p, s, z, faces);
        }
        sweep = dot(away, perp(d1)) >= 0.0 ? PI : -PI;
    }
    uint base;
    if (reserve(3u * fan_segments(sweep), base)) {
        write_fan(base, s, inv, t, a1, sweep);
    }
}

void main() {
    uint v = thread_index();
    if (v >= pc.counts.y) {
        return;
    }
    g_caster = vertex_caster[v];
    if (casters[g_caster].info.w == 0u) {
        return;
    }
    uint count = incident_count[v];
    if (count == 0u) {
        return;
    }
    // The CPU orders a vertex's edges by edge index; the atomics of edges.comp do not.
    n_ids = min(count, MAX_INCIDENT);
    for (uint i = 0u; i < n_ids; ++i) {
        uint id = incident[v * MAX_INCIDENT + i];
        uint j = i;
        while (j > 0u && ids[j - 1u] > id) {
            ids[j] = ids[j - 1u];
            --j;
        }
        ids[j] = id;
    }
    vec3 p = world(v);
    vec2 s;
    float z;
    if (!project(p, s, z)) {
        return;
    }
    float inv = 1.0 / z;
    float t = width_at(z);

    if (count == 2u) {
        two_edge(v, ids[0], ids[1], p, s, z, inv, t);
        return;
    }
    if (count % 2u == 0u && count <= MAX_INCIDENT) {
        vec2 dirs[MAX_INCIDENT];
        for (uint i = 0u; i < n_ids; ++i) {
            dirs[i] = edge_dir[ids[i]];
        }
        uint order[MAX_INCIDENT];
        uint shift = pair_corner_edges(dirs, n_ids, order);
        for (uint j = 0u; j < n_ids / 2u; ++j) {
            uint a = order[(2u * j + shift) % n_ids];
            uint b = order[(2u * j + shift + 1u) % n_ids];
            two_edge(v, ids[min(a, b)], ids[max(a, b)], p, s, z, inv, t);
        }
        return;
    }

    // Special case: spokes at every d_i and at the projected vertex normal; full disc.
    float angles[MAX_SPOKES];
    uint m = 0u;
    for (uint i = 0u; i < n_ids; ++i) {
        vec2 d = edge_dir[ids[i]];
        angles[m++] = atan(d.y, d.x);
    }
    vec3 faces = vec3(0.0);
    for (uint i = 0u; i < n_ids; ++i) {
        faces += edge_face_normals(ids[i]);
    }
    vec2 nv = projected_normal(p, s, z, faces);
    if (length(nv) > 1e-9) {
        angles[m++] = atan(nv.y, nv.x);
    }
    for (uint i = 1u; i < m; ++i) {
        float x = angles[i];
        uint j = i;
        while (j > 0u && angles[j - 1u] > x) {
            angles[j] = angles[j - 1u];
            --j;
        }
        angles[j] = x;
    }
    // Drop spokes within 1e-6 rad of the previous kept one (Vec::dedup_by).
    uint kept = 0u;
    for (uint i = 0u; i < m; ++i) {
        if (kept == 0u || abs(angles[i] - angles[kept - 1u]) >= 1e-6) {
            angles[kept++] = angles[i];
        }
    }
    uint total = 0u;
    for (uint i = 0u; i < kept; ++i) {
        float next = i + 1u < kept ? angles[i + 1u] : angles[0] + 2.0 * PI;
        float gap = next - angles[i];
        if (gap > 1e-6) {
            total += fan_segments(gap);
        }
    }
    uint at;
    if (total == 0u || !reserve(3u * total, at)) {
        return;
    }
    for (uint i = 0u; i < kept; ++i) {
        float next = i + 1u < kept ? angles[i + 1u] : angles[0] + 2.0 * PI;
        float gap = next - angles[i];
        if (gap > 1e-6) {
            write_fan(at, s, inv, t, angles[i], gap);
        }
    }
}
