// Shared constants of the soft shadow maps (Atty et al. 2006), see src/technique/ssm.rs.
#ifndef SSM_GLSL
#define SSM_GLSL

#include "common/far_depth.glsl"

// Anything above EMPTY is "no surface at this texel".
const float EMPTY = 0.5e30;

// Side of the receiver tiles in texels: one workgroup of ssm/receiver_bound.comp and
// ssm/patch_step.comp (BOUND_GROUP in src/technique/ssm_common.rs).
#define SSM_TILE 16

#endif
