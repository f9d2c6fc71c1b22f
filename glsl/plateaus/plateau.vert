#version 450
// Plateau cones and sheets (Haines Sec. 2, Figs. 2 and 4): built on the CPU directly in the
// texture's clip space, z = the penumbra fraction (0 at the hard shadow edge, 1 at its
// outer rim). No projection: the texture is an orthographic top-down view.
layout(location = 0) in vec3 in_clip;

void main() {
    gl_Position = vec4(in_clip, 1.0);
}
