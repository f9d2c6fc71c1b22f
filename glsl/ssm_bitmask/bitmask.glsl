// Shared by the micro-quad pass of ssm-bitmask: the light frame, and the
// light samples on one side of a line, from the edge table (src/technique/ssm_bitmask_table.rs).
#ifndef SSM_BITMASK_GLSL
#define SSM_BITMASK_GLSL
#include "ssm_bitmask/constants.glsl"

const uvec4 NO_SAMPLES = uvec4(0u);
const uvec4 ALL_SAMPLES = uvec4(0xffffffffu);
const float PI = 3.14159265358979;

// Light frame: the light centre at the origin, z = linear depth along the light's axis.
// `px` in occluder-map pixels (texel i spans [i, i+1]). Corner and receiver positions all go
// through this one function, so a corner shared by two micro-quads is the same float triple.
// A sun's frame is its orthographic map's: xy the world offset from the map's centre (the
// map spans res x the world texel at every depth), z the same linear depth.
vec3 light_frame(vec2 px, float z) {
    vec2 ndc = px * (2.0 * SSM_INV_RES) - 1.0;
    if (light_is_sun()) return vec3(ndc * (0.5 * SSM_RES * ssm_sun_texel()), z);
    return vec3(ndc * (frame.light_frustum.x * z), z);
}

// Texels a quad drawn with reach `reach` (v_reach) reaches beyond its square for a receiver
// at depth zr, from its nearest depth znear: under a spotlight reach (1/z_near - 1/z_R),
// under a sun reach (z_R - z_near), the penumbra growing linearly with the distance.
float reach_texels(float reach, float znear, float zr) {
    return light_is_sun() ? reach * (zr - znear) : reach * (1.0 / znear - 1.0 / zr);
}

#endif
