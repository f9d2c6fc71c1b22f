// The corners of one texel's micro-quad, shared by the quad itself (micro_quad.glsl) and
// the occluder blocks that merge micro-quads (occluder_blocks.comp), which must take them
// alike for a block quad to be its micro-quads' union.
#ifndef SSM_BITMASK_CORNERS_GLSL
#define SSM_BITMASK_CORNERS_GLSL
#include "common/frame.glsl"
#include "ssm/ssm.glsl"
#include "ssm_bitmask/constants.glsl"

// Per corner (i, j), (i + 1, j), (i, j + 1), (i + 1, j + 1) of the texel at depth zo, the
// sum of 1/z (a sun: z) over the texels around it that are one surface with the texel, and
// how many they are (at least the texel itself where it is drawn). `z` holds the 3x3
// neighbourhood row by row from offset (-1, -1), FAR_DEPTH outside the map. One surface:
// depths within SSMB_CONNECT_TEXELS texels of slope, a test symmetric in the two depths, so
// that two neighbours agree on whether they connect. A sun's map is orthographic: its
// texels have one world size (the slope is absolute, not relative), and depth is affine
// across a plane's texels, so its corners take the arithmetic mean, a spotlight's the
// harmonic one (1/z is affine across a plane's texels).
void micro_quad_corner_sums(float z[9], float zo, out vec4 sums, out vec4 counts) {
    bool sun = light_is_sun();
    float slope = SSMB_CONNECT_TEXELS * 2.0 * frame.light_frustum.x * SSM_INV_RES;
    float sun_slope = SSMB_CONNECT_TEXELS * ssm_sun_texel();
    float inv[9];
    for (int i = 0; i < 9; ++i) {
        bool one = z[i] < EMPTY && abs(z[i] - zo) <= (sun ? sun_slope : slope * min(z[i], zo));
        inv[i] = one ? (sun ? z[i] : 1.0 / z[i]) : 0.0;
    }
    for (int c = 0; c < 4; ++c) {
        // Corner (i + cx, j + cy) touches the texels at offsets cx-1..cx, cy-1..cy, summed in
        // a fixed order of the map, so a corner's sum is the same in every quad.
        int i0 = (c >> 1) * 3 + (c & 1);   // offset (cx - 1, cy - 1)
        float s = 0.0, m = 0.0;
        for (int t = 0; t < 4; ++t) {
            float v = inv[i0 + (t & 1) + 3 * (t >> 1)];
            s += v;
            m += v > 0.0 ? 1.0 : 0.0;
        }
        sums[c] = s;
        counts[c] = m;
    }
}

#endif
