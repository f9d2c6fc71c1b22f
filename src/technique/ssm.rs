//! # ssm / ssm2 — Atty, Holzschuch, Lapierre, Hasenfratz, Hansen, Sillion 2006,
//! *Soft Shadow Maps: Efficient Sampling of Light Source Visibility*
//! Port sheets: docs/port/ssm.md, docs/port/ssm2.md
//! Speed layer: speed::ssm (the micro-patch step, pass 4; kept under --plain, see there).
//! Over 400 lines because the header (about 130 lines) carries both lights' equations, the
//! spotlight's square light and the sun's square of directions, for a porter in one place.
//!
//! Every texel of an occluder depth map becomes a micro-patch: a square parallel to the
//! light at the texel's depth, covering the texel's image extent (Sec. 3.2). Each
//! micro-patch's penumbra extent is drawn as a quad into the soft shadow map (SSM), whose
//! fragment program back-projects the micro-patch onto the light from the receiver point
//! of that texel and adds the occluded fraction of the light with additive blending
//! (Sec. 3.3-3.4, 4.2). The SSM is then projected onto the receivers. `ssm2` (Sec. 3.5) also
//! discretises the farthest (back) faces of the occluders into a second SSM and merges the
//! two with max.
//!
//! ## The light
//! The paper's light is a rectangle parallel to the occluder map's image plane; docs/DESIGN.md's
//! light is a disk of radius R. Here: the axis-aligned **square of the same area**, side
//! L = R sqrt(pi), centred at the light position, in the light's view plane (axes = the
//! occluder map's axes). R = 0 is a point light: each micro-patch hides the light
//! entirely from the receivers behind its own texel, i.e. a hard shadow at occluder_res.
//!
//! ## Under a sun
//! A sun is every direction within theta of its axis, its map orthographic (`res` texels
//! of one world size E / N at every depth). Its "light" is the square of directions of the
//! same solid angle (small theta): side L_s = sqrt(pi) tan(theta) in tangent units, across
//! the map's axes. A micro-patch is back-projected onto it along directions, not through a
//! point: from the receiver at map texel r and depth z_R, the patch edge at texel a and depth
//! z_O lies in the direction of tangent (a - r) (E / N) / (z_R - z_O), so
//! * (Ss) S = E / (N L_s (z_R - z_O)) squares of directions per texel of (a - r), the
//!   occluded fraction the same product of overlaps with [-1/2, 1/2];
//! * (Hs) the extent grows by h = (L_s / 2) (z_max - z_O) / (E / N) texels: the half-side's
//!   penumbra grows linearly with the blocker-to-receiver distance (under a spotlight as
//!   (1/z_O - 1/z_max)); the micro-patch step (pass 4) takes the same h;
//! * the final lookup's normal offset and depth tolerances take the world texel E / N,
//!   its depth the orthographic clip z (`clip_linear_depth`).
//!
//! Both are `penumbra_half_uv` (glsl/common/frame.glsl) scaled by L / (2 R) = sqrt(pi) / 2:
//! S = 1 / (2 N (L / 2R) penumbra_half_uv(z_R, z_O)), h = N (L / 2R) penumbra_half_uv(z_max,
//! z_O); the spotlight keeps its own expressions, which equal them.
//!
//! ## Resolutions and parameters
//! All light-space buffers of this technique are `Settings::occluder_res` square (occluder
//! maps, receiver map, SSM, one SSM texel per receiver-map texel); `shadow_res` is unused.
//! `Settings::accum_format` picks the SSM format: R32_SFLOAT (default) or R16_SFLOAT (the
//! paper's FP16 blending, to reproduce Appendix A Eq. 4: a micro-patch hiding less than
//! 2^-10 of the light is lost when added to an occlusion near 1, which happens more often
//! as the occluder map grows).
//!
//! ## Occluders and receivers (the paper separates them; scenes here have role `both`)
//! Occluders = objects that cast (`caster`, `both`). Receivers come in two layers in the
//! receiver map: layer 0, "front", the nearest receiving object (`receiver` or `both`) per
//! texel, what the light centre sees of the receivers; layer 1, "pure", the nearest
//! receive-only object (the paper's receivers, e.g. the ground), FAR where there is none.
//! The SSM holds one accumulated occlusion per layer. A point in the final pass that is
//! its texel's front receiver reads layer 0; a point behind it (the ground under a caster,
//! a caster's far side) reads layer 1 — without it, ground under a `both` caster would get
//! the caster's own (unshadowed) value. Self-occlusion follows the paper: a micro-patch
//! at or less than a small guard in front of the receiver is discarded (see the guard
//! below), so a caster does not shadow its own lit surface.
//!
//! ## Passes, in order (`ssm2` names its passes `ssm2/...`)
//! 1-3. `ssm/maps` (one draw of every object into the occluder map, R32G32_SFLOAT, MIN:
//!    r = nearest caster depth, and the receiver map, two R32_SFLOAT layers, MIN: nearest
//!    receiver, nearest pure receiver), `ssm2/back_occluder_map` (ssm2 only: the farthest
//!    caster surfaces, GREATER) and `ssm/receiver_bound` (compute: z_max, the
//!    conservative z_R of the penumbra extents, Sec. 3.3): src/technique/ssm_common.rs,
//!    which lists their attachments and shaders; the bitmask forms share them.
//! 4. `ssm/micro_patch_step` — compute `glsl/ssm/patch_step.comp` (speed::ssm): the side s
//!    of the texel blocks pass 5 draws as one patch; s = 1 (one patch per texel, the paper)
//!    unless the patches would shade more than N^4 / 64 fragments.
//! 5. `ssm/soft_shadow` — one instanced draw, N^2 instances (one per occluder texel) of a
//!    4-vertex triangle strip, no vertex buffer. `glsl/ssm/soft_shadow.vert` texelFetches
//!    the occluder map and emits the penumbra extent (Sec. 3.3, Fig. 7-8) grown from the
//!    texel square by h = L N / (4 tan(fov/2)) (1/z_O - 1/z_max) texels, or a degenerate quad
//!    outside clip space for an empty texel or a patch behind z_max. With s > 1 instance k
//!    draws block k instead: the bounding rectangle of its occupied texels at their harmonic
//!    mean depth, its occlusion scaled by the share of the rectangle they occupy, its extent
//!    from the block's nearest depth and its guard from its farthest.
//!    `glsl/ssm/soft_shadow.frag` reads both receiver layers at its texel and, per layer,
//!    back-projects the patch onto the light: scale S = 2 tan(fov/2) / (N L) z_O z_R /
//!    (z_R - z_O) light widths per texel, occluded fraction = product of the two interval
//!    overlaps with [-1/2, 1/2] (Sec. 4.2). Two attachments of `accum_format` (layer 0,
//!    layer 1), clear 0, blend **ADD**. The GPU generates the quads (the paper read the
//!    occluder map back to the CPU, Sec. 4.1; its Sec. 4.3 suggests this GPU path).
//! 6. `ssm2/soft_shadow_back` (ssm2 only) — pass 5 again with the back occluder map into
//!    two more attachments, with the block side of the front map.
//! 7. `ssm/final` — camera pass (`FinalPass`), `glsl/ssm/final.frag`
//!    (`glsl/ssm2/final.frag` defines TWO_SIDED; both include `glsl/ssm/final.glsl`):
//!    normal-offset point (in occluder texels), 2x2 footprint of the receiver map and the
//!    SSMs; per texel layer 0 if the point is within 3 texels of depth slope of the front
//!    receiver, layer 1 if behind, no data if the front receiver is behind the point
//!    (weights renormalised); ssm2 takes max(front SSM, back SSM) per layer; occlusion
//!    clamped to \[0,1\] per texel, bilinear weights; visibility = 1 - occlusion.
//!
//! ## Equations: what a porter ports
//! - The penumbra extent (Sec. 3.3, Fig. 7-8): `main` of glsl/ssm/soft_shadow.vert.
//! - The back-projection of a micro-patch (Sec. 3.4, Fig. 9; Sec. 4.2's overlaps):
//!   `occlusion` (glsl/ssm/soft_shadow.frag).
//! - The final lookup (Sec. 3.1; ssm2's max, Sec. 3.5): `visibility` (glsl/ssm/final.glsl),
//!   with `ssm_offset_point`, `ssm_layers` and `ssm_footprint` (glsl/ssm/footprint.glsl).
//!
//! Where the speed layer may change these functions' inputs: culling leaves out objects
//! that write no texel read and no pixel, reuse skips the light passes when nothing moved
//! (`--plain` turns both off); the micro-patch step (s > 1) changes the patches drawn.
//! Every map is drawn whole and the final pass is one whole pass.
//! Frame constants: `frame.technique` = (L, N = occluder_res, 1/N, guard in texels).
//!
//! ## Cost
//! Linear in occluder-map texels (one micro-patch each) in `soft_shadow`, after the camera
//! `final` pass; ssm2 adds a second occluder map and micro-patch pass (the paper measures
//! 1.6-1.8x ssm). Measured ratios to `hard`: BENCHMARKS.md.
//!
//! ## Known artefacts
//! - Only what the light centre sees of the occluders is discretised (Sec. 5.1.1): parts of
//!   the occluders visible from the light's edge only are missing (ssm2 adds the back faces).
//! - Back-projections of neighbouring micro-patches overlap or leave gaps (Sec. 5.1.2,
//!   Eq. 1-3): too dark or too light penumbrae for large lights and depth discontinuities;
//!   sums above 1 are clamped.
//! - Occluder-map aliasing: staircase at R = 0 and small R at occluder_res (Sec. 5.2.4).
//! - R16F: lost contributions (too light shadows, "holes") above ~256^2 (Appendix A, Eq. 4).
//! - Surfaces between the two receiver layers (a caster's face hidden by another caster)
//!   take the pure receiver's occlusion behind them; self-shadowing of a caster by its own
//!   parts closer than the guard is missing (the paper has no self-shadowing at all).
//! - Speckles near the terminator of curved casters (bunny): staircase steps of the
//!   caster's own surface deeper than the guard count as occluders of itself.
//! - Cost grows with the penumbra extents: N^2 patches times (2h+1)^2 texels each (Sec. 6),
//!   up to N^4 / 64 fragments; beyond, blocks of texels make coarser penumbrae (pass 4).

use super::ssm_common::{ssm_uniforms, LightInputs, ReceiverMap, MAP_USAGE};
use super::{FrameInput, LightBuffer, Packing, Technique, TechniqueInfo, TechniqueInit};
use crate::gpu::passes::{FinalPass, FinalShader};
use crate::settings::AccumFormat;
use crate::shaders;
use crate::vk::{
    Blend, Clear, Context, CullModeFlags, DescriptorSet, Filter, Format, GraphicsPipelineDesc,
    Image, Pipeline, PrimitiveTopology, Recorder, Resource, Sampler,
};
use anyhow::{Context as _, Result};

pub use super::speed::ssm::PatchStepReport;
pub use super::ssm_common::light_square_side;

pub const INFO: TechniqueInfo = TechniqueInfo {
    name: "ssm",
    summary:
        "Atty et al. 2006: soft shadow map, GPU micro-patch back-projection, additive blending",
    create: |init| Ok(Box::new(Ssm::create(init, false)?)),
};

pub const INFO2: TechniqueInfo = TechniqueInfo {
    name: "ssm2",
    summary:
        "Atty et al. 2006 two-sided: front and back occluder maps, soft shadow maps merged with max",
    create: |init| Ok(Box::new(Ssm::create(init, true)?)),
};

/// One occluder map's micro-patches into one pair of SSM layers.
struct SoftShadow {
    /// Layer 0 (nearest receiver) and layer 1 (pure receiver) accumulations.
    layers: [Image; 2],
    set: DescriptorSet,
    name: &'static str,
}

impl SoftShadow {
    fn new(
        init: &TechniqueInit<'_>,
        inputs: &LightInputs,
        occluder_map: &Image,
        nearest: &Sampler,
        name: &'static str,
    ) -> Result<Self> {
        let (ctx, res) = (init.ctx, init.settings.occluder_res);
        let accum = accum_format(init.settings.accum_format);
        let layers = [
            Image::new_2d(ctx, res, res, accum, MAP_USAGE, &format!("{name} (front)"))?,
            Image::new_2d(ctx, res, res, accum, MAP_USAGE, &format!("{name} (pure)"))?,
        ];
        let set = inputs.patch_set(init, occluder_map, nearest, Vec::new(), name)?;
        Ok(Self { layers, set, name })
    }
}

pub struct Ssm {
    name: &'static str,
    res: u32,
    inputs: LightInputs,
    soft_pipeline: Pipeline,
    front: SoftShadow,
    back_soft: Option<SoftShadow>,
    final_pass: FinalPass,
    final_set: DescriptorSet,
    _nearest: Sampler,
}

fn accum_format(f: AccumFormat) -> Format {
    match f {
        AccumFormat::R32F => Format::R32_SFLOAT,
        AccumFormat::R16F => Format::R16_SFLOAT,
    }
}

impl Ssm {
    fn create(init: &TechniqueInit<'_>, two_sided: bool) -> Result<Self> {
        let ctx = init.ctx;
        let res = init.settings.occluder_res;
        let name = if two_sided { INFO2.name } else { INFO.name };
        let accum = accum_format(init.settings.accum_format);
        ctx.require_blend(accum, Blend::Add, "the soft shadow map (--accum-format)")?;
        let nearest = Sampler::new(ctx, Filter::Nearest).context("ssm sampler")?;

        // Passes 1-4: occluder and receiver maps, receiver bound, micro-patch step.
        let inputs = LightInputs::new(init, name, two_sided, false, &nearest)?;
        let LightInputs {
            occluder,
            back,
            receivers,
            ..
        } = &inputs;

        // Passes 5-6: the micro-patches of each occluder map.
        let soft =
            |map: &Image, pass: &'static str| SoftShadow::new(init, &inputs, map, &nearest, pass);
        let front = soft(
            &occluder.depth,
            if two_sided {
                "ssm2/soft_shadow"
            } else {
                "ssm/soft_shadow"
            },
        )
        .context("ssm soft shadow map")?;
        let back_soft = match back {
            Some(b) => {
                Some(soft(&b.depth, "ssm2/soft_shadow_back").context("ssm2 back soft shadow map")?)
            }
            None => None,
        };
        // Both SoftShadow sets are defined identically, so one pipeline serves both.
        let soft_pipeline = Pipeline::graphics(
            ctx,
            &GraphicsPipelineDesc {
                name: front.name,
                vertex: shaders::SSM_SOFT_SHADOW_VERT,
                fragment: Some(shaders::SSM_SOFT_SHADOW_FRAG),
                vertex_stride: 0,
                attributes: &[],
                topology: PrimitiveTopology::TRIANGLE_STRIP,
                cull: CullModeFlags::NONE,
                // ADD sums the micro-patches' occluded fractions (Sec. 4.1).
                colors: &[(accum, Blend::Add), (accum, Blend::Add)],
                depth: None,
                push_constant_bytes: 0,
                sets: &[&front.set],
            },
        )
        .context("ssm soft shadow pipeline")?;

        // Pass 7.
        let (final_pass, final_set) =
            final_pass(init, name, receivers, &front, back_soft.as_ref(), &nearest)
                .context("ssm final pass")?;
        Ok(Self {
            name,
            res,
            inputs,
            soft_pipeline,
            front,
            back_soft,
            final_pass,
            final_set,
            _nearest: nearest,
        })
    }

    fn record_soft(&self, rec: &mut Recorder<'_>, soft: &SoftShadow) {
        rec.begin_rendering(
            &[
                (&soft.layers[0], Clear::Float([0.0; 4])),
                (&soft.layers[1], Clear::Float([0.0; 4])),
            ],
            None,
        );
        rec.bind_pipeline(&self.soft_pipeline);
        rec.bind_sets(&self.soft_pipeline, &[&soft.set]);
        rec.draw(4, self.res * self.res);
        rec.end_rendering();
    }
}

/// The final pass and its set: receiver map and SSMs, read with a nearest sampler.
fn final_pass(
    init: &TechniqueInit<'_>,
    technique: &str,
    receivers: &ReceiverMap,
    front: &SoftShadow,
    back: Option<&SoftShadow>,
    nearest: &Sampler,
) -> Result<(FinalPass, DescriptorSet)> {
    let mut resources = vec![
        ("frame", Resource::Uniform(init.ubo)),
        (
            "receiver_front",
            Resource::Sampled(&receivers.layers[0], nearest),
        ),
        ("ssm_front", Resource::Sampled(&front.layers[0], nearest)),
        ("ssm_pure", Resource::Sampled(&front.layers[1], nearest)),
    ];
    if let Some(b) = back {
        resources.push(("ssm_back_front", Resource::Sampled(&b.layers[0], nearest)));
        resources.push(("ssm_back_pure", Resource::Sampled(&b.layers[1], nearest)));
    }
    let name = format!("{technique}/final");
    let set = DescriptorSet::new(init.ctx, &resources, &name)?;
    let fragment = match back {
        Some(_) => FinalShader {
            color: shaders::SSM2_FINAL_FRAG,
            aov: shaders::SSM2_FINAL_FRAG_AOV,
            count: shaders::SSM2_FINAL_FRAG_COUNT,
        },
        None => FinalShader {
            color: shaders::SSM_FINAL_FRAG,
            aov: shaders::SSM_FINAL_FRAG_AOV,
            count: shaders::SSM_FINAL_FRAG_COUNT,
        },
    };
    let pass = FinalPass::new(init.ctx, &name, fragment, &set)?;
    Ok((pass, set))
}

impl Technique for Ssm {
    fn name(&self) -> &'static str {
        self.name
    }

    fn uniforms(&self, frame: &FrameInput<'_>) -> [[f32; 4]; 2] {
        ssm_uniforms(self.res, frame)
    }

    fn record_light(
        &mut self,
        _ctx: &Context,
        rec: &mut Recorder<'_>,
        frame: &FrameInput<'_>,
    ) -> Result<()> {
        let reach = match frame.light.sun {
            // (Hs): h = (L_s / 2) (z_max - z_O) / (E / N), per unit of z_max - z_O.
            Some(sun) => {
                0.5 * light_square_side(sun.tan_angle) / frame.light.texel_world(0.0, self.res)
            }
            None => {
                let t = (frame.light.fov_deg.to_radians() * 0.5).tan();
                let side = light_square_side(frame.light_radius);
                // soft_shadow.vert's h = L N / (4 tan(fov/2)) (1/z_O - 1/z_max).
                side * self.res as f32 / (4.0 * t)
            }
        };
        self.inputs.record(rec, frame, reach)?;
        rec.pass(self.front.name, |rec| {
            self.record_soft(rec, &self.front);
            Ok(())
        })?;
        if let Some(back) = &self.back_soft {
            rec.pass(back.name, |rec| {
                self.record_soft(rec, back);
                Ok(())
            })?;
        }
        Ok(())
    }

    fn frame_warning(&mut self) -> Result<Option<String>> {
        self.inputs.step_warning()
    }

    fn micro_patch_step(&self) -> Option<PatchStepReport> {
        self.inputs.step_report().ok()
    }

    fn light_passes(&self) -> Vec<String> {
        let mut names = self.inputs.pass_names();
        names.push(self.front.name.into());
        if let Some(b) = &self.back_soft {
            names.push(b.name.into());
        }
        names
    }

    fn record_final(
        &mut self,
        _ctx: &Context,
        rec: &mut Recorder<'_>,
        frame: &FrameInput<'_>,
    ) -> Result<()> {
        self.final_pass.pass(rec, frame, &self.final_set)
    }

    fn light_buffers(&self) -> Vec<LightBuffer<'_>> {
        let buffer = |name, image, channels| LightBuffer {
            name,
            image,
            channels,
            packing: Packing::Plain,
        };
        let mut out = vec![self.inputs.occluder.buffer()];
        out.extend(self.inputs.receivers.buffers());
        // Summed micro-patch occlusion of the light, per receiver layer (>= 0, unclamped).
        out.push(buffer("soft_shadow", &self.front.layers[0], &["occlusion"]));
        out.push(buffer(
            "soft_shadow_pure",
            &self.front.layers[1],
            &["occlusion"],
        ));
        if let Some(b) = &self.inputs.back {
            out.push(b.buffer());
        }
        if let Some(b) = &self.back_soft {
            out.push(buffer("soft_shadow_back", &b.layers[0], &["occlusion"]));
            out.push(buffer(
                "soft_shadow_back_pure",
                &b.layers[1],
                &["occlusion"],
            ));
        }
        out
    }
}
