// The receiver tiles of ssm/patch_step.comp, read where ssm-bitmask derives its micro-quads
// (micro_quad.glsl): a quad is drawn only as far as the deepest receiver under its extent.
#ifndef SSM_TILES_GLSL
#define SSM_TILES_GLSL
#include "ssm/ssm.glsl"

// Per SSM_TILE x SSM_TILE texels, the deepest receiver a micro-patch fragment there stands at
// (the frame's z_max under --plain): src/technique/speed/ssm.rs.
layout(set = 0, binding = 5, std430) readonly buffer Tiles { float zmax[]; } tiles;

// The deepest receiver over the texels that the square [a, b] (texel units) touches, from the
// tiles it overlaps; `zmax`, the frame's, when it overlaps more than 4 x 4 tiles (a bound on
// the reads per quad).
float deepest_receiver(vec2 a, vec2 b, float zmax, int n) {
    int row = (n + SSM_TILE - 1) / SSM_TILE;
    ivec2 t0 = clamp(ivec2(floor(a)), ivec2(0), ivec2(n - 1)) / SSM_TILE;
    ivec2 t1 = clamp(ivec2(floor(b)), ivec2(0), ivec2(n - 1)) / SSM_TILE;
    if (any(greaterThan(t1 - t0, ivec2(3)))) return zmax;
    float deepest = 0.0;
    for (int y = t0.y; y <= t1.y; ++y) {
        for (int x = t0.x; x <= t1.x; ++x) deepest = max(deepest, tiles.zmax[y * row + x]);
    }
    return deepest;
}

#endif
