#version 450
#extension GL_GOOGLE_include_directive : require
#include "common/count.glsl"  // by name: build.rs also builds it counted (-DCOUNT_LIGHT)
// Smoothie pass (Chan & Durand Sec. 3.1): writes the smoothie's linear depth b and its
// remapped alpha into the RG32F smoothie buffer, MIN-blended per channel (clear: far, 1.0).
#include "common/frame.glsl"
#include "smoothies/alpha.glsl"
#include "smoothies/light.glsl"

layout(set = 0, binding = 1) uniform sampler2D shadow_map;   // RG32F: r nearest caster, g nearest surface (the receiver)

layout(location = 0) noperspective in float v_inv_depth;   // 1/b; a sun's: b (smoothies/light.glsl)
layout(location = 1) flat in float v_kind;
layout(location = 2) flat in vec2 v_anchor;
layout(location = 3) flat in vec2 v_dir;
layout(location = 4) noperspective in float v_width;

layout(location = 0) out vec2 o_smoothie;   // (b, alpha)

void main() {
    float t = v_width;
    vec2 uv = gl_FragCoord.xy * frame.light_params.w;
    float b = smoothie_b(v_inv_depth);
    float r = texelFetch(shadow_map, ivec2(gl_FragCoord.xy), 0).g;
    vec2 q = uv - v_anchor;
    // Edges: distance from the silhouette edge along the outward normal; corners: radial.
    float dist = v_kind < 0.5 ? dot(q, v_dir) : length(q);
    float alpha;
    if (!smoothie_alpha(b, r, dist, t, remap_span(), alpha)) discard;
    o_smoothie = vec2(b, alpha);
}
