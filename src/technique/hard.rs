//! # hard — depth map with the hardware's 2x2 filtered comparison
//! Port sheet: docs/port/hard.md
//! Speed layer: none of its own; the renderer's culling and light-pass reuse — off under --plain.
//!
//! The baseline of the smoothie paper's Fig. 7 (Williams 1978 with the 2x2 bilinear
//! "percentage closer" filter that shadow hardware gives for free), built as an engine
//! builds it: a depth-only pass and a comparison sampler. Every other technique's cost is
//! reported as a ratio to this one.
//!
//! ## Passes, in order
//! 1. `hard/shadow_map` — every caster from the light (receivers are not drawn: only the
//!    nearest caster is compared against). Attachment: depth `D32_SFLOAT`, clear 1.0, depth
//!    test LESS, depth write on; no colour attachment, no fragment shader, no rasterizer
//!    depth bias, two-sided (open meshes and planes cast from both sides). Vertex:
//!    `glsl/hard/shadow_map.vert` (the light's view-projection: the buffer holds
//!    z = f / (f - n) * (1 - n / d) of linear depth d, near n and far f of the light; a
//!    sun's orthographic map holds z = (d - n) / (f - n)).
//!    The barrier in front of pass 2 waits for its depth writes and moves it to
//!    SHADER_READ_ONLY_OPTIMAL.
//! 2. `hard/final` — every object from the camera (`gpu::passes::FinalPass`). Fragment
//!    `glsl/hard/final.frag` samples the map through a `sampler2DShadow` (compare
//!    LESS_OR_EQUAL, linear filter, clamp to edge) at the point's own light uv (its light
//!    clip coordinates come interpolated from `common/scene.vert`) and the offset depth d
//!    (`common/shadow.glsl`: the point moved towards the light along its ray until it is 2
//!    texels, scaled by the light's slope, above its tangent plane), with the reference depth
//!    d / (1 + b) mapped to z as above (b the relative bias
//!    `frame.light_frustum.w`, 5e-4): 1 where the point is at or in front of the stored caster,
//!    each of the 2x2 texels compared and the results weighted bilinearly by the sampler.
//!    Writes colour RGBA8 (the untimed AOV pass `hard/aov` also visibility R32F, position
//!    RGBA32F, normal RGBA16F: `FinalPass`).
//!
//! Bias: the receiver offset keeps lit surfaces off their own texel (no acne) without a large
//! constant offset that would detach contact shadows, and unlike a normal offset (the point
//! moved along its normal) it leaves the lookup uv alone, so no shadow shifts across a
//! tilted receiver; the small relative bias absorbs the float rounding of depth. A
//! slope-scaled rasterizer bias is not needed on top.
//!
//! ## Equations: what a porter ports
//! - The receiver offset and the point's light uv and depth: `light_sample`
//!   (glsl/common/shadow.glsl), shared by every shadow-map technique.
//! - The hard test with its 2x2 filter: `visibility` (glsl/hard/final.frag): the
//!   comparison sampler compares and filters; the relative bias is folded into the
//!   reference depth.
//!
//! Where the speed layer (`--plain` turns it off, `Settings::effective`) may change
//! these functions' inputs:
//! - Culling leaves out objects outside the light's frustum (light passes) and the
//!   camera's (final pass): they write no texel a lookup reads and no pixel.
//! - Reuse skips the light passes when the light, its radius and every object are
//!   unchanged: the buffers then hold what the same passes wrote.
//!
//! Nothing else: the final pass is one whole pass.
//!
//! ## Known artefacts
//! Aliasing (staircase edges one shadow-map texel wide, softened over one texel by the 2x2
//! filter); no penumbra at any light radius.

use super::{FrameInput, LightBuffer, Packing, Technique, TechniqueInfo, TechniqueInit};
use crate::gpu::gpu_scene::{DRAW_PUSH_BYTES, SCENE_ATTRIBUTES, SCENE_VERTEX_STRIDE};
use crate::gpu::passes::{FinalPass, FinalShader};
use crate::shaders;
use crate::vk::{
    CompareOp, Context, CullModeFlags, DepthState, DescriptorSet, Format, GraphicsPipelineDesc,
    Image, ImageUsageFlags, Pipeline, PrimitiveTopology, Recorder, Resource, Sampler,
};
use anyhow::{Context as _, Result};

pub const INFO: TechniqueInfo = TechniqueInfo {
    name: "hard",
    summary: "shadow map, one comparison per texel, 2x2 bilinear filter",
    create: |init| Ok(Box::new(Hard::create(init, NAMES)?)),
};

/// The names of the passes (= timestamp and debug labels) and of the technique: `hard`'s,
/// or those of a technique that is `hard` at R = 0 (`ssm-bitmask`, whose soft shadow map
/// has no penumbra to sample under a point light).
pub(crate) struct Names {
    pub technique: &'static str,
    pub shadow_map: &'static str,
    pub final_pass: &'static str,
}

const NAMES: Names = super::pass_names!(
    Names {
        shadow_map: "shadow_map",
        final_pass: "final",
    },
    "hard"
);

pub struct Hard {
    names: Names,
    map: Image,
    map_pipeline: Pipeline,
    map_set: DescriptorSet,
    final_pass: FinalPass,
    final_set: DescriptorSet,
    _sampler: Sampler,
}

impl Hard {
    pub(crate) fn create(init: &TechniqueInit<'_>, names: Names) -> Result<Self> {
        let ctx = init.ctx;
        let res = init.settings.shadow_res;
        let map = Image::new_2d(
            ctx,
            res,
            res,
            Format::D32_SFLOAT,
            ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT
                | ImageUsageFlags::SAMPLED
                | ImageUsageFlags::TRANSFER_SRC,
            &format!("{} depth", names.shadow_map),
        )?;
        let map_set = DescriptorSet::new(
            ctx,
            &[("frame", Resource::Uniform(init.ubo))],
            names.shadow_map,
        )?;
        let map_pipeline = Pipeline::graphics(
            ctx,
            &GraphicsPipelineDesc {
                name: names.shadow_map,
                vertex: shaders::HARD_SHADOW_MAP_VERT,
                fragment: None,
                vertex_stride: SCENE_VERTEX_STRIDE,
                attributes: &SCENE_ATTRIBUTES[..1],
                topology: PrimitiveTopology::TRIANGLE_LIST,
                // Open meshes and planes cast from both sides.
                cull: CullModeFlags::NONE,
                colors: &[],
                depth: Some(DepthState {
                    format: Format::D32_SFLOAT,
                    test: true,
                    write: true,
                    compare: CompareOp::LESS,
                }),
                push_constant_bytes: DRAW_PUSH_BYTES,
                sets: &[&map_set],
            },
        )
        .context("creating the hard shadow-map pipeline")?;
        // Compare LESS_OR_EQUAL: lit where the point's reference depth is at or in front of
        // the stored caster; linear: the 2x2 bilinear filter of the results.
        let sampler = Sampler::compare(ctx, CompareOp::LESS_OR_EQUAL)?;
        let final_set = DescriptorSet::new(
            ctx,
            &[
                ("frame", Resource::Uniform(init.ubo)),
                ("shadow_map", Resource::Sampled(&map, &sampler)),
            ],
            names.final_pass,
        )?;
        let final_pass = FinalPass::new(
            ctx,
            names.final_pass,
            FinalShader {
                color: shaders::HARD_FINAL_FRAG,
                aov: shaders::HARD_FINAL_FRAG_AOV,
                count: shaders::HARD_FINAL_FRAG_COUNT,
            },
            &final_set,
        )?;
        Ok(Self {
            names,
            map,
            map_pipeline,
            map_set,
            final_pass,
            final_set,
            _sampler: sampler,
        })
    }
}

impl Technique for Hard {
    fn name(&self) -> &'static str {
        self.names.technique
    }

    fn record_light(
        &mut self,
        _ctx: &Context,
        rec: &mut Recorder<'_>,
        frame: &FrameInput<'_>,
    ) -> Result<()> {
        let (map, pipeline, set) = (&self.map, &self.map_pipeline, &self.map_set);
        rec.pass(self.names.shadow_map, |rec| {
            rec.begin_rendering(&[], Some((map, Some(1.0))));
            rec.bind_pipeline(pipeline);
            rec.bind_sets(pipeline, &[set]);
            frame.gpu.draw(rec, pipeline, |o| o.role.casts());
            rec.end_rendering();
            Ok(())
        })
    }

    fn light_passes(&self) -> Vec<String> {
        vec![self.names.shadow_map.into()]
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
        vec![LightBuffer {
            name: "shadow_map",
            image: &self.map,
            // The depth buffer as stored: z/w of the light's projection, 1 where no caster.
            channels: &["caster_z"],
            packing: Packing::Plain,
        }]
    }
}
