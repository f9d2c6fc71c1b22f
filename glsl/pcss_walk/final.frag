#version 450
#extension GL_GOOGLE_include_directive : require
// pcss-walk/final: the hierarchy's exact early exits, then the walk of the hierarchy
// for the blocker average and pcss's steps 2 and 3 (pcss_fast/visibility.glsl).
#define PCSS_FAST_WALK
#include "pcss_fast/visibility.glsl"

#include "common/final.glsl"
