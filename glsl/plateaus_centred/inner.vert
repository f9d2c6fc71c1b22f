#version 450
// plateaus-centred/inner: glsl/plateaus/plateau.vert's cones and sheets (texture clip
// space, z = t), with each vertex's step from its edge point (`PlateauVertex::from_edge`,
// src/technique/plateaus_common.rs). It is linear along a cone's spoke and along a sheet's
// ruling, so interpolated it leads a fragment back to the edge point its ruling starts
// from (within the sheet grid's bilinear term, under a texel).
layout(location = 0) in vec3 in_clip;
layout(location = 1) in vec2 in_from_edge;

layout(location = 0) noperspective out vec2 v_from_edge;

void main() {
    gl_Position = vec4(in_clip, 1.0);
    v_from_edge = in_from_edge;
}
