#version 450
#extension GL_GOOGLE_include_directive : require
#include "common/count.glsl"  // by name: build.rs also builds it counted (-DCOUNT_LIGHT)
// ssm-bitmask/resolve: per soft-shadow-map texel, how many light samples each layer's mask
// hides, as one float 256 * front + pure (both 0 ... 128, so the sum is an integer below
// 2^16, exact in a float). The final pass then reads the four texels of its footprint in
// one gather of this R32F map, where it would otherwise fetch both 128-bit masks of each
// texel (eight reads) and count their bits at every pixel.

// RGBA32UI: the samples hidden from layer 0 (the nearest receiver) and from layer 1 (the
// pure receiver behind it).
layout(set = 0, binding = 0) uniform usampler2D mask_front;
layout(set = 0, binding = 1) uniform usampler2D mask_pure;

layout(location = 0) out float o_hidden;

void main() {
    ivec2 t = ivec2(gl_FragCoord.xy);
    ivec4 front = bitCount(texelFetch(mask_front, t, 0));
    ivec4 pure = bitCount(texelFetch(mask_pure, t, 0));
    o_hidden = float(256 * (front.x + front.y + front.z + front.w) + (pure.x + pure.y + pure.z + pure.w));
}
