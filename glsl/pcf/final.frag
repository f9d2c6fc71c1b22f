#version 450
#extension GL_GOOGLE_include_directive : require
// pcf final pass: percentage-closer filtering (Reeves et al. 1987) of the shadow map with
// the kernel of `Settings::pcf_kernel`.
// frame.technique: x = kernel kind (0 box, 1 Poisson), y = N, z = Poisson radius (texels).
#include "pcf/filter.glsl"

// RG32F, MIN-blended, no depth attachment (gpu::passes::ShadowMap): r = nearest caster's
// linear depth, the one compared here.
layout(set = 0, binding = 1) uniform sampler2D shadow_map;

float visibility(vec3 p, vec3 n) {
    LightSample s = light_sample(p, n);
    if (!s.inside) return 1.0;
    int count = int(frame.technique.y);
    if (frame.technique.x < 0.5) {
        ReceiverPlane rp = receiver_plane(s, n, 0.5 * float(count + 1));
        return pcf_box(shadow_map, s.uv, rp, count);
    }
    ReceiverPlane rp = receiver_plane(s, n, frame.technique.z + 1.0);
    return pcf_poisson(shadow_map, s.uv, rp, count, frame.technique.z);
}

#include "common/final.glsl"
