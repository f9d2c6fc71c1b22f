#version 450
#extension GL_GOOGLE_include_directive : require
// Smoothie MRT pass, CPU path: vertex pulling from compact records (see
// src/silhouette/smoothie/records.rs, whose `SmoothieRecords::expand` is this shader on the
// CPU). No vertex buffer: one draw per caster of 6 * edges + 3 * segments vertices. The
// outputs are exactly those of smoothie.vert, so smoothie.frag (and its hand-tuned SPIR-V)
// run unchanged. It needs nothing from the frame constants.

// Per caster, back to back: vertex records (uv, 1/depth, t), edge records (a, b, dir),
// fan records (centre, from, sweep), one word per fan segment (fan << 8 | n << 4 | k).
layout(set = 1, binding = 0, std430) readonly buffer Records { uint words[]; };

layout(push_constant) uniform Caster {
    uint base;      // first word of this caster's records
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
    uint o = pc.base + 4u * i;
    return uintBitsToFloat(uvec4(words[o], words[o + 1u], words[o + 2u], words[o + 3u]));
}

void main() {
    uint id = uint(gl_VertexIndex);
    uint edge_words = pc.base + 4u * pc.vertices;
    vec2 uv;
    if (id < 6u * pc.edges) {
        // Quad (s0, s1, s1 + t1 d), (s0, s1 + t1 d, s0 + t0 d): alpha = dot(p - s0, d) / t.
        uint o = edge_words + 4u * (id / 6u);
        uint corner = id % 6u;
        vec4 a = vertex_record(words[o]);
        vec4 b = vertex_record(words[o + 1u]);
        vec2 d = uintBitsToFloat(uvec2(words[o + 2u], words[o + 3u]));
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
        uint fan_words = edge_words + 4u * pc.edges;
        uint seg = words[fan_words + 4u * pc.fans + j / 3u];
        uint o = fan_words + 4u * (seg >> 8);
        uint n = (seg >> 4) & 15u;
        uint spoke = (seg & 15u) + (j % 3u) - 1u;
        vec4 c = vertex_record(words[o]);
        vec2 from = uintBitsToFloat(uvec2(words[o + 1u], words[o + 2u]));
        float sweep = uintBitsToFloat(words[o + 3u]);
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
