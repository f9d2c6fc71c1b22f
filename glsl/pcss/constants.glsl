// pcss's per-technique constants (frame.technique, frame.technique2, common/frame.glsl),
// named once here: build.rs turns each #define into `shaders::constants::NAME`, the slot that
// src/technique/pcss.rs fills by that name. Equation numbers as in src/technique/pcss.rs.
#ifndef PCSS_CONSTANTS_GLSL
#define PCSS_CONSTANTS_GLSL
#include "common/frame.glsl"

#define PCSS_LIGHT_UV_NEAR frame.technique.x       // light radius in uv at the near plane (Eq. 2)
#define PCSS_PENUMBRA_SCALE frame.technique.y      // R / (2 tan(fov/2)): Eq. 4 without its depths
#define PCSS_MAX_RADIUS_TEXELS frame.technique.z   // largest search and filter radius, texels
#define PCSS_FILTER_SAMPLES frame.technique.w      // Poisson samples of the filter
#define PCSS_SEARCH_SAMPLES frame.technique2.x     // Poisson samples of the blocker search

#endif
