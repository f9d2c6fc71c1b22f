#version 450
#extension GL_GOOGLE_include_directive : require
// Drop shadow: intensity 0 at depth 0 (the "hither"), so no plateau primitive drawn later can
// cover it under the LESS depth test.
#include "common/frame.glsl"
#include "plateaus/plane.glsl"

layout(location = 0) in float v_height;
layout(location = 0) out float o_fraction;

void main() {
    // A caster below the plane is hidden from the light by the plane itself. A caster surface
    // ON the plane (height within the final pass's on-plane tolerance, plane.params.x) is
    // part of the receiver there, not above it: Haines' drop shadow is the shadow cast onto the
    // plane by objects between it and the light (Sec. 2), and a point at height 0 projects
    // onto itself, where the light sees it. Case `caster-on-receiver`: a flat sheet lying
    // exactly in the ground plane was drawn as its own umbra (its cones, radius R h / (H - h)
    // = 0, add nothing). Casters resting on the plane lose only the sliver below the
    // tolerance, whose drop shadow the rest of their surface covers.
    if (v_height <= plane.params.x) discard;
    o_fraction = 0.0;
}
