// The plateau texture's plane (Haines 2001): its frame and the top-down mapping, written by
// the CPU once per frame. Mirrors `PlaneUniforms` in src/technique/plateaus_common.rs (std140).
#ifndef PLATEAUS_PLANE_GLSL
#define PLATEAUS_PLANE_GLSL

layout(set = 0, binding = 1, std140) uniform Plane {
    mat4 drop_shadow;   // world -> texture clip: central projection from the light onto the plane, z = 0
    mat4 to_texture;    // world -> (texture u, texture v, height above the plane, 1)
    vec4 params;        // x: on-plane height tolerance, y: on-plane |cos| of the normals
    vec4 normal;        // xyz: unit plane normal, on the light's side
} plane;

#endif
