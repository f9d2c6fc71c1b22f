//! Building blocks several techniques share: the linear-depth shadow map pass, the camera
//! targets, the final camera pass, and the sinusoidal falloff lookup texture.

use super::gpu_scene::{
    GpuObject, GpuScene, DRAW_PUSH_BYTES, SCENE_ATTRIBUTES, SCENE_VERTEX_STRIDE,
};
use crate::frustum::{camera_view_proj, split_object, PixelBox, Polytope};
use crate::shaders;
use crate::vk::{
    Blend, Buffer, BufferUsageFlags, Clear, CompareOp, Context, CullModeFlags, DepthState,
    DescriptorSet, Extent2D, Format, FrameRunner, GraphicsPipelineDesc, Image, ImageUsageFlags,
    Offset2D, Pipeline, PrimitiveTopology, Recorder, Rect2D, Resource,
};
use anyhow::{bail, Result};
use glam::{Mat4, Vec3, Vec4};
use rayon::prelude::*;

/// Clear value of linear-depth targets: "nothing here", farther than any far plane, finite
/// so that ratios like b / r stay finite.
pub const FAR_DEPTH: f32 = 1.0e30;

/// What the r and g channels of a shadow map of every object hold (`ShadowMap::new`, and the
/// soft shadow maps' occluder map), for `--buffers`.
pub const SURFACE_MAP_CHANNELS: &[&str] = &["caster_depth", "surface_depth"];

/// Linear light-space depths from the light, MIN-blended (Volokh 3.2), in one of two
/// layouts (`ShadowMap::new`, `ShadowMap::casters`):
///
/// - every object drawn: `depth` R32G32_SFLOAT, clear (FAR_DEPTH, FAR_DEPTH), blend MIN, no
///   depth attachment. r = nearest caster (what shadow comparisons test, read as component
///   0 by `textureGather`), g = nearest surface of any role (the receiver depth behind
///   smoothies and penumbra-map geometry: a receiver-only ground plane must be there, or
///   the smoothie remap alpha / (1 - b/r) sees no receiver and never hardens at contacts).
///   Fragment `common/shadow_depth.frag` (the draw's cast flag picks r's value);
/// - casters only, for techniques that read r alone (pcf, pcss, plateaus):
///   `depth` R32_SFLOAT, clear FAR_DEPTH, blend MIN, no depth attachment; the same r texel
///   for texel, without drawing the receivers (a ground fills the whole map: 0.7-1.5 ms on
///   lavapipe at 1024^2) or clearing a second channel. Fragment `common/caster_depth.frag`.
///
/// Reads: the drawn objects' positions, the frame UBO, the draw's cast flag.
pub struct ShadowMap {
    pub depth: Image,
    pipeline: Pipeline,
    set: DescriptorSet,
    pub resolution: u32,
    /// What r and g hold, for `--buffers`: `["caster_depth", "surface_depth"]`, or
    /// `["caster_depth"]` for the casters-only map.
    pub channels: &'static [&'static str],
    casters_only: bool,
}

impl ShadowMap {
    /// The map of every object: r = nearest caster, g = nearest surface.
    pub fn new(ctx: &Context, ubo: &Buffer, resolution: u32, name: &str) -> Result<Self> {
        Self::create(ctx, ubo, resolution, name, false)
    }

    /// The map of the casters alone: r = nearest caster.
    pub fn casters(ctx: &Context, ubo: &Buffer, resolution: u32, name: &str) -> Result<Self> {
        Self::create(ctx, ubo, resolution, name, true)
    }

    fn create(
        ctx: &Context,
        ubo: &Buffer,
        resolution: u32,
        name: &str,
        casters_only: bool,
    ) -> Result<Self> {
        let (format, fragment, channels): (_, _, &'static [&'static str]) = if casters_only {
            (
                Format::R32_SFLOAT,
                shaders::COMMON_CASTER_DEPTH_FRAG,
                &["caster_depth"],
            )
        } else {
            (
                Format::R32G32_SFLOAT,
                shaders::COMMON_SHADOW_DEPTH_FRAG,
                SURFACE_MAP_CHANNELS,
            )
        };
        let depth = Image::new_2d(
            ctx,
            resolution,
            resolution,
            format,
            ImageUsageFlags::COLOR_ATTACHMENT
                | ImageUsageFlags::SAMPLED
                | ImageUsageFlags::TRANSFER_SRC,
            &format!("{name} shadow map"),
        )?;
        ctx.require_blend(format, Blend::Min, "the shadow map")?;
        let set = DescriptorSet::new(ctx, &[("frame", Resource::Uniform(ubo))], name)?;
        let pipeline = Pipeline::graphics(
            ctx,
            &depth_only_pipeline(DepthOnly {
                name,
                fragment,
                colors: &[(format, Blend::Min)],
                depth: None,
                sets: &[&set],
            }),
        )?;
        Ok(Self {
            depth,
            pipeline,
            set,
            resolution,
            channels,
            casters_only,
        })
    }

    /// `record` as one timed pass named as the pipeline (the name given to `new`).
    pub fn pass(&self, rec: &mut Recorder<'_>, scene: &GpuScene) -> Result<()> {
        self.pass_in(rec, scene, &MapArea::WHOLE)
    }

    /// `record_in` as one timed pass named as the pipeline.
    pub fn pass_in(&self, rec: &mut Recorder<'_>, scene: &GpuScene, area: &MapArea) -> Result<()> {
        rec.pass(&self.pipeline.name, |rec| {
            self.record_in(rec, scene, area);
            Ok(())
        })
    }

    /// Draws every object (or every caster) from the light into the whole of `depth`.
    pub fn record(&self, rec: &mut Recorder<'_>, scene: &GpuScene) {
        self.record_in(rec, scene, &MapArea::WHOLE);
    }

    /// Clears `area.all` and draws the casters into it, then the receivers that cast
    /// nothing where `area.receivers` says (MIN blending: the order changes no texel).
    pub fn record_in(&self, rec: &mut Recorder<'_>, scene: &GpuScene, area: &MapArea) {
        rec.begin_rendering_in(
            &[(&self.depth, Clear::Float([FAR_DEPTH; 4]))],
            None,
            area.all,
        );
        rec.bind_pipeline(&self.pipeline);
        rec.bind_sets(&self.pipeline, &[&self.set]);
        scene.draw(rec, &self.pipeline, |o| o.role.casts());
        if !self.casters_only {
            let receivers = |o: &GpuObject| !o.role.casts();
            match area.receivers {
                Receivers::Everywhere => scene.draw(rec, &self.pipeline, receivers),
                Receivers::Within(r) => {
                    rec.set_scissor(Some(r));
                    scene.draw(rec, &self.pipeline, receivers);
                    rec.set_scissor(None);
                }
                Receivers::Nowhere => {}
            }
        }
        rec.end_rendering();
    }
}

/// Where a shadow-map pass clears and draws (`ShadowMap::record_in`): a technique that
/// reads the receivers' depth (g) only in part of the map, and knows where its casters
/// are, confines the pass to those texels; every texel outside must then already hold the
/// clear value (nothing drawn there since its last clear), which is the caller's to keep.
pub struct MapArea {
    /// Cleared, and where the casters are drawn; `None`: the whole map.
    pub all: Option<Rect2D>,
    /// Where the objects that receive but cast nothing are drawn, inside `all`.
    pub receivers: Receivers,
}

/// See `MapArea::receivers`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Receivers {
    Everywhere,
    Within(Rect2D),
    Nowhere,
}

impl MapArea {
    /// The whole map, every object.
    pub const WHOLE: MapArea = MapArea {
        all: None,
        receivers: Receivers::Everywhere,
    };
}

/// What differs between the depth-only pipelines (scene geometry drawn from the light,
/// linear depth out): the shared shadow map, ssm's receiver map and back occluder map.
pub struct DepthOnly<'a> {
    pub name: &'a str,
    /// A fragment shader reading `common/shadow_depth.vert`'s `v_depth` (location 0).
    pub fragment: &'a [u8],
    pub colors: &'a [(Format, Blend)],
    pub depth: Option<DepthState>,
    pub sets: &'a [&'a DescriptorSet],
}

/// The pipeline of a depth-only pass: scene positions through `common/shadow_depth.vert`
/// (linear light depth out), triangle lists, no culling, the draw push constants.
pub fn depth_only_pipeline(d: DepthOnly<'_>) -> GraphicsPipelineDesc<'_> {
    GraphicsPipelineDesc {
        name: d.name,
        vertex: shaders::COMMON_SHADOW_DEPTH_VERT,
        fragment: Some(d.fragment),
        vertex_stride: SCENE_VERTEX_STRIDE,
        // Depth only needs the position; an unread normal is a validation warning.
        attributes: &SCENE_ATTRIBUTES[..1],
        topology: PrimitiveTopology::TRIANGLE_LIST,
        // Open meshes and planes cast from both sides; the farthest surface of any winding.
        cull: CullModeFlags::NONE,
        colors: d.colors,
        depth: d.depth,
        push_constant_bytes: DRAW_PUSH_BYTES,
        sets: d.sets,
    }
}

/// What the final camera passes write, at the camera's resolution: the timed pass the colour
/// (and depth), the AOV pass all of them.
pub struct CameraTargets {
    /// RGBA8 UNORM, gamma-encoded shaded colour (the PNG).
    pub color: Image,
    /// R32F light visibility in \[0,1\]; background 1.
    pub visibility: Image,
    /// RGBA32F world position, A = 1 on surfaces, 0 on background.
    pub position: Image,
    /// RGBA16F world normal (facing the camera).
    pub normal: Image,
    /// RGBA32F per-pixel work of the counting pass (`FrameInput::count`): texels read,
    /// search, filter and march iterations, summed over the fragments shaded there.
    pub count: Image,
    pub depth: Image,
    pub width: u32,
    pub height: u32,
}

impl CameraTargets {
    pub fn new(ctx: &Context, width: u32, height: u32) -> Result<Self> {
        let usage = ImageUsageFlags::COLOR_ATTACHMENT | ImageUsageFlags::TRANSFER_SRC;
        Ok(Self {
            color: Image::new_2d(
                ctx,
                width,
                height,
                Format::R8G8B8A8_UNORM,
                usage,
                "camera colour",
            )?,
            visibility: Image::new_2d(
                ctx,
                width,
                height,
                Format::R32_SFLOAT,
                usage,
                "camera visibility",
            )?,
            position: Image::new_2d(
                ctx,
                width,
                height,
                Format::R32G32B32A32_SFLOAT,
                usage,
                "camera position",
            )?,
            normal: Image::new_2d(
                ctx,
                width,
                height,
                Format::R16G16B16A16_SFLOAT,
                usage,
                "camera normal",
            )?,
            count: Image::new_2d(
                ctx,
                width,
                height,
                Format::R32G32B32A32_SFLOAT,
                usage,
                "camera lookup counts",
            )?,
            depth: Image::new_2d(
                ctx,
                width,
                height,
                Format::D32_SFLOAT,
                ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT,
                "camera depth",
            )?,
            width,
            height,
        })
    }

    /// The AOV pass's attachments, in the order of glsl/common/final.glsl's outputs; the
    /// timed pass has the first (colour) only.
    pub const AOV_FORMATS: [(Format, Blend); 4] = [
        (Format::R8G8B8A8_UNORM, Blend::None),
        (Format::R32_SFLOAT, Blend::None),
        (Format::R32G32B32A32_SFLOAT, Blend::None),
        (Format::R16G16B16A16_SFLOAT, Blend::None),
    ];

    /// The counting pass's attachments: the colour, then the counts, added up per pixel.
    pub const COUNT_FORMATS: [(Format, Blend); 2] = [
        (Format::R8G8B8A8_UNORM, Blend::None),
        (Format::R32G32B32A32_SFLOAT, Blend::Add),
    ];

    /// Clear colour of the shaded image (the background).
    pub const BACKGROUND: [f32; 4] = [0.05, 0.05, 0.06, 1.0];
}

/// A final pass's fragment shader in its two builds from one source (build.rs compiles every
/// shader that includes glsl/common/final.glsl with and without `-DAOV`).
#[derive(Clone, Copy)]
pub struct FinalShader {
    /// Writes the shaded colour only: the timed pass.
    pub color: &'static [u8],
    /// Also writes visibility, position and normal: the untimed AOV pass.
    pub aov: &'static [u8],
    /// Also adds up the texels read and the loop iterations (`-DCOUNT`): the untimed
    /// counting pass.
    pub count: &'static [u8],
}

/// The final pass from the camera: the scene's surfaces with a technique's fragment shader
/// (which defines `visibility()` and includes glsl/common/final.glsl). Vertex shader
/// glsl/common/scene.vert: world position and normal, and their light clip coordinates
/// (`light_view_proj` times each), which common/shadow.glsl's `light_sample()` uses instead
/// of two 4x4 products a pixel.
///
/// Timed pass `T/final`: colour RGBA8 (clear dark grey) and depth D32 (clear 1, LESS), no
/// blending: what an engine's frame writes. The AOV pass `T/aov` (`FrameInput::aov`, run by
/// `Renderer::read_back`, untimed) draws the same geometry with the same shader source built
/// with `-DAOV`, so its colour and visibility are bit-identical to the timed pass's, into
/// colour, visibility R32F (clear 1), position RGBA32F (clear 0), normal RGBA16F (clear 0).
///
/// A technique that knows where its visibility can be below 1 builds it with `split` and
/// records it with `pass_in`: the timed pass then draws each object with the technique's
/// shader only where a shadow can fall on it and with glsl/common/unshadowed.frag elsewhere
/// (`record_split`); same image, and the AOV pass still runs the shader everywhere.
pub struct FinalPass {
    pipeline: Pipeline,
    aov: Pipeline,
    /// The counting build, drawn as the timed pass is (split where it is split); `None` on
    /// a device without `independentBlend`.
    count: Option<Pipeline>,
    /// `FinalPass::split`'s: the same pass with `visibility()` = 1 (glsl/common/unshadowed.frag),
    /// drawn where the technique's shader would give exactly 1; and its counting build.
    unshadowed: Option<(Pipeline, Option<Pipeline>)>,
    /// Rows a light mesh (a ground) is cut into by `record_split` (`with_bands`).
    bands: u32,
}

/// Where a final pass's `visibility()` can be below 1 (`FinalPass::pass_in`).
#[derive(Clone, Debug, PartialEq)]
pub enum Shadowed {
    Everywhere,
    /// Only at points inside one of these convex regions, each the intersection of
    /// world-space half-spaces where plane · (x, 1) is at least 0 (such as the light's
    /// frustum over the texels a caster and its smoothies drew); everywhere else the
    /// technique's shader gives exactly 1. No region: nowhere; a region without a plane:
    /// everywhere.
    Inside(Vec<Vec<Vec4>>),
}

impl Shadowed {
    /// Whether the technique's shader may give less than 1 at world point `p`.
    pub fn contains(&self, p: Vec3) -> bool {
        match self {
            Shadowed::Everywhere => true,
            Shadowed::Inside(regions) => regions
                .iter()
                .any(|planes| planes.iter().all(|q| q.dot(p.extend(1.0)) >= 0.0)),
        }
    }
}

impl FinalPass {
    pub fn new(
        ctx: &Context,
        name: &str,
        fragment: FinalShader,
        set: &DescriptorSet,
    ) -> Result<Self> {
        let desc = |name: &str, fragment: &[u8], colors: &[(Format, Blend)]| {
            Self::pipeline(ctx, name, fragment, colors, set)
        };
        let pipeline = desc(name, fragment.color, &CameraTargets::AOV_FORMATS[..1])?;
        let aov_name = match name.strip_suffix("/final") {
            Some(technique) => format!("{technique}/aov"),
            None => format!("{name}/aov"),
        };
        let aov = desc(&aov_name, fragment.aov, &CameraTargets::AOV_FORMATS)?;
        let count_name = match name.strip_suffix("/final") {
            Some(technique) => format!("{technique}/count"),
            None => format!("{name}/count"),
        };
        let count = match ctx.independent_blend {
            true => Some(desc(
                &count_name,
                fragment.count,
                &CameraTargets::COUNT_FORMATS,
            )?),
            false => None,
        };
        Ok(Self {
            pipeline,
            aov,
            count,
            unshadowed: None,
            bands: SPLIT_BANDS,
        })
    }

    /// `new`, for a technique that knows where its visibility can be below 1
    /// (`pass_in`): the timed pass then runs the shader only there and a shader without
    /// shadow lookups elsewhere. On a CPU driver (lavapipe) that is most of the pass's cost
    /// wherever the shadows are small on screen: it runs both sides of a branch, so the
    /// technique's own early-outs save nothing.
    pub fn split(
        ctx: &Context,
        name: &str,
        fragment: FinalShader,
        set: &DescriptorSet,
    ) -> Result<Self> {
        let mut pass = Self::new(ctx, name, fragment, set)?;
        pass.unshadowed = Some((
            Self::pipeline(
                ctx,
                &format!("{name} (unshadowed)"),
                shaders::COMMON_UNSHADOWED_FRAG,
                &CameraTargets::AOV_FORMATS[..1],
                set,
            )?,
            match ctx.independent_blend {
                true => Some(Self::pipeline(
                    ctx,
                    &format!("{name} (unshadowed, counting)"),
                    shaders::COMMON_UNSHADOWED_FRAG_COUNT,
                    &CameraTargets::COUNT_FORMATS,
                    set,
                )?),
                false => None,
            },
        ));
        Ok(pass)
    }

    /// A split pass that cuts a light mesh (a ground) into `bands` rows instead of
    /// `SPLIT_BANDS`: each row is a draw of its own, whose overhead (lavapipe: the
    /// scissored tiles, the pipeline switches) a cheap lookup does not win back.
    pub fn with_bands(mut self, bands: u32) -> Self {
        self.bands = bands;
        self
    }

    /// One camera pipeline: scene.vert, `fragment`, depth test LESS with writes, no
    /// culling (two-sided surfaces), the draw push constants.
    fn pipeline(
        ctx: &Context,
        name: &str,
        fragment: &[u8],
        colors: &[(Format, Blend)],
        set: &DescriptorSet,
    ) -> Result<Pipeline> {
        Pipeline::graphics(
            ctx,
            &GraphicsPipelineDesc {
                name,
                vertex: shaders::COMMON_SCENE_VERT,
                fragment: Some(fragment),
                vertex_stride: SCENE_VERTEX_STRIDE,
                attributes: SCENE_ATTRIBUTES,
                topology: PrimitiveTopology::TRIANGLE_LIST,
                cull: CullModeFlags::NONE,
                colors,
                depth: Some(DepthState {
                    format: Format::D32_SFLOAT,
                    test: true,
                    write: true,
                    compare: CompareOp::LESS,
                }),
                push_constant_bytes: DRAW_PUSH_BYTES,
                sets: &[set],
            },
        )
    }

    /// `record` as one pass named as the pipeline: `T/final` (timed), or `T/aov` when
    /// `frame.aov`.
    pub fn pass(
        &self,
        rec: &mut Recorder<'_>,
        frame: &crate::gpu::FrameInput<'_>,
        set: &DescriptorSet,
    ) -> Result<()> {
        self.pass_in(rec, frame, set, &Shadowed::Everywhere)
    }

    /// `pass`, with the technique's shader only where `shadowed` says (a `split` pass;
    /// others, and the AOV pass, run it everywhere).
    pub fn pass_in(
        &self,
        rec: &mut Recorder<'_>,
        frame: &crate::gpu::FrameInput<'_>,
        set: &DescriptorSet,
        shadowed: &Shadowed,
    ) -> Result<()> {
        let mode = Mode::of(frame);
        if mode == Mode::Count && self.count.is_none() {
            bail!("counting lookups needs the independentBlend device feature, which this device lacks");
        }
        rec.pass(&self.pipeline_of(mode).name, |rec| {
            // `Settings::plain`: one full-screen pass, as a technique without regions.
            let shadowed = match frame.settings.plain {
                true => &Shadowed::Everywhere,
                false => shadowed,
            };
            match (&self.unshadowed, mode, shadowed) {
                (Some((timed, _)), Mode::Timed, Shadowed::Inside(regions)) => {
                    self.record_split(rec, frame, set, timed, mode, regions)
                }
                (Some((_, Some(counting))), Mode::Count, Shadowed::Inside(regions)) => {
                    self.record_split(rec, frame, set, counting, mode, regions)
                }
                _ => self.record_mode(rec, frame.targets, frame.gpu, set, mode),
            }
            Ok(())
        })
    }

    /// Each object with the technique's pipeline where it can be shadowed and the
    /// unshadowed one elsewhere (`frustum::split_object`), each part a scissor of one
    /// rendering scope. The objects are drawn in the scene's order and each pixel of an
    /// object in exactly one part, so the depth test keeps the same fragment as one
    /// whole-image draw would. Meshes are cut into fewer parts the more triangles they
    /// have: every part shades all of its vertices again. A caster in the light is not cut
    /// at all: every region is built around its caster's own texels, so the caster lies in
    /// its own, and the parts around a cut would hold none of its pixels.
    fn record_split(
        &self,
        rec: &mut Recorder<'_>,
        frame: &crate::gpu::FrameInput<'_>,
        set: &DescriptorSet,
        unshadowed: &Pipeline,
        mode: Mode,
        regions: &[Vec<Vec4>],
    ) {
        let t = frame.targets;
        let view_proj = camera_view_proj(frame.scene, t.width, t.height);
        let shader = self.pipeline_of(mode);
        self.begin(rec, t, mode);
        let mut bound: Option<bool> = None;
        let mut area = [0u64; 2];
        for (i, o) in frame.gpu.objects.iter().enumerate() {
            if !o.in_camera {
                continue;
            }
            let parts = if o.role.receives() && o.role.casts() && o.in_light {
                // In its own region (see above): one part, the technique's shader.
                Polytope::hexahedron(&o.world_corners())
                    .screen_box(view_proj, t.width, t.height)
                    .map(|b| vec![(true, b)])
                    .unwrap_or_default()
            } else if o.role.receives() {
                let bands = match o.index_count / 3 {
                    0..=256 => self.bands,
                    257..=4096 => 1,
                    _ => 0,
                };
                split_object(
                    &o.world_corners(),
                    regions,
                    view_proj,
                    t.width,
                    t.height,
                    bands,
                )
            } else {
                // visibility() is never called for it: its screen box, unshadowed.
                Polytope::hexahedron(&o.world_corners())
                    .screen_box(view_proj, t.width, t.height)
                    .map(|b| vec![(false, b)])
                    .unwrap_or_default()
            };
            for (shadowed, part) in parts {
                area[shadowed as usize] += part.area();
                let pipeline = if shadowed { shader } else { unshadowed };
                if bound != Some(shadowed) {
                    rec.bind_pipeline(pipeline);
                    rec.bind_sets(pipeline, &[set]);
                    bound = Some(shadowed);
                }
                rec.set_scissor(Some(rect_of(part)));
                frame.gpu.draw_object(rec, pipeline, i);
            }
        }
        rec.end_rendering();
        let drawn = area[0] + area[1];
        let fraction = if drawn == 0 {
            0.0
        } else {
            area[1] as f64 / drawn as f64
        };
        rec.lookup_area(&shader.name, fraction);
    }

    fn pipeline_of(&self, mode: Mode) -> &Pipeline {
        match mode {
            Mode::Timed => &self.pipeline,
            Mode::Aov => &self.aov,
            Mode::Count => self.count.as_ref().unwrap_or(&self.pipeline),
        }
    }

    /// Draws the camera view: colour only, or with `aov` the colour and the AOVs.
    pub fn record(
        &self,
        rec: &mut Recorder<'_>,
        t: &CameraTargets,
        scene: &GpuScene,
        set: &DescriptorSet,
        aov: bool,
    ) {
        let mode = if aov { Mode::Aov } else { Mode::Timed };
        self.record_mode(rec, t, scene, set, mode);
    }

    fn record_mode(
        &self,
        rec: &mut Recorder<'_>,
        t: &CameraTargets,
        scene: &GpuScene,
        set: &DescriptorSet,
        mode: Mode,
    ) {
        let pipeline = self.pipeline_of(mode);
        self.begin(rec, t, mode);
        rec.bind_pipeline(pipeline);
        rec.bind_sets(pipeline, &[set]);
        scene.draw_camera(rec, pipeline);
        rec.end_rendering();
    }

    /// Opens the rendering scope: the colour (with the AOVs, or the counts) and depth,
    /// cleared.
    fn begin(&self, rec: &mut Recorder<'_>, t: &CameraTargets, mode: Mode) {
        let depth = Some((&t.depth, Some(1.0)));
        if mode == Mode::Count {
            rec.begin_rendering(
                &[
                    (&t.color, Clear::Float(CameraTargets::BACKGROUND)),
                    (&t.count, Clear::Float([0.0; 4])),
                ],
                depth,
            );
        } else if mode == Mode::Aov {
            rec.begin_rendering(
                &[
                    (&t.color, Clear::Float(CameraTargets::BACKGROUND)),
                    (&t.visibility, Clear::Float([1.0; 4])),
                    (&t.position, Clear::Float([0.0; 4])),
                    (&t.normal, Clear::Float([0.0; 4])),
                ],
                depth,
            );
        } else {
            rec.begin_rendering(
                &[(&t.color, Clear::Float(CameraTargets::BACKGROUND))],
                depth,
            );
        }
        // The depth buffer only serves this scope's depth test.
        rec.discard_after(&t.depth);
    }
}

/// Which build of a final pass a frame records.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Mode {
    /// Colour only: the timed frame.
    Timed,
    /// Colour and AOVs, the technique's shader everywhere.
    Aov,
    /// Colour and counts, drawn as the timed frame is.
    Count,
}

impl Mode {
    fn of(frame: &crate::gpu::FrameInput<'_>) -> Self {
        match (frame.aov, frame.count) {
            (true, _) => Mode::Aov,
            (false, true) => Mode::Count,
            (false, false) => Mode::Timed,
        }
    }
}

/// A pixel box as a scissor or render area.
pub fn rect_of(b: PixelBox) -> Rect2D {
    Rect2D {
        offset: Offset2D {
            x: b.x0 as i32,
            y: b.y0 as i32,
        },
        extent: Extent2D {
            width: b.x1.saturating_sub(b.x0),
            height: b.y1.saturating_sub(b.y0),
        },
    }
}

/// Rows a light mesh (a ground) is cut into by `FinalPass::record_split`, each with its
/// own shadowed columns: a slanted shadow's screen box holds much lit ground. Unless the
/// technique says otherwise (`FinalPass::with_bands`).
const SPLIT_BANDS: u32 = 8;

/// Number of texels of the falloff lookup texture.
pub const FALLOFF_TEXELS: u32 = 256;

/// The sinusoidal falloff 0.5 - 0.5 cos(pi x) (Haines; Chan & Durand Sec. 3.1) as a 1-D
/// R32F texture: an S-curve like the visible fraction of a disc light crossing a straight
/// edge, flat at both ends so penumbrae blend into umbra and light without a crease.
pub fn falloff_lut(ctx: &Context) -> Result<Image> {
    let mut runner = FrameRunner::new(ctx, 1)?;
    let texels: Vec<f32> = (0..FALLOFF_TEXELS)
        .map(|i| {
            let x = i as f32 / (FALLOFF_TEXELS - 1) as f32;
            0.5 - 0.5 * (std::f32::consts::PI * x).cos()
        })
        .collect();
    let staging = Buffer::with_data(
        ctx,
        bytemuck::cast_slice(&texels),
        BufferUsageFlags::TRANSFER_SRC,
        "falloff staging",
    )?;
    let image = Image::new_1d(
        ctx,
        FALLOFF_TEXELS,
        Format::R32_SFLOAT,
        ImageUsageFlags::SAMPLED | ImageUsageFlags::TRANSFER_DST,
        "falloff lut",
    )?;
    runner.run(|rec| {
        rec.copy_buffer_to_image(&staging, &image);
        Ok(())
    })?;
    Ok(image)
}

/// Vertices rebuilt on the CPU whenever the light or a caster moves (smoothies,
/// penumbra-map cones and sheets, plateaus), in one host-visible vertex buffer that grows
/// by half again when too small, so a light sweeping over a mesh does not reallocate every
/// frame.
pub struct DynamicVertices {
    buffer: Option<Buffer>,
    count: u32,
    name: &'static str,
}

impl DynamicVertices {
    pub fn new(name: &'static str) -> Self {
        Self {
            buffer: None,
            count: 0,
            name,
        }
    }

    /// Replaces the contents (the GPU finished with the old ones: frames wait on their
    /// fence), reallocating the buffer when they do not fit.
    pub fn upload<T: bytemuck::Pod>(&mut self, ctx: &Context, vertices: &[T]) -> Result<()> {
        let bytes: &[u8] = bytemuck::cast_slice(vertices);
        let fits = self
            .buffer
            .as_ref()
            .is_some_and(|b| b.size >= bytes.len() as u64);
        if !fits {
            let size = (bytes.len() as u64 * 3 / 2).max(4096);
            self.buffer = Some(Buffer::new(
                ctx,
                size,
                BufferUsageFlags::VERTEX_BUFFER,
                crate::vk::MemoryLocation::CpuToGpu,
                self.name,
            )?);
        }
        if let Some(b) = self.buffer.as_mut() {
            b.write(0, bytes)?;
        }
        self.count = vertices.len() as u32;
        Ok(())
    }

    pub fn is_empty(&self) -> bool {
        self.count == 0
    }

    /// Binds the buffer and draws every vertex with the bound pipeline (nothing when empty).
    pub fn draw(&self, rec: &mut Recorder<'_>) {
        if let (Some(b), false) = (self.buffer.as_ref(), self.is_empty()) {
            rec.bind_vertex_buffer(b);
            rec.draw(self.count, 1);
        }
    }
}

/// Per-caster CPU geometry kept between frames: a caster is rebuilt only when its model
/// matrix or the frame's `key` (everything else the geometry depends on: the light, the
/// widths...) changed, so a moving caster rebuilds only its own silhouette geometry.
/// `T` is one caster's geometry (`CasterCache` holds vertex lists).
pub struct CasterCacheOf<K, T> {
    entries: Vec<Option<(Mat4, K, T)>>,
}

/// Per-caster vertex lists.
pub type CasterCache<K, V> = CasterCacheOf<K, Vec<V>>;

impl<K: PartialEq + Copy, T> CasterCacheOf<K, T> {
    /// One slot per scene object.
    pub fn new(objects: usize) -> Self {
        Self {
            entries: (0..objects).map(|_| None).collect(),
        }
    }

    /// Every cached object's geometry, in object order.
    pub fn iter(&self) -> impl Iterator<Item = &T> {
        self.entries.iter().flatten().map(|e| &e.2)
    }

    /// Object `i`'s cached geometry, if it has any.
    pub fn get(&self, i: usize) -> Option<&T> {
        self.entries.get(i)?.as_ref().map(|e| &e.2)
    }

    /// One part of every cached object's geometry (`part`: a side's vertices), concatenated
    /// in object order: what one draw of that part uploads.
    pub fn concat_by<V: Copy>(&self, part: impl Fn(&T) -> &[V]) -> Vec<V> {
        let n = self.iter().map(|t| part(t).len()).sum();
        let mut out = Vec::with_capacity(n);
        for t in self.iter() {
            out.extend_from_slice(part(t));
        }
        out
    }
}

impl<K: Send, T: Send> CasterCacheOf<K, T> {
    /// Every cached object's geometry, to change in parallel (rayon).
    pub fn par_values_mut(&mut self) -> impl ParallelIterator<Item = &mut T> {
        self.entries.par_iter_mut().flatten().map(|e| &mut e.2)
    }

    /// Every cached object's geometry with its object index, to change in parallel.
    pub fn par_indexed_mut(&mut self) -> impl ParallelIterator<Item = (usize, &mut T)> {
        self.entries
            .par_iter_mut()
            .enumerate()
            .filter_map(|(i, e)| e.as_mut().map(|e| (i, &mut e.2)))
    }
}

impl<K: PartialEq + Copy + Send + Sync, T: Send> CasterCacheOf<K, T> {
    /// Rebuilds, with `build(adjacency, model)`, every caster (object with an adjacency)
    /// whose slot is stale (all of them when `force`); returns how many were rebuilt. The
    /// casters are built in parallel on rayon (each slot is its caster's alone, so the result
    /// does not depend on the schedule): a light move rebuilds every caster, and `dense`'s
    /// 36 then share the cores instead of queueing on one.
    pub fn update(
        &mut self,
        objects: &[crate::scene::Object],
        adjacency: &[Option<std::sync::Arc<crate::silhouette::Adjacency>>],
        key: K,
        force: bool,
        build: impl Fn(&crate::silhouette::Adjacency, Mat4) -> T + Sync,
    ) -> usize {
        self.entries
            .par_iter_mut()
            .zip(objects)
            .zip(adjacency)
            .map(|((slot, o), adj)| {
                let Some(adj) = adj else { return 0 };
                let model = o.transform;
                let fresh = slot
                    .as_ref()
                    .is_some_and(|(m, k, _)| *m == model && *k == key);
                if force || !fresh {
                    *slot = Some((model, key, build(adj, model)));
                    1
                } else {
                    0
                }
            })
            .sum()
    }
}

impl<K: PartialEq + Copy, V: Copy> CasterCacheOf<K, Vec<V>> {
    /// Every cached object's geometry, in object order.
    pub fn concat(&self) -> Vec<V> {
        self.concat_by(|v| v)
    }
}
