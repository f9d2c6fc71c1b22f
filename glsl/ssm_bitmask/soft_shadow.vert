#version 450
#extension GL_GOOGLE_include_directive : require
#include "common/count.glsl"  // by name: build.rs also builds it counted (-DCOUNT_LIGHT)
// ssm-bitmask/soft_shadow: one instance per occluder-map texel, 4 vertices (triangle strip).
// The micro-quad of texel (i, j) spans its pixel square [i, i+1] x [j, j+1]; each corner's
// depth is the harmonic mean (exact for a plane: 1/z is affine across the map) of the up to
// four texels around that corner that are one surface with (i, j): a depth within
// SSMB_CONNECT_TEXELS texels of slope. Neighbouring quads of one surface thus share their
// corners (no gaps between micro-patches); at a silhouette or a depth discontinuity the
// corner keeps the texel's own depth, so the quad ends at the texel's edge as the paper's
// micro-patch does. The quad drawn is the penumbra extent as ssm's (soft_shadow.vert there):
// the texel square grown by h = R' N / (2 tan(fov/2)) (1/z_near - 1/z_max) texels, R' the
// disc's reach on the light's image plane, z_near the quad's nearest corner. Empty texels
// and quads behind every receiver become a degenerate quad outside clip space.
//
// Under a sun (orthographic map) depth is affine across a plane's texels, so a corner takes
// the arithmetic mean of its connected depths, the connect test is CONNECT_TEXELS world
// texels, and the quad grows by h = EXTENT_MARGIN tan(theta) (z_max - z_near) / texel.
//
// When ssm-bitmask/micro_patch_step found the quads' penumbrae too large for its budget
// (bound.step > 1, glsl/ssm/patch_step.comp), instance k draws block k of step x step
// texels instead: the quad spans the bounding rectangle of the block's occupied texels,
// each corner at the depth of the occupied texel nearest to it, its guard depth the block's
// farthest. The block is then a small part of the penumbra it casts (the paper's lower
// occluder resolution for large penumbrae, Sec. 6.1), and the pass draws step^2 times
// fewer quads of the same extents.
#include "common/frame.glsl"
#include "ssm/ssm.glsl"
#include "ssm_bitmask/constants.glsl"

// r = the casters' linear depth: the RG32F MIN-blended shared shadow map (front surfaces).
layout(set = 0, binding = 1) uniform sampler2D occluder_map;
layout(set = 0, binding = 4, std430) readonly buffer Bound { uint zmax_bits; uint step; } bound;

layout(location = 0) flat out vec3 v_patch;          // texel (i, j) and its depth z_O
layout(location = 1) flat out vec4 v_corner_depth;   // corners (i,j), (i+1,j), (i,j+1), (i+1,j+1)
// Texels of extent per unit of (1/z_near - 1/z_R): the quad reaches receivers at depth z_R
// at most v_reach (1/z_near - 1/z_R) texels beyond its own square.
layout(location = 2) flat out float v_reach;
layout(location = 3) flat out vec2 v_size;           // the quad's side in texels (1: one texel)

// This vertex of the texels [lo, lo + size) grown by h texels, in clip coordinates.
vec4 quad_corner(vec2 lo, vec2 size, float h, int n) {
    // A hair of margin: fragments on the exact border see the quad edge-on.
    vec2 a = lo - h - 1e-3;
    vec2 b = lo + size + h + 1e-3;
    vec2 corner = vec2(float(gl_VertexIndex & 1), float(gl_VertexIndex >> 1));
    vec2 px = mix(a, b, corner);
    return vec4(px * (2.0 / float(n)) - 1.0, 0.0, 1.0);
}

// The quad of the texels [lo, lo + size) at depth znear (its nearest corner), grown by the
// disc's reach towards the farthest receiver; sets v_reach.
vec4 extent(vec2 lo, vec2 size, float znear, float zmax, int n) {
    if (light_is_sun()) {
        // A sun's disc of directions is tan(theta) wide in every direction from every
        // receiver (no stretch): the quad grows by EXTENT_MARGIN tan(theta) (z_max - z_near)
        // world units, the penumbra's half-width linear in the distance.
        v_reach = SSMB_EXTENT_RADIUS / ssm_sun_texel();
        return quad_corner(lo, size, v_reach * (zmax - znear), n);
    }
    // The disc faces the receiver, so the cone from a receiver to it is R wide across the
    // line to the light's centre and R / cos(alpha) wide in the map's plane, alpha the
    // line's angle to the light's axis: SSMB_EXTENT_RADIUS is R / cos(alpha) at the
    // frustum's corner; near the axis the extent is smaller. Bound alpha over the receivers
    // the corner-bound extent reaches, then grow the quad by the bound at that alpha.
    float t = frame.light_frustum.x;
    float reach = float(n) / (2.0 * t) * (1.0 / znear - 1.0 / zmax);
    float h_corner = SSMB_EXTENT_RADIUS * reach;
    vec2 ndc = abs((lo + 0.5 * size) * (2.0 * SSM_INV_RES) - 1.0) + (h_corner + size) * 2.0 * SSM_INV_RES;
    // SSMB_EXTENT_RADIUS = margin R sqrt(1 + 2 tan^2): the corner's 1 / cos(alpha) with the
    // margin; scaled to the 1 / cos(alpha) of this ndc.
    float stretch = min(SSMB_EXTENT_RADIUS * sqrt((1.0 + t * t * dot(ndc, ndc)) / (1.0 + 2.0 * t * t)), SSMB_EXTENT_RADIUS);
    v_reach = stretch * float(n) / (2.0 * t);
    float h = v_reach * (1.0 / znear - 1.0 / zmax);
    return quad_corner(lo, size, h, n);
}

// One instance per block of `step` x `step` texels (see the header).
void block_quad(int n, int step, float zmax) {
    int blocks = (n + step - 1) / step;
    v_patch = vec3(0.0, 0.0, FAR_DEPTH);
    v_corner_depth = vec4(FAR_DEPTH);
    v_size = vec2(float(step));
    v_reach = 0.0;
    gl_Position = vec4(2.0, 2.0, 2.0, 1.0);
    if (gl_InstanceIndex >= blocks * blocks) return;
    ivec2 b0 = ivec2(gl_InstanceIndex % blocks, gl_InstanceIndex / blocks) * step;
    ivec2 b1 = min(b0 + step, ivec2(n));
    ivec2 lo = ivec2(n), hi = ivec2(-1);
    float znear = FAR_DEPTH, zfar = 0.0;
    // Per block corner, the depth of the occupied texel nearest to it (city-block distance).
    vec4 zc = vec4(FAR_DEPTH);
    ivec4 dc = ivec4(4 * n);
    for (int j = b0.y; j < b1.y; ++j) {
        for (int i = b0.x; i < b1.x; ++i) {
            float z = texelFetch(occluder_map, ivec2(i, j), 0).r;
            if (z < EMPTY && z < zmax) {
                lo = min(lo, ivec2(i, j));
                hi = max(hi, ivec2(i, j));
                znear = min(znear, z);
                zfar = max(zfar, z);
                for (int c = 0; c < 4; ++c) {
                    ivec2 corner = ivec2((c & 1) != 0 ? b1.x - 1 : b0.x, (c >> 1) != 0 ? b1.y - 1 : b0.y);
                    ivec2 d = abs(ivec2(i, j) - corner);
                    if (d.x + d.y < dc[c]) {
                        dc[c] = d.x + d.y;
                        zc[c] = z;
                    }
                }
            }
        }
    }
    if (hi.x < 0) return;
    v_corner_depth = zc;
    // The self-occlusion guard is taken from the block's farthest texel: a surface steep to
    // the light spans many texels of depth within a block, and its nearer texels would
    // otherwise shadow its own farther ones.
    v_patch = vec3(vec2(lo), zfar);
    v_size = vec2(hi - lo + 1);
    gl_Position = extent(vec2(lo), v_size, znear, zmax, n);
}

void main() {
    int n = int(SSM_RES);
    float zmax = uintBitsToFloat(bound.zmax_bits);
    int step = int(bound.step);
    if (step > 1) {
        block_quad(n, step, zmax);
        return;
    }
    v_size = vec2(1.0);
    ivec2 texel = ivec2(gl_InstanceIndex % n, gl_InstanceIndex / n);
    float zo = texelFetch(occluder_map, texel, 0).r;
    v_patch = vec3(vec2(texel), zo);
    v_corner_depth = vec4(zo);
    v_reach = 0.0;
    if (zo >= EMPTY || !(zo < zmax)) {
        gl_Position = vec4(2.0, 2.0, 2.0, 1.0);
        return;
    }
    // 1/z (a sun: z) of the 3x3 neighbourhood where it is one surface with the texel, else 0. The
    // test is symmetric in the two depths, so two neighbours agree on whether they connect.
    // A sun's map is orthographic: its texels have one world size (the slope is absolute,
    // not relative), and depth is affine across a plane's texels, so its corners take the
    // arithmetic mean.
    bool sun = light_is_sun();
    float slope = SSMB_CONNECT_TEXELS * 2.0 * frame.light_frustum.x * SSM_INV_RES;
    float sun_slope = SSMB_CONNECT_TEXELS * ssm_sun_texel();
    float inv[9];
    for (int k = 0; k < 9; ++k) {
        ivec2 q = texel + ivec2(k % 3 - 1, k / 3 - 1);
        float z = FAR_DEPTH;
        if (all(greaterThanEqual(q, ivec2(0))) && all(lessThan(q, ivec2(n)))) {
            z = texelFetch(occluder_map, q, 0).r;
        }
        bool one = z < EMPTY && abs(z - zo) <= (sun ? sun_slope : slope * min(z, zo));
        inv[k] = one ? (sun ? z : 1.0 / z) : 0.0;
    }
    float znear = zo;
    for (int c = 0; c < 4; ++c) {
        // Corner (i + cx, j + cy) touches the texels at offsets cx-1..cx, cy-1..cy: indices
        // below in a fixed order of the map, so a corner's sum is the same in every quad.
        int cx = c & 1, cy = c >> 1;
        int k0 = cy * 3 + cx;   // offset (cx - 1, cy - 1)
        float s = 0.0, m = 0.0;
        for (int t = 0; t < 4; ++t) {
            float v = inv[k0 + (t & 1) + 3 * (t >> 1)];
            s += v;
            m += v > 0.0 ? 1.0 : 0.0;
        }
        // s > 0: the texel itself is always one of the four.
        float zc = sun ? s / m : m / s;
        v_corner_depth[c] = zc;
        znear = min(znear, zc);
    }
    gl_Position = extent(vec2(texel), vec2(1.0), znear, zmax, n);
}
