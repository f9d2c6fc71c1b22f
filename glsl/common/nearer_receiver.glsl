// The centred forms' final passes: an inner value seen from a point nearer than the receiver
// it was made for.
//
// An inner value is the profile (common/penumbra.glsl) at its texel for one receiver depth
// Z_R, the surface just outside the silhouette edge. A point between the caster and that
// surface (a rail right behind a post, the body under an ear) sees a narrower penumbra: the
// half-width grows as 1/b - 1/d under a spotlight (d - b under a sun), b the blocker's depth
// and d the receiver's, so the point's penumbra is k = w(d) / w(Z_R) as wide and its share
// s on the inner side s / k. Without this such a point took Z_R's wider penumbra and was
// lit up to a third into the umbra.
#ifndef NEARER_RECEIVER_GLSL
#define NEARER_RECEIVER_GLSL
#include "common/frame.glsl"
#include "common/constants.glsl"

// The inner side's visibility v from share s is taken as linear here, v ~ (1 - s) / 2 (exact
// at the hard edge and at the umbra's end), so that narrowing by k is arithmetic:
// s = 1 - 2 v, v' = (1 - s / k) / 2 = (v - (1 - k) / 2) / k. At k = 1 it returns v itself.
// Inverting the disc chord itself (a power, or Newton's method) gave the same errors on
// every built-in scene for several times the final pass's arithmetic, which every fragment
// of a CPU driver pays.
vec4 narrowed_inner(vec4 v, vec4 k) {
    return max(v - 0.5 * (1.0 - k), 0.0) / max(k, 1e-6);
}

// The inner visibilities `v` of a footprint's texels, made for receivers at `receiver` behind
// casters at `blocker`, seen from a point at `depth`: narrowed where the point is more than
// RECEIVER_EPS nearer, measured from that window's edge (k = 1 there: no step where a point
// leaves the window). Values above 0.5 (a thin blocker's far side let light through) keep
// their value.
vec4 inner_at_depth(vec4 v, vec4 receiver, vec4 blocker, float depth) {
    vec4 r = receiver * (1.0 - RECEIVER_EPS);
    // (1/b - 1/d) / (1/b - 1/r) = (d - b) r / ((r - b) d) under a spotlight. The guard keeps
    // k finite where a texel's receiver is its caster: the caller mixes by weight, and a NaN
    // would pass through a zero weight.
    vec4 k = (depth - blocker) / max(r - blocker, 1e-6 * r) * (light_is_sun() ? vec4(1.0) : r / depth);
    vec4 nearer = vec4(lessThan(vec4(depth), r)) * vec4(lessThan(v, vec4(0.5)));
    return mix(v, narrowed_inner(v, k), greaterThan(nearer, vec4(0.5)));
}

#endif
