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

// The share s of the profile above at x_tex texels from the hard edge (>= 0, on either
// side) of a penumbra of half-width w_tex texels, as the centred forms draw it into their
// light-space buffers. Their final passes interpolate those texels bilinearly, a tent one
// texel wide that adds its variance (1/6 texel^2) to the profile's: a penumbra narrower than
// a texel came out about a texel wide, lit up to a texel into the umbra (on `dense`, whose
// blobs stand close to the ground). Drawn with the half-width sqrt(w^2 - 1/6), a half-width
// of 4 texels narrows by 0.5 %, and one under 0.41 texel is drawn as the hard step. A third
// of a texel^2 sharpened too far (`bunny`'s p99_lit rose above pcss's).
float drawn_share(float x_tex, float w_tex) {
    float w = sqrt(max(w_tex * w_tex - 1.0 / 6.0, 0.0));
    return w > 0.0 ? x_tex / w : sign(x_tex);
}

#endif
