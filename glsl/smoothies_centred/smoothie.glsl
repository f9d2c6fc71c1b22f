// What smoothies-centred's two smoothie fragment shaders (outer.frag, inner.frag) share: the
// varyings of glsl/smoothies/smoothie.vert (the paper form's vertex shader, unchanged) and
// the smoothie's own distance from its hard-edge line (src/technique/smoothies_centred.rs).
#ifndef SMOOTHIES_CENTRED_SMOOTHIE_GLSL
#define SMOOTHIES_CENTRED_SMOOTHIE_GLSL
#include "common/frame.glsl"
#include "common/penumbra.glsl"

layout(set = 0, binding = 1) uniform sampler2D shadow_map;   // RG32F: r nearest caster, g nearest surface

layout(location = 0) noperspective in float v_inv_depth;
layout(location = 1) flat in float v_kind;
layout(location = 2) flat in vec2 v_anchor;
layout(location = 3) flat in vec2 v_dir;
layout(location = 4) noperspective in float v_width;

#include "common/far_depth.glsl"
// REMAP_EPS and the outer smoothies' decision: the paper form's own.
#include "smoothies/alpha.glsl"
// smoothie_b, remap_span: the light kind's depth varying and remap.
#include "smoothies/light.glsl"

// Distance (light uv) of this fragment from its smoothie's hard-edge line (edge quads) or
// silhouette vertex (corner fans), along the smoothie's extrusion direction `dir`.
float smoothie_distance(vec2 uv, out vec2 dir) {
    vec2 q = uv - v_anchor;
    if (v_kind < 0.5) {
        dir = v_dir;
        return dot(q, v_dir);
    }
    float r = length(q);
    dir = r > 0.0 ? q / r : vec2(0.0);
    return r;
}

#endif
