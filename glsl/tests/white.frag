#version 450
// A fragment shader with no input: every covered pixel white (tests/work_counts.rs).
layout(location = 0) out vec4 o_color;

void main() {
    o_color = vec4(1.0);
}
