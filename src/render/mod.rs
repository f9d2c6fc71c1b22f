//! One frame of one technique: frame constants, the camera targets, and the readback of
//! the image and AOVs. `Renderer` is what `render`, `bench` and the tests drive.
//! `describe` writes a technique's port sheet from one logged frame.

pub mod describe;

use crate::frustum::{camera_view_proj, check_radius, effective_depth_bias, fit_light};
use crate::gpu::{CameraTargets, GpuScene};
use crate::output::FrameImages;
use crate::scene::{LightView, Scene};
use crate::settings::Settings;
use crate::technique::{self, packed, FrameInput, Packing, Technique, TechniqueInit};
use crate::vk::describe::FrameLog;
use crate::vk::{read_image, Buffer, BufferUsageFlags, Context, FrameRunner, FrameTimings};
use anyhow::{bail, Context as _, Result};
use bytemuck::{Pod, Zeroable};
use glam::Mat4;
use half::f16;

/// Largest number of timed passes in one frame.
const MAX_PASSES: u32 = 32;

/// Frame constants; mirrors `Frame` in glsl/common/frame.glsl (std140: only mat4 and vec4).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct FrameUniforms {
    pub cam_view_proj: [f32; 16],
    pub light_view: [f32; 16],
    pub light_view_proj: [f32; 16],
    pub light_pos_radius: [f32; 4],
    pub cam_pos: [f32; 4],
    pub light_params: [f32; 4],
    pub light_frustum: [f32; 4],
    pub technique: [f32; 4],
    pub technique2: [f32; 4],
    /// x: 1 for a sun (orthographic map), 0 for a spotlight; y: tan of the sun's angular
    /// radius; z: a sun's world texel size; w: 0.
    pub sun: [f32; 4],
    /// `LightView::spot_from_clip`: light clip coordinates to the spot cone's own, for the
    /// spot falloff when the map is fitted inside the cone.
    pub spot_from_light_clip: [f32; 16],
}

impl FrameUniforms {
    /// The frame constants of `scene` seen at `width` x `height` (`settings`) under `light`
    /// with radius `light_radius`, and a technique's own two vec4s. Public so that a port
    /// (or `examples/gl_hard_frame.rs`) can feed its shaders the very same constants.
    pub fn new(
        scene: &Scene,
        settings: &Settings,
        light: &LightView,
        light_radius: f32,
        technique: [[f32; 4]; 2],
    ) -> Self {
        let (s, l) = (settings, light);
        let tan_half = (l.fov_deg.to_radians() * 0.5).tan();
        Self {
            cam_view_proj: camera_view_proj(scene, s.width, s.height).to_cols_array(),
            light_view: l.view.to_cols_array(),
            light_view_proj: l.view_proj.to_cols_array(),
            // A sun has no position: its unit direction towards the light instead.
            light_pos_radius: match l.sun {
                Some(_) => scene.light.direction().extend(0.0).to_array(),
                None => l.position.extend(light_radius).to_array(),
            },
            cam_pos: scene.camera.position.extend(1.0).to_array(),
            light_params: [
                l.near,
                l.far,
                s.shadow_res as f32,
                1.0 / s.shadow_res as f32,
            ],
            light_frustum: [
                tan_half,
                2.0 * tan_half / s.shadow_res as f32,
                s.normal_offset_texels,
                effective_depth_bias(s.depth_bias, l.depth_span, l.far),
            ],
            technique: technique[0],
            technique2: technique[1],
            sun: match l.sun {
                Some(sun) => [1.0, sun.tan_angle, l.texel_world(0.0, s.shadow_res), 0.0],
                None => [0.0; 4],
            },
            spot_from_light_clip: l.spot_from_clip.to_cols_array(),
        }
    }
}

fn frame_uniforms(f: &FrameInput<'_>, technique: [[f32; 4]; 2]) -> FrameUniforms {
    FrameUniforms::new(f.scene, f.settings, f.light, f.light_radius, technique)
}

pub struct Renderer<'c> {
    ctx: &'c Context,
    pub scene: Scene,
    pub settings: Settings,
    gpu: GpuScene,
    ubo: Buffer,
    targets: CameraTargets,
    runner: FrameRunner,
    technique: Box<dyn Technique>,
    pub light: LightView,
    last_light_key: Option<LightKey>,
}

/// What the light-space passes of a frame depend on (`Renderer::render` skips them when it
/// equals the last frame's).
#[derive(Clone, Debug, PartialEq)]
struct LightKey {
    light: crate::scene::Light,
    radius: f32,
    near_far: (f32, f32),
    /// The light's frame: fitted to what the camera sees, it moves with the camera.
    view_proj: Mat4,
    transforms: Vec<Mat4>,
    any_caster: bool,
    settings: Settings,
}

impl<'c> Renderer<'c> {
    pub fn new(
        ctx: &'c Context,
        scene: Scene,
        technique_name: &str,
        settings: Settings,
    ) -> Result<Self> {
        settings.validate(ctx)?;
        let settings = settings.effective();
        scene.validate()?;
        check_radius(&scene, settings.radius_for(&scene))?;
        // The radius in effect is the scene's from here on: the light's fit reads it for
        // the penumbrae's reach (`frustum::fit_light`).
        let mut scene = scene;
        scene.light.radius = settings.radius_for(&scene);
        let info = technique::find(technique_name)?;
        technique::check_light(info.name, &scene)?;
        let gpu = GpuScene::new(ctx, &scene).context("uploading the scene")?;
        let ubo = Buffer::new(
            ctx,
            std::mem::size_of::<FrameUniforms>() as u64,
            BufferUsageFlags::UNIFORM_BUFFER,
            crate::vk::MemoryLocation::CpuToGpu,
            "frame uniforms",
        )?;
        let targets = CameraTargets::new(ctx, settings.width, settings.height)?;
        let runner = FrameRunner::new(ctx, MAX_PASSES)?;
        let technique = (info.create)(&TechniqueInit {
            ctx,
            scene: &scene,
            gpu: &gpu,
            ubo: &ubo,
            settings: &settings,
        })
        .with_context(|| format!("creating technique {}", info.name))?;
        let light = fit_light(&scene);
        Ok(Self {
            ctx,
            scene,
            settings,
            gpu,
            ubo,
            targets,
            runner,
            technique,
            light,
            last_light_key: None,
        })
    }

    pub fn technique_name(&self) -> &'static str {
        self.technique.name()
    }

    /// The Rust type that implements the technique (`Technique::type_name`).
    pub fn technique_type(&self) -> &'static str {
        self.technique.type_name()
    }

    /// Renders `frames` frames as `render` does, logging every command they record
    /// (`vk::describe`): what `softshadow describe` draws a port sheet from.
    pub fn log_frames(&mut self, frames: u32) -> Result<FrameLog> {
        self.runner.start_log();
        let rendered = (0..frames).try_for_each(|_| self.render().map(|_| ()));
        let log = self.runner.take_log();
        rendered.map(|()| log)
    }

    /// The soft shadow maps' micro-patch block side of the last frame
    /// (`Technique::micro_patch_step`).
    pub fn micro_patch_step(&self) -> Option<crate::technique::ssm::PatchStepReport> {
        self.technique.micro_patch_step()
    }

    /// Where the last frame's timed final pass ran the technique's shader
    /// (`Technique::shadowed`).
    pub fn shadowed(&self) -> Option<&crate::gpu::passes::Shadowed> {
        self.technique.shadowed()
    }

    /// The light radius in effect.
    pub fn light_radius(&self) -> f32 {
        self.settings.radius_for(&self.scene)
    }

    /// Renders one frame and returns its per-pass timings.
    pub fn render(&mut self) -> Result<FrameTimings> {
        self.light = fit_light(&self.scene);
        self.gpu.set_transforms(&self.scene);
        let cam = camera_view_proj(&self.scene, self.settings.width, self.settings.height);
        let any_caster = self
            .gpu
            .cull(self.light.view_proj, cam, self.settings.culling);
        // Everything the light-space passes depend on; the camera only through the light's fit.
        let light_key = Some(LightKey {
            light: self.scene.light,
            radius: self.light_radius(),
            near_far: (self.light.near, self.light.far),
            view_proj: self.light.view_proj,
            transforms: self.scene.objects.iter().map(|o| o.transform).collect(),
            any_caster,
            settings: self.settings.clone(),
        });
        let input = FrameInput {
            scene: &self.scene,
            gpu: &self.gpu,
            light: &self.light,
            settings: &self.settings,
            targets: &self.targets,
            light_radius: self.light_radius(),
            aov: false,
            count: false,
        };
        let u = frame_uniforms(&input, self.technique.uniforms(&input));
        self.ubo.write(0, bytemuck::bytes_of(&u))?;
        let ctx = self.ctx;
        let technique = &mut self.technique;
        let skip = match (light_key == self.last_light_key, any_caster) {
            _ if !self.settings.cache_light_passes => None,
            (true, true) => Some("light and casters unchanged"),
            // The first frame still records the (culled, empty) passes so that every buffer the
            // final pass samples is initialised (cleared to "lit").
            (true, false) => Some("no caster in the light frustum"),
            (false, _) => None,
        };
        let timings = self.runner.run(|rec| {
            match skip {
                Some(reason) => {
                    for name in technique.light_passes() {
                        rec.skip(&name, reason);
                    }
                }
                None => technique.record_light(ctx, rec, &input)?,
            }
            technique.record_final(ctx, rec, &input)
        })?;
        self.last_light_key = light_key;
        if let Some(w) = self.technique.frame_warning()? {
            eprintln!("warning: {w}");
        }
        let mut timings = timings;
        timings.image_pixels = self.settings.width as u64 * self.settings.height as u64;
        timings.map_texels = self.settings.shadow_res as u64 * self.settings.shadow_res as u64;
        Ok(timings)
    }

    /// Reads the image of the last frame back to the host, then runs the AOV pass (the
    /// technique's final pass again, untimed, same geometry and visibility code, writing
    /// visibility, position and normal too) and reads those. The timed frame writes colour
    /// only, as an engine's would; the AOV pass's colour is bit-identical (tests/core.rs).
    pub fn read_back(&mut self) -> Result<FrameImages> {
        let color = self.read_color()?;
        self.render_aov()?;
        let t = &self.targets;
        let visibility = read_image::<f32>(self.ctx, &mut self.runner, &t.visibility)?;
        let position = read_image::<[f32; 4]>(self.ctx, &mut self.runner, &t.position)?;
        let normal16 = read_image::<[f16; 4]>(self.ctx, &mut self.runner, &t.normal)?;
        let normal = normal16
            .iter()
            .map(|n| [n[0].to_f32(), n[1].to_f32(), n[2].to_f32()])
            .collect();
        let spot = normal16.iter().map(|n| n[3].to_f32()).collect();
        Ok(FrameImages {
            width: t.width,
            height: t.height,
            color,
            visibility,
            position,
            normal,
            spot,
        })
    }

    /// The colour target as the last pass left it (RGBA8, row 0 at the top).
    pub fn read_color(&mut self) -> Result<Vec<[u8; 4]>> {
        read_image::<[u8; 4]>(self.ctx, &mut self.runner, &self.targets.color)
    }

    /// The technique's final pass with the AOV targets, after the last `render` (its light
    /// passes' buffers and frame constants are reused as they are).
    fn render_aov(&mut self) -> Result<()> {
        let input = FrameInput {
            scene: &self.scene,
            gpu: &self.gpu,
            light: &self.light,
            settings: &self.settings,
            targets: &self.targets,
            light_radius: self.settings.radius_for(&self.scene),
            aov: true,
            count: false,
        };
        let (ctx, technique) = (self.ctx, &mut self.technique);
        self.runner
            .run(|rec| technique.record_final(ctx, rec, &input))
            .context("rendering the AOV pass")?;
        Ok(())
    }

    /// The counting frame (untimed, after the last `render`, like the AOV pass): the light
    /// passes again, with every pipeline that reads a texture bound as its counting build
    /// (`-DCOUNT_LIGHT`: texels read, added up per 8x4 tile of the pass's target), then the
    /// final pass again, built with `-DCOUNT` and drawn as the timed one was (split where it
    /// is split), adding up per pixel the texels its shader read and its search, filter and
    /// march iterations (glsl/common/count.glsl). The light passes run even where the timed
    /// frame reused them, and give the same buffers; the image equals the timed frame's bit
    /// for bit (tests/work_counts.rs), so `read_color` after it still gives the image.
    pub fn count_lookups(&mut self) -> Result<LookupCounts> {
        let input = FrameInput {
            scene: &self.scene,
            gpu: &self.gpu,
            light: &self.light,
            settings: &self.settings,
            targets: &self.targets,
            light_radius: self.settings.radius_for(&self.scene),
            aov: false,
            count: true,
        };
        let s = &self.settings;
        let extent = [s.width, s.height, s.shadow_res, s.occluder_res]
            .into_iter()
            .max()
            .unwrap_or(1);
        let (ctx, technique) = (self.ctx, &mut self.technique);
        let (timings, light) = self
            .runner
            .run_counting(ctx, extent, |rec| {
                technique.record_light(ctx, rec, &input)?;
                technique.record_final(ctx, rec, &input)
            })
            .context("rendering the counting frame")?;
        let counts = read_image::<[f32; 4]>(self.ctx, &mut self.runner, &self.targets.count)?;
        Ok(LookupCounts {
            pass: timings
                .passes
                .iter()
                .map(|p| p.name.clone())
                .find(|n| n.ends_with("/count"))
                .unwrap_or_default(),
            width: self.targets.width,
            height: self.targets.height,
            per_pixel: counts
                .iter()
                .map(|c| c.map(|v| v.max(0.0).round() as u64))
                .collect(),
            light,
        })
    }

    /// The silhouette edges the GPU found in the last build, per caster (object index,
    /// caster-local edges), or `None` when the technique does not run the GPU path.
    pub fn read_gpu_silhouettes(
        &mut self,
    ) -> Result<Option<crate::silhouette::gpu::CasterSilhouettes>> {
        let Some(gpu) = self.technique.gpu_silhouettes() else {
            return Ok(None);
        };
        let words: Vec<u32> =
            crate::vk::read_buffer(self.ctx, &mut self.runner, gpu.silhouette_flags())?;
        Ok(Some(gpu.decode(&words)))
    }

    /// The geometry the GPU silhouette passes built, per caster (object index, the floats of
    /// the vertices its indirect draw draws), or `None` when the technique does not run the
    /// GPU path.
    pub fn read_gpu_geometry(&mut self) -> Result<Option<crate::silhouette::gpu::CasterGeometry>> {
        let Some(gpu) = self.technique.gpu_silhouettes() else {
            return Ok(None);
        };
        let (commands, vertices) = gpu.geometry_buffers();
        let commands: Vec<u32> = crate::vk::read_buffer(self.ctx, &mut self.runner, commands)?;
        let floats: Vec<f32> = crate::vk::read_buffer(self.ctx, &mut self.runner, vertices)?;
        Ok(Some(gpu.decode_geometry(&commands, &floats)))
    }

    /// How many objects the last frame's culling kept for the light-space passes and for the
    /// camera pass: (in the light's frustum, in the camera's). Every object when culling is
    /// off (tests/avoided_work.rs).
    pub fn objects_in_frusta(&self) -> (usize, usize) {
        self.gpu.in_frusta()
    }

    /// How many casters the GPU silhouette passes rebuilt in the last frame that ran them.
    pub fn gpu_silhouettes_rebuilt(&self) -> Option<usize> {
        self.technique.gpu_silhouettes().map(|g| g.rebuilt())
    }

    /// Names of the technique's light-space buffers (`read_technique_buffer`), in the
    /// order the technique lists them; empty when it has none.
    pub fn technique_buffer_names(&self) -> Vec<&'static str> {
        self.technique
            .light_buffers()
            .iter()
            .map(|b| b.name)
            .collect()
    }

    /// Reads a technique buffer by name (`technique_buffer_names`), one Vec per channel
    /// with the channel names (the linear shadow map has two: caster_depth, surface_depth;
    /// `hard`'s D32 map one, the light's z/w of the nearest caster).
    pub fn read_technique_buffer(&mut self, name: &str) -> Result<TechniqueBuffer> {
        let buffers = self.technique.light_buffers();
        let Some(buffer) = buffers.iter().find(|b| b.name == name) else {
            bail!(
                "technique {} has no buffer named '{name}' (it has: {})",
                self.technique.name(),
                buffers
                    .iter()
                    .map(|b| b.name)
                    .collect::<Vec<_>>()
                    .join(", ")
            );
        };
        let img = buffer.image;
        let (width, height) = (img.extent.width, img.extent.height);
        let channels = match img.format {
            crate::vk::Format::R16_SFLOAT => {
                vec![read_image::<f16>(self.ctx, &mut self.runner, img)?
                    .into_iter()
                    .map(f16::to_f32)
                    .collect()]
            }
            crate::vk::Format::R16G16B16A16_SFLOAT => {
                let texels = read_image::<[f16; 4]>(self.ctx, &mut self.runner, img)?;
                planes(&texels, f16::to_f32)
            }
            crate::vk::Format::R16G16_SFLOAT => {
                let texels = read_image::<[f16; 2]>(self.ctx, &mut self.runner, img)?;
                planes(&texels, f16::to_f32)
            }
            crate::vk::Format::R32G32_SFLOAT => {
                let texels = read_image::<[f32; 2]>(self.ctx, &mut self.runner, img)?;
                planes(&texels, |x| x)
            }
            // A light-sample bitmask (ssm-bitmask): one channel, the fraction of its 128 bits
            // that are set.
            crate::vk::Format::R32G32B32A32_UINT => {
                let texels = read_image::<[u32; 4]>(self.ctx, &mut self.runner, img)?;
                vec![texels
                    .iter()
                    .map(|t| {
                        t.iter().map(|w| w.count_ones()).sum::<u32>() as f32
                            / crate::technique::ssm_bitmask::SAMPLES as f32
                    })
                    .collect()]
            }
            // Two values packed in one key (technique::packed), unpacked with this frame's
            // depth range.
            crate::vk::Format::R32_SFLOAT if buffer.packing != Packing::Plain => {
                let keys = read_image::<f32>(self.ctx, &mut self.runner, img)?;
                let (near, far) = (self.light.near, self.light.far);
                let texels: Vec<[f32; 2]> = keys
                    .iter()
                    .map(|&k| packed::unpack(buffer.packing, k, near, far))
                    .collect();
                planes(&texels, |x| x)
            }
            // D32: `hard`'s depth map, the light's z/w in [0, 1] as the rasterizer stored it.
            crate::vk::Format::R32_SFLOAT | crate::vk::Format::D32_SFLOAT => {
                vec![read_image::<f32>(self.ctx, &mut self.runner, img)?]
            }
            f => bail!(
                "buffer '{name}' has format {f:?}, which read_technique_buffer does not decode"
            ),
        };
        if channels.len() != buffer.channels.len() {
            bail!(
                "buffer '{name}' has {} channels but names {:?}",
                channels.len(),
                buffer.channels
            );
        }
        Ok(TechniqueBuffer {
            width,
            height,
            channel_names: buffer.channels,
            channels,
        })
    }
}

/// Texels of N channels as N planes of f32.
fn planes<T: Copy, const N: usize>(texels: &[[T; N]], to_f32: impl Fn(T) -> f32) -> Vec<Vec<f32>> {
    (0..N)
        .map(|c| texels.iter().map(|t| to_f32(t[c])).collect())
        .collect()
}

/// Per-pixel work of a final pass from the counting frame (`Renderer::count_lookups`):
/// texels read, then search, filter and march iterations, each summed over the fragments
/// shaded at the pixel.
#[derive(Clone, Debug, PartialEq)]
pub struct LookupCounts {
    /// The counting pass's name, `T/count`.
    pub pass: String,
    pub width: u32,
    pub height: u32,
    /// Row-major, row 0 at the top: [texels, search, filter, march].
    pub per_pixel: Vec<[u64; 4]>,
    /// Each light pass that read a texture, in the order they ran (empty on a device
    /// without `Context::light_counting`).
    pub light: Vec<crate::vk::LightPassCount>,
}

/// Width and height of the pixel tile one warp of 32 fragments shades (4 x 2 quads).
pub const WARP_TILE: (u32, u32) = (8, 4);

impl LookupCounts {
    /// Counter `k` (0 texels, 1 search, 2 filter, 3 march) summed over every pixel.
    pub fn sum(&self, k: usize) -> u64 {
        self.per_pixel.iter().map(|c| c[k]).sum()
    }

    /// What a warp pays: over the 8x4 tiles of the image, 32 x the tile's largest
    /// per-pixel count `k`, summed (a tile cut by the image's edge still pays 32 lanes).
    pub fn warp_sum(&self, k: usize) -> u64 {
        let (tw, th) = WARP_TILE;
        let mut total = 0;
        for ty in (0..self.height).step_by(th as usize) {
            for tx in (0..self.width).step_by(tw as usize) {
                let mut most = 0;
                for y in ty..(ty + th).min(self.height) {
                    for x in tx..(tx + tw).min(self.width) {
                        most = most.max(self.per_pixel[(y * self.width + x) as usize][k]);
                    }
                }
                total += (tw * th) as u64 * most;
            }
        }
        total
    }

    /// Counter `k` at pixel (x, y).
    pub fn at(&self, x: u32, y: u32, k: usize) -> u64 {
        self.per_pixel[(y * self.width + x) as usize][k]
    }
}

/// A light-space buffer read back to the host.
pub struct TechniqueBuffer {
    pub width: u32,
    pub height: u32,
    /// What each channel holds (`LightBuffer::channels`): the EXR's channel names.
    pub channel_names: &'static [&'static str],
    /// One Vec per channel, row-major.
    pub channels: Vec<Vec<f32>>,
}
