//! # penumbra-map — Wyman & Hansen 2003, *Penumbra Maps: Approximate Soft Shadows in Real-Time*
//! Port sheet: docs/port/penumbra-map.md
//! Speed layer: speed::penumbra_map, speed::regions — off under --plain.
//! Over 400 lines because this module is the one struct both forms run: the construction
//! they share, both geometry paths (CPU, GPU compute) and the passes in order; what is the
//! centred form's own is in penumbra_map_centred.rs and every speed trick in
//! speed/penumbra_map.rs.
//!
//! A shadow map for the umbra plus a "penumbra map": per shadow-map texel, the light
//! intensity of the foremost surface seen from the light, rendered by drawing a cone at each
//! silhouette vertex and a sheet along each silhouette edge (from the light's centre) and
//! evaluating Eq. 1 per fragment. The final pass does two lookups. Outer penumbra only: the
//! umbra is the hard shadow, the penumbra grows outward from it. This module is the struct
//! both forms run, in pass order; `penumbra-map-centred`'s own attachment, pipelines and
//! shaders (inner cones and sheets too) are in src/technique/penumbra_map_centred.rs.
//!
//! ## Passes, in order
//! 0. `penumbra-map/silhouettes` — per caster: silhouette edges from the light centre over
//!    the edge adjacency built once per mesh, then the cones and sheets in world space
//!    (`silhouette::penumbra`): cone tip at vertex v (linear light depth Zv), base at depth
//!    Z_far with the paper's radius C_r = (Z_far - Zv) Lr / Zv (Sec. 3, third bullet; Lr =
//!    the light radius R), 16 triangles, one cone per distinct silhouette vertex; one sheet
//!    per edge, the plane through the edge tangent to the light disc on the inner side (the
//!    exact outer tangent of the two cones, fourth bullet; planar, so never subdivided).
//!    Z_far = 0.995 x the light's far plane (`frustum::fit_light` puts it 1 % beyond the
//!    farthest scene corner; the margin keeps the bases inside the clip volume). 24 bytes a
//!    vertex (`PENUMBRA_ATTRIBUTES`): world position, (Zv k, k), the object's angular radius
//!    `reach` from the light centre. R = 0: no geometry. Two interchangeable paths
//!    (`--silhouettes`) build the same triangles (tests/gpu_penumbra.rs): the GPU's compute
//!    passes (`GpuSilhouettes::new_penumbra`, glsl/silhouette/penumbra_*.comp, one indirect
//!    draw per caster; a timed pass) and the CPU's (`speed::penumbra_map::CpuPenumbra`; a
//!    `cpu` timing).
//! 1. `penumbra-map/shadow_map` — the shared `gpu::passes::ShadowMap`: every object from
//!    the light into one R32G32_SFLOAT target, clear 1e30 (`FAR_DEPTH`), blend MIN, no depth
//!    attachment; r = the nearest caster's linear depth (the final test's shadow map), g =
//!    the nearest surface of any role (Z_P of Eq. 1). The paper's shadow map holds every
//!    object; our receive-only grounds need a depth for Eq. 1 but must not cast, hence two
//!    channels.
//! 2. `penumbra-map/penumbra` — cones and sheets from the light, culling off (cones are seen
//!    from inside), no depth attachment; one colour attachment, the penumbra map:
//!    R16_SFLOAT intensity, clear 1.0 (the paper's "clear to white"), blend MIN: the paper
//!    writes I' as the fragment depth with a LESS test (Sec. 4), the same selection in a map
//!    sampled as a plain colour texture. `glsl/penumbra_map/penumbra.vert` projects with
//!    the light's view-projection and passes Z_F and (Zv k, k) perspective-correctly;
//!    `penumbra.frag` reads Z_P = the shadow map's g at its own texel and discards when
//!    nothing is there, when Z_F > Z_P (pseudocode step 4) and when Z_P - Zv <= 1e-4 Z_P
//!    (no penumbra, no NaN/Inf); writes s = 3 I^2 - 2 I^3 (Parker et al.'s falloff) raised
//!    to the blocker-size bound (`blocker_floor`, not in the paper: a caster smaller than
//!    the light cannot hide more than a strip of its disc).
//! 3. `penumbra-map/final` — from the camera (`FinalPass`), `glsl/penumbra_map/final.frag`:
//!    textureGather of the shadow map's r and g and of the penumbra map at the lookup
//!    point; per texel visibility = lit test x intensity, bilinear weights (the 2x2 filter
//!    of `hard`). A texel whose foremost surface lies more than 1 % beyond the point's own
//!    surface at that texel counts as intensity 1: it holds a background surface's penumbra
//!    (`own_surface`, glsl/penumbra_map/surface.glsl, says why). Writes colour RGBA8. Where
//!    all four texels are lit and read intensity 1, v is exactly 1 (`bilinear_lit`).
//!
//! ## Equations: what a porter ports
//! Sec. 3: C_r = (Z_far - Z_v) L_r / Z_v. Eq. 1 in linear depths, as the paper's pseudocode
//! converts them: I = (Z_F - Z_v) / (Z_P - Z_v), Z_F = cone/sheet fragment depth, Z_P =
//! surface depth, Z_v = silhouette vertex depth, exact per sheet fragment as the ratio of
//! two perspective-correct attributes (the paper interpolates it linearly).
//! - The cones and sheets (C_r): `build_penumbra` (src/silhouette/penumbra.rs).
//! - Eq. 1 and its guards: `eq1_depths` (glsl/penumbra_map/wedge.glsl); the blocker-size
//!   bound: `blocker_floor` (same file); the falloff and the write: `main` of
//!   glsl/penumbra_map/penumbra.frag.
//! - The final lookup and the own-surface window: `visibility` (glsl/penumbra_map/
//!   final.frag) with `own_surface` (glsl/penumbra_map/surface.glsl).
//!
//! The speed layer leaves each texel read and each shaded pixel's inputs as the whole
//! passes give them, up to the rounding of Zv interpolated over the cut cones' and
//! sheets' shorter triangles (src/technique/speed/penumbra_map.rs; tests/plain.rs).
//!
//! ## Under a sun
//! A sun is every direction within its angular radius theta of its axis, shadow-mapped with
//! an orthographic map of side 2 h world units (`frustum::fit_sun`); linear depth is the
//! distance from the map's eye plane (clip z carries it: common/frame.glsl
//! `clip_linear_depth`; penumbra.vert's Z_F too). Parallel rays: a blocker edge at depth
//! d_b throws a penumbra that grows linearly, w = 2 (d_r - d_b) tan(theta) on a receiver at
//! d_r, half of it on each side of the hard edge. The paper's construction follows:
//! - Sec. 3 (cones): the lines through silhouette vertex v along the sun's directions form
//!   a cone of half-angle theta about v's own axis; its radius at depth Z is
//!   (Z - Z_v) tan(theta) world units, not R (Z - Z_v) / Z_v, so
//!   (Sec. 3s) C_r = (Z_far - Z_v) tan(theta), centred on v's map xy (no Z_far / Z_v).
//! - Sec. 3 (sheets): every sun cone is one cone translated, so the plane through an edge
//!   tangent to one end's cone is tangent to the other's: the same planar tangent quad
//!   between the base discs (src/silhouette/penumbra.rs, "Under a sun"), its ruling lines
//!   parallel, so Z_v is affine on it: k = 1 at every corner.
//! - Eq. 1, I = (Z_F - Z_v) / (Z_P - Z_v), is unchanged and exact: F on P's map ray lies
//!   (Z_F - Z_v) tan(theta) outside v's hard edge, where P's outer penumbra reaches
//!   (Z_P - Z_v) tan(theta). The paper form's penumbra is the outer half only:
//!   (d_r - d_b) tan(theta) wide, through 3 I^2 - 2 I^3.
//! - The blocker-size bound: `reach` is world units across the map, the strip the caster
//!   covers seen from P is reach / (Z_P - Z_v) against the disc's tan(theta)
//!   (`blocker_floor`).
//! - The final pass's own-surface window follows the point's plane along the map's parallel
//!   rays (`plane_depth`, glsl/penumbra_map/surface.glsl).
//!
//! The cones' spread is tan(theta) (`penumbra::cone_spread`; theta = 0 draws no geometry and
//! gives `hard`), silhouettes are taken from a stand-in point far towards the sun
//! (`silhouette::light_point`) on both geometry paths, and the split final pass is not
//! planned for a sun (`regions::shadowed`: the shader runs everywhere).
//!
//! ## Known artefacts
//! No inner penumbra: the umbra is the hard shadow at every light radius, so shadows are too
//! dark and too large for big lights or far casters (Sec. 4.1). Overlapping penumbrae take
//! the darkest, not the sum or product (Sec. 4, Fig. 6), with creases at silhouette
//! concavities. Full cones also cover the caster's own lit surface next to its silhouette
//! and can darken it where that surface recedes behind the silhouette vertex (self-shadowing
//! the paper accepts). Silhouettes are taken from the light's centre only, so they pop under
//! light motion. One surface per texel: a receive-only object in front of a caster (seen
//! from the light) hides the penumbra of whatever lies behind it.
use super::speed::penumbra_map::{Areas, CpuPenumbra, Drawn};
use super::{
    light_target_images, penumbra_map_centred, target_buffers, Form, FrameInput, LightBuffer,
    LightTarget, Packing, Technique, TechniqueInfo, TechniqueInit,
};
use crate::frustum::fit_light;
use crate::gpu::passes::{FinalPass, FinalShader, ShadowMap, Shadowed};
use crate::scene::LightView;
use crate::settings::SilhouettePath;
use crate::shaders;
use crate::silhouette::gpu::{Emit, GpuSilhouettes};
use crate::silhouette::penumbra::{PenumbraKey, PenumbraVertex};
use crate::silhouette::{self, Adjacency};
use crate::vk::{
    Blend, Clear, Context, CullModeFlags, DescriptorSet, Filter, Format, GraphicsPipelineDesc,
    Image, Pipeline, PrimitiveTopology, Recorder, Resource, Sampler,
};
use anyhow::{Context as _, Result};
use std::sync::Arc;

pub const INFO: TechniqueInfo = TechniqueInfo {
    name: "penumbra-map",
    summary: "Wyman & Hansen 2003: shadow map + penumbra map of silhouette cones and sheets",
    create: |init| PenumbraMap::create(init, Form::Paper),
};

/// Locations of `PenumbraVertex` fields in glsl/penumbra_map/penumbra.vert.
const PENUMBRA_ATTRIBUTES: &[crate::vk::Attribute] = &[
    (0, Format::R32G32B32_SFLOAT, 0),
    (1, Format::R32G32_SFLOAT, 12),
    (2, Format::R32_SFLOAT, 20),
];

/// Z_far as a fraction of the light's far plane (see the module header).
const Z_FAR_OF_FAR: f32 = 0.995;

/// Depth of the cone bases for `light`.
pub fn cone_base_depth(light: &LightView) -> f32 {
    light.far * Z_FAR_OF_FAR
}

/// The names of one form's passes (= timestamp and debug labels).
pub(super) struct Names {
    pub technique: &'static str,
    pub silhouettes: &'static str,
    pub shadow_map: &'static str,
    pub penumbra: &'static str,
    pub final_pass: &'static str,
}

impl Form {
    pub(super) fn names(self) -> Names {
        super::pass_names!(
            Names {
                silhouettes: "silhouettes",
                shadow_map: "shadow_map",
                penumbra: "penumbra",
                final_pass: "final",
            },
            match self {
                Form::Paper => "penumbra-map",
                Form::Centred => "penumbra-map-centred",
            }
        )
    }
}

/// The paper's penumbra map (pass 2).
const PAPER_TARGETS: [LightTarget; 1] = [LightTarget {
    name: "penumbra_map",
    format: Format::R16_SFLOAT,
    // The paper's "clear to white".
    clear: [1.0; 4],
    // Eq. 1's intensity, darkest (MIN) of the cones and sheets; 1 = lit.
    channels: &["intensity"],
    packing: Packing::Plain,
}];

/// The penumbra pass's attachments of `form`: the paper form's map; the centred form's
/// outer and inner maps, one per pipeline.
fn penumbra_targets(form: Form) -> &'static [LightTarget] {
    match form {
        Form::Paper => &PAPER_TARGETS,
        Form::Centred => &penumbra_map_centred::TARGETS,
    }
}

/// A penumbra pipeline (pass 2; the centred form's two too): `PenumbraVertex` triangle
/// lists through glsl/penumbra_map/penumbra.vert and `fragment` into `colors`.
pub(super) fn penumbra_pipeline_desc<'a>(
    name: &'a str,
    fragment: &'a [u8],
    colors: &'a [(Format, Blend)],
    sets: &'a [&'a DescriptorSet],
) -> GraphicsPipelineDesc<'a> {
    GraphicsPipelineDesc {
        name,
        vertex: shaders::PENUMBRA_MAP_PENUMBRA_VERT,
        fragment: Some(fragment),
        vertex_stride: std::mem::size_of::<PenumbraVertex>() as u32,
        attributes: PENUMBRA_ATTRIBUTES,
        topology: PrimitiveTopology::TRIANGLE_LIST,
        // Cones are seen from inside, sheets from either side.
        cull: CullModeFlags::NONE,
        colors,
        depth: None,
        push_constant_bytes: 0,
        sets,
    }
}

/// The paper's final shader (pass 3).
const PAPER_FINAL_SHADER: FinalShader = FinalShader {
    color: shaders::PENUMBRA_MAP_FINAL_FRAG,
    aov: shaders::PENUMBRA_MAP_FINAL_FRAG_AOV,
    count: shaders::PENUMBRA_MAP_FINAL_FRAG_COUNT,
};

pub struct PenumbraMap {
    form: Form,
    shadow: ShadowMap,
    /// The penumbra pass's attachments, as `penumbra_targets(form)` describes them.
    penumbra: Vec<Image>,
    penumbra_pipeline: Pipeline,
    /// Centred form: the inner cones' and sheets' pipeline.
    inner_pipeline: Option<Pipeline>,
    penumbra_set: DescriptorSet,
    final_pass: FinalPass,
    final_set: DescriptorSet,
    _nearest: Sampler,
    /// Edge adjacency per object (None for non-casters), built once per mesh and shared
    /// by the objects that instance it (`silhouette::caster_adjacency`).
    adjacency: Vec<Option<Arc<Adjacency>>>,
    /// CPU path: every caster's cones and sheets, outer then inner side.
    cpu: CpuPenumbra,
    /// GPU path: silhouettes, cones and sheets by compute, drawn indirectly (None on the CPU
    /// path, or when no caster has an edge).
    gpu_silhouettes: Option<GpuSilhouettes>,
    /// Whether the penumbra pass draws anything this frame (R > 0).
    draw_geometry: bool,
    /// Where the light passes clear and draw, and where the final shader runs.
    areas: Areas,
}

impl PenumbraMap {
    pub(crate) fn create(init: &TechniqueInit<'_>, form: Form) -> Result<Box<dyn Technique>> {
        let ctx = init.ctx;
        let names = form.names();
        let res = init.settings.shadow_res;
        let shadow = ShadowMap::new(ctx, init.ubo, res, names.shadow_map)?;
        let penumbra = light_target_images(ctx, penumbra_targets(form), res, names.technique)
            .context("creating the penumbra maps")?;
        let nearest = Sampler::new(ctx, Filter::Nearest).context("creating the nearest sampler")?;

        let penumbra_set = DescriptorSet::new(
            ctx,
            &[
                ("frame", Resource::Uniform(init.ubo)),
                ("shadow_map", Resource::Sampled(&shadow.depth, &nearest)),
            ],
            names.penumbra,
        )?;
        let (penumbra_pipeline, inner_pipeline, final_shader) = match form {
            Form::Paper => {
                // Darkest wins (the paper's LESS test on intensity stored as depth).
                let colors = [(PAPER_TARGETS[0].format, Blend::Min)];
                let fragment = shaders::PENUMBRA_MAP_PENUMBRA_FRAG;
                let sets = [&penumbra_set];
                let desc = penumbra_pipeline_desc(names.penumbra, fragment, &colors, &sets);
                (Pipeline::graphics(ctx, &desc)?, None, PAPER_FINAL_SHADER)
            }
            Form::Centred => {
                let [outer, inner] = penumbra_map_centred::pipelines(init, &penumbra_set)?;
                (outer, Some(inner), penumbra_map_centred::FINAL_SHADER)
            }
        };
        let final_resources: Vec<_> = [
            ("frame", Resource::Uniform(init.ubo)),
            ("shadow_map", Resource::Sampled(&shadow.depth, &nearest)),
        ]
        .into_iter()
        .chain(
            penumbra_targets(form)
                .iter()
                .zip(&penumbra)
                .map(|(target, image)| (target.name, Resource::Sampled(image, &nearest))),
        )
        .collect();
        let final_set = DescriptorSet::new(ctx, &final_resources, names.final_pass)?;
        // Split: the shader runs only where a caster or its cones and sheets project.
        let final_pass = FinalPass::split(ctx, names.final_pass, final_shader, &final_set)?;
        let adjacency = silhouette::caster_adjacency(init.scene, |_| true)?;
        let gpu_silhouettes = match form.silhouette_path(init) {
            SilhouettePath::Cpu | SilhouettePath::Auto => None,
            SilhouettePath::Gpu => {
                // Sized for the scene's own light; `prepare` grows it when a frame needs more.
                let light = fit_light(init.scene);
                let radius = init.settings.radius_for(init.scene);
                GpuSilhouettes::new_penumbra(
                    ctx,
                    init.ubo,
                    &init.scene.objects,
                    &adjacency,
                    &light,
                    radius,
                    cone_base_depth(&light),
                )
                .context("creating the GPU penumbra-map geometry passes")?
            }
        };
        Ok(Box::new(Self {
            form,
            shadow,
            penumbra,
            penumbra_pipeline,
            inner_pipeline,
            penumbra_set,
            final_pass,
            final_set,
            _nearest: nearest,
            cpu: CpuPenumbra::new(adjacency.len()),
            adjacency,
            gpu_silhouettes,
            draw_geometry: false,
            areas: Areas::default(),
        }))
    }
}

impl Technique for PenumbraMap {
    fn name(&self) -> &'static str {
        self.form.names().technique
    }

    fn record_light(
        &mut self,
        ctx: &Context,
        rec: &mut Recorder<'_>,
        frame: &FrameInput<'_>,
    ) -> Result<()> {
        let names = self.form.names();
        // Without pass caching every frame rebuilds everything (the bench's baseline).
        let force = !frame.settings.cache_light_passes;
        let casters = self.adjacency.iter().flatten().count();
        let z_far = cone_base_depth(frame.light);
        let key = PenumbraKey::new(frame.light, frame.light_radius, z_far);
        // R = 0 (a point light; a sun of angle 0): every cone has radius 0, the result is
        // `hard`.
        self.draw_geometry = key.radius > 0.0;
        let centred = self.form == Form::Centred;
        // Pass 0: the cones and sheets, on the GPU or on the CPU.
        if !self.draw_geometry {
            if self.gpu_silhouettes.is_some() {
                rec.skip(names.silhouettes, "light radius 0: hard shadows");
            }
            self.cpu.clear(ctx)?;
        } else if let Some(gpu) = self.gpu_silhouettes.as_mut() {
            let emit = Emit::Penumbra(frame.light, key);
            let objects = &frame.scene.objects;
            gpu.frame_pass(ctx, rec, names.silhouettes, casters, force, objects, emit)?;
        } else {
            let adjacency = &self.adjacency;
            let res = self.shadow.resolution;
            let rebuilt = rec.cpu(names.silhouettes, || {
                self.cpu.build(frame, adjacency, key, force, centred, res)
            });
            rec.rebuilt(names.silhouettes, rebuilt, casters);
            self.cpu.upload(ctx, centred)?;
        }

        let drawn = match (self.draw_geometry, &self.gpu_silhouettes) {
            (false, _) => Drawn::Nothing,
            (true, Some(_)) => Drawn::Gpu,
            (true, None) => Drawn::Cpu(&self.cpu),
        };
        let res = self.shadow.resolution;
        let (map_area, penumbra_area) = self.areas.light_areas(frame, res, z_far, drawn);
        // Pass 1.
        self.shadow.pass_in(rec, frame.gpu, &map_area)?;
        // Pass 2.
        rec.pass(names.penumbra, |rec| {
            // Each pipeline into its own map: the paper form's one, the centred form's
            // outer and inner (the GPU path draws the outer side only).
            let pipelines = [Some(&self.penumbra_pipeline), self.inner_pipeline.as_ref()];
            let maps = self.penumbra.iter().zip(penumbra_targets(self.form));
            for (side, ((image, target), pipeline)) in maps.zip(pipelines).enumerate() {
                let clear = Clear::Float(target.clear);
                rec.begin_rendering_in(&[(image, clear)], None, Some(penumbra_area));
                if let Some(pipeline) = pipeline.filter(|_| self.draw_geometry) {
                    let vertices = &self.cpu.sides()[side];
                    match &self.gpu_silhouettes {
                        Some(gpu) if side == 0 => {
                            rec.bind_pipeline(pipeline);
                            rec.bind_sets(pipeline, &[&self.penumbra_set]);
                            gpu.draw(rec);
                        }
                        _ if !vertices.is_empty() => {
                            rec.bind_pipeline(pipeline);
                            rec.bind_sets(pipeline, &[&self.penumbra_set]);
                            vertices.draw(rec);
                        }
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
        let names = self.form.names();
        let mut passes = vec![names.shadow_map, names.penumbra];
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
        target_buffers(&self.shadow, &self.penumbra, penumbra_targets(self.form))
    }

    fn gpu_silhouettes(&self) -> Option<&GpuSilhouettes> {
        self.gpu_silhouettes.as_ref()
    }
}
