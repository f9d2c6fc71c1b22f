// The thin-blocker march, shared by the inner passes of the centred forms
// (penumbra_map_centred, smoothies_centred, plateaus_centred inner.frag) and by the outer
// fragments of penumbra_map_centred and smoothies_centred (`outer_far_share`). The includer
// #defines INNER_MAP, the sampler2D the march reads (texels of the light-space map the
// fragment is drawn into), and defines `blocked_at` after the include.
#ifndef INNER_MARCH_GLSL
#define INNER_MARCH_GLSL
#include "common/count.glsl"
#include "common/penumbra.glsl"

// How far outside the edge (texels) the outside is read: past the texel the edge crosses.
const float OUT_TEXELS = 1.5;
// How far inside the edge (texels) an outer fragment's march starts: a texel whose centre
// lies this far in along the normal is the blocker's, whichever way the edge crosses it.
const float IN_TEXELS = 1.0;
// Most bisections of the thin-blocker search: the far edge to 1/64 of the reach.
const int BISECT_STEPS = 6;

ivec2 texel_at(vec2 pos) {
    ivec2 size = textureSize(INNER_MAP, 0);
    return clamp(ivec2(floor(pos)), ivec2(0), size - 1);
}

bool inside_map(vec2 pos) {
    vec2 size = vec2(textureSize(INNER_MAP, 0));
    return all(greaterThanEqual(pos, vec2(0.0))) && all(lessThan(pos, size));
}

// Whether the blocker covers the map at `pos` (texels), for a receiver at depth z_r.
bool blocked_at(vec2 pos, float z_r);

// Thin blocker: the distance (texels) from `here` along the inward direction `dir` to the
// blocker's far edge, when it lies within the penumbra's half-width w_tex; -1 when the
// blocker is wider, or still covers the texel w_tex away (or the map's border before it).
// Through a strip between two parallel edges a point sees the disc's segment beyond each
// edge, so the caller adds disc_chord(distance / w).
//
// The end of the reach is read first: still blocked there, the blocker is taken as at
// least that wide and nothing more is read (one read where most fragments, beside or inside
// a blocker wider than its penumbra, find no edge). Else, `here` being blocked and the end
// open, bisections narrow the step between them, to an eighth of a texel or 1/64 of the
// reach (BISECT_STEPS). Where two blockers lie within the reach, they converge on the far
// edge of either.
//
// One loop with one read per trip serves both (the end, the bisections): the same reads as
// a loop per phase, in one place in the code. A rasteriser that runs every statement for
// every fragment under a lane mask (lavapipe) pays each read in the code once per fragment
// even where no fragment takes it, and a loop as many trips as its slowest lane.
float far_edge_texels(vec2 here, vec2 dir, float w_tex, float z_r) {
    if (!(w_tex > 0.0)) return -1.0;
    int bisections = clamp(int(ceil(log2(max(w_tex, 1.0) * 8.0))), 1, BISECT_STEPS);
    float lo = 0.0;
    float hi = w_tex;
    for (int trip = 0; trip <= BISECT_STEPS; ++trip) {
        float d = trip == 0 ? w_tex : 0.5 * (lo + hi);
        vec2 pos = here + dir * d;
        if (trip > 0) COUNT_LOOP(COUNT_MARCH);
        // The end reads nothing outside the map (the search stops at its border); a
        // bisection lies between two samples already read.
        if (trip == 0 && !inside_map(pos)) return -1.0;
        bool blocked = blocked_at(pos, z_r);
        if (trip == 0) {
            if (blocked) return -1.0;
        } else if (blocked) {
            lo = d;
        } else {
            hi = d;
        }
        if (trip == bisections) break;
    }
    // The far edge lies between the last blocked and the first open sample.
    return 0.5 * (lo + hi);
}

// Thin blocker seen from outside its hard shadow: what the blocker's far side adds to the
// visibility of a lit point x_tex texels outside its edge along `out_dir`, where the
// penumbra's half-width is w_tex. Through a strip W texels wide the point sees the disc's
// segment beyond the far edge as well, disc_chord((x + W) / w), which the inner side adds
// at its own texels too: without it the two sides disagree at the hard edge by that
// segment, and a blocker narrower than its penumbra keeps its hard outline. W is found by
// marching inward from IN_TEXELS inside the edge for what is left of the half-width,
// only where the blocker no longer covers the end of that reach; 0 when the blocker is
// wider, or the march does not start inside it.
float outer_far_share(vec2 here, vec2 out_dir, float x_tex, float w_tex, float z_r) {
    float left = w_tex - x_tex - IN_TEXELS;
    if (!(left > 0.0)) return 0.0;
    vec2 start = here - out_dir * (x_tex + IN_TEXELS);
    if (!inside_map(start) || !blocked_at(start, z_r)) return 0.0;
    float d = far_edge_texels(start, -out_dir, left, z_r);
    return d > 0.0 ? disc_chord((x_tex + IN_TEXELS + d) / w_tex) : 0.0;
}

#endif
