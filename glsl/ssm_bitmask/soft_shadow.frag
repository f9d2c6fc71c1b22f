#version 450
#extension GL_GOOGLE_include_directive : require
#include "common/count.glsl"  // by name: build.rs also builds it counted (-DCOUNT_LIGHT)
// ssm-bitmask/soft_shadow: for the receiver point of this soft-shadow-map texel (one per
// receiver layer), the set of light samples the micro-quad hides, as a 128-bit mask; the
// pipeline's logic op OR makes the texel's mask the union over every micro-quad (Schwarz &
// Stamminger 2007), where ssm ADDs occluded areas (Atty et al. Sec. 4.1).
//
// The disc light faces the receiver p (docs/DESIGN.md): centre at the light frame's origin,
// radius R, normal w = -p/|p|, axes u, v. A corner q of the quad is projected from p onto
// the disc's plane: X = p + s (q - p), s = |p| / ((q - p).w), so that in disc units
// (X.u, X.v) / R = ((q - p).u, (q - p).v) |p| / ((q - p).w R). Projection from a point maps
// lines to lines: the quad's two triangles (corners 0-1-3 and 0-3-2) stay triangles, and
// the samples inside one are the AND of three half-planes, each read from the edge table.
// The vertex stage's push constants only (ssm_bitmask/quad_vertex.glsl).
#define FRAME_NO_DRAW_PUSH
#include "common/frame.glsl"
#include "ssm/ssm.glsl"
#include "ssm_bitmask/bitmask.glsl"
#include "ssm_bitmask/guard.glsl"

layout(set = 0, binding = 2) uniform sampler2D receiver_front;   // R32F nearest receiver
layout(set = 0, binding = 3) uniform sampler2D receiver_pure;    // R32F nearest pure receiver
layout(set = 0, binding = 4, std430) readonly buffer Bound { uint zmax_bits; } bound;
// The edge table: row a (line direction of pseudo-angle (a + 1/2) 2 / SSMB_LUT_ROWS, in
// `line_mask`), column d (signed distance of the line from the disc centre, (d + 1/2) 2 /
// columns - 1): the mask of the samples left of the directed line
// (src/technique/ssm_bitmask_table.rs, `edge_table`).
layout(set = 0, binding = 6, std430) readonly buffer Table { uvec4 masks[]; } table;

layout(location = 0) flat in vec3 v_patch;    // the quad's first texel, its guard depth
layout(location = 1) flat in vec4 v_corner_depth;
layout(location = 2) flat in float v_reach;   // see soft_shadow.vert
layout(location = 3) flat in vec2 v_size;     // the quad's side in texels (1: one texel)

layout(location = 0) out uvec4 o_front;   // samples hidden from the nearest receiver
layout(location = 1) out uvec4 o_pure;    // samples hidden from the pure receiver behind it

// The samples left of the line through a and b, taken in its canonical direction (+y, or +x
// when horizontal); `flipped` says that direction is b -> a. Both triangles that share an
// edge compute the same line from the same two points, so between them they take every
// sample exactly once: no sample falls in a gap between two micro-quads.
uvec4 line_mask(vec2 a, vec2 b, out bool flipped) {
    flipped = b.y < a.y || (b.y == a.y && b.x < a.x);
    vec2 o = flipped ? b : a;
    vec2 e = flipped ? a - b : b - a;
    float len = length(e);
    if (len == 0.0) return NO_SAMPLES;   // its triangles have no area either
    vec2 nrm = vec2(-e.y, e.x) / len;
    float d = dot(nrm, o);
    if (d <= -1.0) return ALL_SAMPLES;
    if (d >= 1.0) return NO_SAMPLES;
    const int angles = int(SSMB_LUT_ROWS);
    const int columns = int(SSMB_LUT_COLUMNS);
    // The direction's pseudo-angle in [0, 2] (e.y >= 0), monotonic in its angle: the rows'
    // index, without an arctangent per edge.
    float pseudo = 1.0 - e.x / (abs(e.x) + e.y);
    int row = min(int(pseudo * (0.5 * float(angles))), angles - 1);
    int col = min(int((d + 1.0) * 0.5 * float(columns)), columns - 1);
    COUNT_READ();
    return table.masks[row * columns + col];
}

// The half of the line's mask that holds the triangle: its left when the triangle turns
// counter-clockwise and the line was not flipped (or both were).
uvec4 inside(uvec4 m, bool flipped, bool ccw) {
    return ccw != flipped ? m : ~m;
}

float cross2(vec2 a, vec2 b) {
    return a.x * b.y - a.y * b.x;
}

// The samples inside the quad whose corners, projected from the receiver, are c (in units
// of the light's radius: the disc is the unit disc).
uvec4 quad_mask(vec2 c[4]) {
    vec2 lo = min(min(c[0], c[1]), min(c[2], c[3]));
    vec2 hi = max(max(c[0], c[1]), max(c[2], c[3]));
    // Entirely beside the disc.
    if (any(greaterThanEqual(lo, vec2(1.0))) || any(lessThanEqual(hi, vec2(-1.0)))) return NO_SAMPLES;
    bool f01, f13, f03, f32, f20;
    uvec4 m01 = line_mask(c[0], c[1], f01);
    uvec4 m13 = line_mask(c[1], c[3], f13);
    uvec4 m03 = line_mask(c[0], c[3], f03);   // the diagonal, shared by both triangles
    uvec4 m32 = line_mask(c[3], c[2], f32);
    uvec4 m20 = line_mask(c[2], c[0], f20);
    uvec4 mask = NO_SAMPLES;
    // Triangle 0-1-3: edges 0->1, 1->3, 3->0 (the diagonal backwards: flipped inverts).
    float a1 = cross2(c[1] - c[0], c[3] - c[0]);
    if (a1 != 0.0) {
        bool ccw = a1 > 0.0;
        mask |= inside(m01, f01, ccw) & inside(m13, f13, ccw) & inside(m03, !f03, ccw);
    }
    // Triangle 0-3-2: edges 0->3, 3->2, 2->0.
    float a2 = cross2(c[3] - c[0], c[2] - c[0]);
    if (a2 != 0.0) {
        bool ccw = a2 > 0.0;
        mask |= inside(m03, f03, ccw) & inside(m32, f32, ccw) & inside(m20, f20, ccw);
    }
    return mask;
}

// Under a sun the light is the disc of directions within theta of its axis (-z in the light
// frame, towards the light): a corner q seen from the receiver p lies in the direction of
// tangent (q - p).xy / (z_R - z_q) off the axis, and the disc is tan(theta) (SSMB_RADIUS)
// in tangent units. The projection from p onto the plane one unit towards the light keeps
// lines lines, as the spotlight's. `zcap`: corners deeper than the guard are pulled in
// front of it, as the spotlight's.
uvec4 hidden_directions(vec3 p, float zcap) {
    vec2 c[4];
    for (int k = 0; k < 4; ++k) {
        vec2 px = v_patch.xy + vec2(float(k & 1), float(k >> 1)) * v_size;
        vec3 dq = light_frame(px, min(v_corner_depth[k], zcap)) - p;
        c[k] = dq.xy / (max(-dq.z, 1e-6 * p.z) * SSMB_RADIUS);
    }
    return quad_mask(c);
}

// Whether the quad can hide a sample from the receiver at depth zr at texel r: beyond the
// guard, and within the reach at the receiver's own depth (the quad was drawn for the
// deepest receiver under it; a nearer one is reached by less). The receiver's texel centre
// lies half a texel inside its square: one texel of slack.
bool reaches(float zr, vec2 r) {
    float zo = v_patch.z;
    if (zr - zo <= guard_depth(zr)) return false;
    vec4 zc = v_corner_depth;
    float znear = min(zo, min(min(zc.x, zc.y), min(zc.z, zc.w)));
    float h = reach_texels(v_reach, znear, zr) + 1.0;
    vec2 outside = max(v_patch.xy - r, r - (v_patch.xy + v_size));
    return all(lessThanEqual(outside, vec2(h)));
}

// The samples the quad hides from the receiver at depth zr at texel r, which it reaches.
uvec4 hidden(float zr, vec2 r) {
    // R > 0 (a sun: tan(theta) > 0) here: at R = 0 the technique is built as `hard`
    // (src/technique/ssm_bitmask.rs, `create_either`, and `record_light` refuses R = 0), so
    // the projection below never divides by a zero radius.
    // Corners deeper than the guard are pulled in front of it: the quad reaches down to the
    // receiver (a caster standing on it), and the projection stays finite.
    float zcap = zr - guard_depth(zr);
    vec3 p = light_frame(r, zr);
    if (light_is_sun()) return hidden_directions(p, zcap);
    float dist = length(p);
    vec3 w = -p / dist;
    vec3 u = normalize(cross(vec3(0.0, 1.0, 0.0), w));
    vec3 v = cross(w, u);
    vec2 c[4];
    for (int k = 0; k < 4; ++k) {
        vec2 px = v_patch.xy + vec2(float(k & 1), float(k >> 1)) * v_size;
        vec3 dq = light_frame(px, min(v_corner_depth[k], zcap)) - p;
        float den = max(dot(dq, w), 1e-6 * dist);
        c[k] = vec2(dot(dq, u), dot(dq, v)) * (dist / (den * SSMB_RADIUS));
    }
    return quad_mask(c);
}

void main() {
    ivec2 texel = ivec2(gl_FragCoord.xy);
    float z1 = texelFetch(receiver_front, texel, 0).r;
    if (z1 >= EMPTY) discard;   // no receiver here: nothing to shadow
    float z2 = texelFetch(receiver_pure, texel, 0).r;
    float zmax = uintBitsToFloat(bound.zmax_bits);
    // No pure receiver behind: stand in the farthest receiver plane, which the extents
    // cover.
    z2 = min(z2, zmax);
    // The layers the quad reaches (the pure receiver only where it is another surface).
    // Two named masks, not an array indexed by the layer: a per-fragment index into a local
    // array is a scatter through memory on a SIMD CPU driver.
    vec2 r = gl_FragCoord.xy;
    bool front = reaches(z1, r);
    bool pure = z2 != z1 && reaches(z2, r);
    uvec4 front_mask = NO_SAMPLES;
    uvec4 pure_mask = NO_SAMPLES;
    if (front) front_mask = hidden(z1, r);
    if (pure) pure_mask = hidden(z2, r);
    o_front = front_mask;
    o_pure = z2 == z1 ? front_mask : pure_mask;
    if (all(equal(o_front | o_pure, NO_SAMPLES))) discard;
}
