#version 450
#extension GL_GOOGLE_include_directive : require
#include "common/count.glsl"  // by name: build.rs also builds it counted (-DCOUNT_LIGHT)
// ssm/soft_shadow: one instance per occluder-map texel, 4 vertices (triangle strip).
// The micro-patch of texel (i, j) at depth z_O (Sec. 3.2) has the pixel square [i, i+1] x
// [j, j+1] of the map; its penumbra extent on the plane of the farthest receiver z_max is
// that square grown by h texels on every side (Sec. 3.3: RR' = LL' (z_R - z_O) / z_O,
// written in texels: h = L N / (4 tan(fov/2)) (1/z_O - 1/z_max)). Empty texels and patches
// behind every receiver become a degenerate quad outside clip space (no fragment).
//
// When ssm/micro_patch_step found the patches' penumbrae too large for its budget
// (bound.step > 1, glsl/ssm/patch_step.comp), instance k draws block k of step x step
// texels as one patch instead (Sec. 6.1: a lower occluder resolution for large penumbrae):
// the bounding rectangle of the block's occupied texels, at their harmonic mean depth,
// with the share of the rectangle they occupy as its density (the occluded fraction is
// scaled by it, so a sparse block hides no more of the light than its texels would), its
// extent from the block's nearest depth and its self-occlusion guard from its farthest.
#include "common/frame.glsl"
#include "ssm/ssm.glsl"
#include "ssm/constants.glsl"

// r = the casters' linear depth: the RG32F MIN-blended shared shadow map (front surfaces),
// or ssm2's R32F back occluder map (farthest surfaces, GREATER depth test).
layout(set = 0, binding = 1) uniform sampler2D occluder_map;
layout(set = 0, binding = 4, std430) readonly buffer Bound { uint zmax_bits; uint step; } bound;

layout(location = 0) flat out vec3 v_patch;   // patch texel (i, j) and its depth z_O
layout(location = 1) flat out vec4 v_block;   // side in texels (x, y), density, guard depth

// The extent of the patch [lo, lo + size) whose nearest depth is `znear`.
vec4 extent(vec2 lo, vec2 size, float znear, float zmax, int n) {
    // A sun: the square of directions' half-side penumbra at z_max, (d_r - d_b) tan grows
    // linearly (src/technique/ssm.rs, "Under a sun").
    float h = light_is_sun()
        ? penumbra_half_uv(zmax, znear) * SSM_HALF_SIDE_PER_RADIUS * float(n)
        : SSM_LIGHT_SIDE * float(n) / (4.0 * frame.light_frustum.x) * (1.0 / znear - 1.0 / zmax);
    // A hair of margin: fragments on the exact border contribute 0 anyway.
    vec2 a = lo - h - 1e-3;
    vec2 b = lo + size + h + 1e-3;
    vec2 corner = vec2(float(gl_VertexIndex & 1), float(gl_VertexIndex >> 1));
    vec2 px = mix(a, b, corner);
    return vec4(px * (2.0 / float(n)) - 1.0, 0.0, 1.0);
}

// One instance per block of `step` x `step` texels (see the header).
void block_patch(int n, int step, float zmax) {
    int blocks = (n + step - 1) / step;
    v_patch = vec3(0.0, 0.0, FAR_DEPTH);
    v_block = vec4(0.0, 0.0, 0.0, FAR_DEPTH);
    gl_Position = vec4(2.0, 2.0, 2.0, 1.0);
    if (gl_InstanceIndex >= blocks * blocks) return;
    ivec2 b0 = ivec2(gl_InstanceIndex % blocks, gl_InstanceIndex / blocks) * step;
    ivec2 b1 = min(b0 + step, ivec2(n));
    ivec2 lo = ivec2(n), hi = ivec2(-1);
    float znear = FAR_DEPTH, zfar = 0.0, inv = 0.0, count = 0.0;
    for (int j = b0.y; j < b1.y; ++j) {
        for (int i = b0.x; i < b1.x; ++i) {
            float z = texelFetch(occluder_map, ivec2(i, j), 0).r;
            if (z < EMPTY && z < zmax) {
                lo = min(lo, ivec2(i, j));
                hi = max(hi, ivec2(i, j));
                znear = min(znear, z);
                zfar = max(zfar, z);
                inv += 1.0 / z;
                count += 1.0;
            }
        }
    }
    if (hi.x < 0) return;
    vec2 size = vec2(hi - lo + 1);
    v_patch = vec3(vec2(lo), count / inv);
    v_block = vec4(size, count / (size.x * size.y), zfar);
    gl_Position = extent(vec2(lo), size, znear, zmax, n);
}

void main() {
    int n = int(SSM_RES);
    float zmax = uintBitsToFloat(bound.zmax_bits);
    int step = int(bound.step);
    if (step > 1) {
        block_patch(n, step, zmax);
        return;
    }
    ivec2 texel = ivec2(gl_InstanceIndex % n, gl_InstanceIndex / n);
    float zo = texelFetch(occluder_map, texel, 0).r;
    v_patch = vec3(vec2(texel), zo);
    v_block = vec4(1.0, 1.0, 1.0, zo);
    if (zo >= EMPTY || !(zo < zmax)) {
        gl_Position = vec4(2.0, 2.0, 2.0, 1.0);
        return;
    }
    gl_Position = extent(vec2(texel), vec2(1.0), zo, zmax, n);
}
