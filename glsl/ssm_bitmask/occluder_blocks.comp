#version 450
#extension GL_GOOGLE_include_directive : require
#include "common/count.glsl"  // by name: build.rs also builds it counted (-DCOUNT_LIGHT)
// ssm-bitmask/occluder_blocks: which micro-quads are drawn as one (the hierarchical
// occluder map, src/technique/ssm_bitmask.rs "Occluder blocks"). One invocation per
// occluder texel, a workgroup per SSM_TILE x SSM_TILE tile. An aligned s x s block of
// texels (s = 2, 4, 8, 16, within the tile) is one quad when
//   - every texel in it is drawn (a caster nearer than z_max);
//   - the corners of each of its micro-quads, as that micro-quad takes them (the harmonic
//     mean of the texels around the corner that are one surface with its own texel:
//     soft_shadow.vert), lie on the block quad's two triangles (corners 0-1-3 and 0-3-2, as
//     each micro-quad splits) within SSMB_MERGE_FLATNESS self-occlusion guards of depth
//     (`flat_tolerance`); the block quad's own corners are those of the micro-quads at the
//     block's corners. The micro-quads' union is then the block quad, which back-projects
//     to the same samples, but for receivers within the guard behind it. Inside a
//     surface neighbouring micro-quads share their corners; at its silhouette a corner
//     keeps its texel's depth on either side, and the block ends there as its micro-quads
//     do;
//   - its corners span at most SSMB_MERGE_GUARDS self-occlusion guards of depth: the block
//     quad takes the guard of its farthest corner, so a receiver between its nearest and
//     farthest corners loses what its nearer texels alone would hide; the bound keeps that
//     to a band of receivers as thin as the guard itself.
// The largest such block holding a texel is its quad. Writes per texel the side of the quad
// it begins (s at a block's first texel, 0 at its other texels, 1 where the texel is its
// own micro-quad) and, at a block's first texel, the block quad's corner depths.
//
// Three barriers: a CPU driver runs a workgroup's invocations as coroutines that switch at
// each one. Every texel tests its own four corners against its block at every level at
// once, and the blocks are found flat by texels that each can only clear a block's flag.
#define FRAME_NO_DRAW_PUSH
#include "common/frame.glsl"
#include "ssm/ssm.glsl"
#include "ssm_bitmask/constants.glsl"
#include "ssm_bitmask/guard.glsl"
#include "ssm_bitmask/corners.glsl"

layout(local_size_x = SSM_TILE, local_size_y = SSM_TILE) in;

// r = the casters' linear depth: the RG32F MIN-blended shared shadow map (front surfaces).
layout(set = 0, binding = 1) uniform sampler2D occluder_map;
layout(set = 0, binding = 4, std430) readonly buffer Bound { uint zmax_bits; uint step; } bound;
layout(set = 0, binding = 9, std430) writeonly buffer Blocks { uint side[]; } blocks;
layout(set = 0, binding = 10, std430) writeonly buffer BlockCorners { vec4 depth[]; } block_corners;
#define DRAWN_TILES_BINDING 11
#define DRAWN_TILES_ACCESS readonly
#include "ssm/drawn_tiles.glsl"

layout(push_constant) uniform Push {
    // 1: one workgroup per listed tile (the speed layer: tiles without a drawn texel hold
    // no quad, and no micro-quad reads their sides); 0: one per tile of the map.
    uint listed;
} pc;

// The tile and a ring of one texel: depth (FAR_DEPTH where empty or outside the map).
const int HALO = SSM_TILE + 2;
shared float halo_depth[HALO * HALO];
// Per texel of the tile, its micro-quad's four corners (1/depth; a sun's: depth), in the
// order (i, j), (i + 1, j), (i, j + 1), (i + 1, j + 1).
shared vec4 own_corners[SSM_TILE * SSM_TILE];
// Per block side 2, 4, 8, 16: whether every texel of each aligned block of the tile is
// drawn and every corner of its micro-quads lies on the block quad (offsets 0, 64, 80, 84).
shared bool flat_block[85];

// Block sides 2^1 ... 2^LEVELS: up to the tile's.
const int LEVELS = 4;

int level_offset(int level) {
    return level == 1 ? 0 : level == 2 ? 64 : level == 3 ? 80 : 84;
}

float depth_at(ivec2 h) {
    return halo_depth[h.y * HALO + h.x];
}

// The depth of a corner value c (1/depth; a sun's: depth).
float corner_depth(float c) {
    return light_is_sun() ? c : 1.0 / c;
}

// The block quad through its corner values c = (c00, c10, c01, c11) at (x, y), in units of
// its side: corners 0-1-3 (x >= y) and 0-3-2 (the rest) span its two triangles, as each
// micro-quad's.
float block_plane(vec4 c, vec2 xy) {
    return xy.x >= xy.y ? c.x + (c.y - c.x) * xy.x + (c.w - c.y) * xy.y
                        : c.x + (c.z - c.x) * xy.y + (c.w - c.z) * xy.x;
}

// The corner values of the block of side s at tile texel lo: the outer corners of the
// micro-quads at its corners.
vec4 block_corner_values(ivec2 lo, int s) {
    int last = s - 1;
    return vec4(own_corners[lo.y * SSM_TILE + lo.x].x,
                own_corners[lo.y * SSM_TILE + lo.x + last].y,
                own_corners[(lo.y + last) * SSM_TILE + lo.x].z,
                own_corners[(lo.y + last) * SSM_TILE + lo.x + last].w);
}

// Whether a block quad with corner values c spans at most SSMB_MERGE_GUARDS guards of
// depth: flat to within the flatness, it lies between its corners' depths.
bool block_is_thin(vec4 c) {
    float near_c = max(max(c.x, c.y), max(c.z, c.w));
    float far_c = min(min(c.x, c.y), min(c.z, c.w));
    // 1/depth is largest at the nearest corner (a sun's depth smallest).
    bool sun = light_is_sun();
    float z_near = corner_depth(sun ? far_c : near_c);
    float z_far = corner_depth(sun ? near_c : far_c);
    return z_far - z_near <= SSMB_MERGE_GUARDS * guard_depth(z_far);
}

// How far (in corner values) a micro-quad corner with value c may lie off its block quad:
// SSMB_MERGE_FLATNESS self-occlusion guards at its depth. A corner that close to the block
// quad is within the guard that a receiver behind it is tested with anyway. A spotlight's
// guard grows with depth, guard_depth(z) = z guard_depth(1), so in 1/depth it is the same
// fraction of c at every depth.
float flat_tolerance(float c) {
    return SSMB_MERGE_FLATNESS * (light_is_sun() ? guard_depth(c) : abs(c) * guard_depth(1.0));
}

// The flag of the block of side 2^level holding tile texel `local`.
int block_flag(ivec2 local, int level) {
    return level_offset(level) + (local.y >> level) * (SSM_TILE >> level) + (local.x >> level);
}

void main() {
    int n = int(SSM_RES);
    ivec2 tile = workgroup_tile(pc.listed != 0u, bound.step, n);
    int li = int(gl_LocalInvocationIndex);
    float zmax = uintBitsToFloat(bound.zmax_bits);
    for (int i = li; i < HALO * HALO; i += SSM_TILE * SSM_TILE) {
        ivec2 p = tile + ivec2(i % HALO, i / HALO) - 1;
        float z = FAR_DEPTH;
        if (all(greaterThanEqual(p, ivec2(0))) && all(lessThan(p, ivec2(n)))) {
            z = texelFetch(occluder_map, p, 0).r;
        }
        halo_depth[i] = z < EMPTY ? z : FAR_DEPTH;
    }
    if (li < 85) flat_block[li] = true;
    barrier();

    ivec2 local = ivec2(gl_LocalInvocationID.xy);
    ivec2 h = local + 1;
    float zo = depth_at(h);
    bool drawn = zo < EMPTY && zo < zmax;
    // This texel's micro-quad corners, as micro_quad.glsl takes them: per corner the mean
    // (1/depth; a sun's depth) of the texels around it that are one surface with this one.
    float z[9];
    for (int i = 0; i < 9; ++i) z[i] = depth_at(h + ivec2(i % 3 - 1, i / 3 - 1));
    vec4 sums, counts;
    micro_quad_corner_sums(z, zo, sums, counts);
    vec4 own = drawn ? sums / counts : vec4(0.0);
    own_corners[li] = own;
    barrier();

    // Each texel clears the flag of its block at every level where it is not drawn or one
    // of its four corners lies off the block quad; every writer writes the same false.
    for (int level = 1; level <= LEVELS; ++level) {
        int s = 1 << level;
        ivec2 lo = local & ~(s - 1);
        vec4 quad = block_corner_values(lo, s);
        float inv_side = 1.0 / float(s);
        bool flat_here = drawn;
        for (int c = 0; c < 4; ++c) {
            vec2 xy = vec2(local - lo + ivec2(c & 1, c >> 1)) * inv_side;
            flat_here = flat_here && abs(own[c] - block_plane(quad, xy)) <= flat_tolerance(own[c]);
        }
        if (!flat_here) flat_block[block_flag(local, level)] = false;
    }
    barrier();

    ivec2 g = tile + local;
    if (any(greaterThanEqual(g, ivec2(n)))) return;
    // The largest block holding this texel that is one quad: every texel of a block finds
    // the same.
    uint side = 1u;
    for (int level = LEVELS; level >= 1; --level) {
        int s = 1 << level;
        ivec2 lo = local & ~(s - 1);
        if (flat_block[block_flag(local, level)] && block_is_thin(block_corner_values(lo, s))) {
            side = all(equal(local, lo)) ? uint(s) : 0u;
            break;
        }
    }
    blocks.side[g.y * n + g.x] = side;
    if (side > 1u) {
        vec4 c = block_corner_values(local, int(side));
        block_corners.depth[g.y * n + g.x] = vec4(corner_depth(c.x), corner_depth(c.y), corner_depth(c.z), corner_depth(c.w));
    }
}
