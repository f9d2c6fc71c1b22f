// The final pass from the camera, shared by every technique: the technique's fragment
// shader defines `float visibility(vec3 p, vec3 n)` and includes this file. Writes the
// shaded colour; built with AOV defined (build.rs compiles both), also the AOVs
// (visibility, world position, world normal and spot factor) for the untimed AOV pass. The timed pass
// writes colour only, as an engine's frame would.
#include "common/frame.glsl"
#include "common/shadow.glsl"   // surface_light_clip, _normal, _facet_normal, set below

layout(location = 0) in vec3 v_world;
layout(location = 1) in vec3 v_normal;
layout(location = 2) in vec4 v_light_clip;
layout(location = 3) in vec4 v_light_normal;
layout(location = 0) out vec4 o_color;
#ifdef COUNT
// Texels read, then search, filter and march iterations (common/count.glsl), added up
// per pixel by the blend.
layout(location = 1) out vec4 o_count;
#endif
#ifdef AOV
layout(location = 1) out float o_visibility;
layout(location = 2) out vec4 o_position;
layout(location = 3) out vec4 o_normal;
#endif

float visibility(vec3 p, vec3 n);

void main() {
    vec3 n = normalize(v_normal);
    // Two-sided surfaces (planes, fences): use the side the camera sees.
    float side = dot(n, frame.cam_pos.xyz - v_world) < 0.0 ? -1.0 : 1.0;
    n *= side;
    surface_light_clip = v_light_clip;
    surface_light_normal = v_light_normal * (side * inversesqrt(dot(v_normal, v_normal)));
    // In uniform control flow: the derivatives are undefined inside visibility()'s branches.
    vec3 ng = cross(dFdx(v_world), dFdy(v_world));
    ng = dot(ng, ng) > 0.0 ? normalize(ng) : n;
    surface_facet_normal = dot(ng, n) < 0.0 ? -ng : ng;
    float vis = draw.albedo_receives.w > 0.5 ? visibility(v_world, n) : 1.0;
    vec3 l = light_direction(v_world);
    float ndl = max(dot(n, l), 0.0);
    // Spot cone: dark outside the light's cone, as a spotlight's would be, from the cone's
    // own axis and angle (the map may be fitted inside it). A sun lights everything; its map
    // covers what the camera sees (frustum::fit_sun).
    vec4 c = frame.spot_from_light_clip * v_light_clip;
    vec2 ndc = c.xy / max(c.w, 1e-30);
    float spot = light_is_sun() ? 1.0 : c.w > 0.0 ? 1.0 - smoothstep(0.85, 1.0, max(abs(ndc.x), abs(ndc.y))) : 0.0;
    float k = 0.12 + 0.88 * ndl * vis * spot;
    // pow(min(albedo * k, 1), 1/2.2) as min(albedo^(1/2.2) * k^(1/2.2), 1): equal for
    // albedo, k >= 0, with albedo^(1/2.2) per draw from the CPU (draw.flags.yzw). One scalar
    // pow a pixel instead of three: llvmpipe runs each as exp2(log2(x) y) on every lane.
    o_color = vec4(min(draw.flags.yzw * pow(k, 1.0 / 2.2), vec3(1.0)), 1.0);
#ifdef COUNT
    o_count = vec4(float(count_texels), vec3(count_loops));
#endif
#ifdef AOV
    o_visibility = vis;
    o_position = vec4(v_world, 1.0);
    // The spot factor in alpha: metrics judge only pixels where light can fall (spot > 0);
    // outside the cone every technique writes v = 1 unread by the shading.
    o_normal = vec4(n, spot);
#endif
}
