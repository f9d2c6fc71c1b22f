#version 450
#extension GL_GOOGLE_include_directive : require
#include "common/count.glsl"  // by name: build.rs also builds it counted (-DCOUNT_LIGHT)
// ssm/receiver_bound: the farthest receiver depth of the frame (both receiver layers,
// empty texels ignored), the z_R that bounds every micro-patch's penumbra extent
// (Sec. 3.3, RR' = LL' (z_R - z_O) / z_O grows with z_R). One atomicMax per workgroup of
// 16x16 texels, each invocation 2x2 of them: a CPU driver switches between a workgroup's
// invocations at each barrier, so fewer invocations cost less.
#include "ssm/ssm.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 1) uniform sampler2D receiver_front;   // R32F nearest receiver
layout(set = 0, binding = 2) uniform sampler2D receiver_pure;    // R32F nearest pure receiver
layout(set = 0, binding = 3, std430) buffer Bound { uint zmax_bits; } bound;

shared uint group_max;

void main() {
    if (gl_LocalInvocationIndex == 0) group_max = 0u;
    barrier();
    float m = 0.0;
    for (int k = 0; k < 4; ++k) {
        ivec2 p = 2 * ivec2(gl_GlobalInvocationID.xy) + ivec2(k & 1, k >> 1);
        if (all(lessThan(p, textureSize(receiver_front, 0)))) {
            float z1 = texelFetch(receiver_front, p, 0).r;
            float z2 = texelFetch(receiver_pure, p, 0).r;
            if (z1 < EMPTY) m = max(m, z1);
            if (z2 < EMPTY) m = max(m, z2);
        }
    }
    // Non-negative floats order like their bit patterns, so integer max is float max.
    atomicMax(group_max, floatBitsToUint(m));
    barrier();
    if (gl_LocalInvocationIndex == 0 && group_max > 0u) atomicMax(bound.zmax_bits, group_max);
}
