#version 450
#extension GL_GOOGLE_include_directive : require
#include "common/count.glsl"  // by name: build.rs also builds it counted (-DCOUNT_LIGHT)
// ssm/soft_shadow: for the receiver point of this soft-shadow-map texel (one per receiver
// layer), back-project the micro-patch onto the square light (Sec. 3.4, Fig. 9) and write
// the occluded fraction of the light's area; ADD blending sums the micro-patches (Sec. 4.1).
//
// In light view space (light centre at the origin, square light of side L in the plane
// z = 0, axis-aligned with the map), a patch edge at ndc a and depth z_O seen from the
// receiver at ndc r and depth z_R lands on the light plane at
//     X = tan(fov/2) (a - r) z_O z_R / (z_R - z_O),
// so in light widths per texel of (a - r): S = 2 tan(fov/2) / (N L) * z_O z_R / (z_R - z_O).
// The occluded fraction is the product of the two interval overlaps with [-1/2, 1/2]
// (Sec. 4.2: "MOV_SAT, SUB, MUL").
#include "common/frame.glsl"
#include "ssm/ssm.glsl"
#include "ssm/constants.glsl"

layout(set = 0, binding = 2) uniform sampler2D receiver_front;   // R32F nearest receiver
layout(set = 0, binding = 3) uniform sampler2D receiver_pure;    // R32F nearest pure receiver
layout(set = 0, binding = 4, std430) readonly buffer Bound { uint zmax_bits; } bound;

layout(location = 0) flat in vec3 v_patch;   // the patch's first texel and its depth
layout(location = 1) flat in vec4 v_block;    // side in texels (x, y), density, guard depth

layout(location = 0) out float o_front;   // occlusion of the nearest receiver
layout(location = 1) out float o_pure;    // occlusion of the pure receiver behind it

float occlusion(float zr, vec2 r) {
    float zo = v_patch.z;
    float n = SSM_RES;
    float t = frame.light_frustum.x;
    // Self-occlusion guard (the paper separates occluders from receivers): a patch less than
    // `SSM_SELF_GUARD_TEXELS` texels of depth slope in front of the receiver is the receiver's own
    // surface (same texel, or a staircase step of a sloped surface), not an occluder.
    float guard = light_is_sun()
        ? zr * frame.light_frustum.w + SSM_SELF_GUARD_TEXELS * ssm_sun_texel()
        : zr * (frame.light_frustum.w + SSM_SELF_GUARD_TEXELS * 2.0 * t / n);
    if (zr - v_block.w <= guard) return 0.0;
    vec2 size = v_block.xy;
    vec2 d0 = v_patch.xy - r;   // patch's low edge minus receiver, in texels
    float L = SSM_LIGHT_SIDE;
    if (L <= 0.0) {
        // Point light: the patch hides the whole light iff it covers the receiver's ray.
        return all(lessThanEqual(d0, vec2(0.0))) && all(greaterThan(d0 + size, vec2(0.0))) ? v_block.z : 0.0;
    }
    // A sun: one texel of (a - r) is E / N world units, a direction tangent of
    // E / (N (z_R - z_O)), in sides L_s = sqrt(pi) tan(theta) of the square of directions:
    // the same 1 / (2 N x the half-side's penumbra in uv) as the spotlight's S.
    float s = light_is_sun()
        ? 0.5 / (SSM_HALF_SIDE_PER_RADIUS * n * penumbra_half_uv(zr, zo))
        : 2.0 * t / (n * L) * zo * zr / (zr - zo);
    vec2 w = clamp((d0 + size) * s, -0.5, 0.5) - clamp(d0 * s, -0.5, 0.5);
    return v_block.z * (w.x * w.y);
}

void main() {
    ivec2 texel = ivec2(gl_FragCoord.xy);
    float z1 = texelFetch(receiver_front, texel, 0).r;
    if (z1 >= EMPTY) discard;   // no receiver here: nothing to shadow
    float z2 = texelFetch(receiver_pure, texel, 0).r;
    float zmax = uintBitsToFloat(bound.zmax_bits);
    // No pure receiver behind: stand in the farthest receiver plane, which the extents cover.
    z2 = min(z2, zmax);
    o_front = occlusion(z1, gl_FragCoord.xy);
    o_pure = occlusion(z2, gl_FragCoord.xy);
    if (o_front == 0.0 && o_pure == 0.0) discard;
}
