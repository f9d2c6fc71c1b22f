#version 450
// Bound, with common/noop.vert, at the start of every frame that counts pipeline
// statistics: lavapipe emits the bound shader state (push constants included) when such a
// query begins, and crashes where no pipeline of a stage was bound yet. Never dispatched.
layout(local_size_x = 1) in;

void main() {}
