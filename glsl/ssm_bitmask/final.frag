#version 450
#extension GL_GOOGLE_include_directive : require
// ssm-bitmask final pass: the OR-combined light-sample masks projected onto
// the receivers (the two-sided form ORs its back micro-quads into the same masks, so the
// final pass is the same).
#include "ssm_bitmask/final.glsl"
#include "common/final.glsl"
