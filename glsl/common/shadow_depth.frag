#version 450
// Writes linear light-space depth into the R32F shadow map. The D32 attachment's LESS test
// keeps the nearest caster, so no blending is needed on the R32F target.
layout(location = 0) in float v_depth;
layout(location = 0) out float o_depth;

void main() {
    o_depth = v_depth;
}
