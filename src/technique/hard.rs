//! # hard — shadow map with a 2x2 filtered comparison
//!
//! The baseline of the smoothie paper's Fig. 7 (Williams 1978 with the 2x2 bilinear
//! "percentage closer" filter that shadow hardware gives for free). Every other technique's
//! cost is reported as a ratio to this one.
//!
//! ## Passes, in order
//! 1. `hard/shadow_map` — every object from the light (`render::passes::ShadowMap`).
//!    Attachment: R32G32_SFLOAT (clear 1e30, blend MIN), no depth attachment: r = linear
//!    depth of the nearest caster, g = of the nearest surface of any role. Vertex:
//!    `glsl/common/shadow_depth.vert` (clip w = linear depth); fragment:
//!    `glsl/common/shadow_depth.frag`.
//! 2. `hard/final` — every object from the camera (`render::passes::FinalPass`).
//!    Fragment `glsl/hard/final.frag` reads the shadow map with `textureGather` at the
//!    normal-offset point's light uv, compares each of the 4 texels with the point's linear
//!    depth (relative bias `frame.light_frustum.w`), and weights the 4 results bilinearly.
//!    Writes colour RGBA8 (the untimed AOV pass `hard/aov` also visibility R32F, position
//!    RGBA32F, normal RGBA16F: `FinalPass`).
//!
//! ## Known artefacts
//! Aliasing (staircase edges one shadow-map texel wide, softened over one texel by the 2x2
//! filter); no penumbra at any light radius.

use super::{shadow_map_buffer, FrameInput, LightBuffer, Technique, TechniqueInfo, TechniqueInit};
use crate::render::passes::{FinalPass, FinalShader, ShadowMap};
use crate::shaders;
use crate::vk::{Context, DescriptorSet, Filter, Recorder, Resource, Sampler};
use anyhow::Result;

pub const INFO: TechniqueInfo = TechniqueInfo {
    name: "hard",
    summary: "shadow map, one comparison per texel, 2x2 bilinear filter",
    create: Hard::create,
};

pub struct Hard {
    shadow: ShadowMap,
    final_pass: FinalPass,
    final_set: DescriptorSet,
    _sampler: Sampler,
}

impl Hard {
    fn create(init: &TechniqueInit<'_>) -> Result<Box<dyn Technique>> {
        let ctx = init.ctx;
        let shadow = ShadowMap::new(ctx, init.ubo, init.settings.shadow_res, "hard/shadow_map")?;
        // Nearest: textureGather ignores filtering, and no path may blend depths.
        let sampler = Sampler::new(ctx, Filter::Nearest)?;
        let final_set = DescriptorSet::new(
            ctx,
            &[
                Resource::Uniform(init.ubo),
                Resource::Sampled(&shadow.depth, &sampler),
            ],
            "hard/final",
        )?;
        let final_pass = FinalPass::new(
            ctx,
            "hard/final",
            FinalShader {
                color: shaders::HARD_FINAL_FRAG,
                aov: shaders::HARD_FINAL_FRAG_AOV,
            },
            &final_set,
        )?;
        Ok(Box::new(Self {
            shadow,
            final_pass,
            final_set,
            _sampler: sampler,
        }))
    }
}

impl Technique for Hard {
    fn name(&self) -> &'static str {
        INFO.name
    }

    fn record_light(
        &mut self,
        _ctx: &Context,
        rec: &mut Recorder<'_>,
        frame: &FrameInput<'_>,
    ) -> Result<()> {
        self.shadow.pass(rec, frame.gpu)?;
        Ok(())
    }

    fn light_passes(&self) -> Vec<String> {
        vec!["hard/shadow_map".into()]
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
        vec![shadow_map_buffer("shadow_map", &self.shadow)]
    }
}
