// Per-frame constants shared by every pass (set 0, binding 0) and the per-draw push
// constants (compute shaders with their own push constants define FRAME_NO_DRAW_PUSH).
// Mirrors `FrameUniforms` (src/render/mod.rs) and `DrawPush` (src/gpu/gpu_scene.rs), std140.
#ifndef FRAME_GLSL
#define FRAME_GLSL
#include "common/count.glsl"

layout(set = 0, binding = 0, std140) uniform Frame {
    mat4 cam_view_proj;
    mat4 light_view;
    mat4 light_view_proj;
    vec4 light_pos_radius;   // xyz: light centre (world), w: light radius R; a sun: its unit direction towards the light, 0
    vec4 cam_pos;            // xyz: camera position
    vec4 light_params;       // near, far, shadow-map resolution, 1 / resolution
    vec4 light_frustum;      // tan(fov/2), world texel size per unit depth, normal offset (texels), relative depth bias
    vec4 technique;          // technique-specific, named by each glsl/<technique>/constants.glsl
    vec4 technique2;         // technique-specific, named likewise
    vec4 sun;                // x: 1 for a sun (orthographic light), y: tan of its angular radius, z: world texel size
    mat4 spot_from_light_clip; // light clip -> the spot cone's own clip (the map may be fitted inside the cone)
} frame;

// A sun's shadow map is orthographic: clip w is 1 and clip z = (d - near) / (far - near)
// carries the linear depth d. A spotlight's perspective clip w is d itself.
bool light_is_sun() {
    return frame.sun.x > 0.5;
}

// The light's spread: a spotlight's radius R, a sun's tan(theta); 0 for a point light.
float light_spread() {
    return light_is_sun() ? frame.sun.y : frame.light_pos_radius.w;
}

// The linear light depth (distance along the light's axis) of light clip coordinates c.
float clip_linear_depth(vec4 c) {
    return light_is_sun() ? frame.light_params.x + c.z * (frame.light_params.y - frame.light_params.x) : c.w;
}

// Unit direction from the world point p towards the light (a sun's is the same everywhere).
vec3 light_direction(vec3 p) {
    return light_is_sun() ? frame.light_pos_radius.xyz : normalize(frame.light_pos_radius.xyz - p);
}

// Half the width of the penumbra, in shadow-map uv at the receiver, that a blocker at linear
// light depth d_b throws onto a receiver at d_r (d_b <= d_r), for either light kind:
// - spotlight (a disc of radius R at the frustum's apex, perspective map): the light seen
//   through the blocker's edge spans R (d_r - d_b) / d_b world units at the receiver, where
//   the map spans 2 d_r tan(fov/2);
// - sun (every direction within theta of its axis, orthographic map): parallel projection,
//   so the edge's penumbra grows as (d_r - d_b) tan(theta) and the map spans the same
//   res x texel world units at every depth.
// With d_b = near it is the widest penumbra any blocker in front of d_r can throw: the
// reach of a blocker search.
float penumbra_half_uv(float d_r, float d_b) {
    float d = max(d_r - d_b, 0.0);
    if (light_is_sun()) return d * frame.sun.y / (frame.sun.z * frame.light_params.z);
    return frame.light_pos_radius.w * d / (2.0 * frame.light_frustum.x * d_b * d_r);
}

#ifndef FRAME_NO_DRAW_PUSH
layout(push_constant, std430) uniform Draw {
    mat4 model;
    vec4 albedo_receives;    // rgb: albedo, w: 1 if the object receives shadows
    vec4 flags;              // x: 1 if the object casts shadows, yzw: albedo^(1/2.2)
} draw;
#endif

#endif
