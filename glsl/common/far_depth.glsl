// The clear value of the linear-depth maps and the depth a non-caster writes into the
// shared shadow map (gpu::passes::FAR_DEPTH): neutral under MIN blending.
#ifndef COMMON_FAR_DEPTH_GLSL
#define COMMON_FAR_DEPTH_GLSL

const float FAR_DEPTH = 1.0e30;

#endif
