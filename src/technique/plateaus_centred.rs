//! # plateaus-centred — Haines 2001 with the penumbra centred on the hard edge
//! Port sheet: docs/port/plateaus-centred.md
//!
//! `plateaus` (src/technique/plateaus.rs, whose header this one builds on; relations
//! (P1)-(P4) there) takes the hard drop shadow as the umbra and grows the penumbra outward
//! from it (Sec. 2: "the umbra is ... the hard shadow"), so every shadow on the plane is too
//! large and too dark. From the light's centre the drop shadow's edge is where the true
//! visibility of a disc light is 0.5; the true penumbra runs from the inner edge (0) through
//! the hard edge to the outer edge (1) with the disc-chord profile
//! v(s) = (1/pi)(acos s - s sqrt(1 - s^2)) (glsl/common/penumbra.glsl, s = the signed
//! distance from the hard edge over the half-width (P2) r = R h / (H - h), positive inside).
//! This form draws the paper's cones and outer sheets, and the same cones with INNER sheets
//! (the other common tangent of the two discs, (P3) with p -> -p: `PlateauBuilder` with
//! `Side::Inner`) opening into the drop shadow. On the plane the receiver is known, so the
//! inner side needs no receiver estimate (unlike smoothies-centred and
//! penumbra-map-centred): a plateau's depth t is s itself. Same struct as the paper form
//! (`plateaus::Plateaus`, `Form::Centred`); same planar-receiver rule (a scene without one
//! is refused), same plane frame and texture square.
//!
//! ## Passes, in order
//! 0. CPU `plateaus-centred/silhouettes` (R > 0, light above the plane) — per moved caster:
//!    silhouette from the light centre, then its cones and outer sheets and its cones and
//!    inner sheets in the texture's clip space (12-byte `PlateauVertex`, depth = t),
//!    uploaded to two host-visible vertex buffers.
//! 1. `plateaus-centred/drop_shadow` — the casters through (P1) as the paper's pass
//!    (glsl/plateaus/drop_shadow.vert/.frag, unchanged) but into their own attachment,
//!    `coverage` R16_SFLOAT, clear 1.0, no blend, NO depth attachment: 0 under any
//!    caster's drop shadow. Not into the plateau texture: there its depth 0 would hide a
//!    second caster's outer plateaus over this one's umbra.
//! 2. `plateaus-centred/plateaus` — always runs (R = 0: clears only): the cones and outer
//!    sheets into the plateau texture R32_SFLOAT (clear 1.0, no blend) with the z-buffer
//!    D32_SFLOAT (clear 1.0, LESS, write): glsl/plateaus/plateau.vert/.frag, the paper's
//!    darkest-wins by depth; f = the smallest outer fraction at each texel.
//! 3. `plateaus-centred/inner` — always runs: the cones and inner sheets into `inner`
//!    R16_SFLOAT, clear 0.0, blend MAX (the lightest inner estimate wins), no depth
//!    attachment; plateau.vert, then `glsl/plateaus_centred/inner.frag` (reads `coverage`
//!    at set 0 binding 0): t = the fragment's depth; discarded outside the drop shadow, and
//!    where the plane 1.5 texels outside the edge (along minus the gradient of t) is under
//!    a drop shadow too (a caster nearer the light there covers the edge's outside; a
//!    farther one blocks what the edge lets through, and one MAX image cannot take the
//!    minimum over casters: the union's outline draws the inner penumbra instead). Else
//!    v = disc_chord(t) plus the thin-blocker term below.
//! 4. `plateaus-centred/shadow_map` — the casters-only `ShadowMap` (for receivers other
//!    than the plane), as the paper form's: its final pass reads r alone.
//! 5. `plateaus-centred/final` — `FinalPass` with `glsl/plateaus_centred/final.frag`: a
//!    point on the plane (the paper form's test) takes, at each of the 4 nearest texels,
//!    outer = disc_chord(-f) (1 where no plateau: lit); outside every drop shadow: outer;
//!    under one: min(inner, outer) (a second caster's outer plateau over this umbra is never
//!    lightened). Bilinear weights, no falloff texture (the profile is in the values). Every
//!    other point, and every point at R = 0, gets the shadow map's 2x2 bilinear comparison:
//!    R = 0 is `hard`'s image exactly (unlike the paper form, whose drop shadow only
//!    matches hard up to the texel grids' aliasing). At R > 0 split as the paper form's
//!    (`Plateaus::shadow_regions`): the inner cones and sheets lie in the same discs' hull.
//!
//! ## Equations: what a porter ports
//! - (P1)-(P3), both sides: the paper form's functions (src/technique/plateaus.rs), the
//!   inner sheets by the same builder with `Side::Inner`.
//! - The disc-chord profile v(s): `disc_chord` (glsl/common/penumbra.glsl).
//! - The inner side: `main` of glsl/plateaus_centred/inner.frag, with `far_edge_texels`
//!   (glsl/common/inner_march.glsl).
//! - The final combination: `visibility` (glsl/plateaus_centred/final.frag).
//!
//! Where the speed layer (`--plain` turns it off, `Settings::effective`) may change
//! these functions' inputs:
//! - The plateau, coverage and inner images are cleared and drawn only over the texels the
//!   final pass can read, as the paper form's: every texel read holds what the whole passes
//!   write.
//! - `FinalPass::split` chooses which pixels run the final shader and which get 1 without
//!   a lookup; where the shader runs its inputs are the whole pass's (bit for bit).
//! - Culling leaves out objects outside the light's frustum (light passes) and the
//!   camera's (final pass): they write no texel a lookup reads and no pixel.
//! - Reuse skips the light passes when the light, its radius and every object are
//!   unchanged: the buffers then hold what the same passes wrote.
//!
//! ## Combining edges (what the centring approximates)
//! - Outer: the darkest (LESS on depth t), as the paper. Exact for one edge; two casters'
//!   overlapping outer penumbrae are never lighter than either alone.
//! - Inner: the lightest (MAX). For a convex blocker the light reaching a point is at least
//!   what the nearest edge alone lets through; the cones inside a convex corner are darker
//!   than the sheets beside them and lose.
//! - Thin blockers: each inner fragment marches `coverage` inward (8 steps over the
//!   half-width, then 3 bisections) for the drop shadow's far edge, d beyond the texel, and
//!   adds disc_chord(d / w): through a strip between parallel edges a point sees the disc's
//!   segment beyond each edge. A blocker narrower than its penumbra is never a full umbra.
//!   The outer side has no such term: a point just outside a thin blocker gets the single
//!   edge's value (too dark), which is what limits the `radius-huge` stress case (a light
//!   larger than the scene: 0.33 mae_lit, allowance in src/eval/stress.rs).
//! - Overlapping casters: the march runs over the union of the drop shadows, and an edge
//!   whose outside lies in any drop shadow draws no inner penumbra (silhouette edges inside
//!   a caster's own outline, e.g. folds of `bunny`, included): the union's outline draws
//!   it. Letting edges through when the caster outside is at about the same height (to
//!   soften a fence's rail-post crossings) lightened bunny's umbra: mae_lit 0.030 -> 0.048.
//!
//! ## Known artefacts
//! The paper's: cones are circles, exact for a disc light parallel to the plane (a low
//! light stretches the true penumbra along its direction: the tip of `cylinder`'s long
//! shadow is too sharp on both sides), creases at concavities, only the chosen plane is
//! soft: other receivers get the shadow map's hard result, so a thin blocker's shadow on
//! anything but the plane (a fence's post over its rail) is still a full umbra
//! (tests/centred_penumbra.rs judges this form's thin-blocker rule on the plane only). Both halves use the
//! straight-edge profile, so curved outlines get a slightly too dark inner penumbra. The
//! march and the hidden-edge test are quantised to the texture's texels. The inner
//! fragments cost up to 13 texel fetches each (own texel, hidden-edge test, 8 + 3 march
//! steps), only inside the drop shadow.

use super::plateaus::Plateaus;
use super::{Form, TechniqueInfo};

pub const INFO: TechniqueInfo = TechniqueInfo {
    name: "plateaus-centred",
    summary: "plateaus with inner cones and sheets: disc-chord penumbra centred on the hard edge",
    create: |init| Plateaus::create(init, Form::Centred),
};
