//! # plateaus-centred — Haines 2001 with the penumbra centred on the hard edge
//! Port sheet: docs/port/plateaus-centred.md
//! Speed layer: speed::plateaus (light-pass areas, split final pass) — off under --plain.
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
//! penumbra-map-centred): a plateau's depth t is s itself. The passes below are this module's;
//! the planar-receiver rule (a scene without one is refused), the plane frame, the texture
//! square and the cone and sheet builder are the paper form's
//! (src/technique/plateaus_common.rs).
//!
//! Under a sun (plateaus.rs, "Under a sun"): the drop shadow is (P1s)'s parallel
//! projection and the half-width (P2s) r = h tan(theta) / (n . s), the same on both sides of
//! the hard edge across the sun's azimuth and (P2e)'s 1 / (n . s) times that along it; the
//! inner sheets need no change (t is still s), so the centred profile spans 2 h tan(theta)
//! overhead, the sun's straight-edge penumbra.
//!
//! ## Passes, in order
//! 0. CPU `plateaus-centred/silhouettes` (R > 0, light above the plane) — per caster:
//!    silhouette from the light centre, then its cones and outer sheets and its cones and
//!    inner sheets in the texture's clip space (the outer side's 12-byte `PlateauVertex`:
//!    x, y, depth = t; the inner side's 20-byte `PlateauEdgeVertex` adds `from_edge`, the
//!    step from the vertex's edge point along its cone's spoke or sheet's ruling),
//!    uploaded to two host-visible vertex buffers. The cones' bases are
//!    (P2e)'s ellipses, not the paper form's circles (`PlateauBuilder::with_ellipses`): a
//!    low light stretches each point's penumbra along its azimuth (2.5x at the tip of
//!    `cylinder`'s shadow). A side's cone is drawn only at a vertex where that side's two
//!    sheets leave a gap (`PlateauBuilder::with_trimmed_cones`, `sheets_cover`): the outer
//!    side's at convex corners, the inner side's at reflex ones, either where the sheets'
//!    ends lean apart by more than the corner turns. Elsewhere a sheet covers every texel
//!    of the cone at a smaller t, so the cone would lose (LESS outside, MAX of
//!    disc_chord(t) inside) but for its thin-blocker share, marched radially out of a thin
//!    blocker's tip. Where two silhouette curves cross at a vertex (its edges' rays
//!    alternate between arriving and leaving), each of the side's corners there is judged
//!    alike, and the cone is left out when all are covered.
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
//!    R16_SFLOAT, clear 0.0, blend MAX (the lightest inner estimate wins: (1 - s) / 2 of
//!    the inner visibility's share s, glsl/common/penumbra.glsl, 0 umbra), no depth
//!    attachment; `glsl/plateaus_centred/inner.vert` (plateau.vert with `from_edge`
//!    interpolated), then `glsl/plateaus_centred/inner.frag` (reads `coverage` at set 0
//!    binding 0): t = the fragment's depth; discarded outside the drop shadow, and where
//!    the plane 1.5 texels outside the fragment's own edge point (back along its ruling:
//!    where a sheet's rim is not parallel to its edge, t's gradient crosses the edge at a
//!    slant and a point found along it can land on the coverage image's staircase, a
//!    single umbra texel in the penumbra) is under a drop shadow too (a caster nearer the
//!    light there covers the edge's outside; a farther one blocks what the edge lets
//!    through, and one MAX image cannot take the minimum over casters: the union's outline
//!    draws the inner penumbra instead). Else
//!    v = disc_chord(t) plus the thin-blocker term below, written as its share: t, or
//!    `chord_share(v)` (disc_chord's inverse) where the term adds light. Shares, not
//!    visibilities, for the final pass to interpolate (smoothies_centred.rs, pass 2, says
//!    why); the outer plateaus' fraction f is a share already (-f).
//! 4. `plateaus-centred/shadow_map` — the casters-only `ShadowMap` (for receivers other
//!    than the plane), as the paper form's: its final pass reads r alone.
//! 5. `plateaus-centred/final` — `FinalPass` with `glsl/plateaus_centred/final.frag`: a
//!    point on the plane (the paper form's test) takes, at each of the 4 nearest texels,
//!    the outer share -f (-1 where no plateau: lit); outside every drop shadow: outer;
//!    under one: the larger of the inner share and the outer one (a second caster's outer
//!    plateau over this umbra is never lightened); the inner values are gathered only
//!    where a footprint texel lies under a drop shadow, first there (under one at all
//!    four, none holding an inner value, the umbra's inside: 0 from two gathers, as the
//!    max with the inner umbra gives). The shares are interpolated with bilinear weights
//!    and the visibility is disc_chord of the result (`share_visibility`); no falloff
//!    texture. Every other point, and
//!    every point at R = 0, gets the shadow map's 2x2 bilinear comparison: R = 0 is
//!    `hard`'s image exactly (unlike the paper form, whose drop shadow only matches hard up
//!    to the texel grids' aliasing). The speed layer's split final pass holds the inner
//!    cones and sheets too: they lie in the same discs' hull.
//!
//! ## Equations: what a porter ports
//! - (P1)-(P3) and (P2e), both sides: the paper form's functions
//!   (src/technique/plateaus.rs), the inner sheets by the same builder with `Side::Inner`,
//!   the ellipses by `Disc` (src/technique/plateaus_common.rs).
//! - The disc-chord profile v(s), its inverse, the share of an edge plus added light and
//!   the final pass's visibility of an interpolated share: `disc_chord`, `chord_share`,
//!   `summed_share`, `share_visibility` (glsl/common/penumbra.glsl).
//! - The inner side: `main` of glsl/plateaus_centred/inner.frag, with `far_edge_texels`
//!   (glsl/common/inner_march.glsl).
//! - The final combination: `visibility` (glsl/plateaus_centred/final.frag).
//!
//! Where the speed layer may change these functions' inputs: as the paper form's (the
//! plateau, coverage and inner images are cleared and drawn only over the texels the final
//! pass can read; every texel read holds what the whole passes write).
//!
//! ## Combining edges (what the centring approximates)
//! - Outer: the darkest (LESS on depth t), as the paper. Exact for one edge; two casters'
//!   overlapping outer penumbrae are never lighter than either alone.
//! - Inner: the lightest (MAX). For a convex blocker the light reaching a point is at least
//!   what the nearest edge alone lets through; a cone inside a convex corner would be darker
//!   than the sheets beside it, and is not drawn.
//! - Thin blockers: each inner fragment searches `coverage` inward (up to 6 bisections
//!   between its own texel and the texel one half-width in; not at all where the drop
//!   shadow still covers that texel, and two gaps inside that reach give either) for the
//!   drop shadow's far edge, d beyond the texel, and adds disc_chord(d / w): through a
//!   strip between parallel edges a point sees the disc's segment beyond each edge. A
//!   blocker narrower than its penumbra is never a full umbra. The outer side has no such
//!   term: a point just outside a thin blocker gets the single edge's value (too dark),
//!   which is what limits the `radius-huge` stress case (a light larger than the scene:
//!   0.40 mae_lit, allowance in src/eval/stress.rs).
//! - Overlapping casters: the march runs over the union of the drop shadows, and an edge
//!   whose outside lies in any drop shadow draws no inner penumbra (silhouette edges inside
//!   a caster's own outline, e.g. folds of `bunny`, included): the union's outline draws
//!   it. Letting edges through when the caster outside is at about the same height (to
//!   soften a fence's rail-post crossings) lightened bunny's umbra: mae_lit 0.030 -> 0.048.
//!
//! ## Known artefacts
//! The paper's: creases at concavities, only the chosen plane is
//! soft: other receivers get the shadow map's hard result, so a thin blocker's shadow on
//! anything but the plane (a fence's post over its rail) is still a full umbra
//! (tests/centred_penumbra.rs judges this form's thin-blocker rule on the plane only). Both halves use the
//! straight-edge profile, so curved outlines get a slightly too dark inner penumbra. A
//! sheet takes one stretch for both its cones, so where the stretch changes along an edge
//! it meets them off their tangents (a crease, at most the two ellipses' difference). The
//! march and the hidden-edge test are quantised to the texture's texels. The inner
//! fragments cost up to 9 texel fetches each (own texel, hidden-edge test, the texel one
//! half-width in, and up to 6 bisections only where the drop shadow has ended by then),
//! only inside the drop shadow.

use super::plateaus::{drop_shadow_pipeline, plateau_pipeline};
use super::plateaus_common::{PlateauCommon, PLATEAU_EDGE_ATTRIBUTES, PLATEAU_EDGE_VERTEX_BYTES};
use super::{
    shadow_map_buffer, FrameInput, LightBuffer, Packing, Technique, TechniqueInfo, TechniqueInit,
};
use crate::gpu::passes::{DynamicVertices, FinalPass, FinalShader, Shadowed};
use crate::shaders;
use crate::vk::{
    Blend, Clear, Context, CullModeFlags, DescriptorSet, Format, GraphicsPipelineDesc, Image,
    ImageUsageFlags, Pipeline, PrimitiveTopology, Recorder, Resource,
};
use anyhow::Result;

pub const INFO: TechniqueInfo = TechniqueInfo {
    name: "plateaus-centred",
    summary: "plateaus with inner cones and sheets: disc-chord penumbra centred on the hard edge",
    create: |init| Ok(Box::new(PlateausCentred::create(init)?)),
};

/// The pass names (= timestamp and debug labels).
struct Names {
    technique: &'static str,
    silhouettes: &'static str,
    drop_shadow: &'static str,
    plateaus: &'static str,
    inner: &'static str,
    shadow_map: &'static str,
    final_pass: &'static str,
}

const NAMES: Names = super::pass_names!(
    Names {
        silhouettes: "silhouettes",
        drop_shadow: "drop_shadow",
        plateaus: "plateaus",
        inner: "inner",
        shadow_map: "shadow_map",
        final_pass: "final",
    },
    "plateaus-centred"
);

pub struct PlateausCentred {
    /// The receiver, plane uniforms, plateau texture, z-buffer, shadow map and geometry.
    common: PlateauCommon,
    /// R16F, clear 1: 0 where a caster's drop shadow falls.
    coverage: Image,
    /// R16F, clear 0, MAX: (1 - s) / 2 of the lightest inner share s.
    inner: Image,
    drop_pipeline: Pipeline,
    plateau_pipeline: Pipeline,
    inner_pipeline: Pipeline,
    inner_set: DescriptorSet,
    /// Every caster's cones and inner sheets.
    inner_vertices: DynamicVertices,
    final_pass: FinalPass,
    final_set: DescriptorSet,
}

impl PlateausCentred {
    fn create(init: &TechniqueInit<'_>) -> Result<Self> {
        let ctx = init.ctx;
        let res = init.settings.shadow_res;
        let common = PlateauCommon::new(init, NAMES.drop_shadow, NAMES.shadow_map)?;
        ctx.require_blend(Format::R16_SFLOAT, Blend::Max, NAMES.technique)?;
        let usage = ImageUsageFlags::COLOR_ATTACHMENT
            | ImageUsageFlags::SAMPLED
            | ImageUsageFlags::TRANSFER_SRC;
        let coverage = Image::new_2d(ctx, res, res, Format::R16_SFLOAT, usage, "plateau coverage")?;
        let inner = Image::new_2d(ctx, res, res, Format::R16_SFLOAT, usage, "plateau inner")?;
        // The drop shadow into its own coverage image, without the z-buffer: the outer
        // plateaus of other casters must stay visible inside it.
        let drop_pipeline = drop_shadow_pipeline(
            ctx,
            NAMES.drop_shadow,
            &common.drop_set,
            Format::R16_SFLOAT,
            None,
        )?;
        let plateau_pipeline = plateau_pipeline(ctx, NAMES.plateaus)?;
        let nearest = &common.nearest;
        let inner_set = DescriptorSet::new(
            ctx,
            &[("coverage", Resource::Sampled(&coverage, nearest))],
            NAMES.inner,
        )?;
        let inner_pipeline = Pipeline::graphics(
            ctx,
            &GraphicsPipelineDesc {
                name: NAMES.inner,
                vertex: shaders::PLATEAUS_CENTRED_INNER_VERT,
                fragment: Some(shaders::PLATEAUS_CENTRED_INNER_FRAG),
                vertex_stride: PLATEAU_EDGE_VERTEX_BYTES,
                attributes: PLATEAU_EDGE_ATTRIBUTES,
                topology: PrimitiveTopology::TRIANGLE_LIST,
                cull: CullModeFlags::NONE,
                // Lightest inner estimate wins.
                colors: &[(Format::R16_SFLOAT, Blend::Max)],
                depth: None,
                push_constant_bytes: 0,
                sets: &[&inner_set],
            },
        )?;
        // The final pass reads the shadow map's r alone: the inner plateaus are built on
        // the plane, from the drop shadow's coverage, not from receiver depths.
        let final_set = DescriptorSet::new(
            ctx,
            &[
                ("frame", Resource::Uniform(init.ubo)),
                ("plane", Resource::Uniform(&common.plane_ubo)),
                ("plateau_tex", Resource::Sampled(&common.texture, nearest)),
                (
                    "shadow_map",
                    Resource::Sampled(&common.shadow.depth, nearest),
                ),
                ("coverage", Resource::Sampled(&coverage, nearest)),
                ("inner_tex", Resource::Sampled(&inner, nearest)),
            ],
            NAMES.final_pass,
        )?;
        let final_shader = FinalShader {
            color: shaders::PLATEAUS_CENTRED_FINAL_FRAG,
            aov: shaders::PLATEAUS_CENTRED_FINAL_FRAG_AOV,
            count: shaders::PLATEAUS_CENTRED_FINAL_FRAG_COUNT,
        };
        let final_pass = FinalPass::split(ctx, NAMES.final_pass, final_shader, &final_set)?;
        Ok(Self {
            common,
            coverage,
            inner,
            drop_pipeline,
            plateau_pipeline,
            inner_pipeline,
            inner_set,
            inner_vertices: DynamicVertices::new("plateau inner vertices"),
            final_pass,
            final_set,
        })
    }
}

impl Technique for PlateausCentred {
    fn name(&self) -> &'static str {
        NAMES.technique
    }

    fn record_light(
        &mut self,
        ctx: &Context,
        rec: &mut Recorder<'_>,
        frame: &FrameInput<'_>,
    ) -> Result<()> {
        // Pass 0, and where the speed layer lets passes 1-4 draw.
        let p = self
            .common
            .prepare(ctx, rec, frame, NAMES.silhouettes, true)?;
        self.inner_vertices.upload(ctx, &p.inner)?;
        let (c, area) = (&self.common, p.areas.texture);
        rec.pass(NAMES.drop_shadow, |rec| {
            rec.begin_rendering_in(&[(&self.coverage, Clear::Float([1.0; 4]))], None, area);
            if p.lit_plane {
                c.draw_drop_shadow(rec, frame, &self.drop_pipeline);
            }
            rec.end_rendering();
            Ok(())
        })?;
        // Outer plateaus over a cleared texture and z-buffer (no drop shadow in them), then
        // the inner ones; both passes run at R = 0 too, so that the final pass always reads
        // written images.
        rec.pass(NAMES.plateaus, |rec| {
            rec.begin_rendering_in(
                &[(&c.texture, Clear::Float([1.0; 4]))],
                Some((&c.zbuffer, Some(1.0))),
                area,
            );
            rec.discard_after(&c.zbuffer);
            if !c.vertices.is_empty() {
                rec.bind_pipeline(&self.plateau_pipeline);
                c.vertices.draw(rec);
            }
            rec.end_rendering();
            Ok(())
        })?;
        rec.pass(NAMES.inner, |rec| {
            rec.begin_rendering_in(&[(&self.inner, Clear::Float([0.0; 4]))], None, area);
            if !self.inner_vertices.is_empty() {
                rec.bind_pipeline(&self.inner_pipeline);
                rec.bind_sets(&self.inner_pipeline, &[&self.inner_set]);
                self.inner_vertices.draw(rec);
            }
            rec.end_rendering();
            Ok(())
        })?;
        c.shadow.pass_in(rec, frame.gpu, &p.areas.map)
    }

    fn light_passes(&self) -> Vec<String> {
        [
            NAMES.drop_shadow,
            NAMES.plateaus,
            NAMES.inner,
            NAMES.shadow_map,
        ]
        .map(String::from)
        .to_vec()
    }

    fn record_final(
        &mut self,
        _ctx: &Context,
        rec: &mut Recorder<'_>,
        frame: &FrameInput<'_>,
    ) -> Result<()> {
        let shadowed = self.common.speed.shadowed();
        self.final_pass
            .pass_in(rec, frame, &self.final_set, shadowed)
    }

    fn shadowed(&self) -> Option<&Shadowed> {
        Some(self.common.speed.shadowed())
    }

    fn light_buffers(&self) -> Vec<LightBuffer<'_>> {
        vec![
            // The outer plateaus' fraction f only (no drop shadow), 1 lit.
            LightBuffer {
                name: "plateaus",
                image: &self.common.texture,
                channels: &["fraction"],
                packing: Packing::Plain,
            },
            shadow_map_buffer("shadow_map", &self.common.shadow),
            // 0 under a caster's drop shadow, 1 elsewhere.
            LightBuffer {
                name: "coverage",
                image: &self.coverage,
                channels: &["drop_shadow_visibility"],
                packing: Packing::Plain,
            },
            // (1 - s) / 2 of the lightest inner share s (glsl/common/penumbra.glsl), the
            // profile's linear stand-in: 0.5 at the hard edge, 0 umbra (and where none was
            // drawn), above 0.5 where a thin blocker's far side lets light through.
            LightBuffer {
                name: "inner",
                image: &self.inner,
                channels: &["inner_linear_visibility"],
                packing: Packing::Plain,
            },
        ]
    }
}
