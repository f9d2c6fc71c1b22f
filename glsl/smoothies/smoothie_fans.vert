#version 450
#extension GL_GOOGLE_include_directive : require
// Smoothie corner fans from records (see records.glsl): vertex 3 s + c of the draw is
// corner c (centre, spoke k, spoke k + 1) of fan segment s.
#include "smoothies/records.glsl"

void main() {
    uint j = uint(gl_VertexIndex);
    uint fan_units = pc.base + pc.vertices + pc.edges;
    vec2 uv;
    // Fan segment k of n: centre, spoke k, spoke k + 1 at radius t / cos(phi / 2).
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
    float r = extent(c) / cos(phi * 0.5);
    float ang = -pad + phi * float(spoke);
    vec2 dir = from * cos(ang) + vec2(-from.y, from.x) * sin(ang);
    uv = j % 3u == 0u ? c.xy : c.xy + r * dir;
    v_inv_depth = c.z;
    v_kind = 1.0;
    v_anchor = c.xy;
    v_dir = vec2(0.0);
    v_width = c.w;
    gl_Position = vec4(uv * 2.0 - 1.0, 0.0, 1.0);
}
