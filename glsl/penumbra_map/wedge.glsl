// What the penumbra-map passes (penumbra_map/penumbra.frag, penumbra_map_centred/*.frag)
// share per cone or sheet fragment: Eq. 1's three depths at the fragment's texel, the tests
// of the paper's fragment program, and the blocker-size bound.
#ifndef PENUMBRA_MAP_WEDGE_GLSL
#define PENUMBRA_MAP_WEDGE_GLSL
#include "common/frame.glsl"

#include "common/far_depth.glsl"
// Below this Z_P - Z_v (relative to Z_P) the receiver touches the silhouette vertex: no
// penumbra (contact), and no division by a rounding-sized denominator (no NaN, Inf, speckle).
const float CONTACT_EPS = 1e-4;

// Linear depths of Eq. 1 at one fragment: the foremost surface P behind its texel, the
// fragment F, the silhouette point v, and Z_P - Z_v.
struct Eq1 {
    float zp;
    float zf;
    float zv;
    float denom;
};

// Z_v of the fragment: (Zv k, k) interpolated perspective-correctly (src/silhouette/
// penumbra.rs). k >= 1 always; the max only guards a corrupt vertex.
float fragment_zv(vec2 zv_h) {
    return zv_h.x / max(zv_h.y, 1e-30);
}

// Whether a receiver at depth `zp`, `denom` = Z_P - Z_v behind the silhouette point, is
// clear of contact (CONTACT_EPS); false for a NaN denominator too.
bool clear_of_contact(float zp, float denom) {
    return denom > CONTACT_EPS * zp;
}

// Eq. 1's depths, with `zp` the surface depth read at the fragment's own texel; false where
// the paper's fragment program discards.
bool eq1_depths(float zp, float zf, vec2 zv_h, out Eq1 e) {
    e.zp = zp;
    e.zf = zf;
    e.zv = fragment_zv(zv_h);
    e.denom = zp - e.zv;
    if (zp >= 0.5 * FAR_DEPTH) return false;
    // Step (4): a cone or sheet behind the surface cannot shadow it.
    if (zf > zp) return false;
    // The surface is at or in front of the silhouette vertex (e.g. the caster itself).
    return clear_of_contact(zp, e.denom);
}

// Blocker-size bound (not in the paper). Cases `blocker-near-light`, `near-far-1e-4`: a
// caster smaller than the light, near it, has cones of radius (Z_far - Zv) Lr / Zv that span
// the whole map, and Eq. 1 darkens everything under them to ~0 (I ~ (Zv / Z_P) f / (1 - f)
// at the fraction f across the penumbra), while such a caster hides only a sliver of the
// light. Seen from P, the caster (within `reach` of its centre, in tangent units, so within
// reach Zv laterally at depth Zv) covers on the light's plane at most a strip of half-width
// r = reach Zv Z_P / (Z_P - Zv) through the disc of radius Lr: a fraction <= 4 r / (pi Lr)
// of its area. P keeps at least the rest. For casters as large as the light (every standard
// scene) the bound is <= 0 and changes nothing; it assumes the caster's depth extent is
// small against Z_P - Zv. Returns that least visibility (denom = zp - zv > 0).
// Under a sun (disc of directions of angular radius theta) the caster, `reach` world units
// across the map around its centre, spans at most r = reach / (Z_P - Zv) (tangent units)
// seen from P: a strip of the disc of radius tan theta, a fraction <= 4 r / (pi tan theta).
float blocker_floor(float reach, float zv, float zp, float denom) {
    bool sun = light_is_sun();
    float lr = light_spread();
    float r = sun ? reach / denom : reach * zv * (zp / denom);
    float hidden = lr > 0.0 ? min(4.0 * r / (3.14159265 * lr), 1.0) : 1.0;
    return 1.0 - hidden;
}

// How far a cone or sheet point at depth z lies from the hard-edge line of its silhouette
// point at depth zv (z >= zv), in the map's lateral unit `wedge_unit_per_texel` measures:
// a spotlight's Lr (1/zv - 1/z) tangent units (lateral offset over depth); a sun's
// (z - zv) tan theta world units (parallel rays). The penumbra's half-width at a receiver
// at depth z too.
float wedge_offset(float zv, float z) {
    return light_is_sun() ? frame.sun.y * (z - zv)
                          : frame.light_pos_radius.w * (1.0 / zv - 1.0 / z);
}

// `wedge_offset`'s unit per shadow-map texel: tangent units, or a sun's world units.
float wedge_unit_per_texel() {
    return light_is_sun() ? frame.sun.z : frame.light_frustum.y;
}

// The share of the outer penumbra half-width at P (depth zp) where the fragment F (depth
// zf) lies, from Eq. 1's I = (Z_F - Z_v) / (Z_P - Z_v): a spotlight's
// (1/Zv - 1/Z_F) / (1/Zv - 1/Z_P) = I Z_P / Z_F; a sun's I itself (offsets grow linearly in
// depth under parallel rays, so Eq. 1 is exact).
float outer_share(float i, float zp, float zf) {
    return light_is_sun() ? i : i * (zp / zf);
}

#endif
