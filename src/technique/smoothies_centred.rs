//! # smoothies-centred — Chan & Durand 2003 with the penumbra centred on the hard edge
//! Port sheet: docs/port/smoothies-centred.md
//! Speed layer: speed::smoothies, speed::regions — off under --plain.
//!
//! `smoothies` (src/technique/smoothies.rs, whose header this one builds on) takes the hard
//! shadow from the light's centre as the umbra and grows the penumbra outward from it (the
//! paper's Sec. 3: "smoothies ... only extend outward"), so every shadow is too large and
//! too dark. From the light's centre the hard edge of a straight blocker edge is where the
//! true visibility of a disc light is 0.5; the true penumbra runs from the inner edge (0,
//! inside the hard shadow) through the hard edge to the outer edge (1), with the disc-chord
//! profile v(s) = (1/pi)(acos s - s sqrt(1 - s^2)) (glsl/common/penumbra.glsl, s = the signed
//! distance from the hard edge over the penumbra's half-width, positive inside). This form
//! draws the paper's outer smoothies AND inner smoothies, extruded from the silhouette into
//! the hard shadow: the inner and outer fins of Cai, Jia, Wang, Hu & Martin, *Multilayered
//! shadow fins* (CGF 25(1) 2006), which avoid the umbra over-estimation the same way. Same
//! pass order and struct as the paper form (`smoothies::Smoothies`, `Form::Centred`); this
//! module holds what is the centred form's own: the smoothie pass's attachments
//! (`TARGETS`), its outer and inner pipelines (`pipelines`) and the final shader
//! (`FINAL_SHADER`).
//!
//! ## Geometry
//! The reference construction, `silhouette::smoothie::build_smoothies_side`: `Side::Outer`
//! is the paper's (edge quads outward by t, corner fans over the gaps between outward
//! normals); `Side::Inner` is the same construction reflected into the hard shadow (quads
//! extruded by -d, each fan reflected through its vertex; module doc of
//! src/silhouette/smoothie.rs, "Inner smoothies"). The renderer draws the compact records of
//! `smoothie::records` for both sides: the inner records are the outer ones with each
//! edge's direction and each fan's first spoke negated (`SmoothieRecords::mirrored`,
//! expanded without the copy by `expand_side`), held to the inner reference by
//! `silhouette::smoothie::equivalence`. The GPU path (`--silhouettes gpu`, the paper
//! form's compute passes, glsl/silhouette/) writes the outer smoothies only; the inner
//! pipeline draws that same buffer again through `glsl/smoothies_centred/mirrored.vert`,
//! which reflects each quad's vertex across its hard-edge line (direction negated) and
//! each fan's through its silhouette vertex: the mirrored records' triangles, without a
//! second buffer (tests/gpu_silhouettes.rs: the same image as the CPU path).
//!
//! The width t is the paper form's (`--smoothie-t`, else calibrated per silhouette vertex,
//! t = R / (2 b tan(fov/2)), capped at 0.2). With the calibrated t, a disc light of radius
//! R gives a receiver at linear depth r a penumbra of half-width t (1 - b/r) uv on either
//! side of the hard edge of a blocker edge at depth b: the paper's remap
//! alpha' = alpha / (1 - b/r) (Eq. 1) is s itself, on both sides.
//!
//! Under a sun (smoothies.rs, "Under a sun"): t = D tan(theta) / (2 h) for every vertex,
//! D the map's depth range and 2 h its side, and (Eq. 1s) alpha' = alpha / ((r - b) / D)
//! in place of Eq. 1, so the half-width is t (r - b) / D = (r - b) tan(theta) / (2 h) uv on
//! either side of the hard edge: outer s = alpha' as above, inner s = x / (t (Z_R - b) /
//! D) (`remap_denom` in inner.frag); the centred profile spans 2 (r - b) tan(theta), the
//! sun's straight-edge penumbra under an overhead sun. b is interpolated linearly for a
//! sun (glsl/smoothies/light.glsl). The inner side's hidden-receiver estimate is the
//! spotlight's (1/depth extrapolated over a plane); under a parallel projection depth
//! itself is affine there, so on a tilted receiver Z_R bends by up to its 5 % limit.
//!
//! ## Passes, in order
//! 0. `smoothies-centred/silhouettes` (R > 0) — CPU path (a `cpu` timing): per moved
//!    caster, silhouette from the light centre, then the smoothie records (`build_records`,
//!    as the paper form's CPU path), expanded into the outer smoothies' triangles and the
//!    inner (mirrored) ones' (`SmoothieRecords::expand_side`); every caster's outer
//!    triangles are uploaded to one host-visible vertex buffer, every caster's inner ones
//!    to another. GPU path (a timed pass): the paper form's compute dispatches, outer
//!    smoothies only, cut by the speed layer to one extent for the frame, the inner side's
//!    (`speed::smoothies::gpu_extent`; full width t under `--plain`).
//! 1. `smoothies-centred/shadow_map` — the shared `ShadowMap`: R32G32_SFLOAT, clear 1e30,
//!    blend MIN, no depth attachment; r = nearest caster's linear depth, g = nearest
//!    surface's of any role. Read only by pass 2: g at the smoothie fragment's own texel
//!    and, for an inner one, 1.0 and 5.0 texels outside its edge (1.5 and 5.5 past a caster
//!    in front at 1.0); r along the thin-blocker marches (both sides) and, for an inner
//!    one, at its own texel.
//! 2. `smoothies-centred/smoothie` — one timed pass, two rendering scopes (outer, then
//!    inner), each with one colour attachment of its own, no depth attachment, culling off:
//!    `smoothie_outer` = R32_SFLOAT, clear 2^24 - 1, blend MIN: the outer key
//!    (glsl/common/packed.glsl, `packed`) of the outer visibility's share s (the profile's
//!    argument, glsl/common/penumbra.glsl: -1 lit, 0 the hard edge; the darkest value, the
//!    largest s, wins: the paper's rule) and the linear depth b of the smoothie that made
//!    it: the paper form's buffer, with the share in place of alpha, in one channel;
//!    `smoothie_inner` = R32_SFLOAT, clear 2^24 - 1, blend MIN: the inner key of the inner
//!    visibility's share (1 umbra; MIN keeps the lightest inner estimate) and the depth of
//!    the receiver it was made for (of equal shares, the farthest). Shares, not
//!    visibilities: across a straight edge's penumbra the share is linear in the distance,
//!    so the final pass's bilinear interpolation reproduces it exactly, where the S-shaped
//!    profile, flat at both ends, would spread each penumbra by a tent one texel wide.
//!    A key holds the value MIN must pick in its high bits (-s, outside the hard edge,
//!    over 512 levels of [0, 1]; the inner (1 + s) / 2 over 1024) and a depth code in
//!    its low bits (b over 32768, the receiver over 16384, on a log scale of the light's
//!    range: rounded within 1.8e-4 and 3.5e-4 of the depth, below the depth bias and the
//!    5 % receiver window they are tested with), so that the final pass reads both values
//!    with one gather where two channels cost two.
//!    The depth that travels with a value is the one it was made with: of several outer
//!    smoothies over a texel, b is the darkest one's (the paper's buffer keeps the nearest
//!    b beside the darkest v); of several inner values, the receiver is the lightest
//!    one's (where the farthest of all had let a point deep behind one caster take a
//!    value made for a nearer receiver: fewer false edges on `bunny` and `fence` at their
//!    radii, mae_lit within 1e-4 on every built-in scene). An attachment per side: a
//!    fragment blends only the 4 bytes its side makes, and every value is MIN, so no
//!    independentBlend.
//!    Two pipelines, both with glsl/smoothies/smoothie.vert over the CPU path's expanded
//!    triangles (`SmoothieRecords::expand_side`), one draw each: every caster's outer
//!    smoothies into `smoothie_outer`, then every caster's inner ones (the same records
//!    mirrored) into `smoothie_inner`. On the GPU path both draw the compute passes'
//!    buffer indirectly, the inner pipeline through glsl/smoothies_centred/mirrored.vert
//!    (the reflection, "Geometry" above):
//!    - outer smoothies, `glsl/smoothies_centred/outer.frag`: the paper form's fragment
//!      program and decision (`smoothie_alpha`, glsl/smoothies/alpha.glsl: receiver r =
//!      the shadow map's g at its texel), s = alpha' in [0, 1), v = disc_chord(-s) in
//!      [0.5, 1), plus, for a blocker narrower than its penumbra, the disc's segment
//!      beyond its far edge (`outer_far_share`, below); writes the key of (v's share, b):
//!      -s, or where the far segment adds light, `chord_share(v)` (disc_chord's inverse,
//!      glsl/common/penumbra.glsl), only where the smoothie darkens a surface, as the
//!      paper form: discarded where g holds no surface, b/r > 1, 1 - b/r < 1e-4 and s >= 1
//!      (fully lit). A lit fragment's key would lose every MIN to a darker one; where it
//!      won, its b would put the points between its depth and the surface's behind a
//!      smoothie that does not darken them (tests/centred_penumbra.rs,
//!      `outer_smoothies_write_only_what_darkens`).
//!    - inner smoothies, `glsl/smoothies_centred/inner.frag`: x = the fragment's distance
//!      inside the hard-edge line (corner: from the vertex), `dir` inward. The receiver
//!      behind this texel is hidden from the light, so its depth Z_R is estimated from the
//!      shadow map's g 1.0 and 5.0 texels outside the edge along -dir: the plane through
//!      the two samples (1/depth is affine across the map over a plane) extrapolated to
//!      this texel, within 5 % of the nearer sample. 1.0 texel is the nearest point whose
//!      texel is not the edge's own caster's: read farther out, a fold just inside a bumpy
//!      blocker's outline would skip the lip between them and draw a penumbra, made for the
//!      ground beyond, that the lip hides (on `dense`, the ground's umbra lit beside
//!      penumbrae about a pixel wide); read there, the lip is the fold's receiver, at its
//!      own depth, and the fold draws nothing. Where a caster more than 1 % in front of b
//!      covers that texel, the samples move to 1.5 and 5.5 texels, so that a neighbour that
//!      only borders the edge does not hide it. Discarded when a caster more than 1 % in
//!      front of b covers 1.5 texels too (the edge is hidden by another caster: no inner
//!      penumbra through it), when this texel is not behind a caster 1 % nearer than Z_R,
//!      or when s = x / (t (1 - b/Z_R)) (a sun's t (Z_R - b) / D) is at least 1 (umbra).
//!      Else v = disc_chord(s) in [0, 0.5], plus the thin-blocker term below; writes the
//!      key of (v's share, Z_R): s, or `chord_share(v)` where the term adds light. Z_R is
//!      at most
//!      Z, 1.05 times the deepest surface where it reads g (a depth the map holds,
//!      extrapolated by at most 5 %), so nothing is written beyond t (1 - b/Z) from the
//!      edge (what the speed layer's shortened inner smoothies rely on).
//! 3. `smoothies-centred/final` — `FinalPass` with `glsl/smoothies_centred/final.frag`: per
//!    texel of the 2x2 footprint (textureGather of the shadow map's r and of the keys of
//!    `smoothie_outer` and `smoothie_inner` at the lookup point, three gathers), as
//!    shares: outer = the outer share if the point is behind its smoothie (its key's depth
//!    code against the point's, `in_front_of_codes`), else -1; in front of the nearest
//!    caster: outer; behind it: max(outer, the inner share) if the point is at most 5 %
//!    beyond the receiver depth that inner value was made for, else 1 (a
//!    point behind a second caster, e.g. the ground under two stacked boxes, stays in the
//!    umbra), the inner share s over k where the point is more than 5 % nearer than that
//!    receiver (its own penumbra, k times as wide: `inner_at_depth`,
//!    glsl/common/nearer_receiver.glsl). The shares are interpolated with `hard`'s
//!    bilinear weights and the visibility is disc_chord of the result (`share_visibility`,
//!    exactly 1 and 0 at the ends); no falloff texture. R = 0 draws no
//!    smoothie and returns `hard`'s bilinear value: `hard`'s image exactly. Outside the
//!    casters' projections and their smoothies every lookup reads "far" and the shader
//!    returns 1; where every footprint texel is in front of every caster it returns the
//!    outer shares' result without gathering the inner ones. Where a texel is
//!    behind a caster the inner keys are gathered right after the casters: behind at
//!    all four, none holding an inner value (the umbra's inside), it returns 0 from those
//!    two gathers, as the whole combination would (its max takes the inner umbra).
//!
//! ## Equations: what a porter ports
//! - The geometry, both sides: `build_smoothies_side` (src/silhouette/smoothie.rs); the
//!   width t: `Width::at`.
//! - The disc-chord profile v(s), its inverse, the share of an edge plus added light and
//!   the final pass's visibility of an interpolated share: `disc_chord`, `chord_share`,
//!   `summed_share`, `share_visibility` (glsl/common/penumbra.glsl).
//! - The outer side (s = Eq. 1's alpha', and which fragments are written): `smoothie_alpha`
//!   (glsl/smoothies/alpha.glsl), called by glsl/smoothies_centred/outer.frag, with the
//!   thin blocker's far side `outer_far_share` (glsl/common/inner_march.glsl).
//! - The inner side: `main` of glsl/smoothies_centred/inner.frag, with the hidden receiver
//!   `receiver_beyond` and `blocked_at` (glsl/common/inner_receiver.glsl) and the thin
//!   blocker's far edge `far_edge_texels` (glsl/common/inner_march.glsl).
//! - The final combination: `visibility` (glsl/smoothies_centred/final.frag).
//! - Each side's two values in one R32F key (the value MIN picks in the high bits, a
//!   log-scale depth code in the low ones): `outer_key`, `inner_key` and their unpacking
//!   (glsl/common/packed.glsl). A port may keep two MIN-blended channels instead, for
//!   one more gather a side: each channel then keeps its own extreme (the nearest depth,
//!   the farthest receiver), not the depth that travels with the value kept.
//!
//! The speed layer may change these functions' inputs: shortened smoothies round t and 1/b,
//! interpolated over other triangles, differently (visibility within one key step, 1e-3,
//! tests/plain.rs); every other trick leaves each texel read and each shaded pixel's inputs
//! as the whole passes give them (src/technique/speed/smoothies.rs).
//!
//! ## Combining edges (what the centring approximates)
//! - Several outer smoothies at a texel: the darkest (MIN), as the paper. Exact for one
//!   edge; two blockers' overlapping outer penumbrae are never lighter than either alone,
//!   but the darkening of their sum is not modelled.
//! - Several inner smoothies at a texel: the lightest (MIN of the share). For a convex
//!   blocker the light reaching a point is at least what the nearest edge alone lets
//!   through; inner quads overlap at convex corners, and the lighter (nearer edge's) wins.
//! - Thin blockers: each inner fragment searches the shadow map inward along `dir` (up to 6
//!   bisections between its own texel and the texel w in; not at all where the blocker
//!   still covers that texel, and two blockers inside w give either far edge) for the
//!   blocker's far edge, d beyond the texel, and adds disc_chord(d / w): through a strip
//!   between parallel edges a point sees the disc's segment beyond each edge, so per-edge
//!   shares add (the key holds the sum's share, `chord_share`). Inner extents meeting from
//!   both sides of a blocker narrower than its penumbra give partial light, never 0. Each
//!   outer fragment, x outside its edge, does the same from IN_TEXELS (1) inside the edge
//!   for what is left of w (`outer_far_share`; not at all where the blocker still covers
//!   the end of that reach, so a gap between two blockers inside it is not looked for): a
//!   blocker W wide adds disc_chord((x + W) / w), so both sides give
//!   0.5 + disc_chord(W / w) at the hard edge. Without it the outer side kept the
//!   half-plane's 0.5 there while the inner side let the far segment through, and a
//!   blocker narrower than its penumbra (the bunny's ears at 3x its radius) kept its hard
//!   outline inside a penumbra lighter than the ring around it. At a sharp corner of a thin
//!   blocker the march can leave through the other edge and count its segment fully: too
//!   light there; beyond a thin blocker's tip the march runs along it and finds no far
//!   edge: too dark there.
//! - Overlapping casters: an edge whose outside is covered by a nearer caster draws no
//!   inner smoothie, so one caster's inner penumbra never lightens another's umbra; a
//!   caster behind the blocker but in front of the receiver ends the march, and a receiver
//!   behind that second caster gets 0 (the receiver-depth check). A hidden receiver under
//!   another caster's outer smoothie takes the darker of the two (the larger share).
//!
//! ## Known artefacts
//! One receiver per texel on the inner side: Z_R is the plane of the surface just outside
//! the edge; a hidden point more than 5 % beyond it gets the umbra (right behind a second
//! caster, too dark behind a receiver that curves away); one nearer (a rail right behind a
//! post) gets that penumbra narrowed to its own depth. The march and the edge test are
//! quantised to shadow-map texels. Both halves are evaluated for a straight edge, so curved
//! silhouettes get a slightly too dark inner penumbra. The paper's known artefacts remain:
//! silhouettes from the light centre (they pop under light motion; thick smoothies snap on
//! coarse meshes), min rather than the product for overlapping outer penumbrae, and the cap
//! t <= 0.2 (a blocker near the light gets too narrow a penumbra). The inner fragments cost
//! up to 10 shadow-map fetches each (two receiver samples, own texel, the texel one
//! half-width in, and up to 6 bisections only where the blocker has ended by then), only in
//! the inner band; the outer ones one, as the paper's, two more beside a blocker (the
//! search's start inside the edge and the end of the rest of the half-width) and up to 6
//! bisections only where the blocker has ended by then.

use super::packed::{inner_target, outer_target};
use super::smoothies::{smoothie_pipeline_desc, Smoothies};
use super::{Form, LightTarget, TechniqueInfo, TechniqueInit};
use crate::gpu::passes::FinalShader;
use crate::shaders;
use crate::vk::{Blend, DescriptorSet, GraphicsPipelineDesc, Pipeline};
use anyhow::Result;

pub const INFO: TechniqueInfo = TechniqueInfo {
    name: "smoothies-centred",
    summary:
        "smoothies with inner and outer smoothies: disc-chord penumbra centred on the hard edge",
    create: |init| Smoothies::create(init, Form::Centred),
};

/// Pass 2's attachments, one for each side, each drawn by its own pipeline alone: a
/// fragment blends only the values its side makes. Each holds its two values packed in one
/// R32F key (`packed`), so that the final pass reads both with one gather.
pub(super) const TARGETS: [LightTarget; 2] = [
    // The outer share with the depth b of the smoothie that made it (1e30: none): the
    // paper form's buffer, with the share for alpha.
    outer_target("smoothie_outer", &["outer_share", "depth"]),
    inner_target("smoothie_inner"),
];

/// Pass 2's two pipelines, both into `TARGETS` with MIN blending: the outer smoothies'
/// (glsl/smoothies_centred/outer.frag), then the inner ones' (inner.frag; `mirrored`, the
/// GPU path: over the outer smoothies reflected by glsl/smoothies_centred/mirrored.vert).
pub(super) fn pipelines(
    init: &TechniqueInit<'_>,
    smoothie_set: &DescriptorSet,
    mirrored: bool,
) -> Result<[Pipeline; 2]> {
    let [outer_colors, inner_colors] = TARGETS.map(|t| [(t.format, Blend::Min)]);
    let name = Form::Centred.smoothie_names().smoothie;
    let sets = [smoothie_set];
    let outer = shaders::SMOOTHIES_CENTRED_OUTER_FRAG;
    let inner = shaders::SMOOTHIES_CENTRED_INNER_FRAG;
    let inner_desc = GraphicsPipelineDesc {
        // The GPU path's buffer holds the outer smoothies only: reflected here.
        vertex: if mirrored {
            shaders::SMOOTHIES_CENTRED_MIRRORED_VERT
        } else {
            shaders::SMOOTHIES_SMOOTHIE_VERT
        },
        ..smoothie_pipeline_desc(name, inner, &inner_colors, &sets)
    };
    Ok([
        Pipeline::graphics(
            init.ctx,
            &smoothie_pipeline_desc(name, outer, &outer_colors, &sets),
        )?,
        Pipeline::graphics(init.ctx, &inner_desc)?,
    ])
}

/// Pass 3's fragment shader (no falloff texture: the profile is in the values).
pub(super) const FINAL_SHADER: FinalShader = FinalShader {
    color: shaders::SMOOTHIES_CENTRED_FINAL_FRAG,
    aov: shaders::SMOOTHIES_CENTRED_FINAL_FRAG_AOV,
    count: shaders::SMOOTHIES_CENTRED_FINAL_FRAG_COUNT,
};
