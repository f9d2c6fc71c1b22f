//! # pcf — percentage-closer filtering of a shadow map (Reeves, Salesin & Cook 1987)
//! Port sheet: docs/port/pcf.md
//! Speed layer: speed::regions (light-area-limited map, split final pass) — off under --plain.
//!
//! A hard shadow map filtered by a fixed kernel: the fraction of shadow-map texels around
//! the point's light uv that are farther than the point is its visibility. The kernel's
//! size is fixed in shadow-map texels, so the penumbra width does not depend on the light
//! radius R nor on the blocker/receiver distances (compare `pcss`); R is not read.
//!
//! ## Kernel (`Settings::pcf_kernel`, `--pcf-kernel`)
//! * `boxN` (N odd, 1..=15): N x N bilinear taps one texel apart, equally weighted. With
//!   f = fract(uv * res - 0.5) the summed weight of each texel of the (N+1) x (N+1) footprint
//!   is (Eq. 1, per axis) w(0) = 1 - f, w(N) = f, w(i) = 1 otherwise; visibility =
//!   sum(w_x w_y lit) / N^2. The footprint is read 2x2 texels per `textureGather`,
//!   ((N+1)/2)^2 gathers (box5: 9 gathers for 36 texels). `box1` is exactly `hard`.
//! * `poissonN` (N in 1..=64): the first N points of a fixed 64-point Poisson disc
//!   (`glsl/pcf/filter.glsl`, best-candidate order so every prefix is well spread) scaled
//!   to a radius of sqrt(N / pi) texels (Eq. 2: one sample per texel of disc area), each a
//!   2x2 bilinear tap (one gather), equally weighted. No per-pixel rotation: deterministic.
//!
//! ## Receiver plane
//! Each gather compares with the depth of the point's tangent plane along that tap's light
//! ray where the plane is closer than the point (after Isidoro 2006, receiver plane depth
//! bias; `glsl/pcf/filter.glsl`): d(uv) = d0 / (1 + g . (uv - uv0)), g = 2 tan(fov/2)
//! (Nx, Ny) / (N . D(uv0)) with N the light-view normal and D(uv) the light ray direction
//! ((2u-1) tan, (2v-1) tan, -1) (Eq. 3); under a sun's parallel rays d(uv) = d0 (1 - g .
//! (uv - uv0)), g = 2 h (Nx, Ny) / (d0 (N . D)), h the map's half width. Shifted by at most
//! a slope of 8 over the kernel radius. Without it a wide kernel reads the surface's own texels and shadows a surface
//! that slopes away from the light. Offsets are whole texels from the point's own 2x2
//! footprint, so box1 still compares at the point's depth: `box1` = `hard` exactly.
//!
//! ## Passes, in order
//! 1. `pcf/shadow_map` — casters from the light (`gpu::passes::ShadowMap::casters`).
//!    Attachment: R32_SFLOAT linear depth, clear 1e30 (`FAR_DEPTH`), blend MIN, no depth
//!    attachment; receivers are not drawn. Vertex `glsl/common/shadow_depth.vert`, fragment
//!    `glsl/common/caster_depth.frag`. Whole map under `--plain`; sampled by pass 2.
//! 2. `pcf/final` — every object from the camera (`gpu::passes::FinalPass`), fragment
//!    `glsl/pcf/final.frag`: reads the shadow map (nearest sampler, gathers) at the
//!    point's light uv, compares each texel with the point's offset linear depth
//!    (relative bias `frame.light_frustum.w`) and filters with the kernel above.
//!    Inputs: `frame.technique` = (kind: 0 box / 1 Poisson, N, Poisson radius in texels, 0).
//!    Writes colour RGBA8, no blending (the untimed AOV pass `pcf/aov` also visibility R32F,
//!    position RGBA32F, normal RGBA16F: `FinalPass`). Where every texel the kernel reads is
//!    lit the filter returns exactly 1 (it would be 1 only up to rounding as a weighted
//!    sum): what lets the speed layer's split pass give 1 without a lookup beyond the
//!    kernel's reach (`reach_texels`) of every caster.
//!
//! ## Equations: what a porter ports
//! - Eq. 1 (the box's per-texel weights): `pcf_box` (glsl/pcf/filter.glsl).
//! - Eq. 2 (the disc's radius): `poisson_radius_texels` here; the disc's taps: `pcf_poisson`
//!   (glsl/pcf/filter.glsl, the 64 points in `POISSON`).
//! - Eq. 3 (the receiver plane): `receiver_plane` and `plane_depth` (glsl/pcf/filter.glsl).
//!
//! Where the speed layer (`--plain` turns it off, `Settings::effective`) may change
//! these functions' inputs:
//! - The shadow map is cleared and drawn only over the casters' projected boxes
//!   (`regions::AroundCasters`): every texel outside holds the clear value, as in a
//!   whole map.
//! - `FinalPass::split` chooses which pixels run the final shader and which get 1 without
//!   a lookup; where the shader runs its inputs are the whole pass's (bit for bit).
//! - Culling leaves out objects outside the light's frustum (light passes) and the
//!   camera's (final pass): they write no texel a lookup reads and no pixel.
//! - Reuse skips the light passes when the light, its radius and every object are
//!   unchanged: the buffers then hold what the same passes wrote.
//!
//! ## Known artefacts
//! Penumbra of constant width in texels (too wide at contacts, too narrow far from them);
//! curved casters (concave toward the light) still shadow themselves under wide kernels,
//! the receiver plane being flat; few Poisson samples band the penumbra into N visible
//! steps; the acne of `hard` on faces lit at grazing angles (shared receiver offset and bias)
//! remains, slightly smoothed.

use super::{
    regions, shadow_map_buffer, technique_constants, FrameInput, LightBuffer, Technique,
    TechniqueInfo, TechniqueInit,
};
use crate::gpu::passes::{FinalPass, FinalShader, ShadowMap, Shadowed};
use crate::settings::PcfKernel;
use crate::shaders::{self, constants as k};
use crate::vk::{Context, DescriptorSet, Filter, Recorder, Resource, Sampler};
use anyhow::{Context as _, Result};

pub const INFO: TechniqueInfo = TechniqueInfo {
    name: "pcf",
    summary: "shadow map, percentage-closer filter (box NxN or Poisson disc)",
    create: Pcf::create,
};

/// Poisson kernel radius in texels for N samples (Eq. 2): one sample per texel of area.
pub fn poisson_radius_texels(samples: u32) -> f32 {
    (samples as f32 / std::f32::consts::PI).sqrt()
}

/// How far beyond the point's own 2x2 footprint, in texels, the kernel's gathers read:
/// box N reads (N - 1) / 2 texels before it and (N + 1) / 2 after; a Poisson tap lies
/// within the radius of the point (the points lie inside the unit disc) and its gather's
/// footprint is `regions::shadowed`'s.
pub fn reach_texels(kernel: PcfKernel) -> f32 {
    match kernel {
        PcfKernel::Box(n) => (n as f32 + 1.0) * 0.5,
        PcfKernel::Poisson(n) => poisson_radius_texels(n),
    }
}

/// The constants of `glsl/pcf/constants.glsl` for `kernel`.
pub fn kernel_uniform(kernel: PcfKernel) -> [[f32; 4]; 2] {
    let mut c = [0.0; 8];
    match kernel {
        PcfKernel::Box(n) => c[k::PCF_SAMPLES] = n as f32,
        PcfKernel::Poisson(n) => {
            c[k::PCF_KERNEL_KIND] = 1.0;
            c[k::PCF_SAMPLES] = n as f32;
            c[k::PCF_POISSON_RADIUS] = poisson_radius_texels(n);
        }
    }
    technique_constants(c)
}

pub struct Pcf {
    shadow: ShadowMap,
    final_pass: FinalPass,
    final_set: DescriptorSet,
    /// Where a caster texel lies within the kernel's reach, built with the light pass
    /// (`regions::AroundCasters`).
    shadowed: Shadowed,
    /// The casters' outlines `shadowed` is built from.
    around: regions::AroundCasters,
    kernel: PcfKernel,
    _sampler: Sampler,
}

impl Pcf {
    fn create(init: &TechniqueInit<'_>) -> Result<Box<dyn Technique>> {
        let ctx = init.ctx;
        let kernel = init.settings.pcf_kernel;
        // Renderer::new validated the settings already; a technique built another way must
        // not run a kernel the shader's loops and table do not cover.
        kernel.check()?;
        let shadow = ShadowMap::casters(ctx, init.ubo, init.settings.shadow_res, "pcf/shadow_map")
            .context("pcf shadow map")?;
        // Nearest: gathers ignore filtering, and no path may blend depths.
        let sampler = Sampler::new(ctx, Filter::Nearest).context("pcf sampler")?;
        let final_set = DescriptorSet::new(
            ctx,
            &[
                ("frame", Resource::Uniform(init.ubo)),
                ("shadow_map", Resource::Sampled(&shadow.depth, &sampler)),
            ],
            "pcf/final",
        )
        .context("pcf final descriptor set")?;
        // Split: the shader runs only within the kernel's reach of a caster (speed/regions.rs).
        let final_pass = FinalPass::split(
            ctx,
            "pcf/final",
            FinalShader {
                color: shaders::PCF_FINAL_FRAG,
                aov: shaders::PCF_FINAL_FRAG_AOV,
                count: shaders::PCF_FINAL_FRAG_COUNT,
            },
            &final_set,
        )
        .context("pcf final pass")?;
        Ok(Box::new(Self {
            shadow,
            final_pass,
            final_set,
            shadowed: Shadowed::Everywhere,
            around: regions::AroundCasters::default(),
            kernel,
            _sampler: sampler,
        }))
    }
}

impl Technique for Pcf {
    fn name(&self) -> &'static str {
        INFO.name
    }

    fn uniforms(&self, _frame: &FrameInput<'_>) -> [[f32; 4]; 2] {
        kernel_uniform(self.kernel)
    }

    fn record_light(
        &mut self,
        _ctx: &Context,
        rec: &mut Recorder<'_>,
        frame: &FrameInput<'_>,
    ) -> Result<()> {
        let area = self.around.map_area(frame, self.shadow.resolution);
        self.shadow.pass_in(rec, frame.gpu, &area)?;
        let res = self.shadow.resolution;
        self.shadowed = self.around.shadowed(frame, res, reach_texels(self.kernel));
        Ok(())
    }

    fn light_passes(&self) -> Vec<String> {
        vec!["pcf/shadow_map".into()]
    }

    fn record_final(
        &mut self,
        _ctx: &Context,
        rec: &mut Recorder<'_>,
        frame: &FrameInput<'_>,
    ) -> Result<()> {
        self.final_pass
            .pass_in(rec, frame, &self.final_set, &self.shadowed)
    }

    fn shadowed(&self) -> Option<&Shadowed> {
        Some(&self.shadowed)
    }

    fn light_buffers(&self) -> Vec<LightBuffer<'_>> {
        vec![shadow_map_buffer("shadow_map", &self.shadow)]
    }
}
