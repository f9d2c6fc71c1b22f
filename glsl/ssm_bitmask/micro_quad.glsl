// ssm-bitmask's micro-quads: what glsl/ssm_bitmask/soft_shadow.vert draws for one instance,
// a texel (or a block of texels) of the occluder map, as one function that the plain draw's
// vertex shader runs per vertex and the quad list (micro_quads.comp, speed::ssm) once per
// quad. See soft_shadow.vert for the quad itself.
#ifndef SSM_BITMASK_MICRO_QUAD_GLSL
#define SSM_BITMASK_MICRO_QUAD_GLSL
#include "common/frame.glsl"
#include "ssm/ssm.glsl"
#include "ssm/tiles.glsl"
#include "ssm_bitmask/constants.glsl"
#include "ssm_bitmask/corners.glsl"

// r = the casters' linear depth: the RG32F MIN-blended shared shadow map (front surfaces).
layout(set = 0, binding = 1) uniform sampler2D occluder_map;
layout(set = 0, binding = 4, std430) readonly buffer Bound { uint zmax_bits; uint step; } bound;
// Per texel, the side of the quad it begins (occluder_blocks.comp): 1 its own micro-quad,
// s > 1 the s x s block it is the first texel of, 0 a texel of another's block.
layout(set = 0, binding = 9, std430) readonly buffer Blocks { uint side[]; } blocks;
// At a block's first texel, the block quad's corner depths.
layout(set = 0, binding = 10, std430) readonly buffer BlockCorners { vec4 depth[]; } block_corners;

// One micro-quad: what the fragment shader reads (flat) and the texels it covers.
struct MicroQuad {
    vec3 first;         // its first texel (i, j) and its guard depth z_O
    vec4 corner_depth;  // corners (i,j), (i+1,j), (i,j+1), (i+1,j+1)
    // Texels of extent per unit of (1/z_near - 1/z_R): the quad reaches receivers at depth
    // z_R at most `reach` (1/z_near - 1/z_R) texels beyond its own square.
    float reach;
    vec2 size;          // the quad's side in texels (1: one texel)
    // The texels drawn: [first.xy, first.xy + size) grown by this many texels; negative
    // (NOT_DRAWN): none.
    float grow;
};

const float NOT_DRAWN = -1.0;

// The texels [lo, lo + size) at depth znear (its nearest corner), grown by the disc's reach
// towards the deepest receiver it can reach; sets q.reach and q.grow.
void extent(inout MicroQuad q, vec2 lo, vec2 size, float znear, float zmax, int n) {
    float h;
    if (light_is_sun()) {
        // A sun's disc of directions is tan(theta) wide in every direction from every
        // receiver (no stretch): the quad grows by EXTENT_MARGIN tan(theta) (z_max -
        // z_near) world units, the penumbra's half-width linear in the distance.
        q.reach = SSMB_EXTENT_RADIUS / ssm_sun_texel();
        h = q.reach * (zmax - znear);
    } else {
        // The disc faces the receiver, so the cone from a receiver to it is R wide across
        // the line to the light's centre and R / cos(alpha) wide in the map's plane, alpha
        // the line's angle to the light's axis: SSMB_EXTENT_RADIUS is R / cos(alpha) at the
        // frustum's corner; near the axis the extent is smaller. Bound alpha over the
        // receivers the corner-bound extent reaches, then grow the quad by the bound at
        // that alpha.
        float t = frame.light_frustum.x;
        float reach = float(n) / (2.0 * t) * (1.0 / znear - 1.0 / zmax);
        float h_corner = SSMB_EXTENT_RADIUS * reach;
        vec2 ndc = abs((lo + 0.5 * size) * (2.0 * SSM_INV_RES) - 1.0) + (h_corner + size) * 2.0 * SSM_INV_RES;
        // SSMB_EXTENT_RADIUS = margin R sqrt(1 + 2 tan^2): the corner's 1 / cos(alpha) with
        // the margin; scaled to the 1 / cos(alpha) of this ndc.
        float stretch = min(SSMB_EXTENT_RADIUS * sqrt((1.0 + t * t * dot(ndc, ndc)) / (1.0 + 2.0 * t * t)), SSMB_EXTENT_RADIUS);
        q.reach = stretch * float(n) / (2.0 * t);
        h = q.reach * (1.0 / znear - 1.0 / zmax);
    }
    // No receiver under that extent is deeper than `deepest` (the receiver tiles), and the
    // fragment shader's reach test (one texel of slack) takes none beyond its reach at its
    // own depth: the quad stops there, or is not drawn when nothing lies behind it.
    float deepest = deepest_receiver(lo - h, lo + size + h, zmax, n);
    if (!(deepest > znear)) return;
    float h_deepest = light_is_sun() ? q.reach * (deepest - znear) : q.reach * (1.0 / znear - 1.0 / deepest);
    q.grow = min(h, h_deepest + 1.0);
}

// Block k of `step` x `step` texels (soft_shadow.vert's header).
MicroQuad block_quad(int k, int n, int step, float zmax) {
    int blocks = (n + step - 1) / step;
    MicroQuad q = MicroQuad(vec3(0.0, 0.0, FAR_DEPTH), vec4(FAR_DEPTH), 0.0, vec2(float(step)), NOT_DRAWN);
    if (k >= blocks * blocks) return q;
    ivec2 b0 = ivec2(k % blocks, k / blocks) * step;
    ivec2 b1 = min(b0 + step, ivec2(n));
    ivec2 lo = ivec2(n), hi = ivec2(-1);
    float znear = FAR_DEPTH, zfar = 0.0;
    // Per block corner, the depth of the occupied texel nearest to it (city-block
    // distance).
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
    if (hi.x < 0) return q;
    q.corner_depth = zc;
    // The self-occlusion guard is taken from the block's farthest texel: a surface steep to
    // the light spans many texels of depth within a block, and its nearer texels would
    // otherwise shadow its own farther ones.
    q.first = vec3(vec2(lo), zfar);
    q.size = vec2(hi - lo + 1);
    extent(q, vec2(lo), q.size, znear, zmax, n);
    return q;
}

// The quad of the s x s occluder block whose first texel is `first` (occluder_blocks.comp:
// every corner of its micro-quads on it, its corners those of the micro-quads at the
// block's corners; the block quad is their union). Its guard depth is its farthest
// corner's.
MicroQuad merged_quad(ivec2 first, int s, vec4 corner_depth, float zmax, int n) {
    float znear = min(min(corner_depth.x, corner_depth.y), min(corner_depth.z, corner_depth.w));
    float zfar = max(max(corner_depth.x, corner_depth.y), max(corner_depth.z, corner_depth.w));
    MicroQuad q = MicroQuad(vec3(vec2(first), zfar), corner_depth, 0.0, vec2(float(s)), NOT_DRAWN);
    extent(q, vec2(first), q.size, znear, zmax, n);
    return q;
}

// The micro-quad of instance k: texel k of the occluder map (or the block it begins, or
// none when it lies in another texel's block: occluder_blocks.comp), or block k when the
// micro-patch step is above 1 (glsl/ssm/patch_step.comp).
MicroQuad micro_quad(int k) {
    int n = int(SSM_RES);
    float zmax = uintBitsToFloat(bound.zmax_bits);
    int step = int(bound.step);
    if (step > 1) return block_quad(k, n, step, zmax);
    ivec2 texel = ivec2(k % n, k / n);
    float zo = texelFetch(occluder_map, texel, 0).r;
    MicroQuad q = MicroQuad(vec3(vec2(texel), zo), vec4(zo), 0.0, vec2(1.0), NOT_DRAWN);
    if (zo >= EMPTY || !(zo < zmax)) return q;
    uint side = blocks.side[k];
    if (side == 0u) return q;
    if (side > 1u) return merged_quad(texel, int(side), block_corners.depth[k], zmax, n);
    float z[9];
    for (int i = 0; i < 9; ++i) {
        ivec2 p = texel + ivec2(i % 3 - 1, i / 3 - 1);
        z[i] = FAR_DEPTH;
        if (all(greaterThanEqual(p, ivec2(0))) && all(lessThan(p, ivec2(n)))) {
            z[i] = texelFetch(occluder_map, p, 0).r;
        }
    }
    vec4 s, m;
    micro_quad_corner_sums(z, zo, s, m);
    // s > 0: the texel itself is always one of the four.
    q.corner_depth = light_is_sun() ? s / m : m / s;
    float znear = min(zo, min(min(q.corner_depth.x, q.corner_depth.y),
                              min(q.corner_depth.z, q.corner_depth.w)));
    extent(q, vec2(texel), vec2(1.0), znear, zmax, n);
    return q;
}

#endif
