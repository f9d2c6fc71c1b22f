// The centred forms' final passes: an inner value seen from a point nearer than the receiver
// it was made for.
//
// An inner value is the profile's share s (common/penumbra.glsl) at its texel for one
// receiver depth Z_R, the surface just outside the silhouette edge. A point between the
// caster and that surface (a rail right behind a post, the body under an ear) sees a
// narrower penumbra: the half-width grows as 1/b - 1/d under a spotlight (d - b under a
// sun), b the blocker's depth and d the receiver's, so the point's penumbra is
// k = w(d) / w(Z_R) as wide and its share on the inner side s / k. Without this such a
// point took Z_R's wider penumbra and was lit up to a third into the umbra.
#ifndef NEARER_RECEIVER_GLSL
#define NEARER_RECEIVER_GLSL
#include "common/frame.glsl"
#include "common/constants.glsl"

// The inner shares `s` of a footprint's texels, made for receivers at `receiver` behind
// casters at `blocker`, seen from a point at `depth`: s / k where the point is more than
// RECEIVER_EPS nearer, measured from that window's edge (k = 1 there: no step where a point
// leaves the window). Shares below 0 (a thin blocker's far side let light through) keep
// their value.
vec4 inner_at_depth(vec4 s, vec4 receiver, vec4 blocker, float depth) {
    vec4 r = receiver * (1.0 - RECEIVER_EPS);
    // (1/b - 1/d) / (1/b - 1/r) = (d - b) r / ((r - b) d) under a spotlight. The guards
    // keep k finite where a texel's receiver is its caster: the caller mixes by weight, and
    // a NaN would pass through a zero weight.
    vec4 k = (depth - blocker) / max(r - blocker, 1e-6 * r) * (light_is_sun() ? vec4(1.0) : r / depth);
    vec4 nearer = vec4(lessThan(vec4(depth), r)) * vec4(greaterThan(s, vec4(0.0)));
    vec4 narrowed = min(s / max(k, vec4(1e-6)), vec4(1.0));
    return mix(s, narrowed, greaterThan(nearer, vec4(0.5)));
}

#endif
