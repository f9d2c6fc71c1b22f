// Smoothie MRT pass, CPU path: vertex pulling from compact records (see
// src/silhouette/smoothie/records.rs, whose `SmoothieRecords::expand` is these shaders on
// the CPU). No vertex buffer: per caster, smoothie_edges.vert draws 6 vertices per edge
// and smoothie_fans.vert 3 per fan segment. Two shaders rather than one branch on
// gl_VertexIndex: lavapipe shades vertices on one thread, 8 lanes at a time, and pays for
// both sides of a divergent branch. The outputs are exactly those of smoothie.vert, so
// smoothie.frag (and its hand-tuned SPIR-V) run unchanged. Nothing from the frame
// constants is needed.
#ifndef SMOOTHIE_RECORDS_GLSL
#define SMOOTHIE_RECORDS_GLSL

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
    // smoothies-centred's inner side: the farthest receiver depth an inner fragment can
    // find, Z; 0 elsewhere (the full width t). See `extent`.
    float extent_depth;
    float extent_pad;   // light uv added to a shrunk extent: a rasterisation margin
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

// How far a vertex record's smoothie reaches from the silhouette: its width t, or on the
// inner side t (1 - b / Z) plus the margin. An inner fragment x from the hard edge is
// discarded unless x < t (1 - b / z_r) (its penumbra's half-width), and the receiver depth
// z_r it finds is at most Z, so nothing past that reach is ever written: the shorter quads
// and fans only leave out fragments that would be discarded. The varyings are those of
// the full-width geometry (t and 1/b vary along the edge only), up to interpolation
// rounding.
float extent(vec4 v) {
    if (pc.extent_depth <= 0.0) return v.w;
    float k = max(1.0 - 1.0 / (v.z * pc.extent_depth), 0.0);
    return min(v.w, v.w * k + pc.extent_pad);
}

#endif
