// Smoothies' per-technique constants (frame.technique, common/frame.glsl), named once here:
// build.rs turns each #define into `shaders::constants::NAME`, the slot that
// src/technique/smoothies.rs fills by that name. The hand-tuned final.frag.spvasm reads
// SMOOTHIE_T as member 7, component 0 of the Frame block.
#ifndef SMOOTHIES_CONSTANTS_GLSL
#define SMOOTHIES_CONSTANTS_GLSL
#include "common/frame.glsl"

#define SMOOTHIE_T frame.technique.x         // representative width t; 0 when R = 0 (`hard`)
#define SMOOTHIE_FIXED_T frame.technique.y   // --smoothie-t for the GPU silhouette passes, or -1

#endif
