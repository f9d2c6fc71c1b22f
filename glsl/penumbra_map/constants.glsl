// Penumbra maps' per-technique constants (frame.technique, common/frame.glsl), named once
// here: build.rs turns each #define into `shaders::constants::NAME`, the slot that
// src/technique/penumbra_map.rs fills by that name. Informational (debug captures): no
// shader reads them.
#ifndef PENUMBRA_MAP_CONSTANTS_GLSL
#define PENUMBRA_MAP_CONSTANTS_GLSL
#include "common/frame.glsl"

#define PENUMBRA_MAP_LIGHT_RADIUS frame.technique.x   // Lr
#define PENUMBRA_MAP_Z_FAR frame.technique.y          // depth of the cone bases

#endif
