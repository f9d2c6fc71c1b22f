// The smoothie pass's vertex stage (smoothies/smoothie.vert, and smoothies_centred/
// mirrored.vert for the centred form's inner smoothies on the GPU path): vertices are
// already in light screen space (built on the CPU or by the GPU silhouette pass), so the
// position is passed through without a projection.
#ifndef SMOOTHIES_VERTEX_GLSL
#define SMOOTHIES_VERTEX_GLSL
#include "common/frame.glsl"

layout(location = 0) in vec2 in_uv;
layout(location = 1) in float in_inv_depth;
layout(location = 2) in float in_kind;
layout(location = 3) in vec2 in_anchor;
layout(location = 4) in vec2 in_dir;
layout(location = 5) in float in_width;

// 1/depth is linear in a perspective map's screen space for a planar smoothie, depth itself
// is not; in a sun's orthographic map depth is, so a sun interpolates b (smoothies/light.glsl).
layout(location = 0) noperspective out float v_inv_depth;
layout(location = 1) flat out float v_kind;
layout(location = 2) flat out vec2 v_anchor;
layout(location = 3) flat out vec2 v_dir;
// Per-vertex width t (calibrated from each silhouette vertex's depth), linear along an edge.
layout(location = 4) noperspective out float v_width;

// Emits the vertex at light uv `uv` with the extrusion direction `dir`, the other
// attributes as read.
void smoothie_vertex(vec2 uv, vec2 dir) {
    gl_Position = vec4(uv * 2.0 - 1.0, 0.0, 1.0);
    v_inv_depth = light_is_sun() ? 1.0 / in_inv_depth : in_inv_depth;
    v_kind = in_kind;
    v_anchor = in_anchor;
    v_dir = dir;
    v_width = in_width;
}

#endif
