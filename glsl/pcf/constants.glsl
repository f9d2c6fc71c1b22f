// pcf's per-technique constants (frame.technique, common/frame.glsl), named once here:
// build.rs turns each #define into `shaders::constants::NAME`, the slot that
// src/technique/pcf.rs fills by that name.
#ifndef PCF_CONSTANTS_GLSL
#define PCF_CONSTANTS_GLSL
#include "common/frame.glsl"

#define PCF_KERNEL_KIND frame.technique.x      // 0: box, 1: Poisson disc
#define PCF_SAMPLES frame.technique.y          // N: the box's side or the disc's samples
#define PCF_POISSON_RADIUS frame.technique.z   // the disc's radius, texels

#endif
