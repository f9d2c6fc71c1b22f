#version 450
#extension GL_GOOGLE_include_directive : require
// ssm final pass: the one-sided soft shadow map projected onto the receivers.
#include "ssm/final.glsl"
#include "common/final.glsl"
