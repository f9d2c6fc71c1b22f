//! # penumbra-map-centred — Wyman & Hansen 2003 with the penumbra centred on the hard edge
//! Port sheet: docs/port/penumbra-map-centred.md
//! Speed layer: speed::penumbra_map, speed::regions — off under --plain.
//!
//! `penumbra-map` (src/technique/penumbra_map.rs, whose header this one builds on) takes the
//! hard shadow from the light's centre as the umbra and grows the penumbra outward from it,
//! so every shadow is too large and too dark (the paper's Sec. 4.1). From the light's centre
//! the hard edge of a straight blocker edge is where the true visibility of a disc light is
//! 0.5; the true penumbra runs from the inner edge (0, inside the hard shadow) through the
//! hard edge to the outer edge (1), with the disc-chord profile
//! v(s) = (1/pi)(acos s - s sqrt(1 - s^2)) (glsl/common/penumbra.glsl, s = the signed distance
//! from the hard edge over the half-width, positive inside). This form draws the paper's
//! outer cones and sheets AND their mirror images inside the hard shadow (our accurate form; Cai et
//! al. 2006's inner and outer fins are the same idea for shadow fins). Same pass structure,
//! same geometry builder (`silhouette::penumbra::build_penumbra_sides`, `Side::Outer` /
//! `Side::Inner`), same struct as the paper form (`penumbra_map::PenumbraMap`, `Form`); this
//! module holds what is the centred form's own: the penumbra pass's attachment (`TARGET`),
//! its outer and inner pipelines (`pipelines`) and the final shader (`FINAL_SHADER`).
//!
//! ## Geometry
//! Half-width of the penumbra that a receiver at linear light depth Z gets from a
//! silhouette point at depth Zv, in tangent units (lateral offset / depth, the light-screen
//! unit): w(Z) = Lr (1/Zv - 1/Z). The outer sheet of an edge is the plane through the edge
//! tangent to the light disc on the inner side (the paper's), the inner sheet the plane
//! through the edge tangent on the outer side; a point of either at depth Z_F lies
//! u = w(Z_F) from the edge's hard-edge line, outside or inside. Cones: arcs between the
//! two sheets' normals at each silhouette vertex, on each side (the gap at a convex vertex
//! outside, at a reflex vertex inside). Both sides are built on the CPU
//! (`--silhouettes gpu` is not implemented for the inner side and builds on the CPU too).
//!
//! Under a sun (penumbra_map.rs, "Under a sun"): parallel rays, so the half-width is
//! w(Z) = (Z - Zv) tan(theta) in world units across the map (`wedge_offset`,
//! glsl/penumbra_map/wedge.glsl), the closed form's (d_r - d_b) tan(theta) either side of
//! the hard edge. The outer fraction is Eq. 1's I itself, s = (Z_F - Zv) / (Z_P - Zv)
//! (`outer_share`), the inner one u / w(Z_R) with u = (Z_F - Zv) tan(theta) and the
//! march's texels in world units (`wedge_unit_per_texel`: the map's world texel). The
//! inner side's hidden-receiver estimate is the spotlight's (1/depth extrapolated over a
//! plane, shared with smoothies-centred); under a parallel projection depth itself is
//! affine there, so on a tilted receiver Z_R bends by up to its 5 % limit.
//!
//! ## Passes, in order
//! 0. CPU `penumbra-map-centred/silhouettes` (R > 0) — per moved caster: silhouette from the
//!    light centre, then the outer and the inner cones and sheets (24-byte
//!    `PenumbraVertex`, as the paper form), uploaded to two host-visible vertex buffers.
//! 1. `penumbra-map-centred/shadow_map` — the shared `ShadowMap`: R32G32_SFLOAT, clear 1e30,
//!    blend MIN, no depth attachment; r = nearest caster's linear depth, g = nearest
//!    surface's of any role. Pass 2 reads g at each outer fragment's own texel and, for an
//!    inner one, 1.0 and 5.0 texels outside its edge (1.5 and 5.5 past a caster in front at
//!    1.0); r (is a caster there?) for an inner one at those points and at its own texel,
//!    and along the inward marches of both sides (thin blockers, below).
//! 2. `penumbra-map-centred/penumbra` — one timed pass, two rendering scopes (outer, then
//!    inner), each with one colour attachment of its own, no depth attachment, culling off:
//!    `penumbra_map` = R32_SFLOAT, clear 2^24 - 1, blend MIN: the outer key
//!    (glsl/common/packed.glsl, `packed`) of the outer visibility's share (the profile's
//!    argument, -1 lit; the darkest value, the largest share, wins: the paper's rule and
//!    the paper form's map) and the depth of the texel's foremost surface (the shadow
//!    map's g there, which the final pass's own-surface test reads);
//!    `penumbra_inner` = R32_SFLOAT, clear 2^24 - 1, blend MIN: the inner key of the inner
//!    visibility's share (1 umbra; MIN keeps the lightest inner estimate) and the depth of
//!    the receiver it was made for (of equal shares, the farthest). Shares, not
//!    visibilities, for the final pass to interpolate (smoothies_centred.rs, pass 2, says
//!    why). A key holds the value
//!    MIN must pick in its high bits and a log-scale depth code in its low bits
//!    (smoothies_centred.rs, pass 2, gives the levels and steps), so that the final pass
//!    reads both with one gather; the surface depth in the outer key spares it the shadow
//!    map's g. A map per side rather than one both share: a fragment blends only the 4
//!    bytes its side makes, and every value is MIN, so no independentBlend. Both draws
//!    use glsl/penumbra_map/penumbra.vert (the paper's).
//!    - outer cones and sheets, `glsl/penumbra_map_centred/outer.frag`: the paper's
//!      fragment program (shared in glsl/penumbra_map/wedge.glsl: Z_P = the shadow map's g at
//!      the fragment's texel, the same discards, the same blocker-size bound) with the exact
//!      outer fraction s = (1/Zv - 1/Z_F) / (1/Zv - 1/Z_P) = I Z_P / Z_F (I = Eq. 1) and
//!      v = disc_chord(-s) in [0.5, 1] (discarded at s >= 1, fully lit), plus, for a
//!      blocker narrower than its penumbra,
//!      the disc's segment beyond its far edge (`outer_far_share`: the shadow map's r
//!      marched inward from 1 texel inside the edge, along the gradient of Z_F, for what
//!      is left of the half-width; "Combining edges"), raised to the paper's blocker-size
//!      bound as the paper form's intensity is; writes the key of (the share, g) to
//!      `penumbra_map`: -s, or `chord_share(max(v, bound))` (disc_chord's inverse,
//!      glsl/common/penumbra.glsl) where the far segment or the bound adds light.
//!    - inner cones and sheets, `glsl/penumbra_map_centred/inner.frag`: u = w(Z_F), the
//!      inward direction = the gradient of u over the map (dFdx/dFdy). The receiver behind
//!      the texel is hidden from the light, so its depth Z_R is estimated from the shadow
//!      map's g 1.0 and 5.0 texels outside the edge along that direction: the plane through
//!      the two samples (1/depth is affine across the map over a plane) extrapolated to the
//!      texel, within 5 % of the nearer sample (1.5 and 5.5 texels where a caster more than
//!      1 % in front of the edge covers the first: smoothies_centred.rs, "inner smoothies",
//!      says why). Discarded when a caster more than 1 % in front of the edge covers the
//!      outside at 1.5 texels too (the edge is hidden by another caster: no inner penumbra
//!      through it), when the fragment's own texel is not behind a caster 1 % nearer than
//!      Z_R, or when s = u / w(Z_R) is at least 1 (umbra). Else v = disc_chord(s) in
//!      [0, 0.5], plus the thin-blocker term below, raised to the blocker-size bound;
//!      writes the key of (v's share, Z_R) to `penumbra_inner`: s, or `chord_share(v)`
//!      where the term or the bound adds light.
//! 3. `penumbra-map-centred/final` — `FinalPass` with
//!    `glsl/penumbra_map_centred/final.frag`: per texel of the 2x2 footprint (textureGather
//!    of the shadow map's r and of the keys of both maps at the lookup point, three
//!    gathers), as shares: in front of the nearest caster, the outer share if the texel's
//!    foremost surface (the outer key's depth) is the point's own (the paper form's
//!    window, glsl/penumbra_map/surface.glsl), else -1; behind it: the inner share if the
//!    point is at most 5 % beyond the receiver depth that inner value was made for, else
//!    1 (a point behind a second caster, e.g. the ground under two stacked boxes, stays in
//!    the umbra), over k where the point is more than 5 % nearer than that receiver (its
//!    own penumbra, k times as wide: `inner_at_depth`, glsl/common/nearer_receiver.glsl),
//!    and never lighter than the outer share (the larger of the two). The shares are
//!    interpolated with `hard`'s bilinear weights and the visibility is disc_chord of the
//!    result (`share_visibility`, exactly 1 and 0 at the ends). R = 0 draws no cones or
//!    sheets, and the pass returns `hard`'s bilinear value: `hard`'s image exactly. The
//!    shader gathers in that order of need: the shadow map's r and the outer keys first
//!    (all four lit and at -1: v = 1; all four in front of every caster: the outer shares
//!    alone), the inner keys only where a footprint texel lies behind a caster, gathered
//!    right after the casters there (behind at all four, none holding an inner value, the
//!    umbra's inside: v = 0 from two gathers, as the max with the inner umbra gives); the
//!    same v, fewer lookups.
//!
//! ## Equations: what a porter ports
//! - The geometry, both sides: `build_penumbra_sides` (src/silhouette/penumbra.rs).
//! - The disc-chord profile v(s), its inverse, the share of an edge plus added light and
//!   the final pass's visibility of an interpolated share: `disc_chord`, `chord_share`,
//!   `summed_share`, `share_visibility` (glsl/common/penumbra.glsl).
//! - The outer fraction s = I Z_P / Z_F: `main` of glsl/penumbra_map_centred/outer.frag,
//!   over the paper form's `eq1_depths` and `blocker_floor` (glsl/penumbra_map/wedge.glsl),
//!   with the thin blocker's far side `outer_far_share` (glsl/common/inner_march.glsl).
//! - The inner side: `main` of glsl/penumbra_map_centred/inner.frag, with
//!   `receiver_beyond`, `blocked_at` (glsl/common/inner_receiver.glsl) and
//!   `far_edge_texels` (glsl/common/inner_march.glsl).
//! - The final combination: `visibility` (glsl/penumbra_map_centred/final.frag).
//! - Each side's two values in one R32F key (the value MIN picks in the high bits, a
//!   log-scale depth code in the low ones): `outer_key`, `inner_key` and their unpacking
//!   (glsl/common/packed.glsl). A port may keep two MIN-blended channels instead, for
//!   one more gather a side: each channel then keeps its own extreme (the nearest depth,
//!   the farthest receiver), not the depth that travels with the value kept.
//!
//! The speed layer leaves each texel read and each shaded pixel's inputs as the whole
//! passes give them, up to the rounding of Zv interpolated over the cut cones' and
//! sheets' shorter triangles (src/technique/speed/penumbra_map.rs; tests/plain.rs).
//!
//! ## Combining edges (what the centring approximates)
//! - Several outer wedges at a texel: the darkest (MIN), as the paper. Exact for one edge;
//!   two blockers' overlapping outer penumbrae are never lighter than either alone (the
//!   union of two blockers hides at least what each hides), but darker-than-both (the sum of
//!   their occlusions) is not modelled.
//! - Several inner wedges at a texel: the lightest (MIN of the share). For a convex
//!   blocker the light that reaches a point is at least what the nearest edge alone lets
//!   through, so MAX of the per-edge values is a lower bound there; neighbouring edges of
//!   a curved silhouette (nearly parallel, same side) give nearly equal values and are not
//!   counted twice.
//! - Thin blockers: a MAX over edges alone would leave a strip narrower than its penumbra
//!   half as bright as it is. Each inner fragment searches the shadow map inward along its
//!   normal (up to 6 bisections between its own texel and the texel w in; not at all where
//!   the blocker still covers that texel, and two blockers inside w give either far edge)
//!   for the blocker's far edge, d beyond the texel. Through a strip between parallel edges
//!   a and b a point sees the disc's segment beyond each edge: the blocked share is
//!   1 - disc_chord(s_a) - disc_chord(s_b), per-edge occlusions combine (they do not take
//!   the minimum); the inner fragment writes the share (`chord_share`) of
//!   disc_chord(s_a) + disc_chord(d / w), so inner extents meeting from both sides give
//!   partial light, exactly for a parallel strip. At a sharp corner of a thin blocker the
//!   search can leave through the other edge and count its segment fully: too light there.
//!   Each outer fragment, x outside its edge, searches the same way from IN_TEXELS (1)
//!   inside the edge for what is left of w (`outer_far_share`; not at all where the blocker
//!   still covers the end of that reach) and adds disc_chord((x + W) / w) for a blocker W
//!   wide, so both sides give 0.5 + disc_chord(W / w) at the hard edge. Without it the
//!   outer side kept the half-plane's 0.5 there while the inner side let the far segment
//!   through: a blocker narrower than its penumbra (the bunny's ears at 3x its radius) kept
//!   its hard outline inside a penumbra lighter than the ring around it. Beyond a thin
//!   blocker's tip the search runs along it and finds no far edge: too dark there.
//! - Hidden receivers under another caster's outer penumbra take the darker of the inner
//!   and the outer value (the larger share), where the outer value was evaluated at the
//!   foremost (nearer) surface: not darker than the outer penumbra at the receiver's own
//!   depth would be.
//! - Overlapping casters: an edge whose outside is covered by a caster in front of it draws
//!   no inner penumbra, so one caster's inner penumbra never lightens another's umbra
//!   (union semantics at the hard-shadow outline). A caster BEHIND the edge but in front of
//!   the receiver ends the march (the blocker and it are one union, through Z_R), and a
//!   receiver behind that second caster gets 0 in the final pass (the receiver-depth check).
//!
//! ## Known artefacts
//! One receiver per texel for the inner side: Z_R is the plane of the surface just outside
//! the edge; a hidden point more than 5 % beyond it gets the umbra (right behind a second
//! caster, too dark behind a receiver that curves away); one nearer (a rail right behind a
//! post) gets that penumbra narrowed to its own depth. Surfaces facing away from the
//! light inside the inner band get the inner penumbra too (the shading's n.l hides it). The
//! search and the edge test are quantised to the shadow map's texels (the far edge to an
//! eighth of a texel after bisection, 1/64 of w where w is wider than 8 texels).
//! Silhouettes from the light centre only (they pop under light motion) and the paper's
//! creases at concavities remain; both halves are evaluated for a straight edge, so curved
//! silhouettes (a sphere's) get a slightly too dark inner penumbra (a convex outline hides
//! less of the disc than the half-plane of its tangent). The inner
//! fragments cost up to 10 shadow-map fetches each (two receiver samples, own texel, the
//! texel one half-width in, and up to 6 bisections only where the blocker has ended by
//! then), only in the inner band; the outer ones two beyond the paper's one beside a
//! blocker (the search's start inside the edge and the end of the rest of the half-width)
//! and up to 6 bisections only where the blocker has ended by then.

use super::packed::{inner_target, outer_target};
use super::penumbra_map::{penumbra_pipeline_desc, PenumbraMap};
use super::{Form, LightTarget, TechniqueInfo, TechniqueInit};
use crate::gpu::passes::FinalShader;
use crate::shaders;
use crate::vk::{Blend, DescriptorSet, Pipeline};
use anyhow::Result;

pub const INFO: TechniqueInfo = TechniqueInfo {
    name: "penumbra-map-centred",
    summary: "penumbra maps with inner and outer cones and sheets: disc-chord penumbra centred on the hard edge",
    create: |init| PenumbraMap::create(init, Form::Centred),
};

/// Pass 2's attachments, one for each side, each drawn by its own pipeline alone: a
/// fragment blends only the values its side makes. Each holds its two values packed in one
/// R32F key (`packed`), so that the final pass reads both with one gather.
pub(super) const TARGETS: [LightTarget; 2] = [
    // The outer share (the paper form's map, as a share) with the depth of the texel's
    // foremost surface it was made for.
    outer_target("penumbra_map", &["outer_share", "surface_depth"]),
    inner_target("penumbra_inner"),
];

/// Pass 2's two pipelines, each into its own of `TARGETS` with MIN blending: the outer
/// cones' and sheets' (glsl/penumbra_map_centred/outer.frag), then the inner ones'
/// (inner.frag).
pub(super) fn pipelines(
    init: &TechniqueInit<'_>,
    penumbra_set: &DescriptorSet,
) -> Result<[Pipeline; 2]> {
    let [outer_colors, inner_colors] = TARGETS.map(|t| [(t.format, Blend::Min)]);
    let name = Form::Centred.names().penumbra;
    let sets = [penumbra_set];
    let outer = shaders::PENUMBRA_MAP_CENTRED_OUTER_FRAG;
    let inner = shaders::PENUMBRA_MAP_CENTRED_INNER_FRAG;
    Ok([
        Pipeline::graphics(
            init.ctx,
            &penumbra_pipeline_desc(name, outer, &outer_colors, &sets),
        )?,
        Pipeline::graphics(
            init.ctx,
            &penumbra_pipeline_desc(name, inner, &inner_colors, &sets),
        )?,
    ])
}

/// Pass 3's fragment shader.
pub(super) const FINAL_SHADER: FinalShader = FinalShader {
    color: shaders::PENUMBRA_MAP_CENTRED_FINAL_FRAG,
    aov: shaders::PENUMBRA_MAP_CENTRED_FINAL_FRAG_AOV,
    count: shaders::PENUMBRA_MAP_CENTRED_FINAL_FRAG_COUNT,
};
