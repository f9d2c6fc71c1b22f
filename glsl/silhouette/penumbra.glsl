// GPU penumbra-map geometry (Wyman & Hansen 2003): the bindings and the cone / sheet math
// shared by penumbra_edges.comp, penumbra_reach.comp and penumbra_emit.comp. Mirrors
// src/silhouette/penumbra.rs (`cone_data`, `sheet`, `blocker_reach`, `cone_arc`,
// `emit_cone`) rule for rule; read its header for the why of each.
#ifndef PENUMBRA_GLSL
#define PENUMBRA_GLSL

#include "silhouette/silhouette.glsl"

// Per frame, written by the CPU (`PenumbraFrame` in src/silhouette/gpu.rs): the light's view
// matrix and its inverse (the CPU's, so both paths use the same matrices) and
// (near, z_far, the cones' spread: Lr, or a sun's tan theta, 1 for a sun else 0).
layout(set = 0, binding = 16, std430) readonly buffer PenumbraFrame {
    mat4 pm_view;
    mat4 pm_view_inv;
    vec4 pm_params;
};
// Per caster, REACH_WORDS words, cleared every frame: the bounding box of its silhouette
// vertices in tangent units (a sun's: world units across the map) as order-preserving keys (~key(min x), ~key(min y), key(max x),
// key(max y): all atomicMax, so that a cleared 0 is the identity), the float bits of the
// bounding circle's radius (atomicMax: non-negative floats order as their bits), and 1 when
// a silhouette vertex was skipped (its reach is then BLOCKER_REACH_UNKNOWN).
layout(set = 0, binding = 17, std430) buffer ReachState { uint reach_state[]; };
const uint REACH_WORDS = 8u;

// src/silhouette/penumbra.rs: BLOCKER_REACH_UNKNOWN, CONE_SEGMENTS, HAIRPIN, ARC_OVERLAP.
const float BLOCKER_REACH_UNKNOWN = 1e6;
const uint CONE_SEGMENTS = 16u;
const float HAIRPIN = PI / 180.0;
const float ARC_OVERLAP = 0.002;
const uint PENUMBRA_FLOATS = 6u;

// One silhouette vertex in light view space (`ConeData`).
struct Cone {
    vec3 world;
    float zv;      // linear depth Zv
    vec2 centre;   // base disc centre at depth z_far
    float radius;  // base disc radius
};

bool finite1(float x) {
    return !isnan(x) && !isinf(x);
}

// Whether the light is a sun (orthographic map: each cone about its vertex's own axis).
bool pm_sun() {
    return pm_params.w > 0.5;
}

// `cone_data`: false when the vertex is at or behind near, at or beyond z_far, or not finite.
bool cone_data(uint v, out Cone c) {
    float near = pm_params.x;
    float z_far = pm_params.y;
    float spread = pm_params.z;
    c.world = world(v);
    vec3 pv = (pm_view * vec4(c.world, 1.0)).xyz;
    c.zv = -pv.z;
    if (!(c.zv > near && c.zv < z_far && finite2(pv.xy) && finite1(pv.z))) {
        return false;
    }
    if (pm_sun()) {
        c.centre = pv.xy;
        c.radius = (z_far - c.zv) * spread;
    } else {
        float k = z_far / c.zv;
        c.centre = pv.xy * k;
        c.radius = (z_far - c.zv) * spread / c.zv;
    }
    return finite2(c.centre) && finite1(c.radius);
}

// A base corner's (Zv k, k): k = z_far / Zv, a sun's k = 1 (`sheet`).
vec2 base_zv_h(Cone c) {
    return pm_sun() ? vec2(c.zv, 1.0) : vec2(pm_params.y, pm_params.y / c.zv);
}

// Order-preserving uint key of a float (larger float, larger key).
uint order_key(float f) {
    uint b = floatBitsToUint(f);
    return (b & 0x80000000u) != 0u ? ~b : (b | 0x80000000u);
}

float from_order_key(uint k) {
    return uintBitsToFloat((k & 0x80000000u) != 0u ? (k & 0x7fffffffu) : ~k);
}

// The point of a cone that the bounding circle encloses (`blocker_reach`).
vec2 reach_point(Cone c) {
    return pm_sun() ? c.centre : c.centre / pm_params.y;
}

// The centre of this caster's bounding box (after penumbra_edges.comp).
vec2 reach_mid() {
    uint o = g_caster * REACH_WORDS;
    vec2 lo = vec2(from_order_key(~reach_state[o + 0u]), from_order_key(~reach_state[o + 1u]));
    vec2 hi = vec2(from_order_key(reach_state[o + 2u]), from_order_key(reach_state[o + 3u]));
    return (lo + hi) * 0.5;
}

// This caster's `reach` (after penumbra_reach.comp).
float caster_reach() {
    uint o = g_caster * REACH_WORDS;
    float r = uintBitsToFloat(reach_state[o + 4u]);
    if (reach_state[o + 5u] != 0u || !finite1(r)) {
        return BLOCKER_REACH_UNKNOWN;
    }
    return min(r, BLOCKER_REACH_UNKNOWN);
}

// `sheet`: the tangent normal n of the sheet of edge a -> b in the base plane, or false.
bool sheet_normal(Cone a, Cone b, out vec2 n) {
    n = vec2(0.0);
    vec2 along = b.centre - a.centre;
    float d = length(along);
    if (isnan(d) || d <= 1e-7 * pm_params.y) {
        return false;
    }
    vec2 u = along / d;
    // Right of a -> b in light uv: the outside of the silhouette (`SilhouetteEdge`).
    vec2 w = vec2(u.y, -u.x);
    float alpha = (a.radius - b.radius) / d;
    if (abs(alpha) >= 1.0 - 1e-6) {
        return false;
    }
    n = alpha * u + sqrt(1.0 - alpha * alpha) * w;
    return true;
}

// The sheet normal of silhouette edge ei (flags as classify returned them).
bool edge_sheet_normal(uint ei, out vec2 n) {
    n = vec2(0.0);
    uint a, b;
    oriented_ends(edges[ei], sil[ei], a, b);
    Cone ca, cb;
    return cone_data(a, ca) && cone_data(b, cb) && sheet_normal(ca, cb, n);
}

void put_penumbra(uint i, vec3 position, vec2 zv_h, float reach) {
    uint o = i * PENUMBRA_FLOATS;
    vertices[o + 0u] = position.x;
    vertices[o + 1u] = position.y;
    vertices[o + 2u] = position.z;
    vertices[o + 3u] = zv_h.x;
    vertices[o + 4u] = zv_h.y;
    vertices[o + 5u] = reach;
}

// A base-plane point (light view xy at depth z_far) in world space.
vec3 base_world(vec2 p) {
    return (pm_view_inv * vec4(p, -pm_params.y, 1.0)).xyz;
}

#endif
