#version 450
#extension GL_GOOGLE_include_directive : require
#include "common/count.glsl"  // by name: build.rs also builds it counted (-DCOUNT_LIGHT)
// pcss-fast/minmax: one level of the caster-depth hierarchy (pcss_fast/hierarchy.glsl: per
// cell min, max caster, sum and count of caster depths) from the level below it, one
// dispatch a level; the first level (2: 4x4 texels a cell) reads the shadow map itself.
#include "pcss_fast/hierarchy.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

// R32F (gpu::passes::ShadowMap::casters): the nearest caster's linear depth (FAR_DEPTH where
// none).
layout(set = 0, binding = 0) uniform sampler2D shadow_map;
// Read (the level below) and written (this level) in one dispatch: disjoint ranges.
layout(std430, set = 0, binding = 1) buffer MinMax { vec4 cells[]; } minmax;

layout(push_constant) uniform Level {
    int src_offset;  // first cell of the level below; < 0: the shadow map, 4x4 texels a cell
    int src_size;    // its cells (texels) a side
    int dst_offset;  // first cell of this level
    int dst_size;    // its cells a side
} level;

// Adds one texel's depth to a cell.
vec4 add_texel(vec4 r, float v) {
    bool c = is_caster(v);
    return vec4(min(r.x, v), c ? max(r.y, v) : r.y, r.z + (c ? v : 0.0), r.w + (c ? 1.0 : 0.0));
}

void main() {
    ivec2 d = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(d, ivec2(level.dst_size)))) return;
    vec4 r = vec4(FAR_DEPTH, 0.0, 0.0, 0.0);
    if (level.src_offset < 0) {
        // A gather at the corner four texels share reads all of them, so four gathers read
        // the cell's 4x4. Past the map's edge the clamp-to-edge sampler repeats the last
        // texels: those repeats are skipped, so that sum and count hold each texel once.
        // 4x4 rather than 2x2 cells first: a level of res²/4 threads cost about as much as
        // the shadow-map pass on lavapipe.
        for (int j = 0; j < 2; ++j) {
            for (int i = 0; i < 2; ++i) {
                ivec2 t0 = 4 * d + 2 * ivec2(i, j);
                vec4 g = textureGather(shadow_map, vec2(t0 + 1) / float(level.src_size), 0);
                // Gather order: (i0, j1), (i1, j1), (i1, j0), (i0, j0).
                bvec2 in0 = lessThan(t0, ivec2(level.src_size));
                bvec2 in1 = lessThan(t0 + 1, ivec2(level.src_size));
                if (in0.x && in1.y) r = add_texel(r, g.x);
                if (in1.x && in1.y) r = add_texel(r, g.y);
                if (in1.x && in0.y) r = add_texel(r, g.z);
                if (in0.x && in0.y) r = add_texel(r, g.w);
            }
        }
    } else {
        for (int j = 0; j < 2; ++j) {
            for (int i = 0; i < 2; ++i) {
                // The last cell of an odd-sized level has one child a side.
                ivec2 s = 2 * d + ivec2(i, j);
                if (any(greaterThanEqual(s, ivec2(level.src_size)))) continue;
                COUNT_READ();
                vec4 v = minmax.cells[level.src_offset + s.y * level.src_size + s.x];
                r = vec4(min(r.x, v.x), max(r.y, v.y), r.z + v.z, r.w + v.w);
            }
        }
    }
    minmax.cells[level.dst_offset + d.y * level.dst_size + d.x] = r;
}
