#version 450
#extension GL_GOOGLE_include_directive : require
// Smoothie MRT pass (Chan & Durand Sec. 3.1): writes the smoothie's linear depth b (R32F)
// and its remapped alpha (R16F), both MIN-blended (clears: far, 1.0).
#include "common/frame.glsl"

layout(set = 0, binding = 1) uniform sampler2D shadow_map;   // RG32F: r nearest caster, g nearest surface (the receiver)

layout(location = 0) noperspective in float v_inv_depth;
layout(location = 1) flat in float v_kind;
layout(location = 2) flat in vec2 v_anchor;
layout(location = 3) flat in vec2 v_dir;
layout(location = 4) noperspective in float v_width;

layout(location = 0) out float o_depth;
layout(location = 1) out float o_alpha;

// Below this 1 - b/r the remap alpha / (1 - b/r) is not trusted (Volokh Sec. 3.5: b ~ r):
// the smoothie touches what it shadows, so it casts nothing (alpha' = 1). 1e-4 is above
// the relative rounding of the two R32F depths, so no speckles where b and r agree.
const float REMAP_EPS = 1e-4;

void main() {
    float t = v_width;
    vec2 uv = gl_FragCoord.xy * frame.light_params.w;
    float b = 1.0 / v_inv_depth;
    float r = texelFetch(shadow_map, ivec2(gl_FragCoord.xy), 0).g;
    float f = b / r;
    // Smoothie behind the surface seen at this texel: it shadows nothing there (paper: discard).
    if (f > 1.0) discard;
    vec2 q = uv - v_anchor;
    // Edges: distance from the silhouette edge along the outward normal; corners: radial.
    float alpha = v_kind < 0.5 ? dot(q, v_dir) : length(q);
    // At or past the smoothie's outer side (alpha >= 1) it adds no shadow: not written, so
    // that its b does not MIN-blend into a texel that another smoothie shades. A corner's
    // polygon overshoots its disc of radius t (chords at t / cos(phi / 2)); without this the
    // overshoot's depths showed, and the image depended on how a corner is split into fans.
    if (alpha >= t) discard;
    alpha = clamp(alpha / t, 0.0, 1.0);
    float denom = 1.0 - f;
    // Eq. 1: alpha' = alpha / (1 - b/r), clamped to [0, 1].
    o_alpha = denom > REMAP_EPS ? min(alpha / denom, 1.0) : 1.0;
    o_depth = b;
}
