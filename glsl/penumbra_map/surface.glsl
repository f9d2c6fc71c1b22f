// The penumbra-map final passes' test of which texels of the 2x2 footprint hold this point's
// own surface (penumbra_map/final.frag, penumbra_map_centred/final.frag).
#ifndef PENUMBRA_MAP_SURFACE_GLSL
#define PENUMBRA_MAP_SURFACE_GLSL
#include "common/shadow.glsl"

// A texel whose foremost surface is more than this (relative) beyond the point's own surface
// at that texel stores the intensity of a background surface (e.g. the ground just outside a
// caster's silhouette, deep in its penumbra): without this test, grazing caster faces a
// texel or two wide would take that darkness through the bilinear footprint. 1 % is far
// above float rounding and below the depth steps at silhouettes.
const float SAME_SURFACE = 0.01;
// How far beyond the point's own depth the receiver-plane extrapolation may move the window
// (relative): slopes of up to ~3 % a texel (a receiver ~15 degrees from grazing at 256^2)
// are followed; steeper ones keep a 5 % window, so a background only a few percent behind a
// grazing face still counts as background.
const float MAX_PLANE_WINDOW = 0.05;

// Linear light depth, at the centre of texel `t` (uv), of the plane through p with normal n.
// Case `blocker-near-light` / `near-far-1e-4`: one window for all four texels (1 % of the
// point's own depth) misclassifies ground texels one texel away on a receiver whose depth
// changes by ~0.8 % a texel; wherever the penumbra map is dark over a large area (the cones
// of a caster at the near plane span the whole map) the misclassified texels read 1 and the
// others the map, in a moire of rings over the whole region. Comparing each texel's stored
// depth with this plane's depth AT THAT TEXEL removes the slope from the test.
// Under a sun the ray through t is parallel to the axis, from (ndc h, 0) in light view
// space (h the map's half width): the plane's depth there is linear in uv.
float plane_depth(vec3 p, vec3 n, vec2 t, float fallback) {
    vec2 ndc = t * 2.0 - 1.0;
    if (light_is_sun()) {
        float h = 0.5 * frame.sun.z * frame.light_params.z;
        vec3 pv = (frame.light_view * vec4(p, 1.0)).xyz;
        vec3 nv = mat3(frame.light_view) * n;
        // nv . ((ndc h, -z) - pv) = 0 along the ray.
        float zs = -pv.z + dot(nv.xy, ndc * h - pv.xy) / nv.z;
        return (zs > 0.0 && !isinf(zs) && !isnan(zs)) ? zs : fallback;
    }
    // World direction of the light ray through t, scaled so its light-view z is -1: the ray
    // parameter is then the linear depth. light_view is rigid, so its inverse rotation is
    // the transpose.
    vec3 dv = vec3(ndc * frame.light_frustum.x, -1.0);
    vec3 d = transpose(mat3(frame.light_view)) * dv;
    float den = dot(n, d);
    float z = dot(n, p - frame.light_pos_radius.xyz) / den;
    // Grazing or back-facing planes (den ~ 0, z <= 0, non-finite): the plain window.
    return (z > 0.0 && !isinf(z) && !isnan(z)) ? z : fallback;
}

// 1 per footprint texel (textureGather order) whose foremost surface (`surfaces`, the
// shadow map's g) is this point's own surface: within SAME_SURFACE of the point's tangent
// plane at that texel.
vec4 own_surface(vec4 surfaces, LightSample s, vec3 p, vec3 n) {
    // Texel centres of the footprint, in textureGather's order (i0,j1), (i1,j1), (i1,j0), (i0,j0).
    float res = frame.light_params.z;
    vec2 c00 = (floor(s.uv * res - 0.5) + 0.5) / res;
    vec2 dt = vec2(frame.light_params.w, 0.0);
    vec4 zt = vec4(plane_depth(p, n, c00 + dt.yx, s.depth),
                   plane_depth(p, n, c00 + dt.xx, s.depth),
                   plane_depth(p, n, c00 + dt.xy, s.depth),
                   plane_depth(p, n, c00, s.depth));
    vec4 window = clamp(zt, vec4(s.depth), vec4(s.depth * (1.0 + MAX_PLANE_WINDOW))) * (1.0 + SAME_SURFACE);
    return step(surfaces, window);
}

#endif
