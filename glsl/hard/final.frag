#version 450
#extension GL_GOOGLE_include_directive : require
// hard: the depth map sampled with a comparison sampler (compare LESS_OR_EQUAL, linear
// filter): the hardware's 2x2 bilinear "percentage closer" filter, as engines do it.
#include "common/shadow.glsl"

layout(set = 0, binding = 1) uniform sampler2DShadow shadow_map;   // D32, z/w of the light

float visibility(vec3 p, vec3 n) {
    LightSample s = light_sample(p, n);
    if (!s.inside) return 1.0;
    // The relative bias of lit_test (lit where d <= stored * (1 + bias)) moved to the
    // reference: d / (1 + bias), mapped to the depth buffer's z = f / (f - n) * (1 - n / d)
    // (glam's perspective_rh, depth 0..1). In z the bias is ~ bias * n / d, far above the
    // float rounding of z (~6e-8 at z ~ 1), so it still absorbs it.
    float near = frame.light_params.x, far = frame.light_params.y;
    float d = s.depth / (1.0 + frame.light_frustum.w);
    // A sun's orthographic map stores z = (d - n) / (f - n).
    float z = light_is_sun() ? (d - near) / (far - near) : far / (far - near) * (1.0 - near / d);
    return texture(shadow_map, vec3(s.uv, z));
}

#include "common/final.glsl"
