#version 450
#extension GL_GOOGLE_include_directive : require
// ssm2 final pass: front and back soft shadow maps merged with max (Atty et al. Sec. 3.5).
#define TWO_SIDED 1
#include "ssm/final.glsl"
#include "common/final.glsl"
