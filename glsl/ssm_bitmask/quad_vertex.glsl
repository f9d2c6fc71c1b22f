// The vertex stage of ssm-bitmask/soft_shadow, shared by its two vertex shaders (the plain
// draw's soft_shadow.vert and the quad list's soft_shadow_list.vert): one vertex of a
// micro-quad and the quad's flat outputs. Each draw of quads is two draws with the same
// instances: a square quad no wider than the device's largest point is one point sprite
// (the square centred on it, one primitive), the others a triangle strip (gl_VertexIndex
// 0-3); each draw places the other's quads outside clip space. A rasteriser that shades
// blocks of pixels (2x2 on a GPU, 4x4 on llvmpipe) shades the blocks along a strip's
// diagonal once per triangle, and sets up two triangles where a point is one square.
#ifndef SSM_BITMASK_QUAD_VERTEX_GLSL
#define SSM_BITMASK_QUAD_VERTEX_GLSL
#include "common/frame.glsl"
#include "ssm/ssm.glsl"
#include "ssm/constants.glsl"

layout(location = 0) flat out vec3 v_patch;          // texel (i, j) and its depth z_O
layout(location = 1) flat out vec4 v_corner_depth;   // corners (i,j), (i+1,j), (i,j+1), (i+1,j+1)
layout(location = 2) flat out float v_reach;         // MicroQuad.reach
layout(location = 3) flat out vec2 v_size;           // the quad's side in texels (1: one texel)

// Which of the two draws this is (FRAME_NO_DRAW_PUSH: the includer's frame.glsl declares no
// push constants of its own).
layout(push_constant, std430) uniform QuadDraw {
    float max_point;   // the widest point the device draws, in texels; 0: none
    uint points;       // 1: this draw's primitives are points, 0: triangle strips
} quad_draw;

// This vertex of the quad: the texels [first.xy, first.xy + size) grown by `grow` texels, in
// clip coordinates, as a point or a strip (above); outside clip space when `grow` is
// negative or the quad is the other draw's.
void emit_quad(vec3 first, vec4 corner_depth, float reach, vec2 size, float grow) {
    v_patch = first;
    v_corner_depth = corner_depth;
    v_reach = reach;
    v_size = size;
    gl_PointSize = 1.0;
    // A hair of margin: fragments on the exact border see the quad edge-on.
    vec2 a = first.xy - grow - 1e-3;
    vec2 b = first.xy + size + grow + 1e-3;
    float side = b.x - a.x;
    bool point = size.x == size.y && side <= quad_draw.max_point;
    if (grow < 0.0 || point != (quad_draw.points != 0u)) {
        gl_Position = vec4(2.0, 2.0, 2.0, 1.0);
        return;
    }
    if (point) {
        // Its centre lies on the quad's texels, inside the map: a point is clipped by its
        // centre alone.
        gl_PointSize = side;
        gl_Position = vec4((a + b) * (1.0 / SSM_RES) - 1.0, 0.0, 1.0);
        return;
    }
    vec2 corner = vec2(float(gl_VertexIndex & 1), float(gl_VertexIndex >> 1));
    vec2 px = mix(a, b, corner);
    gl_Position = vec4(px * (2.0 / SSM_RES) - 1.0, 0.0, 1.0);
}

#endif
