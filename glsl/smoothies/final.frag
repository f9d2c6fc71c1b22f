#version 450
#extension GL_GOOGLE_include_directive : require
// smoothies final pass (Chan & Durand Sec. 3 step 5): at each of the 4 nearest texels,
// behind the blocker -> 0, else behind the smoothie -> its alpha, else 1; bilinear weights;
// then the sinusoidal falloff from a 1-D lookup texture.
#include "common/shadow.glsl"
#include "smoothies/constants.glsl"

layout(set = 0, binding = 1) uniform sampler2D shadow_map;       // RG32F: r = nearest caster depth
layout(set = 0, binding = 2) uniform sampler2D smoothie_buffer;  // RG32F (depth b, alpha), MIN
layout(set = 0, binding = 3) uniform sampler1D falloff;          // R32F 0.5 - 0.5 cos(pi x)

float visibility(vec3 p, vec3 n) {
    LightSample s = light_sample(p, n);
    if (!s.inside) return 1.0;
    vec4 lit = lit_test(textureGather(shadow_map, s.uv, 0), s.depth);
    // t = 0 (a point light, R = 0): exactly `hard`, falloff curve included (it is identity
    // only at 0 and 1, and would reshape the one-texel filtered edge).
    if (SMOOTHIE_T <= 0.0) return bilinear(lit, s.uv);
    // One bilinear sum and one falloff lookup for every case: a CPU driver (lavapipe) runs
    // both sides of every branch under a mask, so a copy of them per case was paid by every
    // pixel. The branches only guard fetches, which a GPU then skips.
    vec4 v4 = lit;
    // Deep umbra (every texel behind the blocker, the common case inside shadows): no
    // smoothie can change a 0.
    if (any(notEqual(lit, vec4(0.0)))) {
        vec4 in_front = lit_test(textureGather(smoothie_buffer, s.uv, 0), s.depth);
        // The alpha fetch only where some texel lies behind a smoothie (penumbrae). in_front
        // is 0 or 1, so max(alpha, in_front) is mix(alpha, 1, in_front) in one instruction.
        if (any(lessThan(in_front, vec4(1.0))))
            v4 = lit * max(textureGather(smoothie_buffer, s.uv, 1), in_front);
    }
    // The LUT gives exactly 0 and 1 at its end texels, so umbra and lit areas pass unchanged.
    // Texel centres: x in [0,1] maps to [0.5, N - 0.5] / N.
    float v = bilinear(v4, s.uv);
    float size = float(textureSize(falloff, 0));
    return texture(falloff, (v * (size - 1.0) + 0.5) / size).r;
}

#include "common/final.glsl"
