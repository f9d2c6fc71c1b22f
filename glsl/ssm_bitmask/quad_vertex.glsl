// The vertex stage of ssm-bitmask/soft_shadow, shared by its two vertex shaders (the plain
// draw's soft_shadow.vert and the quad list's soft_shadow_list.vert): one vertex of a
// micro-quad (triangle strip, gl_VertexIndex 0-3) and the quad's flat outputs.
#ifndef SSM_BITMASK_QUAD_VERTEX_GLSL
#define SSM_BITMASK_QUAD_VERTEX_GLSL
#include "common/frame.glsl"
#include "ssm/ssm.glsl"
#include "ssm/constants.glsl"

layout(location = 0) flat out vec3 v_patch;          // texel (i, j) and its depth z_O
layout(location = 1) flat out vec4 v_corner_depth;   // corners (i,j), (i+1,j), (i,j+1), (i+1,j+1)
layout(location = 2) flat out float v_reach;         // MicroQuad.reach
layout(location = 3) flat out vec2 v_size;           // the quad's side in texels (1: one texel)

// This vertex of the quad: the texels [first.xy, first.xy + size) grown by `grow` texels, in
// clip coordinates; a degenerate quad outside clip space when `grow` is negative.
void emit_quad(vec3 first, vec4 corner_depth, float reach, vec2 size, float grow) {
    v_patch = first;
    v_corner_depth = corner_depth;
    v_reach = reach;
    v_size = size;
    if (grow < 0.0) {
        gl_Position = vec4(2.0, 2.0, 2.0, 1.0);
        return;
    }
    // A hair of margin: fragments on the exact border see the quad edge-on.
    vec2 a = first.xy - grow - 1e-3;
    vec2 b = first.xy + size + grow + 1e-3;
    vec2 corner = vec2(float(gl_VertexIndex & 1), float(gl_VertexIndex >> 1));
    vec2 px = mix(a, b, corner);
    gl_Position = vec4(px * (2.0 / SSM_RES) - 1.0, 0.0, 1.0);
}

#endif
