// ssm-bitmask's self-occlusion guard, read where the micro-quads are shaded
// (soft_shadow.frag) and where neighbouring micro-quads are merged (occluder_blocks.comp).
#ifndef SSM_BITMASK_GUARD_GLSL
#define SSM_BITMASK_GUARD_GLSL
#include "common/frame.glsl"
#include "ssm/constants.glsl"

// As ssm's: a quad whose texel is less than this in front of the receiver at depth zr is
// the receiver's own surface (a sun's texel has one world size).
float guard_depth(float zr) {
    float texel = 2.0 * frame.light_frustum.x * SSM_INV_RES;
    return light_is_sun()
        ? zr * frame.light_frustum.w + SSM_SELF_GUARD_TEXELS * ssm_sun_texel()
        : zr * (frame.light_frustum.w + SSM_SELF_GUARD_TEXELS * texel);
}

#endif
