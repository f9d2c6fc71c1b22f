#version 450
// One triangle covering the whole target: a pass that shades every texel once
// (ssm-bitmask/resolve; tests/work_counts.rs: a full-screen pass at W x H shades W x H
// fragments).

void main() {
    vec2 p = vec2((gl_VertexIndex << 1) & 2, gl_VertexIndex & 2);
    gl_Position = vec4(p * 2.0 - 1.0, 0.0, 1.0);
}
