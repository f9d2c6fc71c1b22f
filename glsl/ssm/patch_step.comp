#version 450
#extension GL_GOOGLE_include_directive : require
#include "common/count.glsl"  // by name: build.rs also builds it counted (-DCOUNT_LIGHT)
// ssm/micro_patch_step: the side of the texel blocks the micro-patch pass draws as one
// patch, from the work the patches would cost (Sec. 6.1: occluder texels times the texels
// of each penumbra extent). Two dispatches of this shader:
// - `choose == 0`, over every occluder texel (an invocation per 2x2): the texel's extent
//   h = reach (1/z_O - 1/z_max) texels beyond its square (z_max from ssm/receiver_bound),
//   and per block side s = 1, 2, 4, ... the texels one s x s block quad covers,
//   min(s + 2h + 2, N)^2, shared by the s^2 texels of a full block; summed over the map
//   into 64-bit counters;
// - `choose == 1`, one invocation: the smallest s whose sum stays within the budget, N^4 /
//   64 fragments (every texel's patch over 1/64 of the map), else N.
// s = 1 is the paper's one micro-patch per texel, the image unchanged. A larger s is the
// paper's remedy for large penumbrae (Sec. 6.1: "a low resolution shadow map would give the
// same visual results"), applied only when the penumbrae are that large.
//
// The first dispatch also lists the tiles that hold a drawn texel (ssm/drawn_tiles.glsl;
// the second writes their indirect dispatch), and writes the receiver tiles: per workgroup
// (SSM_TILE x SSM_TILE texels) the deepest receiver a micro-patch pass fragment there can
// stand at, both layers, with the frame's z_max where a texel has no pure receiver (the
// pass puts it there). A micro-patch is drawn only as far as the deepest receiver under its
// extent (`deepest_receiver`, glsl/ssm/tiles.glsl): the extent for z_max covers every
// receiver a patch can reach, and within it none is deeper than those tiles. Without
// `local` (--plain, and the forms that do not read them) every tile holds z_max.
#define FRAME_NO_DRAW_PUSH
#include "common/frame.glsl"
#include "ssm/ssm.glsl"
#include "ssm/constants.glsl"

// A workgroup per tile of SSM_TILE x SSM_TILE texels, each invocation 2x2 of them: a CPU
// driver switches between a workgroup's invocations at each barrier and serialises their
// shared atomics, so fewer invocations, each adding its texels' sums once, cost less.
layout(local_size_x = SSM_TILE / 2, local_size_y = SSM_TILE / 2) in;

layout(set = 0, binding = 1) uniform sampler2D occluder_map;
layout(set = 0, binding = 3) uniform sampler2D receiver_front;   // R32F nearest receiver
layout(set = 0, binding = 4) uniform sampler2D receiver_pure;    // R32F nearest pure receiver
layout(set = 0, binding = 5, std430) writeonly buffer Tiles { float zmax[]; } tiles;
layout(set = 0, binding = 2, std430) buffer Bound {
    uint zmax_bits;   // ssm/receiver_bound
    uint step;        // the block side chosen (read by the micro-patch pass)
    float budget;     // the fragments allowed (read back for the warning)
    uint pad;
    uint work[];      // per block side 2^l: low word, high word of the estimated fragments
} bound;

#define DRAWN_TILES_BINDING 6
#define DRAWN_TILES_ACCESS
#include "ssm/drawn_tiles.glsl"

layout(push_constant) uniform Push {
    float reach;   // texels of extent per unit of (1/z_O - 1/z_max) (a sun's: of z_max - z_O), the technique's
    uint choose;
    uint local;    // 0: every tile holds the frame's z_max (--plain, and forms without tiles)
} pc;

// The block sides 2^l with 2^l <= N: fewer than 32 for any map an int can index.
const int SIDES = 32;
shared uint group_work[SIDES];
shared uint group_deepest;
shared bool group_drawn;

void choose_step() {
    float n = SSM_RES;
    float budget = n * n * n * n * (1.0 / 64.0);
    bound.budget = budget;
    uint step = uint(n);
    for (int l = 0; (1 << l) < int(n); ++l) {
        float w = float(bound.work[2 * l + 1]) * 4294967296.0 + float(bound.work[2 * l]);
        if (w <= budget) {
            step = uint(1 << l);
            break;
        }
    }
    bound.step = step;
    // The indirect dispatch of the per-tile passes: the listed tiles, or every tile.
    uint row = (uint(n) + uint(SSM_TILE) - 1u) / uint(SSM_TILE);
    drawn_tiles.x = step > 1u ? row * row : drawn_tiles.count;
    drawn_tiles.y = 1u;
    drawn_tiles.z = 1u;
}

void main() {
    if (pc.choose != 0u) {
        if (gl_GlobalInvocationID.xy == uvec2(0)) choose_step();
        return;
    }
    uint li = gl_LocalInvocationIndex;
    if (li < SIDES) group_work[li] = 0u;
    if (li == 0u) {
        group_deepest = 0u;
        group_drawn = false;
    }
    barrier();
    int n = int(SSM_RES);
    float zmax = uintBitsToFloat(bound.zmax_bits);
    float deepest = 0.0;
    // Per texel of the four: its extent h, or -1 where nothing is drawn.
    float h[4];
    for (int k = 0; k < 4; ++k) {
        h[k] = -1.0;
        ivec2 t = 2 * ivec2(gl_GlobalInvocationID.xy) + ivec2(k & 1, k >> 1);
        if (any(greaterThanEqual(t, ivec2(n)))) continue;
        float d = zmax;
        if (pc.local != 0u) {
            float z1 = texelFetch(receiver_front, t, 0).r;
            float z2 = texelFetch(receiver_pure, t, 0).r;
            d = z1 < EMPTY ? max(z1, min(z2, zmax)) : 0.0;
        }
        deepest = max(deepest, d);
        float zo = texelFetch(occluder_map, t, 0).r;
        if (zo < EMPTY && zo < zmax) {
            h[k] = light_is_sun()
                ? max(pc.reach * (zmax - zo), 0.0)
                : max(pc.reach * (1.0 / zo - 1.0 / zmax), 0.0);
        }
    }
    // Non-negative floats order like their bit patterns, so integer max is float max.
    atomicMax(group_deepest, floatBitsToUint(deepest));
    if (max(max(h[0], h[1]), max(h[2], h[3])) >= 0.0) {
        // Every drawn texel's invocation writes the same true.
        group_drawn = true;
        for (int l = 0; (1 << l) <= n; ++l) {
            float s = float(1 << l);
            uint work = 0u;
            for (int k = 0; k < 4; ++k) {
                float side = min(s + 2.0 * h[k] + 2.0, float(n));
                work += h[k] >= 0.0 ? uint(ceil(side * side / (s * s))) : 0u;
            }
            // At most N^2 <= 2^22 per texel, 2^30 per group of 256: no overflow.
            atomicAdd(group_work[l], work);
        }
    }
    barrier();
    uint group = gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x;
    if (li == 0u) tiles.zmax[group] = uintBitsToFloat(group_deepest);
    if (li == 0u && group_drawn) drawn_tiles.tile[atomicAdd(drawn_tiles.count, 1u)] = group;
    if (li < SIDES && group_work[li] > 0u) {
        uint add = group_work[li];
        uint old = atomicAdd(bound.work[2 * li], add);
        // The carry into the high word: the low word wrapped.
        if (old + add < old) atomicAdd(bound.work[2 * li + 1], 1u);
    }
}
