#version 450
#extension GL_GOOGLE_include_directive : require
// Smoothie MRT pass: each vertex as built (smoothies/vertex.glsl).
#include "smoothies/vertex.glsl"

void main() {
    smoothie_vertex(in_uv, in_dir);
}
