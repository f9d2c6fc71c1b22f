// The bitmask soft shadow maps' per-technique constants: ssm's four (frame.technique,
// glsl/ssm/constants.glsl) and these, filled by src/technique/ssm_bitmask.rs by name.
#ifndef SSM_BITMASK_CONSTANTS_GLSL
#define SSM_BITMASK_CONSTANTS_GLSL
#include "ssm/constants.glsl"

#define SSMB_RADIUS frame.technique2.x          // R: radius of the disc light (0: point light)
#define SSMB_EXTENT_RADIUS frame.technique2.y   // reach of the disc on the light's image plane
#define SSMB_CONNECT_TEXELS frame.technique2.z  // one surface: depths closer than this many texels of slope
#define SSMB_LUT_ANGLES frame.technique2.w      // rows of the edge table (line directions)

#endif
