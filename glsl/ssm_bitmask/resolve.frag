#version 450
#extension GL_GOOGLE_include_directive : require
#include "common/count.glsl"  // by name: build.rs also builds it counted (-DCOUNT_LIGHT)
// ssm-bitmask/resolve: per soft-shadow-map texel, each layer's share of hidden light
// samples as the offset of the straight edge that would hide as much of the disc (the
// edge-offset table, src/technique/ssm_bitmask_table.rs `edge_offsets`), both quantised to
// 12 bits in one float, 4096 * front + pure (an integer below 2^24, exact in a float). The
// final pass then reads the four texels of its footprint in one gather of this R32F map,
// where it would otherwise fetch both 128-bit masks of each texel (eight reads) and count
// their bits at every pixel, and interpolates the offsets, which move linearly across a
// receiver behind a straight edge where the share follows the disc's S-shaped profile.
#include "ssm_bitmask/constants.glsl"

// RGBA32UI: the samples hidden from layer 0 (the nearest receiver) and from layer 1 (the
// pure receiver behind it).
layout(set = 0, binding = 0) uniform usampler2D mask_front;
layout(set = 0, binding = 1) uniform usampler2D mask_pure;
// Per count of hidden samples (0 ..= 128), the edge offset in [-1, 1].
layout(set = 0, binding = 2, std430) readonly buffer Offsets { float offset[]; } offsets;

layout(location = 0) out float o_offsets;

// A layer's edge offset, quantised: 0 ..= 4095 over [-1, 1].
float quantised_offset(uvec4 mask) {
    ivec4 bits = bitCount(mask);
    COUNT_READ();
    float d = offsets.offset[bits.x + bits.y + bits.z + bits.w];
    return round((d + 1.0) * (0.5 * SSMB_OFFSET_LEVELS));
}

void main() {
    ivec2 t = ivec2(gl_FragCoord.xy);
    float front = quantised_offset(texelFetch(mask_front, t, 0));
    float pure = quantised_offset(texelFetch(mask_pure, t, 0));
    o_offsets = (SSMB_OFFSET_LEVELS + 1.0) * front + pure;
}
