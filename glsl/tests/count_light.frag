#version 450
#extension GL_GOOGLE_include_directive : require
// A light pass with a known count (tests/work_counts.rs): the fragment at (x, y) reads
// (x mod 8) * scale + (y mod 4) stand-in texels, one loop turn each, so that every 8x4 tile's
// counts follow from the tile grid alone.
#include "common/count.glsl"

layout(set = 0, binding = 0) uniform Params { uint scale; } params;
layout(location = 0) out vec4 o_color;

void main() {
    uvec2 p = uvec2(gl_FragCoord.xy);
    uint n = (p.x % 8u) * params.scale + (p.y % 4u);
    for (uint i = 0u; i < n; ++i) {
        COUNT_LOOP(COUNT_SEARCH);
        COUNT_READ();
    }
    o_color = vec4(1.0);
}
