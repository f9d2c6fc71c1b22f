#version 450
#extension GL_GOOGLE_include_directive : require
// pcss final pass (Fernando 2005): blocker search, penumbra estimate, variable-size PCF,
// all three in this fragment shader (pcss/search.glsl). Equation numbers as in
// src/technique/pcss.rs.
#include "pcss/search.glsl"

float visibility(vec3 p, vec3 n) {
    LightSample s = light_sample(p, n);
    if (!s.inside) return 1.0;
    float search = pcss_search_radius(s);
    return pcss_visibility(s, receiver_plane(s, n, search + 1.0), search);
}

#include "common/final.glsl"
