// Counted lookups. Two untimed builds of one source, beside the timed one (which has none
// of this):
// - COUNT, the counting build of a final pass (build.rs compiles every shader that includes
//   common/final.glsl with -DCOUNT too): common/final.glsl writes each pixel's four counts
//   (texels, search, filter and march iterations) to the additive count attachment.
// - COUNT_LIGHT = 1 (vertex), 2 (fragment) or 3 (compute), the counting build of a light
//   pass (build.rs compiles every other shader that includes this file by name with it):
//   each invocation adds its counts to the storage buffer at set COUNT_LIGHT_SET, which the
//   recorder binds in the counting frame (vk::cmd, `FrameRunner::run_counting`). The buffer
//   is an array of 8-word cells: cell 0 takes what the vertex stage reads, and its word 7
//   holds the number of tiles in a row; every other cell is one 8x4-texel tile of the
//   target (fragments; a pass's draws share them) or one group of 32 invocations of a
//   workgroup (compute; each dispatch has a buffer of its own), with the texels its
//   invocations read (word 0), the most one of them read (1), how many read any (2) and the
//   loop iterations (3..5). Helper invocations' atomics have no effect, so only the
//   invocations that cover the target are counted, as in the final pass's attachment.
// Each texture read adds the texels it reads: texelFetch and imageLoad 1, a bilinear
// `texture` or a comparison-sampler lookup 4, textureGather 4 (a nearest-filtered `texture`
// is counted as 4 too: the model charges a filtered read). The macros wrap the built-in
// functions, so no lookup can be left out; a macro does not expand inside its own body, so
// each still calls the built-in. COUNT_LOOP(k) counts one iteration of a search (k = 0),
// filter (1) or march (2) loop.
#ifndef COUNT_GLSL
#define COUNT_GLSL
#define COUNT_SEARCH 0
#define COUNT_FILTER 1
#define COUNT_MARCH 2
#if defined(COUNT) || defined(COUNT_LIGHT)
uint count_texels = 0u;
uvec3 count_loops = uvec3(0u);

#ifdef COUNT_LIGHT
// Set 1: every counted light pipeline has its own descriptor set at 0 (vk::pipeline).
#define COUNT_LIGHT_SET 1
#define COUNT_CELL_WORDS 8u
layout(set = COUNT_LIGHT_SET, binding = 0, std430) restrict buffer LightCounts {
    uint count_cells[];
};

// The first word of this invocation's cell.
uint count_cell() {
    uint cells = uint(count_cells.length()) / COUNT_CELL_WORDS;
#if COUNT_LIGHT == 2
    uvec2 tile = uvec2(gl_FragCoord.xy) / uvec2(8u, 4u);
    uint cell = 1u + tile.y * count_cells[7] + tile.x;
#elif COUNT_LIGHT == 3
    // The recorder gives each dispatch a buffer with 32 cells a group.
    uvec3 n = gl_NumWorkGroups;
    uvec3 g = gl_WorkGroupID;
    uint group = (g.z * n.y + g.y) * n.x + g.x;
    uint cell = 1u + group * 32u + gl_LocalInvocationIndex / 32u;
#else
    uint cell = 0u;
#endif
    return min(cell, cells - 1u) * COUNT_CELL_WORDS;
}

uint count_add(uint n) {
    uint c = count_cell();
    if (count_texels == 0u && n > 0u) {
        atomicAdd(count_cells[c + 2u], 1u);
    }
    count_texels += n;
    atomicAdd(count_cells[c], n);
    // The running total: a fragment discarded later still paid for what it read.
    atomicMax(count_cells[c + 1u], count_texels);
    return n;
}

void count_loop(uint k) {
    count_loops[k] += 1u;
    atomicAdd(count_cells[count_cell() + 3u + k], 1u);
}
#define COUNT_LOOP(k) count_loop(k)
#else
uint count_add(uint n) {
    count_texels += n;
    return n;
}
#define COUNT_LOOP(k) count_loops[k] += 1u
#endif

#define texture(s, p) (count_add(4u), texture(s, p))
#define textureGather(s, p, c) (count_add(4u), textureGather(s, p, c))
#define texelFetch(s, p, l) (count_add(1u), texelFetch(s, p, l))
#define textureLod(s, p, l) (count_add(4u), textureLod(s, p, l))
#define imageLoad(i, p) (count_add(1u), imageLoad(i, p))
// A read of one element of a storage buffer standing in for a texture (a min-max cell).
#define COUNT_READ() count_add(1u)
#else
#define COUNT_LOOP(k)
#define COUNT_READ()
#endif
#endif
