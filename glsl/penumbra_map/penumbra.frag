#version 450
#extension GL_GOOGLE_include_directive : require
// penumbra-map/penumbra (Wyman & Hansen Sec. 3, the fragment program of Fig. 5): intensity of
// the foremost surface P at this texel from the cone/sheet fragment F in front of it,
// Eq. 1, I = (Z_F - Z_v) / (Z_P - Z_v), then s = 3 I^2 - 2 I^3 (Parker et al.'s spherical
// falloff). Written to R16F with MIN blending: the darkest cone or sheet wins (the paper's
// depth-channel LESS test). All depths are linear light depths, so the paper's
// ConvertToWorldSpace step is not needed.
#include "common/frame.glsl"

layout(set = 0, binding = 1) uniform sampler2D shadow_map;   // RG32F: g = foremost surface of any role

layout(location = 0) in float v_depth;
layout(location = 1) in vec2 v_zv_h;
layout(location = 2) flat in float v_reach;
layout(location = 0) out float o_intensity;

// FAR_DEPTH of src/gpu/passes.rs: texels that see no surface.
const float FAR_DEPTH = 1.0e30;
// Below this Z_P - Z_v (relative to Z_P) the receiver touches the silhouette vertex: no
// penumbra (contact), and no division by a rounding-sized denominator (no NaN, Inf, speckle).
const float CONTACT_EPS = 1e-4;

void main() {
    float zp = texelFetch(shadow_map, ivec2(gl_FragCoord.xy), 0).g;
    float zf = v_depth;
    if (zp >= 0.5 * FAR_DEPTH) discard;
    // Step (4): a cone or sheet behind the surface cannot shadow it.
    if (zf > zp) discard;
    // k >= 1 always; the max only guards a corrupt vertex.
    float zv = v_zv_h.x / max(v_zv_h.y, 1e-30);
    float denom = zp - zv;
    // The surface is at or in front of the silhouette vertex (e.g. the caster itself).
    if (!(denom > CONTACT_EPS * zp)) discard;
    // Rasterised F can fall a rounding error in front of the tip.
    float i = clamp((zf - zv) / denom, 0.0, 1.0);
    float s = i * i * (3.0 - 2.0 * i);
    // Blocker-size bound (not in the paper). Cases `blocker-near-light`, `near-far-1e-4`: a
    // caster smaller than the light, near it, has cones of radius (Z_far - Zv) Lr / Zv that
    // span the whole map, and Eq. 1 darkens everything under them to ~0 (I ~ (Zv / Z_P) f /
    // (1 - f) at the fraction f across the penumbra), while such a caster hides only a
    // sliver of the light. Seen from P, the caster (within v_reach of its centre, in tangent
    // units, so within v_reach Zv laterally at depth Zv) covers on the light's plane at
    // most a strip of half-width r = v_reach Zv Z_P / (Z_P - Zv) through the disc of radius
    // Lr: a fraction <= 4 r / (pi Lr) of its area. P keeps at least the rest. For casters
    // as large as the light (every standard scene) the bound is <= 0 and changes nothing;
    // it assumes the caster's depth extent is small against Z_P - Zv.
    float lr = frame.light_pos_radius.w;
    float r = v_reach * zv * (zp / denom);
    float hidden = lr > 0.0 ? min(4.0 * r / (3.14159265 * lr), 1.0) : 1.0;
    o_intensity = max(s, 1.0 - hidden);
}
