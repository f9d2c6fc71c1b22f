#version 450
#extension GL_GOOGLE_include_directive : require
#include "common/count.glsl"  // by name: build.rs also builds it counted (-DCOUNT_LIGHT)
// penumbra-map/penumbra (Wyman & Hansen Sec. 3, the fragment program of Fig. 5): intensity of
// the foremost surface P at this texel from the cone/sheet fragment F in front of it,
// Eq. 1, I = (Z_F - Z_v) / (Z_P - Z_v), then s = 3 I^2 - 2 I^3 (Parker et al.'s spherical
// falloff). Written to R16F with MIN blending: the darkest cone or sheet wins (the paper's
// depth-channel LESS test). All depths are linear light depths, so the paper's
// ConvertToWorldSpace step is not needed.
#include "common/frame.glsl"
#include "penumbra_map/wedge.glsl"

layout(set = 0, binding = 1) uniform sampler2D shadow_map;   // RG32F: g = foremost surface of any role

layout(location = 0) in float v_depth;
layout(location = 1) in vec2 v_zv_h;
layout(location = 2) flat in float v_reach;
layout(location = 0) out float o_intensity;

void main() {
    Eq1 e;
    if (!eq1_depths(texelFetch(shadow_map, ivec2(gl_FragCoord.xy), 0).g, v_depth, v_zv_h, e)) {
        discard;
    }
    // Rasterised F can fall a rounding error in front of the tip.
    float i = clamp((e.zf - e.zv) / e.denom, 0.0, 1.0);
    float s = i * i * (3.0 - 2.0 * i);
    o_intensity = max(s, blocker_floor(v_reach, e.zv, e.zp, e.denom));
}
