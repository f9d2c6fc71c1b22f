// pcss-fast's per-technique constants beyond pcss's (pcss/constants.glsl, the same slots),
// named once here: build.rs turns each #define into `shaders::constants::NAME`, the slot that
// src/technique/pcss_fast.rs fills by that name.
#ifndef PCSS_FAST_CONSTANTS_GLSL
#define PCSS_FAST_CONSTANTS_GLSL
#include "common/frame.glsl"

#define PCSS_FAST_LAST_LEVEL frame.technique2.y  // the min/max hierarchy's coarsest level (2..LAST)

#endif
