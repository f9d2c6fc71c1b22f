// The min/max hierarchy of the shadow map's caster depths (pcss_fast/minmax.comp writes it,
// pcss_fast/final.frag reads it). Level k (2..PCSS_FAST_LAST_LEVEL) is ceil(res / 2^k) cells
// a side, cell (x, y) holding (min, max) over the shadow-map texels [x 2^k, (x + 1) 2^k) x
// [y 2^k, ...): with sizes rounded up, texel t lies in cell t >> k at every level, whatever
// the resolution. Levels are stored one after another, row by row, level 2 first.
#ifndef PCSS_FAST_HIERARCHY_GLSL
#define PCSS_FAST_HIERARCHY_GLSL

// Cells a side of level k of a res² map.
int level_size(int res, int k) {
    return (res + (1 << k) - 1) >> k;
}

#endif
