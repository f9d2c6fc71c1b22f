#version 450
#extension GL_GOOGLE_include_directive : require
// pcf final pass: percentage-closer filtering (Reeves et al. 1987) of the shadow map with
// the kernel of `Settings::pcf_kernel`.
#include "pcf/filter.glsl"
#include "pcf/constants.glsl"

// R32F, casters only, MIN-blended, no depth attachment (gpu::passes::ShadowMap::casters):
// the nearest caster's linear depth, the one compared here.
layout(set = 0, binding = 1) uniform sampler2D shadow_map;

float visibility(vec3 p, vec3 n) {
    LightSample s = light_sample(p, n);
    if (!s.inside) return 1.0;
    int count = int(PCF_SAMPLES);
    if (PCF_KERNEL_KIND < 0.5) {
        ReceiverPlane rp = receiver_plane(s, n, 0.5 * float(count + 1));
        return pcf_box(shadow_map, s.uv, rp, count);
    }
    ReceiverPlane rp = receiver_plane(s, n, PCF_POISSON_RADIUS + 1.0);
    return pcf_poisson(shadow_map, s.uv, rp, count, PCF_POISSON_RADIUS);
}

#include "common/final.glsl"
