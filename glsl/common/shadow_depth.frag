#version 450
#extension GL_GOOGLE_include_directive : require
// Shadow map pass: every object from the light, MIN-blended into an RG32F target.
//   r = linear depth of the nearest CASTER (what shadow comparisons test against),
//   g = linear depth of the nearest surface of any role (the receiver depth r that
//       smoothies' alpha remap and penumbra maps need behind their geometry).
// One target with MIN blending keeps both exact without a second pass: a depth test could
// keep only one of the two nearest surfaces.
#include "common/frame.glsl"

layout(location = 0) in float v_depth;
layout(location = 0) out vec2 o_depth;

#include "common/far_depth.glsl"

void main() {
    o_depth = vec2(draw.flags.x > 0.5 ? v_depth : FAR_DEPTH, v_depth);
}
