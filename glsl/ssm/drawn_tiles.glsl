// The tiles of the occluder map that hold a drawn caster (speed layer, src/technique/speed/
// ssm.rs `PatchStep::drawn`): written by ssm/patch_step.comp, read by the per-tile passes
// that only work where a micro-patch is drawn, as the arguments and the tiles of an
// indirect dispatch. The includer #defines DRAWN_TILES_BINDING (its set's binding) and
// DRAWN_TILES_ACCESS (readonly, or empty where it is written).
#ifndef SSM_DRAWN_TILES_GLSL
#define SSM_DRAWN_TILES_GLSL
#include "ssm/ssm.glsl"

// A VkDispatchIndirectCommand (x, y, z), the number of tiles listed, then their indices
// (row-major over the tiles). With a micro-patch step above 1 the per-tile passes run every
// tile in order: x is then the tile count and the list is not read.
layout(set = 0, binding = DRAWN_TILES_BINDING, std430) DRAWN_TILES_ACCESS buffer DrawnTiles {
    uint x;
    uint y;
    uint z;
    uint count;
    uint tile[];
} drawn_tiles;

// The first texel of the tile this workgroup works on: its own in a full dispatch, else the
// one listed for it (or the tile of its index, with a step above 1).
ivec2 workgroup_tile(bool listed, uint step, int n) {
    if (!listed) return ivec2(gl_WorkGroupID.xy) * SSM_TILE;
    int row = (n + SSM_TILE - 1) / SSM_TILE;
    int t = int(step > 1u ? gl_WorkGroupID.x : drawn_tiles.tile[gl_WorkGroupID.x]);
    return ivec2(t % row, t / row) * SSM_TILE;
}

#endif
