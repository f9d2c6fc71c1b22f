#version 450
#extension GL_GOOGLE_include_directive : require
#include "common/count.glsl"  // by name: build.rs also builds it counted (-DCOUNT_LIGHT)
// ssm-bitmask/soft_shadow: one instance per occluder-map texel, drawn twice: as a point,
// then as a triangle strip of 4 vertices (quad_vertex.glsl: each quad is one of them). The
// micro-quad of texel (i, j) spans its pixel square [i, i+1] x [j, j+1]; each
// corner's depth is the harmonic mean (exact for a plane: 1/z is affine across the map) of
// the up to four texels around that corner that are one surface with (i, j): a depth within
// SSMB_CONNECT_TEXELS texels of slope. Neighbouring quads of one surface thus share their
// corners (no gaps between micro-patches); at a silhouette or a depth discontinuity the
// corner keeps the texel's own depth, so the quad ends at the texel's edge as the paper's
// micro-patch does. The quad drawn is the penumbra extent as ssm's (soft_shadow.vert
// there): the texel square grown by h = R' N / (2 tan(fov/2)) (1/z_near - 1/z_max) texels,
// R' the disc's reach on the light's image plane, z_near the quad's nearest corner, and no
// farther than the deepest receiver under that extent reaches (the receiver tiles,
// glsl/ssm/tiles.glsl; z_max itself under --plain). Empty texels and quads with no receiver
// behind them become a degenerate quad outside clip space.
//
// Under a sun (orthographic map) depth is affine across a plane's texels, so a corner takes
// the arithmetic mean of its connected depths, the connect test is CONNECT_TEXELS world
// texels, and the quad grows by h = EXTENT_MARGIN tan(theta) (z_max - z_near) / texel.
//
// The quad (its corners, reach and extent) is `micro_quad` (micro_quad.glsl), which this
// shader runs for every vertex of all N^2 instances: the plain draw. The speed layer's quad
// list (micro_quads.comp and soft_shadow_list.vert, src/technique/speed/ssm.rs) runs it
// once per quad and draws only the quads that reach a receiver, with the same result.
//
// Where ssm-bitmask/occluder_blocks found a flat block of drawn texels, its first texel's
// instance draws the block quad (its corner depths from that pass, its guard depth the
// farthest corner's) and the block's other instances draw nothing: the micro-quads' union.
//
// When ssm-bitmask/micro_patch_step found the quads' penumbrae too large for its budget
// (bound.step > 1, glsl/ssm/patch_step.comp), instance k draws block k of step x step
// texels instead: the quad spans the bounding rectangle of the block's occupied texels,
// each corner at the depth of the occupied texel nearest to it, its guard depth the block's
// farthest. The block is then a small part of the penumbra it casts (the paper's lower
// occluder resolution for large penumbrae, Sec. 6.1), and the pass draws step^2 times fewer
// quads of the same extents.
#define FRAME_NO_DRAW_PUSH
#include "ssm_bitmask/micro_quad.glsl"
#include "ssm_bitmask/quad_vertex.glsl"

void main() {
    MicroQuad q = micro_quad(gl_InstanceIndex);
    emit_quad(q.first, q.corner_depth, q.reach, q.size, q.grow);
}
