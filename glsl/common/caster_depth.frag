#version 450
// The casters-only shadow map (gpu::passes::ShadowMap::casters): linear light depth into
// R32F, MIN-blended; only casters are drawn, so no role test.

layout(location = 0) in float v_depth;
layout(location = 0) out float o_depth;

void main() {
    o_depth = v_depth;
}
