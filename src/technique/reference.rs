//! # reference — ray-cast ground truth at the camera's pixels
//! Port sheet: docs/port/reference.md
//! Speed layer: none; the ray cast is reused on a still frame — off under --plain.
//!
//! docs/DESIGN.md's exact visibility: the fraction of the spherical light's disc (centre L,
//! radius R, facing the shaded point) that the point sees, by stratified shadow rays (at least
//! 256 per pixel, deterministic seed) against the casters' exact triangles on the CPU
//! (`reference`, obvhs BVH, rayon), at exactly the surface points the camera pixels
//! show. Not a real-time technique: it is what every other technique's error is measured
//! against, and `--technique reference` shows it as an image.
//!
//! ## Steps, in order
//! 1. `reference/positions` (CPU timer; GPU work on the technique's own command buffer,
//!    before the frame's): the AOV build of the final pass below draws every object from the
//!    camera into the camera targets to get the `position` (RGBA32F) and `normal` (RGBA16F)
//!    AOVs, which are read back. Steps 1 to 3 are skipped (`--timings` prints `reference/ray_cast skipped`)
//!    when the camera, the light, R, the object transforms and the size are those of the
//!    last computed frame.
//! 2. `reference/ray_cast` (CPU): `reference::visibility_cached` at those points
//!    (read from the on-disk cache when the same inputs were computed before).
//! 3. `reference/upload` (CPU + a copy on the technique's command buffer, submitted and
//!    waited for): the values into `reference visibility`, R32_SFLOAT of the camera's size
//!    (filled with 1 at creation so it is never undefined). The copy leaves it in
//!    TRANSFER_DST_OPTIMAL; the frame's barrier in front of step 4 moves it to
//!    SHADER_READ_ONLY_OPTIMAL for the fragment shader.
//! 4. `reference/final` — every object from the camera (`gpu::passes::FinalPass`).
//!    Fragment `glsl/reference/final.frag` reads the image with `texelFetch` at
//!    `gl_FragCoord` (no filtering: one value per pixel). Writes colour RGBA8 (and, in the
//!    untimed AOV pass `reference/aov`, visibility R32F, position RGBA32F, normal RGBA16F;
//!    clear values and depth test of `FinalPass`).
//!
//! Step 1 and step 4 rasterise the same triangles with the same matrices, so each pixel of
//! step 4 reads the value computed at its own surface point.
//!
//! ## What a porter ports
//! A ground truth, not a technique to port: the visibility of one point is
//! `reference::visibility_at` (src/reference.rs; the disc's samples `concentric_disc`, the
//! ray start off the surface `starts`). The speed layer only reuses step 2's result on a
//! still frame (off under `--plain`); the on-disk cache holds the same inputs' exact result.
//!
//! ## Known artefacts
//! Noise of the stratified estimate (256 samples: standard deviation well under 1/256 * 16
//! in penumbrae); seconds to minutes per new view on a CPU (cached afterwards).

use super::{FrameInput, Technique, TechniqueInfo, TechniqueInit};
use crate::gpu::passes::{FinalPass, FinalShader};
use crate::reference::{visibility_cached, ReferenceParams};
use crate::scene::{Camera, Light};
use crate::shaders;
use crate::vk::{
    read_image, Buffer, BufferUsageFlags, Context, DescriptorSet, Filter, Format, FrameRunner,
    Image, ImageUsageFlags, MemoryLocation, Recorder, Resource, Sampler,
};
use anyhow::{Context as _, Result};
use glam::Mat4;

pub const INFO: TechniqueInfo = TechniqueInfo {
    name: "reference",
    summary: "ray-cast exact visibility of the disc light (CPU, BVH, >= 256 rays per pixel)",
    create: Reference::create,
};

/// What the reference of a frame depends on besides the (fixed) meshes.
#[derive(Clone, Debug, PartialEq)]
struct FrameKey {
    camera: Camera,
    light: Light,
    radius: f32,
    transforms: Vec<Mat4>,
    size: (u32, u32),
}

/// Per camera pixel: world position (A = 1 on surfaces) and normal, as the AOVs hold them.
type CameraPoints = (Vec<[f32; 4]>, Vec<[f32; 3]>);

pub struct Reference {
    visibility: Image,
    staging: Buffer,
    final_pass: FinalPass,
    final_set: DescriptorSet,
    _sampler: Sampler,
    /// The technique's own command buffer for the positions pass, readbacks and uploads,
    /// which must finish before the frame's final pass is recorded.
    runner: FrameRunner,
    params: ReferenceParams,
    last: Option<FrameKey>,
}

impl Reference {
    fn create(init: &TechniqueInit<'_>) -> Result<Box<dyn Technique>> {
        let ctx = init.ctx;
        let s = init.settings;
        let params = ReferenceParams {
            samples: s.reference_samples,
            seed: s.reference_seed,
        };
        params.validate()?;
        let visibility = Image::new_2d(
            ctx,
            s.width,
            s.height,
            Format::R32_SFLOAT,
            ImageUsageFlags::SAMPLED | ImageUsageFlags::TRANSFER_DST,
            "reference visibility",
        )
        .context("creating the reference visibility image")?;
        let ones = vec![1.0f32; s.width as usize * s.height as usize];
        let staging = Buffer::new(
            ctx,
            (ones.len() * 4) as u64,
            BufferUsageFlags::TRANSFER_SRC,
            MemoryLocation::CpuToGpu,
            "reference visibility staging",
        )
        .context("creating the reference staging buffer")?;
        // Nearest: texelFetch ignores the filter; no path may blend two pixels' values.
        let sampler =
            Sampler::new(ctx, Filter::Nearest).context("creating the reference sampler")?;
        let final_set = DescriptorSet::new(
            ctx,
            &[
                ("frame", Resource::Uniform(init.ubo)),
                (
                    "reference_visibility",
                    Resource::Sampled(&visibility, &sampler),
                ),
            ],
            "reference/final",
        )
        .context("creating the reference descriptor set")?;
        let final_pass = FinalPass::new(
            ctx,
            "reference/final",
            FinalShader {
                color: shaders::REFERENCE_FINAL_FRAG,
                aov: shaders::REFERENCE_FINAL_FRAG_AOV,
                count: shaders::REFERENCE_FINAL_FRAG_COUNT,
            },
            &final_set,
        )
        .context("creating the reference final pass")?;
        let mut this = Self {
            visibility,
            staging,
            final_pass,
            final_set,
            _sampler: sampler,
            runner: FrameRunner::new(ctx, 1).context("creating the reference command buffer")?,
            params,
            last: None,
        };
        this.upload(&ones)?;
        Ok(Box::new(this))
    }

    /// Copies one value per camera pixel into the visibility image.
    fn upload(&mut self, values: &[f32]) -> Result<()> {
        self.staging.write(0, bytemuck::cast_slice(values))?;
        let (staging, image) = (&self.staging, &self.visibility);
        self.runner
            .run(|rec| {
                rec.copy_buffer_to_image(staging, image);
                Ok(())
            })
            .context("uploading the reference visibility")?;
        Ok(())
    }

    /// Draws the camera view with the final pass and reads its positions and normals back.
    fn camera_points(&mut self, ctx: &Context, frame: &FrameInput<'_>) -> Result<CameraPoints> {
        let (pass, set) = (&self.final_pass, &self.final_set);
        self.runner
            .run(|rec| {
                pass.record(rec, frame.targets, frame.gpu, set, true);
                Ok(())
            })
            .context("rendering the reference's camera positions")?;
        let positions = read_image::<[f32; 4]>(ctx, &mut self.runner, &frame.targets.position)?;
        let normals = read_image::<[half::f16; 4]>(ctx, &mut self.runner, &frame.targets.normal)?
            .into_iter()
            .map(|n| [n[0].to_f32(), n[1].to_f32(), n[2].to_f32()])
            .collect();
        Ok((positions, normals))
    }
}

impl Technique for Reference {
    fn name(&self) -> &'static str {
        INFO.name
    }

    fn record_light(
        &mut self,
        _ctx: &Context,
        _rec: &mut Recorder<'_>,
        _frame: &FrameInput<'_>,
    ) -> Result<()> {
        // Nothing from the light: the ray cast depends on the camera's surface points, so it
        // runs (or is skipped by its own key) in `record_final`.
        Ok(())
    }

    fn light_passes(&self) -> Vec<String> {
        Vec::new()
    }

    fn record_final(
        &mut self,
        ctx: &Context,
        rec: &mut Recorder<'_>,
        frame: &FrameInput<'_>,
    ) -> Result<()> {
        let key = FrameKey {
            camera: frame.scene.camera,
            light: frame.scene.light,
            radius: frame.light_radius,
            transforms: frame.scene.objects.iter().map(|o| o.transform).collect(),
            size: (frame.targets.width, frame.targets.height),
        };
        // `Settings::plain` casts again; the on-disk cache still answers (the same inputs'
        // exact result, not a shortcut of the estimator).
        if !frame.settings.plain && self.last.as_ref() == Some(&key) {
            rec.skip("reference/ray_cast", "camera, light and objects unchanged");
        } else {
            self.last = None;
            let (positions, normals) =
                rec.cpu("reference/positions", || self.camera_points(ctx, frame))?;
            let params = self.params;
            let vis = rec.cpu("reference/ray_cast", || {
                visibility_cached(
                    frame.scene,
                    frame.light_radius,
                    &positions,
                    &normals,
                    &params,
                )
            })?;
            rec.cpu("reference/upload", || self.upload(&vis))?;
            self.last = Some(key);
        }
        self.final_pass.pass(rec, frame, &self.final_set)
    }
}
