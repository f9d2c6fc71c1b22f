// GPU silhouettes of every caster for one light: the bindings, the push constants, the
// silhouette classification (`classify`) and the projection helpers shared by the smoothie
// emitters (edges.comp, corners.comp), the penumbra-map emitters (penumbra_*.comp, with
// penumbra.glsl) and finish.comp.
// The math mirrors src/silhouette/mod.rs (facing, classification) and
// src/silhouette/smoothie.rs (edge quads, corner fans) line for line, so that the CPU and
// GPU paths find the same silhouette edges and build the same smoothies; read those files'
// headers for the why of each rule.
#ifndef SILHOUETTE_GLSL
#define SILHOUETTE_GLSL

#define FRAME_NO_DRAW_PUSH
#include "common/frame.glsl"
#include "smoothies/constants.glsl"

layout(push_constant, std430) uniform Counts {
    uvec4 counts;          // edges, welded vertices, casters (all casters together), 0
    // The smoothies' extent (src/silhouette/smoothie/records.rs `Extent`): quads and fans
    // reach only as far as a fragment can write for receivers at most x deep (0: the full
    // width t), plus y; z a sun's depth range (0: a spotlight).
    vec4 reach;
} pc;

// Static, built once per mesh from `silhouette::Adjacency`, every caster's data one after
// the other with indices rebased to the whole (one dispatch per stage for all casters:
// a dispatch costs more than a small caster's work).
layout(set = 0, binding = 1, std430) readonly buffer Positions { vec4 positions[]; };
// xyz: welded corners (only the third-vertex test reads them).
layout(set = 0, binding = 2, std430) readonly buffer Triangles { uvec4 triangles[]; };
// xyz: unit normal (zero for a degenerate face: no facing test); w: the first corner's x.
// With face_p0yz, all the facing test reads: 6 floats (lavapipe pays per loaded component).
layout(set = 0, binding = 3, std430) readonly buffer FacePlanes { vec4 face_planes[]; };
layout(set = 0, binding = 4, std430) readonly buffer FaceP0yz { vec2 face_p0yz[]; };
// x, y: welded ends (x < y); z, w: the two faces (face << 1 | 1 when its winding runs
// x -> y), or, with w = FACE_LIST, z: where the face count and the entries start in
// edge_faces (one face, or three and more).
layout(set = 0, binding = 5, std430) readonly buffer Edges { uvec4 edges[]; };
layout(set = 0, binding = 6, std430) readonly buffer EdgeFaces { uint edge_faces[]; };
const uint FACE_LIST = 0xffffffffu;

uint face_count(uvec4 e) {
    return e.w != FACE_LIST ? 2u : edge_faces[e.z];
}

// Entry i (face << 1 | forward) of edge e.
uint face_entry(uvec4 e, uint i) {
    return e.w != FACE_LIST ? (i == 0u ? e.z : e.w) : edge_faces[e.z + 1u + i];
}

// The caster of each edge and of each welded vertex.
layout(set = 0, binding = 7, std430) readonly buffer EdgeCaster { uint edge_caster[]; };
layout(set = 0, binding = 8, std430) readonly buffer VertexCaster { uint vertex_caster[]; };

// Per caster, written by the CPU each frame (`CasterData` in src/silhouette/gpu.rs).
struct Caster {
    mat4 model;            // object -> world
    vec4 normal_col[3];    // xyz: columns of the normal matrix; w: the light in object space
    uvec4 info;            // 1 if the model mirrors, first vertex of its region, capacity, 1 if rebuilt this frame
};
layout(set = 0, binding = 9, std430) readonly buffer Casters { Caster casters[]; };

// Per frame, written by the passes.
// Per edge: 0 = not a silhouette; else SIL_* bits (read back by the CPU-vs-GPU test).
layout(set = 0, binding = 10, std430) buffer Silhouette { uint sil[]; };
// Per edge: the outward direction d of its smoothie quad (valid when SIL_QUAD is set).
layout(set = 0, binding = 11, std430) buffer EdgeDir { vec2 edge_dir[]; };
// Per welded vertex: how many kept silhouette edges meet there (cleared every frame) and,
// in MAX_INCIDENT slots, which.
layout(set = 0, binding = 12, std430) buffer IncidentCount { uint incident_count[]; };
layout(set = 0, binding = 13, std430) buffer Incident { uint incident[]; };
// Per caster: the vertices its smoothies asked for (cleared every frame; may exceed the
// capacity, then the CPU grows the buffer) and its VkDrawIndirectCommand.
layout(set = 0, binding = 14, std430) buffer Requested { uint requested[]; };
layout(set = 0, binding = 15, std430) buffer DrawCommands { uvec4 draw_commands[]; };

// Set 1, replaced when the CPU grows the vertex buffer: every caster's region of
// SmoothieVertex (9 floats: uv, inv_depth, kind, anchor, dir, width) or, for penumbra-map,
// PenumbraVertex (6 floats: position, zv_h, reach).
layout(set = 1, binding = 0, std430) buffer Vertices { float vertices[]; };

const uint SIL_EDGE = 1u;       // a silhouette edge
const uint SIL_REVERSED = 2u;   // a -> b runs edge.y -> edge.x
const uint SIL_QUAD = 4u;       // its smoothie quad was built (not skipped)
const uint SIL_KIND_SHIFT = 3u; // 1 boundary, 2 manifold, 3 non-manifold

const uint MAX_INCIDENT = 16u;
const uint FLOATS_PER_VERTEX = 9u;

// src/silhouette/smoothie.rs: MAX_CALIBRATED_T, MAX_SEGMENT, MIN_CORNER_ANGLE, PROBE,
// FAN_OVERLAP, NORMALS_CANCEL.
const float MAX_CALIBRATED_T = 0.2;
const float PI = 3.14159265358979;
const float MAX_SEGMENT = PI / 6.0;
const float MIN_CORNER_ANGLE = 1e-3 * PI / 180.0;
const float PROBE = 1e-3;
const float FAN_OVERLAP = 2.0 * PI / 180.0;
const float NORMALS_CANCEL = 0.05;

// The caster this invocation works for (set first thing in main).
uint g_caster;

// pair_corner_edges of src/silhouette/mod.rs for n (even, 4 to MAX_INCIDENT) outward
// directions `dirs`: `order` gets the positions sorted by angle (ties in position order),
// and the return value is the pairing `shift` with the smaller summed arc (the second only
// when smaller by 1e-4 rad, as on the CPU). Pair j is order[(2 j + shift) % n] and
// order[(2 j + shift + 1) % n].
uint pair_corner_edges(vec2 dirs[MAX_INCIDENT], uint n, out uint order[MAX_INCIDENT]) {
    for (uint i = 0u; i < n; ++i) {
        float a = atan(dirs[i].y, dirs[i].x);
        uint j = i;
        while (j > 0u) {
            vec2 dj = dirs[order[j - 1u]];
            if (atan(dj.y, dj.x) <= a) break;
            order[j] = order[j - 1u];
            --j;
        }
        order[j] = i;
    }
    // The summed unsigned arcs of the two pairings: (0, 1), (2, 3), ... and (1, 2), ...
    float cost0 = 0.0;
    float cost1 = 0.0;
    for (uint j = 0u; j < n / 2u; ++j) {
        vec2 u = dirs[order[2u * j]];
        vec2 w = dirs[order[2u * j + 1u]];
        vec2 x = dirs[order[(2u * j + 2u) % n]];
        cost0 += abs(atan(u.x * w.y - u.y * w.x, dot(u, w)));
        cost1 += abs(atan(w.x * x.y - w.y * x.x, dot(w, x)));
    }
    return cost1 < cost0 - 1e-4 ? 1u : 0u;
}

uint thread_index() {
    // 2-D dispatches carry meshes with more than 65535 workgroups of edges.
    return gl_GlobalInvocationID.x + gl_GlobalInvocationID.y * gl_NumWorkGroups.x * gl_WorkGroupSize.x;
}

vec3 light_obj() {
    vec4 c0 = casters[g_caster].normal_col[0];
    vec4 c1 = casters[g_caster].normal_col[1];
    vec4 c2 = casters[g_caster].normal_col[2];
    return vec3(c0.w, c1.w, c2.w);
}

vec3 world(uint v) {
    return (casters[g_caster].model * vec4(positions[v].xyz, 1.0)).xyz;
}

bool finite2(vec2 v) {
    return !any(isnan(v)) && !any(isinf(v));
}

// LightView::project plus the near-plane and finiteness guard of Projector::project (a
// sun's depth from its orthographic clip z, common/frame.glsl).
bool project(vec3 p, out vec2 uv, out float depth) {
    vec4 c = frame.light_view_proj * vec4(p, 1.0);
    uv = c.xy / c.w * 0.5 + 0.5;
    depth = clip_linear_depth(c);
    return depth > frame.light_params.x && finite2(uv) && !isnan(depth) && !isinf(depth);
}

// Projector::project_normal: screen direction of an object-space normal at world point p.
vec2 project_normal(vec3 p, float depth, vec2 uv, vec3 n_obj) {
    mat3 nm = mat3(casters[g_caster].normal_col[0].xyz, casters[g_caster].normal_col[1].xyz,
                   casters[g_caster].normal_col[2].xyz);
    vec3 n = nm * n_obj;
    // glam's normalize_or_zero: multiply by the reciprocal length, zero when it is not finite.
    float rcp = 1.0 / length(n);
    if (!(rcp > 0.0) || isinf(rcp)) {
        return vec2(0.0);
    }
    n *= rcp;
    float eps = PROBE * depth;
    vec4 c = frame.light_view_proj * vec4(p + n * eps, 1.0);
    vec2 uv2 = c.xy / c.w * 0.5 + 0.5;
    vec2 v = (uv2 - uv) / eps;
    return (c.w > 0.0 && finite2(v)) ? v : vec2(0.0);
}

// Extent::of and ::of_edge (src/silhouette/smoothie/records.rs): how far from its edge or
// vertex a smoothie of width t, whose nearest end lies at 1 / inv_depth, can still write.
float reach_at(float t, float inv_depth) {
    float depth = pc.reach.x;
    if (depth <= 0.0) {
        return t;
    }
    float span = pc.reach.z;
    float b = 1.0 / inv_depth;
    float factor = span > 0.0 ? (depth - b) / span : 1.0 - b / depth;
    return min(t, t * max(factor, 0.0) + pc.reach.y);
}

// Width::at: the fixed t (SMOOTHIE_FIXED_T >= 0; a sun's one width too) or R / (2 b
// tan(fov/2)), clamped.
float width_at(float depth) {
    if (SMOOTHIE_FIXED_T >= 0.0) {
        return SMOOTHIE_FIXED_T;
    }
    float t = frame.light_pos_radius.w / (2.0 * max(depth, 1e-30) * frame.light_frustum.x);
    return clamp(t, 0.0, MAX_CALIBRATED_T);
}

vec2 perp(vec2 v) {
    return vec2(-v.y, v.x);
}

float perp_dot(vec2 a, vec2 b) {
    return a.x * b.y - a.y * b.x;
}

// glam's Vec2::angle_to: signed angle from a to b.
float angle_to(vec2 a, vec2 b) {
    float c = clamp(dot(a, b) / sqrt(dot(a, a) * dot(b, b)), -1.0, 1.0);
    return acos(c) * (perp_dot(a, b) >= 0.0 ? 1.0 : -1.0);
}

const uint BACK = 0u;
const uint FRONT = 1u;
const uint DEGEN = 2u;

bool degenerate(uint f) {
    return all(equal(face_planes[f].xyz, vec3(0.0)));
}

uint facing(uint f, vec3 l) {
    vec4 plane = face_planes[f];
    if (all(equal(plane.xyz, vec3(0.0)))) {
        return DEGEN;
    }
    // `precise`: no fused multiply-add, the same roundings as the CPU's
    // `n.dot(light - p)` ((x + y) + z), so both paths agree on every face, even at grazing
    // light where the product is a few ulps from 0.
    precise vec3 dl = l - vec3(plane.w, face_p0yz[f]);
    vec3 n = plane.xyz;
    precise float s = n.x * dl.x + n.y * dl.y + n.z * dl.z;
    return s > 0.0 ? FRONT : BACK;
}

// The facing test and classification of `classify_range` in src/silhouette/mod.rs for edge
// e of caster g_caster: 0 when it is not a silhouette edge, else its SIL_EDGE,
// SIL_REVERSED and kind bits, with a -> b its ends oriented as `SilhouetteEdge` and
// front_face the face that oriented it. Shared by every emitter, so all GPU paths find the
// same edges as the CPU.
uint classify(uvec4 e, out uint a, out uint b, out uint front_face) {
    uint valid = 0u;
    uint n_front = 0u;
    uint first_front = 0xffffffffu;
    uint first_valid = 0xffffffffu;
    vec3 l = light_obj();
    uint nf = face_count(e);
    for (uint i = 0u; i < nf; ++i) {
        uint ef = face_entry(e, i);
        uint fa = facing(ef >> 1, l);
        if (fa == DEGEN) {
            continue;
        }
        valid += 1u;
        if (first_valid == 0xffffffffu) {
            first_valid = ef;
        }
        if (fa == FRONT) {
            n_front += 1u;
            if (first_front == 0xffffffffu) {
                first_front = ef;
            }
        }
    }
    a = e.x;
    b = e.y;
    front_face = 0u;
    bool boundary = valid == 1u;
    bool is_sil = valid > 0u && (boundary || (n_front > 0u && n_front < valid));
    if (!is_sil) {
        return 0u;
    }
    // Along the front face's winding; a back-facing boundary face backwards (see mod.rs).
    bool along = first_front != 0xffffffffu ? (first_front & 1u) != 0u : (first_valid & 1u) == 0u;
    front_face = (first_front != 0xffffffffu ? first_front : first_valid) >> 1;
    bool reversed = !along;
    if (casters[g_caster].info.x != 0u) {
        reversed = !reversed;
    }
    a = reversed ? e.y : e.x;
    b = reversed ? e.x : e.y;
    uint kind = boundary ? 1u : (valid == 2u ? 2u : 3u);
    return SIL_EDGE | (reversed ? SIL_REVERSED : 0u) | (kind << SIL_KIND_SHIFT);
}

// The oriented ends of silhouette edge e from its flags (as `classify` returned them).
void oriented_ends(uvec4 e, uint flags, out uint a, out uint b) {
    bool reversed = (flags & SIL_REVERSED) != 0u;
    a = reversed ? e.y : e.x;
    b = reversed ? e.x : e.y;
}

void put_vertex(uint i, vec2 uv, float inv_depth, float kind, vec2 anchor, vec2 dir, float width) {
    uint o = i * FLOATS_PER_VERTEX;
    vertices[o + 0u] = uv.x;
    vertices[o + 1u] = uv.y;
    vertices[o + 2u] = inv_depth;
    vertices[o + 3u] = kind;
    vertices[o + 4u] = anchor.x;
    vertices[o + 5u] = anchor.y;
    vertices[o + 6u] = dir.x;
    vertices[o + 7u] = dir.y;
    vertices[o + 8u] = width;
}

// Reserves n vertices in this caster's region; returns false (and the caller writes
// nothing) past its capacity, so that the CPU can grow the buffer from `requested`.
bool reserve(uint n, out uint base) {
    uint local = atomicAdd(requested[g_caster], n);
    base = casters[g_caster].info.y + local;
    return local + n <= casters[g_caster].info.z;
}

#endif
