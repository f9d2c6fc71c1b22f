//! # pcf — percentage-closer filtering of a shadow map (Reeves, Salesin & Cook 1987)
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
//! ## Passes, in order
//! 1. `pcf/shadow_map` — casters from the light (`render::passes::ShadowMap`).
//!    Attachments: R32_SFLOAT linear depth (clear 1e30, no blend) + D32_SFLOAT (clear 1.0,
//!    LESS). Vertex `glsl/common/shadow_depth.vert`, fragment `glsl/common/shadow_depth.frag`.
//! 2. `pcf/final` — every object from the camera (`render::passes::FinalPass`), fragment
//!    `glsl/pcf/final.frag`: reads the shadow map (nearest sampler, gathers) at the
//!    normal-offset point's light uv, compares each texel with the point's linear depth
//!    (relative bias `frame.light_frustum.w`) and filters with the kernel above.
//!    Inputs: `frame.technique` = (kind: 0 box / 1 Poisson, N, Poisson radius in texels, 0).
//!    Writes colour RGBA8, visibility R32F, position RGBA32F, normal RGBA16F (no blending).
//!
//! ## Known artefacts
//! Penumbra of constant width in texels (too wide at contacts, too narrow far from them);
//! large kernels darken lit surfaces that slope away from the light (the texels around the
//! point belong to the same surface at other depths; the normal offset only covers one
//! texel); few Poisson samples band the penumbra into N visible steps.

use super::{FrameInput, Technique, TechniqueInfo, TechniqueInit};
use crate::render::passes::{FinalPass, ShadowMap};
use crate::render::PcfKernel;
use crate::shaders;
use crate::vk::{Context, DescriptorSet, Filter, Image, Recorder, Resource, Sampler};
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

/// `frame.technique` of `glsl/pcf/final.frag`.
pub fn kernel_uniform(kernel: PcfKernel) -> [f32; 4] {
    match kernel {
        PcfKernel::Box(n) => [0.0, n as f32, 0.0, 0.0],
        PcfKernel::Poisson(n) => [1.0, n as f32, poisson_radius_texels(n), 0.0],
    }
}

pub struct Pcf {
    shadow: ShadowMap,
    final_pass: FinalPass,
    final_set: DescriptorSet,
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
        let shadow = ShadowMap::new(ctx, init.ubo, init.settings.shadow_res, "pcf/shadow_map")
            .context("pcf shadow map")?;
        // Nearest: gathers ignore filtering, and no path may blend depths.
        let sampler = Sampler::new(ctx, Filter::Nearest).context("pcf sampler")?;
        let final_set = DescriptorSet::new(
            ctx,
            &[
                Resource::Uniform(init.ubo),
                Resource::Sampled(&shadow.depth, &sampler),
            ],
            "pcf/final",
        )
        .context("pcf final descriptor set")?;
        let final_pass = FinalPass::new(ctx, "pcf/final", shaders::PCF_FINAL_FRAG, &final_set)
            .context("pcf final pass")?;
        Ok(Box::new(Self {
            shadow,
            final_pass,
            final_set,
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
        [kernel_uniform(self.kernel), [0.0; 4]]
    }

    fn record(
        &mut self,
        _ctx: &Context,
        rec: &mut Recorder<'_>,
        frame: &FrameInput<'_>,
    ) -> Result<()> {
        rec.pass("pcf/shadow_map", |rec| {
            self.shadow.record(rec, frame.gpu);
            Ok(())
        })?;
        rec.pass("pcf/final", |rec| {
            self.final_pass
                .record(rec, frame.targets, frame.gpu, &self.final_set);
            Ok(())
        })
    }

    fn debug_image(&self, name: &str) -> Option<&Image> {
        (name == "shadow_map").then_some(&self.shadow.depth)
    }
}
