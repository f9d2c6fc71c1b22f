#version 450
#extension GL_GOOGLE_include_directive : require
// smoothies final pass (Chan & Durand Sec. 3 step 5): at each of the 4 nearest texels,
// behind the blocker -> 0, else behind the smoothie -> its alpha, else 1; bilinear weights;
// then the sinusoidal falloff from a 1-D lookup texture.
#include "common/shadow.glsl"
#include "smoothies/constants.glsl"

layout(set = 0, binding = 1) uniform sampler2D shadow_map;       // RG32F: r = nearest caster depth
layout(set = 0, binding = 2) uniform sampler2D smoothie_depth;   // R32F smoothie depth (MIN)
layout(set = 0, binding = 3) uniform sampler2D smoothie_alpha;   // R16F remapped alpha (MIN)
layout(set = 0, binding = 4) uniform sampler1D falloff;          // R32F 0.5 - 0.5 cos(pi x)

float visibility(vec3 p, vec3 n) {
    LightSample s = light_sample(p, n);
    if (!s.inside) return 1.0;
    vec4 lit = lit_test(textureGather(shadow_map, s.uv, 0), s.depth);
    // Deep umbra: no smoothie can change a 0 (the common case inside shadows).
    if (all(equal(lit, vec4(0.0)))) return 0.0;
    // t = 0 (a point light, R = 0): exactly `hard`, falloff curve included (it is identity
    // only at 0 and 1, and would reshape the one-texel filtered edge).
    if (SMOOTHIE_T <= 0.0) return bilinear(lit, s.uv);
    vec4 in_front = lit_test(textureGather(smoothie_depth, s.uv, 0), s.depth);
    // The alpha fetch is only needed where some texel lies behind a smoothie (penumbrae):
    // lit areas, the bulk of the image, skip it and the falloff lookup.
    if (all(equal(in_front, vec4(1.0)))) {
        float v = bilinear(lit, s.uv);
        if (v == 1.0) return 1.0;
        float size = float(textureSize(falloff, 0));
        return texture(falloff, (v * (size - 1.0) + 0.5) / size).r;
    }
    vec4 alpha = textureGather(smoothie_alpha, s.uv, 0);
    vec4 v = lit * mix(alpha, vec4(1.0), in_front);
    float linear_v = bilinear(v, s.uv);
    // Texel centres of the LUT: x in [0,1] maps to [0.5, N - 0.5] / N.
    float size = float(textureSize(falloff, 0));
    return texture(falloff, (linear_v * (size - 1.0) + 0.5) / size).r;
}

#include "common/final.glsl"
