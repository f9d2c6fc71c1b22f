#version 450
#extension GL_GOOGLE_include_directive : require
// pcss-fast/minmax: one level of the min/max hierarchy (pcss_fast/hierarchy.glsl) from the
// level below it, one dispatch a level; the first level (2: 4x4 texels a cell) reads the
// shadow map itself.
#include "pcss_fast/hierarchy.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

// RG32F, r = the nearest caster's linear depth (1e30 where none).
layout(set = 0, binding = 0) uniform sampler2D shadow_map;
// Read (the level below) and written (this level) in one dispatch: disjoint ranges.
layout(std430, set = 0, binding = 1) buffer MinMax { vec2 cells[]; } minmax;

layout(push_constant) uniform Level {
    int src_offset;  // first cell of the level below; < 0: the shadow map, 4x4 texels a cell
    int src_size;    // its cells (texels) a side
    int dst_offset;  // first cell of this level
    int dst_size;    // its cells a side
} level;

void main() {
    ivec2 d = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(d, ivec2(level.dst_size)))) return;
    vec2 r;
    if (level.src_offset < 0) {
        // A gather at the corner four texels share reads all of them, so four gathers read
        // the cell's 4x4; past the map's edge the clamp-to-edge sampler repeats its last
        // texels, which the cell covers anyway. 4x4 rather than 2x2 cells first: a level of
        // res²/4 threads cost about as much as the shadow-map pass on lavapipe.
        r = vec2(3.0e38, -3.0e38);
        for (int j = 0; j < 2; ++j) {
            for (int i = 0; i < 2; ++i) {
                vec2 corner = vec2(4 * d + 2 * ivec2(i, j) + 1) / float(level.src_size);
                vec4 g = textureGather(shadow_map, corner, 0);
                r = vec2(min(r.x, min(min(g.x, g.y), min(g.z, g.w))),
                         max(r.y, max(max(g.x, g.y), max(g.z, g.w))));
            }
        }
    } else {
        r = vec2(3.0e38, -3.0e38);
        for (int j = 0; j < 2; ++j) {
            for (int i = 0; i < 2; ++i) {
                // The last cell of an odd-sized level has one child a side: read it twice.
                ivec2 s = min(2 * d + ivec2(i, j), ivec2(level.src_size - 1));
                vec2 v = minmax.cells[level.src_offset + s.y * level.src_size + s.x];
                r = vec2(min(r.x, v.x), max(r.y, v.y));
            }
        }
    }
    minmax.cells[level.dst_offset + d.y * level.dst_size + d.x] = r;
}
