//! # penumbra-map — Wyman & Hansen 2003, *Penumbra Maps: Approximate Soft Shadows in Real-Time*
//! Port sheet: docs/port/penumbra-map.md
//!
//! A shadow map for the umbra plus a "penumbra map": per shadow-map texel, the light
//! intensity of the foremost surface seen from the light, rendered by drawing a cone at each
//! silhouette vertex and a sheet along each silhouette edge (from the light's centre) and
//! evaluating Eq. 1 per fragment. The final pass does two lookups. Outer penumbra only: the
//! umbra is the hard shadow, the penumbra grows outward from it. (`penumbra-map-centred`,
//! src/technique/penumbra_map_centred.rs, is this struct with `Form::Centred`: inner cones
//! and sheets too.)
//!
//! ## Passes, in order
//! 0. `penumbra-map/silhouettes` — per caster: brute-force silhouette edges from the light
//!    centre over the edge adjacency built once per mesh, then the cones and sheets in world
//!    space (see `silhouette::penumbra` for the geometry): cone tip at vertex v (linear light
//!    depth Zv), base at depth Z_far with the paper's radius C_r = (Z_far - Zv) Lr / Zv
//!    (Sec. 3, third bullet; Lr = the light radius R), 16 triangles each, one cone per
//!    distinct silhouette vertex however many silhouette edges meet there (the paper's
//!    3..8-edge vertices); one sheet per edge, the plane through the edge tangent to the light
//!    disc on the inner side, i.e. the exact outer tangent of the two cones (fourth bullet).
//!    That quad is planar, so the paper's subdivision of "extremely non-planar" quads is never
//!    needed. Z_far = 0.995 x the light's far plane (`frustum::fit_light` puts it 1 % beyond
//!    the farthest scene corner, so every receiver is nearer; the margin keeps the bases
//!    inside the clip volume). 24 bytes a vertex: world position, (Zv k, k), the object's
//!    angular radius `reach` from the light centre. R = 0: no geometry (the pass is skipped).
//!    Two interchangeable paths (`--silhouettes`, `Settings::silhouettes`):
//!    - GPU (default on a GPU): `silhouette::gpu::GpuSilhouettes::new_penumbra`, four
//!      compute dispatches over every caster (glsl/silhouette/penumbra_*.comp, finish.comp):
//!      the smoothie path's silhouette classification, a per-caster reduction for `reach`
//!      (atomicMax), the cones and sheets, the indirect-draw commands; written straight into
//!      a device-local vertex buffer drawn with one indirect draw per caster. No readback, no
//!      upload but the casters' transforms and the light. A timed pass.
//!    - CPU (default on lavapipe, where the compute passes share the CPU's two cores and are
//!      slower, BENCHMARKS.md): `silhouette::extract` + `penumbra::build_penumbra` (rayon
//!      for casters of 4096 silhouette edges and more),
//!      uploaded to a host-visible vertex buffer. A `cpu` timing.
//!
//!    Both build the same triangles (tests/gpu_penumbra.rs) and keep each caster's geometry
//!    until its model or the light changes (a moved caster rebuilds only its own). Z_far is
//!    part of the light: a receiver that moves the far plane rebuilds every caster.
//! 1. `penumbra-map/shadow_map` — the shared `gpu::passes::ShadowMap`: every object from
//!    the light into one R32G32_SFLOAT target, clear 1e30 (`FAR_DEPTH`), blend MIN, no depth
//!    attachment; r = the nearest caster's linear depth (the shadow map of the final test),
//!    g = the nearest surface of any role (Z_P of Eq. 1: the foremost surface, casting or
//!    not). The paper's shadow map holds every object; our scenes have receive-only
//!    grounds, which need a depth for Eq. 1 but must not cast, hence the two channels. r is
//!    read everywhere, g only where the penumbra map is below 1 (passes 2 and 3). So on the
//!    CPU path the pass clears and draws only the cones' and sheets' texels and the
//!    projected box of each caster they do not hold (a silhouette vertex without a cone,
//!    `CasterGeometry::holds_caster`), joined with last frame's, and draws the objects that
//!    receive but cast nothing (a ground that fills the map) only inside the cones' and
//!    sheets' texels (`light_areas`): g holds 1e30 elsewhere. A porter can draw every
//!    object into the whole map instead: same image (tests/avoided_work.rs,
//!    `Settings::light_areas`).
//! 2. `penumbra-map/penumbra` — cones and sheets from the light, culling off, no depth
//!    attachment; one colour attachment, the penumbra map: R16_SFLOAT intensity, clear 1.0
//!    (the paper's "clear to white"), blend MIN; on the CPU path cleared and drawn only in
//!    the cones' and sheets' texels joined with last frame's (every texel outside holds
//!    the clear value; a porter can clear the whole map). `glsl/penumbra_map/penumbra.vert` projects
//!    with the light's view-projection and passes the linear depth Z_F and (Zv k, k)
//!    perspective-correctly; `penumbra.frag` (its tests and bound in
//!    glsl/penumbra_map/wedge.glsl, shared with the centred form) reads Z_P = the shadow
//!    map's g (foremost surface) at its own texel (texelFetch), discards when nothing is
//!    there, when Z_F > Z_P (pseudocode step 4: the geometry is behind the surface) and when Z_P - Zv <= 1e-4 Z_P (the surface touches or is
//!    in front of the silhouette vertex: no penumbra, and no NaN/Inf from the division), then
//!    writes s = 3 I^2 - 2 I^3 with I = clamp((Z_F - Zv) / (Z_P - Zv), 0, 1) — Eq. 1 (the
//!    issue's I = (ZF - Zv)/(ZP - Zv) is the same formula) with Parker et al.'s falloff —
//!    raised to the blocker-size bound max(s, 1 - 4 r / (pi Lr)), r = reach Zv Z_P / (Z_P - Zv)
//!    (not in the paper; stress cases `blocker-near-light`, `near-far-1e-4`: a caster smaller
//!    than the light cannot hide more than a strip of the light disc; <= 0 for casters as
//!    large as the light).
//!    Darkest wins: the paper writes I' as the fragment depth with a LESS test (Sec. 4); a MIN
//!    blend on a colour target is the same selection, keeps the map sampleable as a plain
//!    colour texture, and leaves no depth attachment to clear. R16F steps 2^-11 near 1.
//! 3. `penumbra-map/final` — from the camera (`FinalPass`), `glsl/penumbra_map/final.frag`:
//!    textureGather of the shadow map's r (casters) and g (foremost surface) and of the
//!    penumbra map at the normal-offset point (the window test below is
//!    glsl/penumbra_map/surface.glsl, shared with the centred form); per texel visibility =
//!    lit test x intensity (0 in the hard shadow, else the penumbra intensity), bilinear weights (the 2x2 filter of `hard`). A
//!    texel whose foremost surface lies more than 1 % beyond the point's own surface AT THAT
//!    TEXEL (the depth of the point's tangent plane through the texel centre, clamped to
//!    [depth, 1.05 depth]) counts as intensity 1: it holds the penumbra of a background
//!    surface (the ground just outside a caster's silhouette), which the bilinear footprint
//!    would otherwise smear over grazing caster faces only a texel or two wide. (A single
//!    window at the point's depth misreads sloped receivers: moire, stress case
//!    `blocker-near-light`.) Writes colour RGBA8 (the untimed AOV pass `penumbra-map/aov`
//!    also visibility, position and normal: `FinalPass`). Where all four texels are lit
//!    and read intensity 1, v is exactly 1 (`bilinear_lit`: the weights' sum is 1 only up
//!    to rounding), and outside the texels a caster or its cones and sheets project to,
//!    every texel is so. So on the CPU path, where that geometry is known, the timed pass
//!    (`FinalPass::split`, src/technique/regions.rs) runs this shader only on the
//!    receivers' parts inside the light frustum over each caster's polygon (its cones' and
//!    sheets' vertices, whose tips on the silhouette bound the caster's projection, and
//!    else its box's projected corners too, `light_uvs`) and glsl/common/unshadowed.frag
//!    elsewhere: the same image (tests/avoided_work.rs), for a fraction of the pass on
//!    lavapipe, which runs every branch for every fragment. A porter can draw the whole
//!    pass with this shader: same image.
//!
//! ## Equations
//! Sec. 3: C_r = (Z_far - Z_v) L_r / Z_v (cone radius). Eq. 1 (in linear, "world-space"
//! depths as the paper's pseudocode converts them; for Zv << Z_P it is far from linear across
//! the penumbra, I ~ (Zv / Z_P) f / (1 - f) at the fraction f): I = 1 - (Z_P - Z_F) / (Z_P -
//! Z_v) = (Z_F - Z_v) / (Z_P - Z_v), Z_F = cone/sheet fragment depth, Z_P = surface depth, Z_v =
//! silhouette vertex depth. Sec. 3 falloff: s = 3 I^2 - 2 I^3. Sheets: Z_v exact per fragment
//! as the ratio of two perspective-correct attributes (the paper interpolates it linearly).
//!
//! ## Equations: what a porter ports
//! - Sec. 3's cones and sheets (C_r): `build_penumbra` (src/silhouette/penumbra.rs).
//! - Eq. 1 (I, with Z_v per fragment) and its guards: `eq1_depths` (glsl/penumbra_map/
//!   wedge.glsl); the blocker-size bound: `blocker_floor` (same file); the falloff and the
//!   write: `main` of glsl/penumbra_map/penumbra.frag.
//! - The final lookup and the own-surface window: `visibility` (glsl/penumbra_map/
//!   final.frag) with `own_surface` (glsl/penumbra_map/surface.glsl).
//!
//! Where the speed layer (`--plain` turns it off, `Settings::effective`) may change
//! these functions' inputs:
//! - The shadow map holds g only where it is read (1e30 elsewhere), and both buffers are
//!   cleared and drawn only over the cones', sheets' and casters' texels
//!   (`regions::silhouette_areas`): every texel read holds what the whole pass writes.
//! - `FinalPass::split` chooses which pixels run the final shader and which get 1 without
//!   a lookup; where the shader runs its inputs are the whole pass's (bit for bit).
//! - Culling leaves out objects outside the light's frustum (light passes) and the
//!   camera's (final pass): they write no texel a lookup reads and no pixel.
//! - Reuse skips the light passes when the light, its radius and every object are
//!   unchanged: the buffers then hold what the same passes wrote.
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

use super::{
    regions, shadow_map_buffer, Form, FrameInput, LightBuffer, Technique, TechniqueInfo,
    TechniqueInit,
};
use crate::frustum::{fit_light, PixelBox};
use crate::gpu::passes::{
    CasterCacheOf, DynamicVertices, FinalPass, FinalShader, MapArea, ShadowMap, Shadowed,
};
use crate::scene::LightView;
use crate::settings::SilhouettePath;
use crate::shaders;
use crate::silhouette::gpu::{Emit, GpuSilhouettes};
use crate::silhouette::penumbra::{build_penumbra_sides, PenumbraKey, PenumbraVertex, Side};
use crate::silhouette::{self, Adjacency};
use crate::vk::{
    Blend, Clear, Context, CullModeFlags, DescriptorSet, Filter, Format, GraphicsPipelineDesc,
    Image, ImageUsageFlags, Pipeline, PrimitiveTopology, Recorder, Rect2D, Resource, Sampler,
};
use anyhow::{Context as _, Result};
use glam::{Vec2, Vec3};
use std::sync::Arc;

pub const INFO: TechniqueInfo = TechniqueInfo {
    name: "penumbra-map",
    summary: "Wyman & Hansen 2003: shadow map + penumbra map of silhouette cones and sheets",
    create: |init| PenumbraMap::create(init, Form::Paper),
};

const PENUMBRA_VERTEX_BYTES: u32 = std::mem::size_of::<PenumbraVertex>() as u32;

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

/// How far (texels) from the cones and sheets the centred form's inner fragments read
/// the shadow map's g (glsl/penumbra_map_centred/inner.frag): a fragment u tangent units
/// inside the hard edge samples u / per_texel + 1.5 and + 5.5 texels away along its
/// gradient (`regions::INNER_RECEIVER_TEXELS`), and u = Lr (1/Zv - 1/Z_F) is at most
/// Lr (1/zv_min - 1/z_far): its depth Z_F on a cone or sheet lies between its silhouette
/// point's Zv and the cone base `cone_base_depth`. `None` for a non-finite reach.
fn inner_read_texels(frame: &FrameInput<'_>, zv_min: f32, res: u32) -> Option<u32> {
    let per_texel = 2.0 * (frame.light.fov_deg.to_radians() * 0.5).tan() / res as f32;
    let u_max = frame.light_radius * (1.0 / zv_min - 1.0 / cone_base_depth(frame.light));
    let texels = (u_max.max(0.0) / per_texel).ceil();
    // Beyond the map's side it reaches everywhere: the whole map, as `grown` clips.
    let texels = texels
        .is_finite()
        .then_some(texels.min(res as f32) as u32)?;
    Some(texels + regions::INNER_RECEIVER_TEXELS)
}

/// The names of one form's passes (= timestamp and debug labels).
struct Names {
    technique: &'static str,
    silhouettes: &'static str,
    shadow_map: &'static str,
    penumbra: &'static str,
    final_pass: &'static str,
}

impl Form {
    fn names(self) -> Names {
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

/// One caster's outer cones and sheets, then its inner ones (empty in the paper form).
type Sides = [Vec<PenumbraVertex>; 2];

/// One caster's per-light geometry on the CPU path, rebuilt when it or the light moves.
struct CasterGeometry {
    sides: Sides,
    /// Every silhouette vertex got its cones, whose tips lie on it: the geometry's points
    /// then bound the caster's own projection ("The silhouette bounds the projection" in
    /// `crate::silhouette`), and its box adds nothing.
    holds_caster: bool,
}

pub struct PenumbraMap {
    form: Form,
    shadow: ShadowMap,
    /// The paper's penumbra map (R16F); the centred form's outer visibility, inner
    /// occlusion and inner receiver nearness (RGBA16F: r, g, b; a unused).
    penumbra: Image,
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
    /// CPU path: per caster, its cones and sheets and what they were built for: a moved
    /// caster rebuilds only its own.
    cache: CasterCacheOf<PenumbraKey, CasterGeometry>,
    vertices: DynamicVertices,
    inner_vertices: DynamicVertices,
    /// GPU path: silhouettes, cones and sheets by compute, drawn indirectly (None on the CPU
    /// path, or when no caster has an edge).
    gpu_silhouettes: Option<GpuSilhouettes>,
    /// Whether the penumbra pass draws anything this frame (R > 0).
    draw_geometry: bool,
    /// Where the final shader can give less than 1, built with the light passes
    /// (`light_areas`; `Everywhere`: not known).
    shadowed: Shadowed,
    /// The texels the last penumbra pass may have drawn; the next pass clears them with its
    /// own (`light_areas`).
    penumbra_drawn: regions::LastDrawn,
    /// The same for the last shadow-map pass.
    map_drawn: regions::LastDrawn,
}

/// What the casters and their cones and sheets cover in light uv (`PenumbraMap::light_uvs`).
struct LightUvs {
    /// Per caster, the polygon around its geometry (and its box's corners, `light_uvs`).
    supports: Vec<regions::Support>,
    /// The texels of the projected boxes of the casters their geometry does not hold.
    casters: PixelBox,
    /// The texels of the cones and sheets.
    geometry: PixelBox,
    /// The centred form: how far (texels) around the cones and sheets the inner fragments
    /// read the shadow map's g (`inner_read_texels`); 0 for the paper form.
    inner_reach: u32,
}

impl PenumbraMap {
    pub(crate) fn create(init: &TechniqueInit<'_>, form: Form) -> Result<Box<dyn Technique>> {
        let ctx = init.ctx;
        let names = form.names();
        let res = init.settings.shadow_res;
        let usage = ImageUsageFlags::COLOR_ATTACHMENT
            | ImageUsageFlags::SAMPLED
            | ImageUsageFlags::TRANSFER_SRC;
        let shadow = ShadowMap::new(ctx, init.ubo, res, names.shadow_map)?;
        // The centred form packs its two maps into one target so that one MIN blend serves
        // both (see penumbra_map_centred.rs).
        let (penumbra_name, penumbra_format) = match form {
            Form::Paper => ("penumbra map", Format::R16_SFLOAT),
            Form::Centred => (
                "penumbra map (outer, inner, receiver)",
                Format::R16G16B16A16_SFLOAT,
            ),
        };
        ctx.require_blend(penumbra_format, Blend::Min, names.technique)?;
        let penumbra = Image::new_2d(ctx, res, res, penumbra_format, usage, penumbra_name)
            .with_context(|| format!("creating the {penumbra_name}"))?;
        let nearest = Sampler::new(ctx, Filter::Nearest).context("creating the nearest sampler")?;

        let penumbra_set = DescriptorSet::new(
            ctx,
            &[
                ("frame", Resource::Uniform(init.ubo)),
                ("shadow_map", Resource::Sampled(&shadow.depth, &nearest)),
            ],
            names.penumbra,
        )?;
        // Darkest wins (the paper's LESS test on intensity stored as depth).
        let colors = &[(penumbra_format, Blend::Min)];
        let penumbra_pipeline_for = |fragment: &[u8]| {
            Pipeline::graphics(
                ctx,
                &GraphicsPipelineDesc {
                    name: names.penumbra,
                    vertex: shaders::PENUMBRA_MAP_PENUMBRA_VERT,
                    fragment: Some(fragment),
                    vertex_stride: PENUMBRA_VERTEX_BYTES,
                    attributes: PENUMBRA_ATTRIBUTES,
                    topology: PrimitiveTopology::TRIANGLE_LIST,
                    // Cones are seen from inside, sheets from either side.
                    cull: CullModeFlags::NONE,
                    colors,
                    depth: None,
                    push_constant_bytes: 0,
                    sets: &[&penumbra_set],
                },
            )
        };
        let (penumbra_pipeline, inner_pipeline) = match form {
            Form::Paper => (
                penumbra_pipeline_for(shaders::PENUMBRA_MAP_PENUMBRA_FRAG)?,
                None,
            ),
            Form::Centred => (
                penumbra_pipeline_for(shaders::PENUMBRA_MAP_CENTRED_OUTER_FRAG)?,
                Some(penumbra_pipeline_for(
                    shaders::PENUMBRA_MAP_CENTRED_INNER_FRAG,
                )?),
            ),
        };
        let final_resources = [
            ("frame", Resource::Uniform(init.ubo)),
            ("shadow_map", Resource::Sampled(&shadow.depth, &nearest)),
            ("penumbra_map", Resource::Sampled(&penumbra, &nearest)),
        ];
        let final_set = DescriptorSet::new(ctx, &final_resources, names.final_pass)?;
        let final_shader = match form {
            Form::Paper => FinalShader {
                color: shaders::PENUMBRA_MAP_FINAL_FRAG,
                aov: shaders::PENUMBRA_MAP_FINAL_FRAG_AOV,
                count: shaders::PENUMBRA_MAP_FINAL_FRAG_COUNT,
            },
            Form::Centred => FinalShader {
                color: shaders::PENUMBRA_MAP_CENTRED_FINAL_FRAG,
                aov: shaders::PENUMBRA_MAP_CENTRED_FINAL_FRAG_AOV,
                count: shaders::PENUMBRA_MAP_CENTRED_FINAL_FRAG_COUNT,
            },
        };
        // Split: the shader runs only where a caster or its cones and sheets project.
        let final_pass = FinalPass::split(ctx, names.final_pass, final_shader, &final_set)?;
        let adjacency = silhouette::caster_adjacency(init.scene, |_| true)?;
        let path = form.silhouette_path(init);
        let gpu_silhouettes = match path {
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
            cache: CasterCacheOf::new(adjacency.len()),
            adjacency,
            vertices: DynamicVertices::new("penumbra-map cones and sheets"),
            inner_vertices: DynamicVertices::new("penumbra-map inner cones and sheets"),
            gpu_silhouettes,
            draw_geometry: false,
            shadowed: Shadowed::Everywhere,
            penumbra_drawn: regions::LastDrawn::default(),
            map_drawn: regions::LastDrawn::default(),
        }))
    }

    /// How many objects cast (have an edge adjacency).
    fn casters(&self) -> usize {
        self.adjacency.iter().flatten().count()
    }

    /// CPU path: silhouettes, cones and sheets of every caster that moved since they were
    /// built (of all when the light changed); returns how many were rebuilt.
    fn build_geometry(&mut self, frame: &FrameInput<'_>, key: PenumbraKey, force: bool) -> usize {
        let (light, radius, z_far) = (frame.light, key.radius, key.z_far);
        let form = self.form;
        self.cache.update(
            &frame.scene.objects,
            &self.adjacency,
            key,
            force,
            |adj, model| {
                let sil = silhouette::extract(adj, model, light.position);
                let (l, r, z) = (light, radius, z_far);
                let (outer, inner) = match form {
                    Form::Paper => {
                        let [outer] =
                            build_penumbra_sides(adj, &sil, model, l, r, z, [Side::Outer]);
                        (outer, Vec::new())
                    }
                    Form::Centred => {
                        let sides = [Side::Outer, Side::Inner];
                        let [outer, inner] = build_penumbra_sides(adj, &sil, model, l, r, z, sides);
                        (outer, inner.vertices)
                    }
                };
                CasterGeometry {
                    // The inner cones have the same tips as the outer ones.
                    holds_caster: outer.skipped_vertices == 0 && outer.cones > 0,
                    sides: [outer.vertices, inner],
                }
            },
        )
    }

    /// Per object, the light-uv points that bound what it draws into the light buffers: its
    /// box's projected corners (a caster in the light, unless its geometry holds it:
    /// `CasterGeometry::holds_caster`) and its cones' and sheets' vertices (a projected
    /// triangle lies inside its vertices' hull; every cached caster's geometry is drawn,
    /// also one just outside the light's frustum, whose cones can reach into it). `None` on
    /// the GPU path, whose geometry only the device knows, and when a box or a vertex
    /// reaches behind the light.
    fn light_uvs(&self, frame: &FrameInput<'_>) -> Option<LightUvs> {
        if self.draw_geometry && self.gpu_silhouettes.is_some() {
            return None;
        }
        let mut corners = regions::caster_corner_uvs(frame)?;
        let cached = |i: usize| self.cache.get(i).filter(|_| self.draw_geometry);
        corners.retain(|(i, _)| !cached(*i).is_some_and(|c| c.holds_caster));
        let mut points = vec![Vec::new(); frame.gpu.objects.len()];
        for (i, uvs) in &corners {
            points[*i].extend(uvs);
        }
        let (mut lo, mut hi) = (Vec2::INFINITY, Vec2::NEG_INFINITY);
        let mut zv_min = f32::INFINITY;
        for (i, caster) in points.iter_mut().enumerate() {
            let sides = cached(i).map(|c| &c.sides);
            for v in sides.into_iter().flatten().flatten() {
                let uv = regions::light_uv(frame, Vec3::from(v.position))?;
                (lo, hi) = (lo.min(uv), hi.max(uv));
                caster.push(uv);
            }
            if let Some([_, inner]) = sides {
                zv_min = inner
                    .iter()
                    .fold(zv_min, |z, v| z.min(v.zv_h[0] / v.zv_h[1]));
            }
        }
        let res = self.shadow.resolution;
        let inner_reach = match self.form {
            Form::Centred if zv_min.is_finite() => inner_read_texels(frame, zv_min, res)?,
            _ => 0,
        };
        Some(LightUvs {
            supports: points
                .iter()
                .filter_map(|p| regions::support_of(p))
                .collect(),
            casters: regions::casters_box(&corners, res),
            geometry: if lo.x <= hi.x {
                PixelBox::of_uv(res, lo, hi)
            } else {
                PixelBox::EMPTY
            },
            inner_reach,
        })
    }

    /// This frame's areas, from `light_uvs` (`regions::silhouette_areas`): the penumbra map
    /// where the cones and sheets project; the shadow map around the casters and where g is
    /// read: under the geometry (the final pass, where the outer value is below 1; the
    /// fragments' own texels), and for the centred form's inner fragments up to
    /// `inner_read_texels` around it (the receiver hidden behind the caster is read just
    /// outside the hard edge). Sets where the final shader can give less than 1: each
    /// caster's polygon (`regions::shadowed` adds the normal offset and the gather's
    /// footprint).
    fn light_areas(&mut self, frame: &FrameInput<'_>) -> (MapArea, Rect2D) {
        let uvs = self.light_uvs(frame);
        let res = self.shadow.resolution;
        self.shadowed = match &uvs {
            Some(u) => regions::shadowed(frame, &u.supports, res, 0.0),
            None => Shadowed::Everywhere,
        };
        regions::silhouette_areas(
            frame,
            res,
            uvs.as_ref().map(|u| u.geometry),
            uvs.as_ref().map(|u| u.casters),
            uvs.as_ref().map_or(0, |u| u.inner_reach),
            [&mut self.penumbra_drawn, &mut self.map_drawn],
        )
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
        // R = 0 (a point light): every cone has radius 0, the result is `hard`.
        self.draw_geometry = frame.light_radius > 0.0;
        // Without pass caching every frame rebuilds everything (the bench's baseline).
        let force = !frame.settings.cache_light_passes;
        let casters = self.casters();
        let key = PenumbraKey::new(
            frame.light,
            frame.light_radius,
            cone_base_depth(frame.light),
        );
        if !self.draw_geometry {
            if self.gpu_silhouettes.is_some() {
                rec.skip(names.silhouettes, "light radius 0: hard shadows");
            }
            self.vertices.upload::<PenumbraVertex>(ctx, &[])?;
            self.inner_vertices.upload::<PenumbraVertex>(ctx, &[])?;
        } else if let Some(gpu) = self.gpu_silhouettes.as_mut() {
            let emit = Emit::Penumbra(frame.light, key);
            let objects = &frame.scene.objects;
            gpu.frame_pass(ctx, rec, names.silhouettes, casters, force, objects, emit)?;
        } else {
            let rebuilt = rec.cpu(names.silhouettes, || self.build_geometry(frame, key, force));
            rec.rebuilt(names.silhouettes, rebuilt, casters);
            let side = |s: usize| self.cache.concat_by(|c| &c.sides[s]);
            self.vertices.upload(ctx, &side(0))?;
            if self.inner_pipeline.is_some() {
                self.inner_vertices.upload(ctx, &side(1))?;
            }
        }

        let (map_area, penumbra_area) = self.light_areas(frame);
        self.shadow.pass_in(rec, frame.gpu, &map_area)?;
        rec.pass(names.penumbra, |rec| {
            // The paper's "clear to white"; the centred form's inner occlusion starts at 1.
            rec.begin_rendering_in(
                &[(&self.penumbra, Clear::Float([1.0; 4]))],
                None,
                Some(penumbra_area),
            );
            if self.draw_geometry {
                rec.bind_pipeline(&self.penumbra_pipeline);
                rec.bind_sets(&self.penumbra_pipeline, &[&self.penumbra_set]);
                match &self.gpu_silhouettes {
                    Some(gpu) => gpu.draw(rec),
                    None => self.vertices.draw(rec),
                }
                if let Some(inner_pipeline) = &self.inner_pipeline {
                    if !self.inner_vertices.is_empty() {
                        rec.bind_pipeline(inner_pipeline);
                        rec.bind_sets(inner_pipeline, &[&self.penumbra_set]);
                        self.inner_vertices.draw(rec);
                    }
                }
            }
            rec.end_rendering();
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
        vec![
            shadow_map_buffer("shadow_map", &self.shadow),
            LightBuffer {
                name: "penumbra_map",
                image: &self.penumbra,
                channels: match self.form {
                    // Eq. 1's intensity, darkest (MIN) of the cones and sheets; 1 = lit.
                    Form::Paper => &["intensity"],
                    // The darkest outer visibility (1 = lit), the least inner occlusion
                    // (1 = umbra) and 1 - the farthest receiver depth / far an inner value
                    // was made for, all MIN (penumbra_map_centred.rs).
                    Form::Centred => &[
                        "outer_visibility",
                        "inner_occlusion",
                        "inner_receiver_nearness",
                        "unused",
                    ],
                },
            },
        ]
    }

    fn gpu_silhouettes(&self) -> Option<&GpuSilhouettes> {
        self.gpu_silhouettes.as_ref()
    }
}
