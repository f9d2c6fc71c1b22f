//! # smoothies — Chan & Durand 2003, *Rendering Fake Soft Shadows with Smoothies*
//! Port sheet: docs/port/smoothies.md
//! Speed layer: speed::smoothies, speed::regions — off under --plain.
//! Over 400 lines because this module is the one struct both forms run: the construction
//! they share, the width calibration, both geometry paths (CPU records, GPU compute) and the
//! passes in order; what is the centred form's own is in smoothies_centred.rs and every
//! speed trick in speed/smoothies.rs.
//!
//! A shadow map plus "smoothies": screen-space rectangles of width t glued to the casters'
//! silhouette edges (and fans at their corners), rendered from the light into a smoothie
//! buffer holding a depth and an alpha per texel. The final pass darkens points behind a
//! smoothie by its alpha, giving a penumbra that grows outward from the hard shadow edge.
//! With the implementation lessons of Volokh's report (extrusion direction from averaged
//! screen-space normals, corner construction, the b ~ r guard, linear R32F depths).
//! This module is the struct both forms run, in pass order; `smoothies-centred`'s own
//! attachments, pipelines and shaders are in src/technique/smoothies_centred.rs.
//!
//! **What to port**: the passes below, with pass 0's geometry from the reference
//! construction, `src/silhouette/smoothie.rs` (`build_smoothies_width`, after the reference
//! extraction `silhouette::extract_reference`), whose header gives every rule (edge quads,
//! corner fans, special vertices, widths). The renderer draws one of two optimisations of
//! it, interchangeable (`--silhouettes`): the CPU path's compact records
//! (`speed::smoothies::CpuSmoothies`) and the GPU path's compute passes (glsl/silhouette/).
//! `silhouette::smoothie::equivalence` holds the records to the reference (edges bit for
//! bit, corners within 1e-5 t) and tests/gpu_silhouettes.rs the compute passes to the
//! records (same edges, same image).
//!
//! ## Passes, in order
//! 0. `smoothies/silhouettes` — per caster, per light: silhouette edges (from the light's
//!    centre; a sun's stand-in point, "Under a sun") over the edge adjacency built once per mesh, then smoothie geometry in light screen space: per edge
//!    a quad from the edge outward by t (alpha 0 -> 1, Sec. 3 step 3, Fig. 2); per
//!    silhouette vertex a fan covering the gap between its two edges with radial alpha
//!    |v - p| / t (Fig. 6); where an even number of four and more silhouette edges meet,
//!    the same fans for the pairs of nearest outward directions; where one or another odd
//!    number meet, a fan over the whole disc (which contains the paper's special case,
//!    Sec. 3). A triangle list of
//!    36-byte `SmoothieVertex`es: uv, 1/depth, kind, anchor, dir, width. GPU path: three
//!    compute dispatches (`silhouette::gpu`) into a device-local buffer drawn indirectly, a
//!    timed pass; CPU path: a `cpu` timing.
//! 1. `smoothies/shadow_map` — `gpu::passes::ShadowMap`: R32G32_SFLOAT, clear 1e30, blend
//!    MIN, no depth attachment; r = nearest caster's linear depth (the umbra test), g =
//!    nearest surface of any role (the receiver depth r of Eq. 1). Linear depth, not the
//!    depth buffer's, because Eq. 1 needs b/r.
//! 2. `smoothies/smoothie` — one pass, no depth attachment, culling off (quads and fans
//!    have either winding). glsl/smoothies/smoothie.vert reads the `SmoothieVertex`
//!    attributes (`SMOOTHIE_ATTRIBUTES`) and passes the light uv through. One attachment,
//!    the smoothie buffer: R32G32_SFLOAT, clear (1e30, 1.0), blend MIN per channel (as two
//!    targets would): r = smoothie linear depth b (the nearest smoothie), g = remapped alpha
//!    (the paper's "minimum blending", Sec. 3.1); one target rather than the paper's two
//!    halves the blend work, and the final pass's two gathers share one texel address.
//!    `glsl/smoothies/smoothie.frag` reads the shadow map's g at its own texel for the
//!    receiver depth r, computes the distance x from the silhouette (edge: along the
//!    outward normal; corner: radial) and Eq. 1's alpha' = (x / t) / (1 - b/r) (a sun:
//!    Eq. 1s, (x / t) / ((r - b) / D)), written
//!    only where the smoothie darkens a surface (`glsl/smoothies/alpha.glsl`). Discarded:
//!    g = 1e30 (no surface at the texel), b/r > 1 (smoothie behind the surface), 1 - b/r
//!    < 1e-4 (Volokh 3.5: b ~ r; no NaN, no Inf, no speckles), and alpha' >= 1, i.e.
//!    x >= t (1 - b/r). The paper writes fully lit fragments too; their b, MIN-blended into
//!    a texel another smoothie shades, hands the receivers between the two smoothies'
//!    depths the farther one's alpha (mae_lit fell on `bunny`, `primitives`, `fence` and
//!    `dense` without them).
//! 3. `smoothies/final` — from the camera (`FinalPass`), `glsl/smoothies/final.frag`: at
//!    each of the 4 nearest texels v = 0 behind the blocker (shadow map r), else alpha
//!    behind the smoothie (smoothie buffer r, then g), else 1 (Sec. 3 step 5); bilinear
//!    weights (the 2x2 tent of the paper's hardware PCF); then the sinusoidal falloff
//!    0.5 - 0.5 cos(pi v) from a 256-texel R32F 1-D texture. Writes the colour target
//!    (RGBA8).
//!
//! `--spirv tuned` (`Settings::spirv`) runs hand-written SPIR-V for passes 2 and 3 instead
//! of glslang's: glsl/smoothies/smoothie.frag.spvasm and final.frag.spvasm, same bindings,
//! same image within one 8-bit level (tests/spirv.rs); each change is commented in the file.
//!
//! ## Equations: what a porter ports
//! - The smoothie geometry (Sec. 3, Fig. 2 and 6; Volokh's corners): the reference
//!   construction `build_smoothies_width` (src/silhouette/smoothie.rs).
//! - The width t (see "The width t"): `Width::at` (src/silhouette/smoothie.rs).
//! - Eq. 1 (alpha' = alpha / (1 - b/r); a sun's Eq. 1s, alpha / ((r - b) / D)) and which
//!   fragments are written: `smoothie_alpha`, `remap_denom` (glsl/smoothies/alpha.glsl),
//!   with b and D from glsl/smoothies/light.glsl.
//! - Step 5 (blocker, smoothie, lit per texel, bilinear weights, falloff): `visibility`
//!   (glsl/smoothies/final.frag).
//!
//! The speed layer may change these functions' inputs: shortened smoothies round t and
//! 1/b, interpolated over other triangles, differently (visibility within 1e-5,
//! tests/plain.rs); every other trick leaves each texel read and each shaded pixel's
//! inputs as the whole passes give them (src/technique/speed/smoothies.rs).
//!
//! ## The width t
//! t is in light-uv units (a fraction of the shadow map's side). `--smoothie-t` fixes it
//! (the paper's knob, the same everywhere); by default it is calibrated from the light
//! radius R per silhouette vertex: a smoothie at blocker depth b shadows a receiver at depth
//! r over t (1 - b/r) uv after the remap, while a disc light of radius R has an outer
//! penumbra of R (r - b) / b in world units, i.e. (1 - b/r) R / (2 b tan(fov/2)) uv at the
//! receiver. The two agree for every r when t = R / (2 b tan(fov/2)) with b the silhouette
//! vertex's own depth (`silhouette::smoothie::Width::Calibrated`), capped at 0.2 (the
//! paper's largest t, `MAX_CALIBRATED_T`: a map-wide smoothie darkens everything). R = 0
//! gives t = 0 and exactly the hard result. Reports print `Width::at` at the casters'
//! centre (`smoothie_width`).
//!
//! ## Under a sun
//! A sun is every direction within its angular radius theta of its unit direction s
//! (towards it), shadow-mapped with an orthographic map of side 2 h world units and depth
//! range D = far - near (`frustum::fit_sun`). Its rays are parallel, so a blocker edge at
//! linear depth b spreads the disc of directions over (r - b) tan(theta) world units on
//! either side of its hard edge at a receiver at depth r (the full penumbra 2 (r - b)
//! tan(theta) under an overhead sun), i.e. (r - b) tan(theta) / (2 h) uv at every depth
//! (common/frame.glsl `penumbra_half_uv`), not (1 - b/r) R / (2 b tan(fov/2)). Eq. 1's
//! remap becomes
//!
//! (Eq. 1s) alpha' = alpha / ((r - b) / D),
//!
//! whose shadow reaches t (r - b) / D uv from the silhouette: the outer penumbra for every
//! r when t = D tan(theta) / (2 h), one width for every silhouette vertex
//! (`sun_smoothie_width`, `Width::Fixed`; `--smoothie-t` fixes it likewise). It is not
//! capped at 0.2: the cap is for blockers near a spotlight, which a sun has not, and
//! `fit_sun` widens the map by tan(theta) D around what the camera sees, so t stays under
//! about half the map. b >= near and r <= far give r - b <= D: the remapped shadow never
//! outgrows its smoothie. theta = 0 gives t = 0 and exactly `hard`. The b ~ r guard is
//! (r - b) / D > 1e-4 (`remap_denom`, glsl/smoothies/alpha.glsl).
//! Depths: the map's linear depth is the view's (clip z carries it, common/frame.glsl
//! `clip_linear_depth`; `LightView::project` and the records' projection use it), and
//! under a parallel projection depth, not 1/depth, is affine in screen space, so the
//! smoothie pass interpolates b itself for a sun (glsl/smoothies/light.glsl, the same
//! `inv_depth` vertex field inverted in glsl/smoothies/smoothie.vert). Silhouettes are taken
//! from a stand-in point far towards the sun (`silhouette::light_point`), on both paths.
//! The speed layer's shortened smoothies use (Eq. 1s)'s factor (`records::Extent::for_sun`);
//! its split final pass follows the central projection and is not planned for a sun.
//!
//! ## Known artefacts
//! Penumbrae only grow outward (no inner penumbra: umbrae are too large for big lights; a
//! sun's straight edge gets half its closed-form penumbra, the outer half, under the
//! falloff's sine ramp);
//! overlapping penumbrae use min, not the product; thick smoothies snap when the silhouette
//! of a coarse mesh changes under a moving light (Volokh Sec. 7); a depth bias that detaches
//! the shadow also detaches the smoothie (Volokh Fig. 8), hence the receiver offset
//! (`light_sample`, glsl/common/shadow.glsl) rather than a constant bias.

use super::speed::regions::INNER_RECEIVER_TEXELS;
use super::speed::smoothies::{gpu_extent, Areas, CpuSmoothies, Drawn, PAPER_SPLIT_BANDS};
use super::{
    light_target_images, smoothies_centred, target_buffers, technique_constants, Form, FrameInput,
    LightBuffer, LightTarget, Packing, Technique, TechniqueInfo, TechniqueInit,
};
use crate::frustum::fit_light;
use crate::gpu::passes::{falloff_lut, FinalPass, FinalShader, ShadowMap, Shadowed, FAR_DEPTH};
use crate::scene::{LightView, Scene};
use crate::settings::SilhouettePath;
use crate::shaders::{self, constants as k};
use crate::silhouette::gpu::{Emit, GpuSilhouettes};
use crate::silhouette::smoothie::records::Extent;
use crate::silhouette::smoothie::{SmoothieVertex, Width};
use crate::silhouette::{self, Adjacency};
use crate::vk::{
    Blend, Clear, Context, CullModeFlags, DescriptorSet, Filter, Format, GraphicsPipelineDesc,
    Image, Pipeline, PrimitiveTopology, Recorder, Resource, Sampler,
};
use anyhow::Result;
use std::sync::Arc;

pub const INFO: TechniqueInfo = TechniqueInfo {
    name: "smoothies",
    summary: "Chan & Durand 2003: shadow map + smoothie buffer (depth, alpha), min blending",
    create: |init| Smoothies::create(init, Form::Paper),
};

/// The names of one form's passes (= timestamp and debug labels).
pub(super) struct Names {
    pub technique: &'static str,
    pub silhouettes: &'static str,
    pub shadow_map: &'static str,
    pub smoothie: &'static str,
    pub final_pass: &'static str,
}

impl Form {
    pub(super) fn smoothie_names(self) -> Names {
        super::pass_names!(
            Names {
                silhouettes: "silhouettes",
                shadow_map: "shadow_map",
                smoothie: "smoothie",
                final_pass: "final",
            },
            match self {
                Form::Paper => "smoothies",
                Form::Centred => "smoothies-centred",
            }
        )
    }
}

/// Locations of `SmoothieVertex` fields in glsl/smoothies/smoothie.vert.
const SMOOTHIE_ATTRIBUTES: &[crate::vk::Attribute] = &[
    (0, Format::R32G32_SFLOAT, 0),
    (1, Format::R32_SFLOAT, 8),
    (2, Format::R32_SFLOAT, 12),
    (3, Format::R32G32_SFLOAT, 16),
    (4, Format::R32G32_SFLOAT, 24),
    (5, Format::R32_SFLOAT, 32),
];

/// The smoothie widths: the fixed knob when given, else calibrated per silhouette vertex
/// from the light radius and the vertex's depth, or for a sun the one width
/// `sun_smoothie_width` (see the module header).
pub fn smoothie_widths(fixed: Option<f32>, light: &LightView, radius: f32) -> Width {
    if light.sun.is_some() {
        return Width::Fixed(fixed.unwrap_or_else(|| sun_smoothie_width(light)));
    }
    match fixed {
        Some(t) => Width::Fixed(t),
        None => Width::Calibrated {
            radius,
            tan_half_fov: (light.fov_deg.to_radians() * 0.5).tan(),
        },
    }
}

/// A sun's calibrated width (module header, "Under a sun"): t = D tan(theta) / (2 h), D the
/// map's depth range far - near (Eq. 1s's span) and 2 h its side in world units, the same
/// for every silhouette vertex; 0 for a spotlight.
pub fn sun_smoothie_width(light: &LightView) -> f32 {
    light.sun.map_or(0.0, |s| {
        let t = s.tan_angle * (light.far - light.near) / (2.0 * s.half_width);
        if t.is_finite() {
            t.max(0.0)
        } else {
            0.0
        }
    })
}

/// A representative smoothie width t in light-uv units, for reports: the fixed knob when
/// given, else the width the renderer draws (`Width::at`, capped at `MAX_CALIBRATED_T`) at
/// the depth of the casters' bounds centre.
pub fn smoothie_width(fixed: Option<f32>, scene: &Scene, light: &LightView, radius: f32) -> f32 {
    let width = smoothie_widths(fixed, light, radius);
    if let Width::Fixed(t) = width {
        return t;
    }
    let Some(b) = scene.caster_bounds() else {
        return 0.0;
    };
    width.at(light.linear_depth((b.min + b.max) * 0.5).max(light.near))
}

/// The paper's smoothie buffer: one RG32F target (pass 2).
const PAPER_TARGETS: &[LightTarget] = &[LightTarget {
    name: "smoothie_buffer",
    format: Format::R32G32_SFLOAT,
    clear: [FAR_DEPTH, 1.0, 0.0, 0.0],
    // The nearest smoothie's linear depth b (1e30: no smoothie); the remapped alpha
    // alpha / (1 - b/r), MIN over smoothies (1: none).
    channels: &["depth", "alpha"],
    packing: Packing::Plain,
}];

/// The smoothie pass's attachments of `form`.
fn smoothie_targets(form: Form) -> &'static [LightTarget] {
    match form {
        Form::Paper => PAPER_TARGETS,
        Form::Centred => &smoothies_centred::TARGETS,
    }
}

/// A smoothie pipeline (pass 2; the centred form's two too): `SmoothieVertex` triangle
/// lists through glsl/smoothies/smoothie.vert and `fragment` into `colors`.
pub(super) fn smoothie_pipeline_desc<'a>(
    name: &'a str,
    fragment: &'a [u8],
    colors: &'a [(Format, Blend)],
    sets: &'a [&'a DescriptorSet],
) -> GraphicsPipelineDesc<'a> {
    GraphicsPipelineDesc {
        name,
        vertex: shaders::SMOOTHIES_SMOOTHIE_VERT,
        fragment: Some(fragment),
        vertex_stride: std::mem::size_of::<SmoothieVertex>() as u32,
        attributes: SMOOTHIE_ATTRIBUTES,
        topology: PrimitiveTopology::TRIANGLE_LIST,
        // Smoothie quads and fans are built in 2-D with either winding.
        cull: CullModeFlags::NONE,
        colors,
        depth: None,
        push_constant_bytes: 0,
        sets,
    }
}

/// The paper's smoothie pipeline (glslang's fragment shader, or the hand-tuned SPIR-V
/// under `--spirv tuned`).
fn paper_pipeline(init: &TechniqueInit<'_>, smoothie_set: &DescriptorSet) -> Result<Pipeline> {
    let fragment = init.settings.spirv.pick(
        shaders::SMOOTHIES_SMOOTHIE_FRAG,
        shaders::SMOOTHIES_SMOOTHIE_FRAG_SPVASM,
    );
    let colors = [(PAPER_TARGETS[0].format, Blend::Min)];
    let name = Form::Paper.smoothie_names().smoothie;
    Pipeline::graphics(
        init.ctx,
        &smoothie_pipeline_desc(name, fragment, &colors, &[smoothie_set]),
    )
}

/// The paper's final shader (hand-tuned SPIR-V under `--spirv tuned`).
fn paper_final_shader(init: &TechniqueInit<'_>) -> FinalShader {
    init.settings.spirv.pick(
        FinalShader {
            color: shaders::SMOOTHIES_FINAL_FRAG,
            aov: shaders::SMOOTHIES_FINAL_FRAG_AOV,
            count: shaders::SMOOTHIES_FINAL_FRAG_COUNT,
        },
        FinalShader {
            color: shaders::SMOOTHIES_FINAL_FRAG_SPVASM,
            aov: shaders::SMOOTHIES_FINAL_FRAG_SPVASM_AOV,
            // The hand-tuned module has no counting build: glslang's counts the same
            // lookups (it is the same source).
            count: shaders::SMOOTHIES_FINAL_FRAG_COUNT,
        },
    )
}

pub struct Smoothies {
    form: Form,
    shadow: ShadowMap,
    /// The smoothie pass's attachments, as `smoothie_targets(form)` lists them.
    smoothie: Vec<Image>,
    /// The outer smoothies' pipeline (both paths; the paper's smoothies).
    smoothie_pipeline: Pipeline,
    /// Centred form: the inner smoothies' pipeline.
    inner_pipeline: Option<Pipeline>,
    smoothie_set: DescriptorSet,
    final_pass: FinalPass,
    final_set: DescriptorSet,
    _falloff: Image,
    _nearest: Sampler,
    _linear: Sampler,
    /// Edge adjacency per object (None for non-casters), built once per mesh and shared
    /// by the objects that instance it (`silhouette::caster_adjacency`).
    adjacency: Vec<Option<Arc<Adjacency>>>,
    path: SilhouettePath,
    /// CPU path: the smoothies of every caster, outer then inner side.
    cpu: CpuSmoothies,
    /// GPU path: silhouettes and geometry by compute, drawn indirectly.
    gpu_silhouettes: Option<GpuSilhouettes>,
    /// Whether the smoothie pass draws anything (false at t = 0).
    draw_smoothies: bool,
    /// Where the light passes clear and draw, and where the final shader runs.
    areas: Areas,
}

impl Smoothies {
    pub(crate) fn create(init: &TechniqueInit<'_>, form: Form) -> Result<Box<dyn Technique>> {
        let ctx = init.ctx;
        let res = init.settings.shadow_res;
        let names = form.smoothie_names();
        let shadow = ShadowMap::new(ctx, init.ubo, res, names.shadow_map)?;
        let smoothie = light_target_images(ctx, smoothie_targets(form), res, names.technique)?;
        let nearest = Sampler::new(ctx, Filter::Nearest)?;
        let linear = Sampler::new(ctx, Filter::Linear)?;
        let falloff = falloff_lut(ctx)?;
        let smoothie_set = DescriptorSet::new(
            ctx,
            &[
                ("frame", Resource::Uniform(init.ubo)),
                ("shadow_map", Resource::Sampled(&shadow.depth, &nearest)),
            ],
            names.smoothie,
        )?;
        let path = init.settings.silhouettes.resolve(init.ctx);
        let (smoothie_pipeline, inner_pipeline) = match form {
            Form::Paper => (paper_pipeline(init, &smoothie_set)?, None),
            Form::Centred => {
                let mirrored = path == SilhouettePath::Gpu;
                let [outer, inner] = smoothies_centred::pipelines(init, &smoothie_set, mirrored)?;
                (outer, Some(inner))
            }
        };
        let mut bindings = vec![
            ("frame", Resource::Uniform(init.ubo)),
            ("shadow_map", Resource::Sampled(&shadow.depth, &nearest)),
        ];
        // The paper's smoothie buffer and falloff curve; the centred form's outer and inner
        // values (its disc-chord profile is computed in the shader).
        let final_shader = match (form, &smoothie[..]) {
            (Form::Paper, [buffer]) => {
                bindings.push(("smoothie_buffer", Resource::Sampled(buffer, &nearest)));
                bindings.push(("falloff", Resource::Sampled(&falloff, &linear)));
                paper_final_shader(init)
            }
            (Form::Centred, [outer, inner]) => {
                bindings.push(("smoothie_outer", Resource::Sampled(outer, &nearest)));
                bindings.push(("smoothie_inner", Resource::Sampled(inner, &nearest)));
                smoothies_centred::FINAL_SHADER
            }
            _ => anyhow::bail!("{} smoothie targets for {form:?}", smoothie.len()),
        };
        let final_set = DescriptorSet::new(ctx, &bindings, names.final_pass)?;
        let mut final_pass = FinalPass::split(ctx, names.final_pass, final_shader, &final_set)?;
        if form == Form::Paper {
            final_pass = final_pass.with_bands(PAPER_SPLIT_BANDS);
        }
        let adjacency = silhouette::caster_adjacency(init.scene, |_| true)?;
        let gpu_silhouettes = match path {
            SilhouettePath::Cpu | SilhouettePath::Auto => None,
            SilhouettePath::Gpu => Self::gpu_silhouettes(init, &adjacency)?,
        };
        Ok(Box::new(Self {
            form,
            shadow,
            smoothie,
            smoothie_pipeline,
            inner_pipeline,
            smoothie_set,
            final_pass,
            final_set,
            _falloff: falloff,
            _nearest: nearest,
            _linear: linear,
            cpu: CpuSmoothies::new(adjacency.len()),
            adjacency,
            path,
            gpu_silhouettes,
            draw_smoothies: false,
            areas: Areas::default(),
        }))
    }

    /// The GPU path's compute passes and buffers, sized for the scene's own light (`prepare`
    /// grows them when a frame needs more).
    fn gpu_silhouettes(
        init: &TechniqueInit<'_>,
        adjacency: &[Option<Arc<Adjacency>>],
    ) -> Result<Option<GpuSilhouettes>> {
        let light = fit_light(init.scene);
        let radius = init.settings.radius_for(init.scene);
        let width = smoothie_widths(init.settings.smoothie_t, &light, radius);
        GpuSilhouettes::new(
            init.ctx,
            init.ubo,
            &init.scene.objects,
            adjacency,
            &light,
            width,
        )
    }
}

impl Technique for Smoothies {
    fn name(&self) -> &'static str {
        self.form.smoothie_names().technique
    }

    fn uniforms(&self, frame: &FrameInput<'_>) -> [[f32; 4]; 2] {
        // The final pass only tests the representative width for 0 (R = 0 is `hard`).
        let t = smoothie_width(
            frame.settings.smoothie_t,
            frame.scene,
            frame.light,
            frame.light_radius,
        );
        let mut c = [0.0; 8];
        c[k::SMOOTHIE_T] = t;
        // The GPU silhouette passes' fixed width (a sun's too), or -1 for the calibrated one.
        let width = smoothie_widths(frame.settings.smoothie_t, frame.light, frame.light_radius);
        c[k::SMOOTHIE_FIXED_T] = match width {
            Width::Fixed(t) => t,
            Width::Calibrated { .. } => -1.0,
        };
        technique_constants(c)
    }

    fn record_light(
        &mut self,
        ctx: &Context,
        rec: &mut Recorder<'_>,
        frame: &FrameInput<'_>,
    ) -> Result<()> {
        let t = smoothie_width(
            frame.settings.smoothie_t,
            frame.scene,
            frame.light,
            frame.light_radius,
        );
        let width = smoothie_widths(frame.settings.smoothie_t, frame.light, frame.light_radius);
        // t = 0 (a point light): no smoothie can shadow anything, the result is `hard`.
        self.draw_smoothies = t > 0.0;
        // Without pass caching every frame rebuilds everything (the bench's baseline).
        let force = !frame.settings.cache_light_passes;
        let casters = self.adjacency.iter().flatten().count();
        let names = self.form.smoothie_names();
        let res = self.shadow.resolution;
        // The GPU path's cut (`speed::smoothies::gpu_extent`).
        let extent = match &self.gpu_silhouettes {
            Some(_) => gpu_extent(frame, width, self.form == Form::Centred, res),
            None => Extent::FULL,
        };
        // Pass 0: the smoothies, on the GPU or on the CPU.
        if !self.draw_smoothies {
            rec.skip(names.silhouettes, "light radius 0: hard shadows");
        } else if let Some(gpu) = self.gpu_silhouettes.as_mut() {
            let emit = Emit::Smoothies(frame.light, width, extent);
            let objects = &frame.scene.objects;
            gpu.frame_pass(ctx, rec, names.silhouettes, casters, force, objects, emit)?;
        } else if self.path == SilhouettePath::Cpu {
            let (adjacency, centred) = (&self.adjacency, self.form == Form::Centred);
            let rebuilt = rec.cpu(names.silhouettes, || {
                self.cpu.build(frame, adjacency, width, force, centred, res)
            });
            rec.rebuilt(names.silhouettes, rebuilt, casters);
            self.cpu.upload(ctx)?;
        }

        let drawn = match (self.draw_smoothies, &self.gpu_silhouettes) {
            (false, _) => Drawn::Nothing,
            (true, Some(_)) => Drawn::Gpu(width, extent),
            (true, None) => Drawn::Cpu(&self.cpu),
        };
        let grow = match self.form {
            Form::Paper => 0,
            Form::Centred => INNER_RECEIVER_TEXELS,
        };
        let (map_area, area) = self.areas.light_areas(frame, res, grow, drawn);
        // Pass 1.
        self.shadow.pass_in(rec, frame.gpu, &map_area)?;
        // Pass 2: each pipeline into its own target (the paper form's one, the centred
        // form's outer and inner).
        rec.pass(names.smoothie, |rec| {
            let pipelines = [Some(&self.smoothie_pipeline), self.inner_pipeline.as_ref()];
            let sides = self.smoothie.iter().zip(smoothie_targets(self.form));
            for (side, ((image, target), pipeline)) in sides.zip(pipelines).enumerate() {
                rec.begin_rendering_in(&[(image, Clear::Float(target.clear))], None, Some(area));
                if let Some(pipeline) = pipeline.filter(|_| self.draw_smoothies) {
                    match (&self.gpu_silhouettes, self.path) {
                        // The inner pipeline draws the same outer smoothies, reflected
                        // (glsl/smoothies_centred/mirrored.vert).
                        (Some(gpu), _) => {
                            rec.bind_pipeline(pipeline);
                            rec.bind_sets(pipeline, &[&self.smoothie_set]);
                            gpu.draw(rec);
                        }
                        (None, SilhouettePath::Cpu) => {
                            let vertices = self.cpu.sides().nth(side);
                            if let Some(vertices) = vertices.filter(|v| !v.is_empty()) {
                                rec.bind_pipeline(pipeline);
                                rec.bind_sets(pipeline, &[&self.smoothie_set]);
                                vertices.draw(rec);
                            }
                        }
                        // No caster edge: nothing to draw.
                        _ => {}
                    }
                }
                rec.end_rendering();
            }
            Ok(())
        })?;
        Ok(())
    }

    fn light_passes(&self) -> Vec<String> {
        let names = self.form.smoothie_names();
        let mut passes = vec![names.shadow_map, names.smoothie];
        if self.gpu_silhouettes.is_some() {
            passes.insert(0, names.silhouettes);
        }
        passes.into_iter().map(String::from).collect()
    }

    /// Pass 3.
    fn record_final(
        &mut self,
        _ctx: &Context,
        rec: &mut Recorder<'_>,
        frame: &FrameInput<'_>,
    ) -> Result<()> {
        self.final_pass
            .pass_in(rec, frame, &self.final_set, self.areas.shadowed())
    }

    fn shadowed(&self) -> Option<&Shadowed> {
        Some(self.areas.shadowed())
    }

    fn light_buffers(&self) -> Vec<LightBuffer<'_>> {
        target_buffers(&self.shadow, &self.smoothie, smoothie_targets(self.form))
    }

    fn gpu_silhouettes(&self) -> Option<&GpuSilhouettes> {
        self.gpu_silhouettes.as_ref()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frustum::PixelBox;
    use crate::silhouette::smoothie::MAX_CALIBRATED_T;
    use crate::technique::speed::regions;
    use glam::Vec2;

    /// The reported t is the drawn one: `Width::at` at the casters' centre, capped where
    /// the renderer caps it, for small and huge lights alike.
    #[test]
    fn reported_width_is_the_rendered_width() {
        let scene = Scene::load("cylinder").unwrap();
        let light = fit_light(&scene);
        let b = scene.caster_bounds().unwrap();
        let depth = light.linear_depth((b.min + b.max) * 0.5);
        // Independently of `Width::at`: the casters' centre, at depth b along the scene
        // light's axis, gets the module header's calibration t = R / (2 b tan(fov/2)),
        // capped at the paper's largest t, 0.2.
        let axis = (scene.light.target - scene.light.position).normalize();
        let b_depth = ((b.min + b.max) * 0.5 - scene.light.position).dot(axis);
        assert!(
            (b_depth - depth).abs() < 1e-3 * depth,
            "{b_depth} vs {depth}"
        );
        let tan_half = (light.fov_deg.to_radians() * 0.5).tan();
        let mut widths = Vec::new();
        for radius in [0.0, 0.01, scene.light.radius, 5.0, 1e3] {
            let t = smoothie_width(None, &scene, &light, radius);
            let drawn = smoothie_widths(None, &light, radius).at(depth);
            assert_eq!(t, drawn, "R {radius}");
            let expected = (radius / (2.0 * b_depth * tan_half)).min(0.2);
            assert!(
                (t - expected).abs() <= 1e-4 * expected.max(1e-3),
                "R {radius}: t {t}, expected {expected}"
            );
            widths.push(t);
        }
        // Wider for a larger light, until the cap.
        assert!(
            widths.windows(2).all(|w| w[1] >= w[0]) && widths[2] > widths[1],
            "{widths:?}"
        );
        assert_eq!(smoothie_width(None, &scene, &light, 1e3), MAX_CALIBRATED_T);
        assert_eq!(smoothie_width(None, &scene, &light, 0.0), 0.0);
        assert_eq!(smoothie_width(Some(0.02), &scene, &light, 1e3), 0.02);
    }

    /// The smoothie pass's area: a uv box grows by a texel each side for rounding and is
    /// clipped to the buffer, an infinite box is the whole buffer, an empty box adds
    /// nothing to a union and becomes the 1x1 area a render area must at least be.
    #[test]
    fn texel_boxes_cover_their_uv_box_and_stay_inside_the_buffer() {
        let b = PixelBox::of_uv(1024, Vec2::new(0.25, 0.5), Vec2::new(0.5, 0.75));
        assert_eq!((b.x0, b.y0, b.x1, b.y1), (255, 511, 513, 769));
        let inf = PixelBox::of_uv(1024, Vec2::NEG_INFINITY, Vec2::INFINITY);
        assert_eq!(inf, PixelBox::whole(1024, 1024));
        let edge = PixelBox::of_uv(1024, Vec2::new(-0.5, 0.999), Vec2::new(0.001, 1.5));
        assert_eq!((edge.x0, edge.y0, edge.x1, edge.y1), (0, 1021, 3, 1024));
        assert!(PixelBox::EMPTY.is_empty());
        assert_eq!(PixelBox::EMPTY.union(b), b);
        assert_eq!(b.union(PixelBox::EMPTY), b);
        let u = b.union(edge);
        assert_eq!((u.x0, u.y0, u.x1, u.y1), (0, 511, 513, 1024));
        let r = regions::render_area(PixelBox::EMPTY);
        assert_eq!(
            (r.offset.x, r.offset.y, r.extent.width, r.extent.height),
            (0, 0, 1, 1)
        );
        let r = regions::render_area(b);
        assert_eq!(
            (r.offset.x, r.offset.y, r.extent.width, r.extent.height),
            (255, 511, 258, 258)
        );
        // The centred form's receiver area: wider by n each side, still inside the buffer.
        let g = b.grown(7, 1024);
        assert_eq!((g.x0, g.y0, g.x1, g.y1), (248, 504, 520, 776));
        let g = edge.grown(7, 1024);
        assert_eq!((g.x0, g.y0, g.x1, g.y1), (0, 1014, 10, 1024));
        assert!(PixelBox::EMPTY.grown(7, 1024).is_empty());
    }
}
