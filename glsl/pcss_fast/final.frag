#version 450
#extension GL_GOOGLE_include_directive : require
// pcss-fast final pass: the hierarchy's exact early exits, then pcss's search and filter
// for the points left (pcss_fast/visibility.glsl).
#include "pcss_fast/visibility.glsl"

#include "common/final.glsl"
