// The soft shadow maps' per-technique constants (frame.technique, common/frame.glsl), named
// once here: build.rs turns each #define into `shaders::constants::NAME`, the slot that
// src/technique/ssm_common.rs fills by that name (`ssm_uniforms`, every form).
#ifndef SSM_CONSTANTS_GLSL
#define SSM_CONSTANTS_GLSL
#include "common/frame.glsl"

#define SSM_LIGHT_SIDE frame.technique.x          // L: side of the square light (light_square_side)
#define SSM_RES frame.technique.y                 // n: side of the occluder and soft shadow maps
#define SSM_INV_RES frame.technique.z             // 1 / n
#define SSM_SELF_GUARD_TEXELS frame.technique.w   // receiver self-occlusion guard, texels of slope

// The square light's half-side over the disc's radius: L / 2 = (sqrt(pi) / 2) R, the same
// for a sun's square of directions (tan units) over tan(theta).
const float SSM_HALF_SIDE_PER_RADIUS = 0.88622692545275801;

// A sun's world texel of the occluder and soft shadow maps: its orthographic map spans
// the same world width as the shadow map's at every depth, over SSM_RES texels.
float ssm_sun_texel() {
    return frame.sun.z * frame.light_params.z / SSM_RES;
}

#endif
