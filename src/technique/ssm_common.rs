//! Passes 1-3 of every soft shadow map form (`ssm`, `ssm2`, src/technique/ssm.rs, and
//! `ssm-bitmask`, src/technique/ssm_bitmask.rs), which they share, with
//! pass 4 of the speed layer (speed::ssm): `LightInputs` records them in order.
//!
//! 1. `NAME/maps` (`ReceiverMap`) — every object from the light, once, into three
//!    attachments, each clear FAR_DEPTH (1e30), blend **MIN** (no z-buffer):
//!    - the occluder map (`OccluderMap`), R32G32_SFLOAT: r the nearest caster (the
//!      occluder map proper), g the nearest surface of any role (as
//!      `gpu::passes::ShadowMap`);
//!    - the receiver map, two R32_SFLOAT layers: layer 0 the nearest receiving surface,
//!      layer 1 the nearest receive-only surface.
//!
//!    Vertex `common/shadow_depth.vert`; one fragment shader a role, writing (layer 0,
//!    layer 1, occluder): `glsl/ssm/receiver_both.frag` (both: (depth, FAR, (depth,
//!    depth))), `glsl/ssm/receiver_only.frag` (receiver: (depth, depth, (FAR, depth))),
//!    `glsl/ssm/caster_only.frag` (caster: (FAR, FAR, (depth, depth))). One pass where the
//!    occluder and receiver maps were two draws of the scene: the vertex work once.
//! 2. `NAME/back_occluder_map` (two-sided forms only, `BackOccluderMap`) — the occluder map
//!    of the farthest surfaces: R32_SFLOAT clear FAR_DEPTH, no blend, + D32_SFLOAT clear
//!    **0.0**, compare **GREATER**, no culling.
//! 3. `NAME/receiver_bound` (`ReceiverBound`) — compute `glsl/ssm/receiver_bound.comp`:
//!    the farthest receiver depth z_max over both layers (16x16 texels a group, 2x2 an
//!    invocation, shared max, one atomicMax per group into a storage buffer, cleared with
//!    vkCmdFillBuffer 0 first):
//!    the conservative z_R of the penumbra extents (Sec. 3.3: the extent grows with z_R).

use super::speed::ssm::{PatchStep, PatchStepReport};
use super::{technique_constants, FrameInput, LightBuffer, Packing, TechniqueInit};
use crate::gpu::passes::{depth_only_pipeline, DepthOnly, FAR_DEPTH, SURFACE_MAP_CHANNELS};
use crate::gpu::GpuScene;
use crate::scene::Role;
use crate::shaders::{self, constants as k};
use crate::vk::{
    Blend, Buffer, BufferUsageFlags, Clear, CompareOp, Context, DepthState, DescriptorSet, Format,
    Image, ImageUsageFlags, MemoryLocation, Pipeline, Recorder, Resource, Sampler,
};
use anyhow::{Context as _, Result};

/// Self-occlusion guard: a micro-patch less than this many texels of depth slope in front of
/// the receiver is the receiver's own surface (its own texel, or the staircase of a surface
/// sloped up to ~55 degrees to the light's image plane), not an occluder.
pub(crate) const SELF_GUARD_TEXELS: f32 = 1.5;

/// Compute workgroup side of `glsl/ssm/receiver_bound.comp`.
pub(crate) const BOUND_GROUP: u32 = 16;

/// Usage of every light-space image of the soft shadow maps: drawn, sampled, read back.
pub(crate) const MAP_USAGE: ImageUsageFlags = ImageUsageFlags::from_raw(
    ImageUsageFlags::COLOR_ATTACHMENT.as_raw()
        | ImageUsageFlags::SAMPLED.as_raw()
        | ImageUsageFlags::TRANSFER_SRC.as_raw(),
);

/// The square light of the same area as the disk of radius `r`: side r sqrt(pi).
pub fn light_square_side(r: f32) -> f32 {
    r * std::f32::consts::PI.sqrt()
}

/// Pass 1's occluder map: r = the nearest caster's linear depth, g = the nearest surface's
/// (of any role), as the shared `gpu::passes::ShadowMap`; drawn by `ReceiverMap::record`.
pub(crate) struct OccluderMap {
    pub depth: Image,
}

impl OccluderMap {
    const FORMAT: Format = Format::R32G32_SFLOAT;

    fn new(ctx: &Context, res: u32, technique: &str) -> Result<Self> {
        ctx.require_blend(Self::FORMAT, Blend::Min, "the occluder map")?;
        let depth = Image::new_2d(
            ctx,
            res,
            res,
            Self::FORMAT,
            MAP_USAGE,
            &format!("{technique} occluder map"),
        )?;
        Ok(Self { depth })
    }

    /// The map as a light buffer (`--buffers`).
    pub fn buffer(&self) -> LightBuffer<'_> {
        LightBuffer {
            name: "occluder_map",
            image: &self.depth,
            channels: SURFACE_MAP_CHANNELS,
            packing: Packing::Plain,
        }
    }
}

/// Pass 1: the two receiver layers (R32F, MIN-blended) and, in the same pass, the occluder
/// map; the pipelines that draw them, one a role.
pub(crate) struct ReceiverMap {
    /// Layer 0: the nearest receiving surface; layer 1: the nearest pure receiver.
    pub layers: [Image; 2],
    set: DescriptorSet,
    both: Pipeline,
    only: Pipeline,
    casters: Pipeline,
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
        let name = format!("{technique}/maps");
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
                        (OccluderMap::FORMAT, Blend::Min),
                    ],
                    depth: None,
                    sets: &[&set],
                }),
            )
        };
        let both = pipeline(shaders::SSM_RECEIVER_BOTH_FRAG, "both")?;
        let only = pipeline(shaders::SSM_RECEIVER_ONLY_FRAG, "receivers")?;
        let casters = pipeline(shaders::SSM_CASTER_ONLY_FRAG, "casters")?;
        Ok(Self {
            layers,
            set,
            both,
            only,
            casters,
        })
    }

    /// Every object once, by role, into the two layers and `occluder`.
    pub fn record(&self, rec: &mut Recorder<'_>, gpu: &GpuScene, occluder: &OccluderMap) {
        rec.begin_rendering(
            &[
                (&self.layers[0], Clear::Float([FAR_DEPTH; 4])),
                (&self.layers[1], Clear::Float([FAR_DEPTH; 4])),
                (&occluder.depth, Clear::Float([FAR_DEPTH; 4])),
            ],
            None,
        );
        for (pipeline, role) in [
            (&self.both, Role::Both),
            (&self.only, Role::Receiver),
            (&self.casters, Role::Caster),
        ] {
            rec.bind_pipeline(pipeline);
            rec.bind_sets(pipeline, &[&self.set]);
            gpu.draw(rec, pipeline, |o| o.role == role);
        }
        rec.end_rendering();
    }

    /// The two layers as light buffers.
    pub fn buffers(&self) -> [LightBuffer<'_>; 2] {
        [
            LightBuffer {
                name: "receiver_map",
                image: &self.layers[0],
                channels: &["receiver_depth"],
                packing: Packing::Plain,
            },
            LightBuffer {
                name: "receiver_map_pure",
                image: &self.layers[1],
                channels: &["pure_receiver_depth"],
                packing: Packing::Plain,
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
    pub res: u32,
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

/// The farthest-surface occluder map of ssm2 (as `ShadowMap`, GREATER instead of LESS).
pub(crate) struct BackOccluderMap {
    pub depth: Image,
    zbuffer: Image,
    pipeline: Pipeline,
    set: DescriptorSet,
    pub name: String,
}

/// Passes 1–4 of every soft shadow map form (`ssm`, `ssm2` and the bitmask forms,
/// src/technique/ssm_bitmask.rs): the occluder and receiver maps, the back occluder map
/// when two-sided, the receiver bound and the micro-patch step, named `NAME/maps`, ...
pub(crate) struct LightInputs {
    name: &'static str,
    pub occluder: OccluderMap,
    pub back: Option<BackOccluderMap>,
    pub receivers: ReceiverMap,
    pub bound: ReceiverBound,
    pub step: PatchStep,
    /// The micro-patch pass reads the receiver tiles (`PatchStep::tiles`): fill them with
    /// each tile's deepest receiver when the speed layer is on.
    tiles: bool,
}

impl LightInputs {
    pub fn new(
        init: &TechniqueInit<'_>,
        name: &'static str,
        two_sided: bool,
        tiles: bool,
        nearest: &Sampler,
    ) -> Result<Self> {
        let (ctx, res) = (init.ctx, init.settings.occluder_res);
        let occluder =
            OccluderMap::new(ctx, res, name).with_context(|| format!("{name} occluder map"))?;
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
        let step = PatchStep::new(
            ctx,
            init.ubo,
            &occluder.depth,
            &receivers.layers,
            &bound,
            nearest,
            name,
        )
        .with_context(|| format!("{name} micro-patch step"))?;
        Ok(Self {
            name,
            occluder,
            back,
            receivers,
            bound,
            step,
            tiles,
        })
    }

    fn pass_name(&self, pass: &str) -> String {
        format!("{}/{pass}", self.name)
    }

    /// Passes 1–4, each timed; `reach` as `PatchStep::record`.
    pub fn record(&self, rec: &mut Recorder<'_>, frame: &FrameInput<'_>, reach: f32) -> Result<()> {
        rec.pass(&self.pass_name("maps"), |rec| {
            self.receivers.record(rec, frame.gpu, &self.occluder);
            Ok(())
        })?;
        if let Some(back) = &self.back {
            rec.pass(&back.name, |rec| {
                back.record(rec, frame.gpu);
                Ok(())
            })?;
        }
        rec.pass(&self.pass_name("receiver_bound"), |rec| {
            self.bound.record(rec);
            Ok(())
        })?;
        rec.pass(&self.pass_name("micro_patch_step"), |rec| {
            let local = self.tiles && frame.settings.light_areas;
            self.step.record(rec, &self.bound, reach, local);
            Ok(())
        })
    }

    /// What the last frame's micro-patch step pass found.
    pub fn step_report(&self) -> Result<PatchStepReport> {
        self.step.report()
    }

    /// The warning for a frame whose micro-patches were drawn in blocks.
    pub fn step_warning(&mut self) -> Result<Option<String>> {
        self.step.warning(self.name)
    }

    /// The set of a micro-patch pass over the occluder map `map`: `frame`,
    /// `occluder_map`, `receiver_front`, `receiver_pure`, `bound`, `tiles`, then `extra`.
    pub fn patch_set(
        &self,
        init: &TechniqueInit<'_>,
        map: &Image,
        nearest: &Sampler,
        extra: Vec<(&'static str, Resource<'_>)>,
        name: &str,
    ) -> Result<DescriptorSet> {
        let mut bindings = vec![
            ("frame", Resource::Uniform(init.ubo)),
            ("occluder_map", Resource::Sampled(map, nearest)),
            (
                "receiver_front",
                Resource::Sampled(&self.receivers.layers[0], nearest),
            ),
            (
                "receiver_pure",
                Resource::Sampled(&self.receivers.layers[1], nearest),
            ),
            ("bound", Resource::Storage(&self.bound.buffer)),
            ("tiles", Resource::Storage(&self.step.tiles)),
        ];
        bindings.extend(extra);
        DescriptorSet::new(init.ctx, &bindings, name)
    }

    /// The names of the passes `record` records, in order.
    pub fn pass_names(&self) -> Vec<String> {
        let mut names = vec![self.pass_name("maps")];
        if let Some(b) = &self.back {
            names.push(b.name.clone());
        }
        names.push(self.pass_name("receiver_bound"));
        names.push(self.pass_name("micro_patch_step"));
        names
    }
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
            packing: Packing::Plain,
        }
    }
}

/// `frame.technique` of every soft shadow map (glsl/ssm/constants.glsl).
pub(crate) fn ssm_uniforms(res: u32, frame: &FrameInput<'_>) -> [[f32; 4]; 2] {
    let n = res as f32;
    let mut c = [0.0; 8];
    // A sun's square of directions, in tan units: sqrt(pi) tan(theta).
    c[k::SSM_LIGHT_SIDE] = match frame.light.sun {
        Some(sun) => light_square_side(sun.tan_angle),
        None => light_square_side(frame.light_radius),
    };
    c[k::SSM_RES] = n;
    c[k::SSM_INV_RES] = 1.0 / n;
    c[k::SSM_SELF_GUARD_TEXELS] = SELF_GUARD_TEXELS;
    technique_constants(c)
}
