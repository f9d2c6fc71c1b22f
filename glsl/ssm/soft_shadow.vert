#version 450
#extension GL_GOOGLE_include_directive : require
#include "common/count.glsl"  // by name: build.rs also builds it counted (-DCOUNT_LIGHT)
// ssm/soft_shadow: one instance per occluder-map texel, 4 vertices (triangle strip).
// The micro-patch of texel (i, j) at depth z_O (Sec. 3.2) has the pixel square [i, i+1] x
// [j, j+1] of the map; its penumbra extent on the plane of the farthest receiver z_max is
// that square grown by h texels on every side (Sec. 3.3: RR' = LL' (z_R - z_O) / z_O,
// written in texels: h = L N / (4 tan(fov/2)) (1/z_O - 1/z_max)). Empty texels and patches
// behind every receiver become a degenerate quad outside clip space (no fragment).
#include "common/frame.glsl"
#include "ssm/ssm.glsl"
#include "ssm/constants.glsl"

// r = the casters' linear depth: the RG32F MIN-blended shared shadow map (front surfaces),
// or ssm2's R32F back occluder map (farthest surfaces, GREATER depth test).
layout(set = 0, binding = 1) uniform sampler2D occluder_map;
layout(set = 0, binding = 4, std430) readonly buffer Bound { uint zmax_bits; } bound;

layout(location = 0) flat out vec3 v_patch;   // patch texel (i, j) and its depth z_O

void main() {
    int n = int(SSM_RES);
    ivec2 texel = ivec2(gl_InstanceIndex % n, gl_InstanceIndex / n);
    float zo = texelFetch(occluder_map, texel, 0).r;
    float zmax = uintBitsToFloat(bound.zmax_bits);
    v_patch = vec3(vec2(texel), zo);
    if (zo >= EMPTY || !(zo < zmax)) {
        gl_Position = vec4(2.0, 2.0, 2.0, 1.0);
        return;
    }
    float h = SSM_LIGHT_SIDE * float(n) / (4.0 * frame.light_frustum.x) * (1.0 / zo - 1.0 / zmax);
    // A hair of margin: fragments on the exact border contribute 0 anyway.
    vec2 lo = vec2(texel) - h - 1e-3;
    vec2 hi = vec2(texel) + 1.0 + h + 1e-3;
    vec2 corner = vec2(float(gl_VertexIndex & 1), float(gl_VertexIndex >> 1));
    vec2 px = mix(lo, hi, corner);
    gl_Position = vec4(px * (2.0 / float(n)) - 1.0, 0.0, 1.0);
}
