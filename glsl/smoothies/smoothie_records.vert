#version 450
#extension GL_GOOGLE_include_directive : require
// Smoothie MRT pass, CPU path: vertex pulling from compact records (see
// src/silhouette/smoothie/records.rs, whose `SmoothieRecords::expand` is this shader on the
// CPU). No vertex buffer: one draw per caster of 6 * edges + 3 * segments vertices. The
// outputs are exactly those of smoothie.vert, so smoothie.frag (and its hand-tuned SPIR-V)
// run unchanged. It needs nothing from the frame constants.

// Per caster, back to back, in 16-byte units: vertex records (uv, 1/depth, t), edge
// records (a, b, dir), fan records (centre, from, sweep), then one word per fan segment
// (fan << 8 | n << 4 | k), four to a unit. Whole 16-byte loads: on lavapipe every buffer
// access is a gather with a bounds check, so one per record rather than one per word.
layout(set = 1, binding = 0, std430) readonly buffer Records { uvec4 units[]; };

layout(push_constant) uniform Caster {
    uint base;      // first unit of this caster's records
    uint vertices;  // vertex records
    uint edges;     // edge records
    uint fans;      // fan records
} pc;

layout(location = 0) noperspective out float v_inv_depth;
layout(location = 1) flat out float v_kind;
layout(location = 2) flat out vec2 v_anchor;
layout(location = 3) flat out vec2 v_dir;
layout(location = 4) noperspective out float v_width;

// src/silhouette/smoothie.rs: FAN_OVERLAP (2 degrees) closes the T-junction cracks between
// a fan's outer spokes and the edge quads beside them.
const float FAN_OVERLAP = 0.034906585;

vec4 vertex_record(uint i) {
    return uintBitsToFloat(units[pc.base + i]);
}

void main() {
    uint id = uint(gl_VertexIndex);
    uint edge_units = pc.base + pc.vertices;
    vec2 uv;
    if (id < 6u * pc.edges) {
        // Quad (s0, s1, s1 + t1 d), (s0, s1 + t1 d, s0 + t0 d): alpha = dot(p - s0, d) / t.
        uvec4 e = units[edge_units + id / 6u];
        uint corner = id % 6u;
        vec4 a = vertex_record(e.x);
        vec4 b = vertex_record(e.y);
        vec2 d = uintBitsToFloat(e.zw);
        bool at_b = corner == 1u || corner == 2u || corner == 4u;
        bool outer = corner == 2u || corner == 4u || corner == 5u;
        vec4 v = at_b ? b : a;
        uv = outer ? v.xy + v.w * d : v.xy;
        v_inv_depth = v.z;
        v_kind = 0.0;
        v_anchor = a.xy;
        v_dir = d;
        v_width = v.w;
    } else {
        // Fan segment k of n: centre, spoke k, spoke k + 1 at radius t / cos(phi / 2).
        uint j = id - 6u * pc.edges;
        uint fan_units = edge_units + pc.edges;
        uint s = j / 3u;
        uint seg = units[fan_units + pc.fans + s / 4u][s % 4u];
        uvec4 f = units[fan_units + (seg >> 8)];
        uint n = (seg >> 4) & 15u;
        uint spoke = (seg & 15u) + (j % 3u) - 1u;
        vec4 c = vertex_record(f.x);
        vec2 from = uintBitsToFloat(f.yz);
        float sweep = uintBitsToFloat(f.w);
        float pad = sweep < 0.0 ? -FAN_OVERLAP : FAN_OVERLAP;
        float phi = (sweep + 2.0 * pad) / float(n);
        float r = c.w / cos(phi * 0.5);
        float ang = -pad + phi * float(spoke);
        vec2 dir = from * cos(ang) + vec2(-from.y, from.x) * sin(ang);
        uv = j % 3u == 0u ? c.xy : c.xy + r * dir;
        v_inv_depth = c.z;
        v_kind = 1.0;
        v_anchor = c.xy;
        v_dir = vec2(0.0);
        v_width = c.w;
    }
    gl_Position = vec4(uv * 2.0 - 1.0, 0.0, 1.0);
}
