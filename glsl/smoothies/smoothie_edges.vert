#version 450
#extension GL_GOOGLE_include_directive : require
// Smoothie edge quads from records (see records.glsl): vertex 6 e + c of the draw is
// corner c of edge record e.
#include "smoothies/records.glsl"

void main() {
    uint id = uint(gl_VertexIndex);
    uint edge_units = pc.base + pc.vertices;
    vec2 uv;
    // Quad (s0, s1, s1 + t1 d), (s0, s1 + t1 d, s0 + t0 d): alpha = dot(p - s0, d) / t.
    uvec4 e = units[edge_units + id / 6u];
    uint corner = id % 6u;
    vec4 a = vertex_record(e.x);
    vec4 b = vertex_record(e.y);
    vec2 d = uintBitsToFloat(e.zw);
    bool at_b = corner == 1u || corner == 2u || corner == 4u;
    bool outer = corner == 2u || corner == 4u || corner == 5u;
    vec4 v = at_b ? b : a;
    uv = outer ? v.xy + extent(v) * d : v.xy;
    v_inv_depth = v.z;
    v_kind = 0.0;
    v_anchor = a.xy;
    v_dir = d;
    v_width = v.w;
    gl_Position = vec4(uv * 2.0 - 1.0, 0.0, 1.0);
}
