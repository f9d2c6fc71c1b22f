//! # ssm / ssm2 — Atty, Holzschuch, Lapierre, Hasenfratz, Hansen, Sillion 2006,
//! *Soft Shadow Maps: Efficient Sampling of Light Source Visibility*
//! Port sheets: docs/port/ssm.md, docs/port/ssm2.md
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
//! ## Resolutions and parameters
//! All light-space buffers of this technique are `Settings::occluder_res` square (occluder
//! maps, receiver map, SSM, one SSM texel per receiver-map texel); `shadow_res` is unused.
//! `Settings::accum_format` picks the SSM format: R32_SFLOAT (default) or R16_SFLOAT (the
//! paper's FP16 blending, to reproduce Appendix A Eq. 4: a micro-patch hiding less than
//! 2^-10 of the light is lost when added to an occlusion near 1, which happens more often
//! as the occluder map grows).
//!
//! ## Occluders and receivers (the paper separates them; scenes here have role `both`)
//! Occluders = objects that cast (`caster`, `both`). Receivers come in two layers, both
//! in the receiver map:
//! - layer 0, "front": the nearest receiving object (`receiver` or `both`) per texel —
//!   what the light centre sees of the receivers (casters' own lit surfaces, the ground);
//! - layer 1, "pure": the nearest receive-only object (`receiver`, the paper's receivers,
//!   e.g. the ground), FAR where there is none.
//!
//! The SSM holds one accumulated occlusion per layer. A point in the final pass that is
//! its texel's front receiver reads layer 0; a point behind it (the ground under a caster,
//! a caster's far side) reads layer 1 — without it, ground under a `both` caster would get
//! the caster's own (unshadowed) value. Self-occlusion follows the paper: a micro-patch
//! at or less than a small guard in front of the receiver is discarded (see the guard
//! below), so a caster does not shadow its own lit surface.
//!
//! ## Passes, in order (`ssm2` names its passes `ssm2/...`)
//! 1. `ssm/occluder_map` — casters from the light, front (nearest) surfaces
//!    (`gpu::passes::ShadowMap`): R32G32_SFLOAT, clear FAR_DEPTH (1e30), blend MIN; the
//!    r channel (nearest caster) is the occluder map. Shaders `glsl/common/shadow_depth.*`.
//! 2. `ssm2/back_occluder_map` (ssm2 only) — the same, farthest surfaces: R32_SFLOAT clear
//!    FAR_DEPTH, no blend, + D32_SFLOAT clear **0.0**, compare **GREATER**, no culling.
//! 3. `ssm/receiver_map` — receiving objects from the light, two R32_SFLOAT attachments
//!    (layer 0, layer 1), clear FAR_DEPTH, blend **MIN** (no z-buffer). Vertex
//!    `common/shadow_depth.vert`; fragment `glsl/ssm/receiver_both.frag` (role both:
//!    writes (depth, FAR)) or `glsl/ssm/receiver_only.frag` (role receiver: (depth, depth)).
//! 4. `ssm/receiver_bound` — compute `glsl/ssm/receiver_bound.comp`: the farthest receiver
//!    depth z_max over both layers (16x16 groups, shared max, one atomicMax per group into a
//!    4-byte storage buffer, cleared with vkCmdFillBuffer 0 first). Used as the conservative
//!    z_R of the penumbra extents (Sec. 3.3: the extent grows with z_R).
//! 5. `ssm/micro_patch_step` — compute `glsl/ssm/patch_step.comp`, two dispatches into the
//!    same buffer after z_max: the side s of the texel blocks pass 6 draws as one patch. Per
//!    occluder texel its extent h (below) and, per s = 1, 2, 4, ..., the fragments of an
//!    s x s block's quad shared by its s^2 texels, summed (64-bit); then the smallest s whose
//!    sum is at most N^4 / 64 fragments, else N. s = 1 (one patch per texel, the paper) on
//!    every built-in scene; narrow cones under wide lights, whose penumbrae span many times
//!    the map, get blocks (Sec. 6.1: a large penumbra needs a lower occluder resolution), and
//!    `render` prints one `warning:` line naming the bound (`Technique::frame_warning`).
//! 6. `ssm/soft_shadow` — one instanced draw, N^2 instances (one per occluder texel) of a
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
//! 7. `ssm2/soft_shadow_back` (ssm2 only) — pass 6 again with the back occluder map into
//!    two more attachments, with the block side of the front map.
//! 8. `ssm/final` — camera pass (`FinalPass`), `glsl/ssm/final.frag` (`glsl/ssm2/final.frag`
//!    defines TWO_SIDED; both include `glsl/ssm/final.glsl`): normal-offset point (in
//!    occluder texels), 2x2 footprint of the receiver map and the SSMs; per texel layer 0 if
//!    the point is within 3 texels of depth slope of the front receiver, layer 1 if behind,
//!    no data if the front receiver is behind the point (weights renormalised); ssm2 takes
//!    max(front SSM, back SSM) per layer; occlusion clamped to \[0,1\] per texel, bilinear
//!    weights; visibility = 1 - occlusion.
//!
//! ## Equations: what a porter ports
//! - The penumbra extent (Sec. 3.3, Fig. 7-8): `main` of glsl/ssm/soft_shadow.vert.
//! - The back-projection of a micro-patch (Sec. 3.4, Fig. 9; Sec. 4.2's overlaps):
//!   `occlusion` (glsl/ssm/soft_shadow.frag).
//! - The final lookup (Sec. 3.1; ssm2's max, Sec. 3.5): `visibility` (glsl/ssm/final.glsl),
//!   with `ssm_offset_point`, `ssm_layers` and `ssm_footprint` (glsl/ssm/footprint.glsl).
//!
//! Where the speed layer (`--plain` turns it off, `Settings::effective`) may change these
//! functions' inputs:
//! - Culling leaves out objects outside the light's frustum (light passes) and the
//!   camera's (final pass): they write no texel a lookup reads and no pixel.
//! - Reuse skips the light passes when the light, its radius and every object are
//!   unchanged: the buffers then hold what the same passes wrote.
//!
//! Nothing else: every map is drawn whole and the final pass is one whole pass.
//!
//! ## Frame constants
//! `frame.technique` = (L, N = occluder_res, 1/N, self-occlusion guard in texels).
//!
//! ## Cost
//! Linear in occluder-map texels (one micro-patch each) in `soft_shadow`; the camera
//! `final` pass dominates the frame, `soft_shadow` comes next, the occluder, receiver and
//! bound passes are small. ssm2 adds a second occluder map and micro-patch pass (the paper
//! measures 1.6-1.8x ssm). Measured ratios to `hard`: BENCHMARKS.md.
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
//!   up to N^4 / 64 fragments; beyond, blocks of texels make coarser penumbrae (pass 5).

use super::{
    shadow_map_buffer, technique_constants, FrameInput, LightBuffer, Technique, TechniqueInfo,
    TechniqueInit,
};
use crate::gpu::passes::{
    depth_only_pipeline, DepthOnly, FinalPass, FinalShader, ShadowMap, FAR_DEPTH,
};
use crate::gpu::GpuScene;
use crate::scene::Role;
use crate::settings::AccumFormat;
use crate::shaders::{self, constants as k};
use crate::vk::{
    Blend, Buffer, BufferUsageFlags, Clear, CompareOp, Context, CullModeFlags, DepthState,
    DescriptorSet, Filter, Format, GraphicsPipelineDesc, Image, ImageUsageFlags, MemoryLocation,
    Pipeline, PrimitiveTopology, Recorder, Resource, Sampler,
};
use anyhow::{Context as _, Result};

pub const INFO: TechniqueInfo = TechniqueInfo {
    name: "ssm",
    summary:
        "Atty et al. 2006: soft shadow map, GPU micro-patch back-projection, additive blending",
    create: create_one_sided,
};

pub const INFO2: TechniqueInfo = TechniqueInfo {
    name: "ssm2",
    summary:
        "Atty et al. 2006 two-sided: front and back occluder maps, soft shadow maps merged with max",
    create: create_two_sided,
};

/// Self-occlusion guard: a micro-patch less than this many texels of depth slope in front of
/// the receiver is the receiver's own surface (its own texel, or the staircase of a surface
/// sloped up to ~55 degrees to the light's image plane), not an occluder.
pub(crate) const SELF_GUARD_TEXELS: f32 = 1.5;

/// Compute workgroup side of `glsl/ssm/receiver_bound.comp`.
const BOUND_GROUP: u32 = 16;

/// Usage of every light-space image of the soft shadow maps: drawn, sampled, read back.
pub(crate) const MAP_USAGE: ImageUsageFlags = ImageUsageFlags::from_raw(
    ImageUsageFlags::COLOR_ATTACHMENT.as_raw()
        | ImageUsageFlags::SAMPLED.as_raw()
        | ImageUsageFlags::TRANSFER_SRC.as_raw(),
);

fn create_one_sided(init: &TechniqueInit<'_>) -> Result<Box<dyn Technique>> {
    Ok(Box::new(Ssm::create(init, false)?))
}

fn create_two_sided(init: &TechniqueInit<'_>) -> Result<Box<dyn Technique>> {
    Ok(Box::new(Ssm::create(init, true)?))
}

/// The square light of the same area as the disk of radius `r`: side r sqrt(pi).
pub fn light_square_side(r: f32) -> f32 {
    r * std::f32::consts::PI.sqrt()
}

/// Pass 3: the two receiver layers (R32F, MIN-blended) and the pipelines that draw them.
pub(crate) struct ReceiverMap {
    /// Layer 0: the nearest receiving surface; layer 1: the nearest pure receiver.
    pub layers: [Image; 2],
    set: DescriptorSet,
    both: Pipeline,
    only: Pipeline,
}

impl ReceiverMap {
    pub fn new(ctx: &Context, ubo: &Buffer, res: u32, technique: &str) -> Result<Self> {
        ctx.require_blend(Format::R32_SFLOAT, Blend::Min, "the receiver map")?;
        let layer = |what: &str| {
            Image::new_2d(
                ctx,
                res,
                res,
                Format::R32_SFLOAT,
                MAP_USAGE,
                &format!("{technique} receiver map ({what})"),
            )
        };
        let layers = [layer("front")?, layer("pure")?];
        let name = format!("{technique}/receiver_map");
        let set = DescriptorSet::new(ctx, &[("frame", Resource::Uniform(ubo))], &name)?;
        let pipeline = |fragment: &[u8], role: &str| {
            Pipeline::graphics(
                ctx,
                &depth_only_pipeline(DepthOnly {
                    name: &format!("{name} ({role})"),
                    fragment,
                    // MIN keeps the nearest depth without a z-buffer per layer.
                    colors: &[
                        (Format::R32_SFLOAT, Blend::Min),
                        (Format::R32_SFLOAT, Blend::Min),
                    ],
                    depth: None,
                    sets: &[&set],
                }),
            )
        };
        let both = pipeline(shaders::SSM_RECEIVER_BOTH_FRAG, "both")?;
        let only = pipeline(shaders::SSM_RECEIVER_ONLY_FRAG, "receivers")?;
        Ok(Self {
            layers,
            set,
            both,
            only,
        })
    }

    pub fn record(&self, rec: &mut Recorder<'_>, gpu: &GpuScene) {
        rec.begin_rendering(
            &[
                (&self.layers[0], Clear::Float([FAR_DEPTH; 4])),
                (&self.layers[1], Clear::Float([FAR_DEPTH; 4])),
            ],
            None,
        );
        rec.bind_pipeline(&self.both);
        rec.bind_sets(&self.both, &[&self.set]);
        gpu.draw(rec, &self.both, |o| o.role == Role::Both);
        rec.bind_pipeline(&self.only);
        rec.bind_sets(&self.only, &[&self.set]);
        gpu.draw(rec, &self.only, |o| o.role == Role::Receiver);
        rec.end_rendering();
    }

    /// The two layers as light buffers.
    pub fn buffers(&self) -> [LightBuffer<'_>; 2] {
        [
            LightBuffer {
                name: "receiver_map",
                image: &self.layers[0],
                channels: &["receiver_depth"],
            },
            LightBuffer {
                name: "receiver_map_pure",
                image: &self.layers[1],
                channels: &["pure_receiver_depth"],
            },
        ]
    }
}

/// Pass 4: the farthest receiver depth z_max, at the start of a storage buffer that pass 5
/// (`PatchStep`) goes on to fill.
pub(crate) struct ReceiverBound {
    pub buffer: Buffer,
    set: DescriptorSet,
    pipeline: Pipeline,
    res: u32,
}

impl ReceiverBound {
    pub fn new(
        ctx: &Context,
        ubo: &Buffer,
        receivers: &ReceiverMap,
        nearest: &Sampler,
        technique: &str,
    ) -> Result<Self> {
        let name = format!("{technique}/receiver_bound");
        let res = receivers.layers[0].extent.width;
        let buffer = Buffer::new(
            ctx,
            PatchStep::bytes(res),
            BufferUsageFlags::STORAGE_BUFFER
                | BufferUsageFlags::TRANSFER_DST
                | BufferUsageFlags::TRANSFER_SRC,
            MemoryLocation::GpuOnly,
            &name,
        )?;
        let set = DescriptorSet::new(
            ctx,
            &[
                ("frame", Resource::Uniform(ubo)),
                (
                    "receiver_front",
                    Resource::Sampled(&receivers.layers[0], nearest),
                ),
                (
                    "receiver_pure",
                    Resource::Sampled(&receivers.layers[1], nearest),
                ),
                ("bound", Resource::Storage(&buffer)),
            ],
            &name,
        )?;
        let pipeline = Pipeline::compute(ctx, &name, shaders::SSM_RECEIVER_BOUND_COMP, &[&set], 0)?;
        Ok(Self {
            buffer,
            set,
            pipeline,
            res,
        })
    }

    pub fn record(&self, rec: &mut Recorder<'_>) {
        rec.fill_buffer(&self.buffer, 0);
        rec.bind_pipeline(&self.pipeline);
        rec.bind_sets(&self.pipeline, &[&self.set]);
        let groups = self.res.div_ceil(BOUND_GROUP);
        rec.dispatch(groups, groups, 1);
    }
}

/// Pass 5: the side of the texel blocks the micro-patch pass draws as one patch
/// (`glsl/ssm/patch_step.comp`): 1, one patch per texel as the paper, unless the patches'
/// penumbrae would cost more fragments than N^4 / 64; then the smallest power of two that
/// keeps the estimate within it (Sec. 6.1: large penumbrae need a lower occluder
/// resolution). Written after z_max into the bound buffer, where the micro-patch vertex
/// shaders read it, and copied to the host for the warning line.
pub(crate) struct PatchStep {
    set: DescriptorSet,
    pipeline: Pipeline,
    readback: Buffer,
    res: u32,
    /// The block side of the last warning (1: none given yet).
    warned: u32,
}

/// What `PatchStep` found in a frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PatchStepReport {
    /// Side of the texel blocks drawn as one micro-patch (1: one per texel).
    pub step: u32,
    /// The fragments allowed.
    pub budget: f64,
    /// The fragments one patch per texel would have cost (estimate, clipped to the map).
    pub work: f64,
}

impl PatchStep {
    /// Bytes of the bound buffer: z_max, the step, the budget, a pad word, then two words
    /// (a 64-bit sum) per block side 1, 2, 4, ..., up to `res`.
    fn bytes(res: u32) -> u64 {
        16 + 8 * (res.ilog2() as u64 + 1)
    }

    fn new(
        ctx: &Context,
        ubo: &Buffer,
        occluder: &Image,
        bound: &ReceiverBound,
        nearest: &Sampler,
        technique: &str,
    ) -> Result<Self> {
        let name = format!("{technique}/micro_patch_step");
        let set = DescriptorSet::new(
            ctx,
            &[
                ("frame", Resource::Uniform(ubo)),
                ("occluder_map", Resource::Sampled(occluder, nearest)),
                ("bound", Resource::Storage(&bound.buffer)),
            ],
            &name,
        )?;
        let pipeline = Pipeline::compute(ctx, &name, shaders::SSM_PATCH_STEP_COMP, &[&set], 8)?;
        let readback = Buffer::new(
            ctx,
            bound.buffer.size,
            BufferUsageFlags::TRANSFER_DST,
            MemoryLocation::GpuToCpu,
            &format!("{name} readback"),
        )?;
        Ok(Self {
            set,
            pipeline,
            readback,
            res: bound.res,
            warned: 1,
        })
    }

    /// `reach`: texels of penumbra extent per unit of (1/z_O - 1/z_max), as the technique's
    /// micro-patch vertex shader grows its quads (at most).
    fn record(&self, rec: &mut Recorder<'_>, bound: &ReceiverBound, reach: f32) {
        let push = |choose: u32| {
            let mut bytes = reach.to_ne_bytes().to_vec();
            bytes.extend_from_slice(&choose.to_ne_bytes());
            bytes
        };
        rec.bind_pipeline(&self.pipeline);
        rec.bind_sets(&self.pipeline, &[&self.set]);
        rec.push_constants(&self.pipeline, &push(0));
        let groups = self.res.div_ceil(BOUND_GROUP);
        rec.dispatch(groups, groups, 1);
        rec.push_constants(&self.pipeline, &push(1));
        rec.dispatch(1, 1, 1);
        rec.copy_buffer(&bound.buffer, &self.readback);
        rec.host_read(&self.readback);
    }

    /// What the last frame that ran the pass found (after it finished).
    fn report(&self) -> Result<PatchStepReport> {
        let words: Vec<u32> = bytemuck::pod_collect_to_vec(self.readback.read()?);
        Ok(PatchStepReport {
            step: words[1],
            budget: f32::from_bits(words[2]) as f64,
            work: words[4] as f64 + words[5] as f64 * 4294967296.0,
        })
    }
}

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
        occluder_map: &Image,
        receivers: &ReceiverMap,
        bound: &ReceiverBound,
        nearest: &Sampler,
        name: &'static str,
    ) -> Result<Self> {
        let (ctx, res) = (init.ctx, init.settings.occluder_res);
        let accum = accum_format(init.settings.accum_format);
        let layers = [
            Image::new_2d(ctx, res, res, accum, MAP_USAGE, &format!("{name} (front)"))?,
            Image::new_2d(ctx, res, res, accum, MAP_USAGE, &format!("{name} (pure)"))?,
        ];
        let set = DescriptorSet::new(
            ctx,
            &[
                ("frame", Resource::Uniform(init.ubo)),
                ("occluder_map", Resource::Sampled(occluder_map, nearest)),
                (
                    "receiver_front",
                    Resource::Sampled(&receivers.layers[0], nearest),
                ),
                (
                    "receiver_pure",
                    Resource::Sampled(&receivers.layers[1], nearest),
                ),
                ("bound", Resource::Storage(&bound.buffer)),
            ],
            name,
        )?;
        Ok(Self { layers, set, name })
    }
}

/// The farthest-surface occluder map of ssm2 (as `ShadowMap`, GREATER instead of LESS).
pub(crate) struct BackOccluderMap {
    pub depth: Image,
    zbuffer: Image,
    pipeline: Pipeline,
    set: DescriptorSet,
    pub name: String,
}

/// Passes 1–5 of every soft shadow map form (`ssm`, `ssm2` and the bitmask forms,
/// src/technique/ssm_bitmask.rs): the occluder map, the back occluder map when two-sided,
/// the receiver map and the receiver bound, named `NAME/occluder_map`, ...
pub(crate) struct LightInputs {
    name: &'static str,
    pub occluder: ShadowMap,
    pub back: Option<BackOccluderMap>,
    pub receivers: ReceiverMap,
    pub bound: ReceiverBound,
    pub step: PatchStep,
}

impl LightInputs {
    pub fn new(
        init: &TechniqueInit<'_>,
        name: &'static str,
        two_sided: bool,
        nearest: &Sampler,
    ) -> Result<Self> {
        let (ctx, res) = (init.ctx, init.settings.occluder_res);
        let occluder = ShadowMap::new(ctx, init.ubo, res, &format!("{name}/occluder_map"))
            .with_context(|| format!("{name} occluder map"))?;
        let back = match two_sided {
            true => Some(
                BackOccluderMap::new(ctx, init.ubo, res, name)
                    .with_context(|| format!("{name} back occluder map"))?,
            ),
            false => None,
        };
        let receivers = ReceiverMap::new(ctx, init.ubo, res, name)
            .with_context(|| format!("{name} receiver map"))?;
        let bound = ReceiverBound::new(ctx, init.ubo, &receivers, nearest, name)
            .with_context(|| format!("{name} receiver bound"))?;
        let step = PatchStep::new(ctx, init.ubo, &occluder.depth, &bound, nearest, name)
            .with_context(|| format!("{name} micro-patch step"))?;
        Ok(Self {
            name,
            occluder,
            back,
            receivers,
            bound,
            step,
        })
    }

    fn pass_name(&self, pass: &str) -> String {
        format!("{}/{pass}", self.name)
    }

    /// Passes 1–5, each timed; `reach` as `PatchStep::record`.
    pub fn record(&self, rec: &mut Recorder<'_>, frame: &FrameInput<'_>, reach: f32) -> Result<()> {
        rec.pass(&self.pass_name("occluder_map"), |rec| {
            self.occluder.record(rec, frame.gpu);
            Ok(())
        })?;
        if let Some(back) = &self.back {
            rec.pass(&back.name, |rec| {
                back.record(rec, frame.gpu);
                Ok(())
            })?;
        }
        rec.pass(&self.pass_name("receiver_map"), |rec| {
            self.receivers.record(rec, frame.gpu);
            Ok(())
        })?;
        rec.pass(&self.pass_name("receiver_bound"), |rec| {
            self.bound.record(rec);
            Ok(())
        })?;
        rec.pass(&self.pass_name("micro_patch_step"), |rec| {
            self.step.record(rec, &self.bound, reach);
            Ok(())
        })
    }

    /// What the last frame's micro-patch step pass found.
    pub fn step_report(&self) -> Result<PatchStepReport> {
        self.step.report()
    }

    /// The warning for a frame whose micro-patches were drawn in blocks (once per block
    /// side: a later frame that needs larger blocks warns again).
    pub fn step_warning(&mut self) -> Result<Option<String>> {
        let r = self.step.report()?;
        if r.step <= self.step.warned {
            return Ok(None);
        }
        self.step.warned = r.step;
        Ok(Some(format!(
            "{}: the micro-patches' penumbrae would cost about {:.3e} fragments, above the bound of {:.3e} (occluder-res^4 / 64): drawn as blocks of {s} x {s} occluder texels, coarser penumbrae",
            self.name, r.work, r.budget, s = r.step
        )))
    }

    /// The names of the passes `record` records, in order.
    pub fn pass_names(&self) -> Vec<String> {
        let mut names = vec![self.pass_name("occluder_map")];
        if let Some(b) = &self.back {
            names.push(b.name.clone());
        }
        names.push(self.pass_name("receiver_map"));
        names.push(self.pass_name("receiver_bound"));
        names.push(self.pass_name("micro_patch_step"));
        names
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

        // Passes 1-5: occluder maps, receiver map, receiver bound, micro-patch step.
        let inputs = LightInputs::new(init, name, two_sided, &nearest)?;
        let LightInputs {
            occluder,
            back,
            receivers,
            bound,
            ..
        } = &inputs;

        // Passes 6-7: the micro-patches of each occluder map.
        let soft = |map: &Image, pass: &'static str| {
            SoftShadow::new(init, map, receivers, bound, &nearest, pass)
        };
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

        // Pass 8.
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

impl BackOccluderMap {
    pub fn new(ctx: &Context, ubo: &Buffer, res: u32, technique: &str) -> Result<Self> {
        let name = format!("{technique}/back_occluder_map");
        let depth = Image::new_2d(
            ctx,
            res,
            res,
            Format::R32_SFLOAT,
            MAP_USAGE,
            &format!("{technique} back occluder map"),
        )?;
        let zbuffer = Image::new_2d(
            ctx,
            res,
            res,
            Format::D32_SFLOAT,
            ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT,
            &format!("{technique} back occluder z-buffer"),
        )?;
        let set = DescriptorSet::new(ctx, &[("frame", Resource::Uniform(ubo))], &name)?;
        let pipeline = Pipeline::graphics(
            ctx,
            &depth_only_pipeline(DepthOnly {
                name: &name,
                fragment: shaders::COMMON_SHADOW_DEPTH_FRAG,
                colors: &[(Format::R32_SFLOAT, Blend::None)],
                // GREATER against a 0 clear keeps the farthest caster surface (Sec. 3.5).
                depth: Some(DepthState {
                    format: Format::D32_SFLOAT,
                    test: true,
                    write: true,
                    compare: CompareOp::GREATER,
                }),
                sets: &[&set],
            }),
        )?;
        Ok(Self {
            depth,
            zbuffer,
            pipeline,
            set,
            name,
        })
    }

    pub fn record(&self, rec: &mut Recorder<'_>, scene: &GpuScene) {
        rec.begin_rendering(
            &[(&self.depth, Clear::Float([FAR_DEPTH; 4]))],
            Some((&self.zbuffer, Some(0.0))),
        );
        rec.discard_after(&self.zbuffer);
        rec.bind_pipeline(&self.pipeline);
        rec.bind_sets(&self.pipeline, &[&self.set]);
        scene.draw(rec, &self.pipeline, |o| o.role.casts());
        rec.end_rendering();
    }

    pub fn buffer(&self) -> LightBuffer<'_> {
        LightBuffer {
            name: "back_occluder_map",
            image: &self.depth,
            channels: &["farthest_caster_depth"],
        }
    }
}

/// `frame.technique` of every soft shadow map (glsl/ssm/constants.glsl).
pub(crate) fn ssm_uniforms(res: u32, frame: &FrameInput<'_>) -> [[f32; 4]; 2] {
    let n = res as f32;
    let mut c = [0.0; 8];
    c[k::SSM_LIGHT_SIDE] = light_square_side(frame.light_radius);
    c[k::SSM_RES] = n;
    c[k::SSM_INV_RES] = 1.0 / n;
    c[k::SSM_SELF_GUARD_TEXELS] = SELF_GUARD_TEXELS;
    technique_constants(c)
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
        let t = (frame.light.fov_deg.to_radians() * 0.5).tan();
        let side = light_square_side(frame.light_radius);
        // soft_shadow.vert's h = L N / (4 tan(fov/2)) (1/z_O - 1/z_max).
        let reach = side * self.res as f32 / (4.0 * t);
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
        };
        let mut out = vec![shadow_map_buffer("occluder_map", &self.inputs.occluder)];
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
