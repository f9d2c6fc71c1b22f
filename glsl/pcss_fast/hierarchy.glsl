// The caster-depth hierarchy of the shadow map (pcss_fast/minmax.comp writes it;
// pcss_fast/visibility.glsl reads it, for the final passes of pcss-fast and pcss-walk).
// Level k (2..PCSS_FAST_LAST_LEVEL) is ceil(res / 2^k) cells a side, cell (x, y) covering
// the shadow-map texels [x 2^k, (x + 1) 2^k) x [y 2^k, ...) that lie inside the map: with
// sizes rounded up, texel t lies in cell t >> k at every level, whatever the resolution,
// and a cell at the far edges covers fewer texels (`cell_texels`). Levels are stored one
// after another, row by row, level 2 first.
//
// A cell is a vec4 over its texels' r (the nearest caster's linear depth, FAR_DEPTH where
// none): x = min over every texel (FAR_DEPTH if none holds a caster), y = max over the
// texels that hold a caster (0 if none), z = sum of those depths, w = their count. The max
// over every texel is y where w == cell_texels, else FAR_DEPTH.
#ifndef PCSS_FAST_HIERARCHY_GLSL
#define PCSS_FAST_HIERARCHY_GLSL

#include "common/far_depth.glsl"

bool is_caster(float r) {
    return r < 0.5 * FAR_DEPTH;
}

// Cells a side of level k of a res² map.
int level_size(int res, int k) {
    return (res + (1 << k) - 1) >> k;
}

// Shadow-map texels inside cell xy of level k (2^2k except along the far edges).
int cell_texels(int res, int k, ivec2 xy) {
    ivec2 side = min((xy + 1) << k, ivec2(res)) - (xy << k);
    return side.x * side.y;
}

#endif
