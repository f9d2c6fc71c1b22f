// The penumbra profile of the accurate ("centred") techniques: the visibility of a disc light
// behind one straight occluder edge.
//
// A straight edge cuts the light disc (radius R) along a chord at signed distance s R from
// the disc's centre; the visible part is a circular segment whose share of the disc is
//     v(s) = (1/pi) (acos s - s sqrt(1 - s^2)),   s in [-1, 1]
// (s = -1: the edge clears the whole disc, lit; s = 0: the edge crosses the centre, 0.5;
// s = 1: the disc is covered, umbra). Seen from a receiver point, s is the point's distance
// from the hard (centre-light) shadow edge, as a share of the half-width of the penumbra
// there, so the profile is centred on the hard edge: 0.5 at the edge, 0 at the inner edge
// (inside the blocker's shadow), 1 at the outer edge. A 1-D check (straight edge, disc light)
// gives it zero error, against 0.21 for the hard step and 0.25 to 0.38 for the papers'
// outward-only ramps.
#ifndef PENUMBRA_GLSL
#define PENUMBRA_GLSL

// v(s) above, for any s (clamped to [-1, 1]).
float disc_chord(float s) {
    s = clamp(s, -1.0, 1.0);
    return (acos(s) - s * sqrt(max(1.0 - s * s, 0.0))) * 0.31830988618379067;
}

// The share s whose profile lets v through: disc_chord's inverse, for v in [0, 1]. On the
// side v <= 0.5 (the other by symmetry, s -> -s), 1 - s is a polynomial in q = (2 v)^(1/3)
// from q^2 (near the umbra's end v grows as (1 - s)^(3/2)) to q^6, fitted for the least
// largest error and summing to 1 at q = 1 (the hard edge's 0 exactly): within 1.3e-4 of s,
// far below a key's level (common/packed.glsl). The light passes store shares, not
// visibilities, and where a thin blocker adds a second edge's segment only the sum's share
// is known. One power and a polynomial, not an iterative solve: a CPU driver runs it at
// every light fragment, whether or not a thin blocker needs it.
float chord_share(float v) {
    float q = pow(2.0 * clamp(min(v, 1.0 - v), 0.0, 0.5), 1.0 / 3.0);
    float p = 0.90457444 + q * (-0.14805148 + q * (0.49247132 + q * (-0.50800223 + q * 0.25900795)));
    float s = 1.0 - q * q * p;
    return v <= 0.5 ? s : -s;
}

// The share of the light an edge at share s lets through plus `extra` more (a thin
// blocker's segment beyond its far edge, or what the blocker-size bound keeps lit): s itself
// when nothing is added, else the sum's share (capped at lit). The centred light passes store
// this, so that their final passes interpolate one share per texel.
float summed_share(float s, float extra) {
    return extra > 0.0 ? chord_share(min(disc_chord(s) + extra, 1.0)) : s;
}

// An interpolated share this close to an end is that end: the profile there is within 1e-7
// of it.
const float SHARE_EPS = 1e-5;

// The visibility of a share that a final pass interpolated between texels: the profile,
// exactly 1 and 0 within SHARE_EPS of the ends (bilinear weights sum to 1 only up to
// rounding, and a lit footprint must give what the lookup-free parts of a split final pass
// give). The light passes store shares, not visibilities: across a straight edge's penumbra
// the share is linear, so interpolating it keeps the penumbra to its width, where
// interpolating the S-shaped profile, flat at both ends, starts it up to a texel early and
// ends it a texel late (a tent one texel wide added to the profile).
float share_visibility(float s) {
    if (s <= SHARE_EPS - 1.0) return 1.0;
    if (s >= 1.0 - SHARE_EPS) return 0.0;
    return clamp(disc_chord(s), 0.0, 1.0);
}

#endif
