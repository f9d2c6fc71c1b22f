#version 450
// See common/noop.comp: bound at the start of a frame that counts pipeline statistics,
// never drawn with.

void main() {
    gl_Position = vec4(0.0, 0.0, 0.0, 1.0);
}
