#version 450
#extension GL_GOOGLE_include_directive : require
// The final pass where a technique's visibility is exactly 1 (`FinalPass::split`): no
// light could be blocked there, so no shadow lookup. Shading as every final pass's, so that
// the colour is bit-identical to the technique's own shader at visibility 1.

float visibility(vec3 p, vec3 n) {
    return 1.0;
}

#include "common/final.glsl"
