// Shared constants of the soft shadow maps (Atty et al. 2006), see src/technique/ssm.rs.
#ifndef SSM_GLSL
#define SSM_GLSL

// Clear value of the linear-depth maps (gpu::passes::FAR_DEPTH); anything above EMPTY
// is "no surface at this texel".
const float FAR_DEPTH = 1.0e30;
const float EMPTY = 0.5e30;

#endif
