//! # smoothies — Chan & Durand 2003, *Rendering Fake Soft Shadows with Smoothies*
//! Port sheet: docs/port/smoothies.md
//!
//! A shadow map plus "smoothies": screen-space rectangles of width t glued to the casters'
//! silhouette edges (and fans at their corners), rendered from the light into a smoothie
//! buffer holding a depth and an alpha per texel. The final pass darkens points behind a
//! smoothie by its alpha, giving a penumbra that grows outward from the hard shadow edge.
//! With the implementation lessons of Volokh's report (extrusion direction from averaged
//! screen-space normals, corner construction, the b ~ r guard, linear R32F depths).
//! (`smoothies-centred`, src/technique/smoothies_centred.rs, is this struct with
//! `Form::Centred`: inner smoothies too, the penumbra centred on the hard edge.)
//!
//! At a glance (each pass in full below):
//! - `smoothies/silhouettes` (CPU, or compute on the GPU path): silhouette edges, then
//!   smoothie quads and corner fans in light uv;
//! - `smoothies/shadow_map`: R32G32_SFLOAT (clear 1e30, blend MIN), no depth attachment,
//!   the receivers drawn only under smoothies (CPU path);
//! - `smoothies/smoothie`: the smoothie buffer, R32G32_SFLOAT (depth, alpha; clear (1e30,
//!   1), MIN per channel), no depth attachment, culling off, cleared and drawn only where
//!   smoothies can be (CPU path);
//! - `smoothies/final`: the camera pass; reads the two buffers and a falloff LUT, writes
//!   the colour target (RGBA8); the shader runs only where a shadow can fall (CPU path).
//!
//! **What to port**: the passes below, with pass 0's geometry from the reference
//! construction, `src/silhouette/smoothie.rs` (`build_smoothies_width`, after the reference
//! extraction `silhouette::extract_reference`), whose header gives every rule (edge quads,
//! corner fans, special vertices, widths). The renderer draws two optimisations of it,
//! interchangeable: the CPU path's compact records (`silhouette/smoothie/records.rs`,
//! expanded into the same triangles on the CPU, `SmoothieRecords::expand_side`) and the GPU
//! path's compute passes (glsl/silhouette/). `silhouette::smoothie::equivalence` holds the records to the
//! reference (edges bit for bit, corners within 1e-5 t) and tests/gpu_silhouettes.rs the
//! compute passes to the records (same edges, same image).
//!
//! ## Passes, in order
//! 0. `smoothies/silhouettes` — per caster, per light: brute-force silhouette edges over
//!    the edge adjacency built once per mesh, then smoothie geometry in light screen space:
//!    per edge a quad from the edge outward by t (alpha 0 -> 1, Sec. 3 step 3, Fig. 2); per
//!    silhouette vertex a fan covering the gap between its two edges with radial alpha
//!    |v - p| / t (Fig. 6); vertices with one or more than two silhouette edges get the
//!    paper's special case (averaged vertex normal, a fan to each adjacent edge; here a fan
//!    over the whole disc, which contains those). What the smoothie pass rasterises is a
//!    triangle list of 36-byte vertices: uv, 1/depth, kind, anchor, dir, width
//!    (`SmoothieVertex`). Two interchangeable paths (`--silhouettes`,
//!    `Settings::silhouettes`):
//!    - GPU (default on a GPU): three compute dispatches over every caster
//!      (`silhouette::gpu`, glsl/silhouette/): edges, corners, indirect-draw commands,
//!      written as expanded `SmoothieVertex`es straight into a device-local vertex buffer;
//!      no readback, no upload but the casters' transforms. A timed pass.
//!    - CPU (default on lavapipe, where the "GPU" is the same two cores, several times
//!      slower at this): `silhouette::extract` + `smoothie::records::build_records`, the
//!      casters in parallel (rayon, `CasterCacheOf::update`): compact records (layout in
//!      src/silhouette/smoothie/records.rs, which the final pass's regions bound), each
//!      expanded there into its `SmoothieVertex` triangle list
//!      (`SmoothieRecords::expand_side`), kept per caster and uploaded caster after
//!      caster to a host-visible vertex buffer. A `cpu` timing. (A vertex shader pulling
//!      the records from a storage buffer, 16 bytes per silhouette vertex, edge and corner
//!      instead of 36 per triangle corner, made lavapipe's smoothie pass 1.3-1.6x longer
//!      on `bunny` and `dense`: its vertex shading is the same CPU, with a bounds-checked
//!      gather per load.)
//!
//!    Both find the same edges (tests/gpu_silhouettes.rs) and keep each caster's geometry
//!    until its model or the light changes: a moved caster rebuilds only its own smoothies.
//! 1. `smoothies/shadow_map` — `gpu::passes::ShadowMap`: R32G32_SFLOAT, clear 1e30,
//!    blend MIN, no depth attachment; r = nearest caster's linear depth (the umbra test),
//!    g = nearest surface of any role (the receiver depth r of Eq. 1). Linear depth, not
//!    the depth buffer's, because Eq. 1 needs b/r. r is read everywhere (pass 3), g only
//!    under smoothies (pass 2). So on the CPU path the pass clears and draws only the
//!    smoothies' texels (pass 2's box) and the projected box of each caster they do not
//!    hold (an edge dropped at the near plane, `SmoothieRecords::holds_caster`), joined
//!    with last frame's, and draws the objects that receive but cast nothing (a ground that
//!    fills the map) only inside the smoothies' texels (`light_areas`): g holds 1e30
//!    elsewhere. A porter can draw every object into the whole map instead: same image
//!    (tests/avoided_work.rs, `Settings::light_areas`).
//! 2. `smoothies/smoothie` — ONE pass, one colour attachment, no depth attachment.
//!    One pipeline for both paths: glsl/smoothies/smoothie.vert reads `SmoothieVertex`
//!    attributes (stride 36: locations 0 uv, 1 1/depth, 2 kind, 3 anchor, 4 dir, 5 width)
//!    and passes the light uv through; one indirect draw on the GPU path, one draw of
//!    every caster's triangles on the CPU path. Attachment: location 0 = the smoothie buffer,
//!    R32G32_SFLOAT, clear (1e30, 1.0), blend MIN (per channel, so r and g blend as two
//!    targets would): r = smoothie linear depth b (the min keeps the nearest smoothie),
//!    g = remapped alpha (the paper's "minimum blending" of overlapping smoothies, Sec.
//!    3.1). One two-channel target rather than the paper's two: half the blend work on a
//!    CPU driver, and the final pass's two gathers of it share one texel address
//!    computation (the alpha gets 32 bits where 16 would do).
//!    `glsl/smoothies/smoothie.frag` reads the shadow map's g at its own texel for the
//!    receiver depth r, computes the distance x from the silhouette (edge: along the
//!    outward normal; corner: radial) and Eq. 1's alpha' = (x / t) / (1 - b/r), written
//!    only where the smoothie darkens a surface (`glsl/smoothies/alpha.glsl`). Discarded:
//!    g = 1e30 (no surface at the texel: nothing to shade, and r is lit there), b/r > 1
//!    (smoothie behind the surface seen there), 1 - b/r < 1e-4 (Volokh 3.5: b ~ r, the
//!    smoothie touches what it shades; no NaN, no Inf, no speckles), and alpha' >= 1, i.e.
//!    x >= t (1 - b/r), which holds everything at or past the smoothie's outer side x = t.
//!    A fully lit fragment casts nothing, and its b must not MIN-blend into a texel that
//!    another smoothie shades: the paper writes it, and then a receiver between the two
//!    smoothies' depths takes the farther one's alpha (mae_lit fell on `bunny`,
//!    `primitives`, `fence` and `dense` when those fragments went, 0.060 -> 0.047 on
//!    `dense`). A corner's polygon overshoots its disc of radius t, so this also makes the
//!    image independent of how a corner is split into fans.
//!    Geometry and area on the CPU path, where the texels are known:
//!    - the quads and fans stop where every fragment further out is discarded:
//!      t (1 - b / Z) plus a texel, with Z the deepest surface under the smoothies' box
//!      (`regions::deepest_surface`), since r <= Z (`records::Extent`; an edge takes its
//!      nearer end's b at both ends, as b is convex along it). A blocker resting on its
//!      receiver has b close to r, and Eq. 1 saturates close to the silhouette: on `bunny`
//!      the triangles' area falls from 360k to 102k texels of the 1024^2 map (the time it
//!      saves on lavapipe: BENCHMARKS.md).
//!      A porter can draw the full width t instead: the same image up to the rounding
//!      of t and 1/b interpolated over other triangles (tests/avoided_work.rs);
//!    - render area and scissor: the texels those triangles can reach, each vertex
//!      record's uv plus and minus its reach (`SmoothieRecords::uv_bounds`), joined with
//!      last frame's, so that every texel outside still holds the clear value
//!      (`light_areas`). That is 12-13 % of the map on `cylinder`, `bunny` and `overlap`,
//!      and the clear of the rest was lavapipe's largest fixed cost here (docs/notes).
//!      A porter can clear the whole buffer instead: same image (`--plain`).
//!
//!    The GPU path draws the full width and clears the whole buffer, as its geometry's
//!    extent is only known on the device.
//! 3. `smoothies/final` — from the camera (`FinalPass`), `glsl/smoothies/final.frag`: at
//!    each of the 4 nearest texels v = 0 behind the blocker (shadow map r), else alpha
//!    behind the smoothie (smoothie buffer r, then g), else 1 (Sec. 3 step 5); bilinear
//!    weights (the 2x2 tent of the paper's hardware PCF); then the sinusoidal falloff
//!    0.5 - 0.5 cos(pi v) from a 256-texel R32F 1-D texture. Outside the texels passes 1
//!    and 2 drew (each caster's projection and its smoothies), every lookup reads "far"
//!    and v is exactly 1. So on the CPU path, where those texels are known, the timed pass
//!    (`FinalPass::split`) takes per caster a 16-sided polygon in light uv around its
//!    smoothies' reach, which holds the caster's own projection too (the convex hull of a
//!    projected mesh is its silhouette vertices'; else its box's projected corners are
//!    added: `shadow_regions`), cuts each receiver's world box to the light frustum over
//!    each polygon (widened by the normal offset and the gather's footprint,
//!    `regions::shadowed`), and draws the object with this shader only in the screen boxes
//!    of those cuts (for a light mesh such as a ground, 2 rows of columns in the paper form,
//!    `PAPER_SPLIT_BANDS`, 8 in the centred one; one box for a heavy mesh), with
//!    glsl/common/unshadowed.frag (visibility 1, no lookup) in the rest
//!    of its screen box: scissors of one rendering scope, objects in the scene's order, so
//!    the image is the whole pass's bit for bit (tests/avoided_work.rs). On lavapipe the
//!    lookups then run on 28-37 % of the area drawn on `cylinder`, `overlap` and `bunny`,
//!    and the pass costs not much more than `hard`'s: a CPU driver runs both sides of a
//!    branch, so the shader's own early-outs save nothing there. On a GPU, where a warp
//!    skips what none of its threads takes, a porter can draw the whole pass with this
//!    shader: same image.
//!
//! `--spirv tuned` (`Settings::spirv`) runs hand-written SPIR-V for passes 2 and 3 instead
//! of glslang's: glsl/smoothies/smoothie.frag.spvasm and final.frag.spvasm, same bindings,
//! same image within one 8-bit level (tests/spirv.rs); each change is commented in the file.
//!
//! ## Equations: what a porter ports
//! - The smoothie geometry (Sec. 3, Fig. 2 and 6; Volokh's corners): the reference
//!   construction `build_smoothies_width` (src/silhouette/smoothie.rs).
//! - The width t (see "The width t"): `Width::at` (src/silhouette/smoothie.rs).
//! - Eq. 1 (alpha' = alpha / (1 - b/r)) and which fragments are written:
//!   `smoothie_alpha` (glsl/smoothies/alpha.glsl).
//! - Step 5 (blocker, smoothie, lit per texel, bilinear weights, falloff): `visibility`
//!   (glsl/smoothies/final.frag).
//!
//! Where the speed layer (`--plain` turns it off, `Settings::effective`) may change
//! these functions' inputs:
//! - Shortened smoothies (`records::Extent`): the quads and fans stop where every
//!   fragment further out is discarded; t and 1/b, interpolated over other triangles,
//!   round differently (visibility within 1e-5, tests/plain.rs).
//! - The shadow map holds g only where the smoothie pass reads it (1e30 elsewhere), and
//!   both buffers are cleared and drawn only over the smoothies' and casters' texels
//!   (`regions::silhouette_areas`): every texel read holds what the whole pass writes.
//! - `FinalPass::split` chooses which pixels run the final shader and which get 1 without
//!   a lookup; where the shader runs its inputs are the whole pass's (bit for bit).
//! - Culling leaves out objects outside the light's frustum (light passes) and the
//!   camera's (final pass): they write no texel a lookup reads and no pixel.
//! - Reuse skips the light passes when the light, its radius and every object are
//!   unchanged: the buffers then hold what the same passes wrote.
//!
//! ## The width t
//! t is in light-uv units (a fraction of the shadow map's side). `--smoothie-t` fixes it
//! (the paper's knob, the same everywhere); by default it is calibrated from the light
//! radius R per silhouette vertex: a smoothie at blocker depth b shadows a receiver at depth
//! r over t (1 - b/r) uv after the remap, while a disc light of radius R has an outer
//! penumbra of R (r - b) / b in world units, i.e. (1 - b/r) R / (2 b tan(fov/2)) uv at the
//! receiver. The two agree for every r when t = R / (2 b tan(fov/2)) with b the silhouette
//! vertex's own depth (`silhouette::smoothie::Width::Calibrated`): each vertex carries its t
//! and the fragment shader divides by the interpolated one, capped at 0.2 (the paper's
//! largest t, `MAX_CALIBRATED_T`: a blocker near the light would ask for up to the whole map,
//! and a map-wide smoothie darkens everything). R = 0 gives t = 0 and exactly the hard
//! result. `Width::at` is the one formula; reports print it at the casters' centre
//! (`smoothie_width`).
//!
//! ## Known artefacts
//! Penumbrae only grow outward (no inner penumbra: umbrae are too large for big lights);
//! overlapping penumbrae use min, not the product; thick smoothies snap when the silhouette
//! of a coarse mesh changes under a moving light (Volokh Sec. 7); a depth bias that detaches
//! the shadow also detaches the smoothie (Volokh Fig. 8), hence normal offset.

use super::{
    regions, shadow_map_buffer, technique_constants, Form, FrameInput, LightBuffer, Technique,
    TechniqueInfo, TechniqueInit,
};
use crate::frustum::{fit_light, PixelBox};
use crate::gpu::passes::{
    falloff_lut, CasterCacheOf, DynamicVertices, FinalPass, FinalShader, MapArea, ShadowMap,
    Shadowed, FAR_DEPTH,
};
use crate::scene::{LightView, Scene};
use crate::settings::SilhouettePath;
use crate::shaders::{self, constants as k};
use crate::silhouette::gpu::{Emit, GpuSilhouettes};
use crate::silhouette::smoothie::records::{build_records, Extent, SmoothieRecords};
use crate::silhouette::smoothie::{GeometryKey, SmoothieVertex, Width};
use crate::silhouette::{self, Adjacency, Side};
use crate::vk::{
    Blend, Clear, Context, CullModeFlags, DescriptorSet, Filter, Format, GraphicsPipelineDesc,
    Image, ImageUsageFlags, Pipeline, PrimitiveTopology, Recorder, Rect2D, Resource, Sampler,
};
use anyhow::Result;
use glam::Vec2;
use rayon::prelude::*;
use std::sync::Arc;

pub const INFO: TechniqueInfo = TechniqueInfo {
    name: "smoothies",
    summary: "Chan & Durand 2003: shadow map + smoothie buffer (depth, alpha), min blending",
    create: |init| Smoothies::create(init, Form::Paper),
};

/// The names of one form's passes (= timestamp and debug labels).
struct Names {
    technique: &'static str,
    silhouettes: &'static str,
    shadow_map: &'static str,
    smoothie: &'static str,
    final_pass: &'static str,
}

impl Form {
    fn smoothie_names(self) -> Names {
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

/// Rows the paper form's split final pass cuts a ground into (`FinalPass::with_bands`),
/// not the default 8: its lookup (three gathers) costs little against a draw per part on
/// lavapipe (measured against 8 rows in docs/notes/engine-like-frames.md). `pcss`, whose
/// lookup is several times dearer, gained nothing from fewer rows.
const PAPER_SPLIT_BANDS: u32 = 2;

const SMOOTHIE_VERTEX_BYTES: u32 = std::mem::size_of::<SmoothieVertex>() as u32;

/// Locations of `SmoothieVertex` fields in glsl/smoothies/smoothie.vert.
const SMOOTHIE_ATTRIBUTES: &[crate::vk::Attribute] = &[
    (0, Format::R32G32_SFLOAT, 0),
    (1, Format::R32_SFLOAT, 8),
    (2, Format::R32_SFLOAT, 12),
    (3, Format::R32G32_SFLOAT, 16),
    (4, Format::R32G32_SFLOAT, 24),
    (5, Format::R32_SFLOAT, 32),
];

/// The farthest receiver depth z_r an inner fragment of the centred form can find
/// (glsl/common/inner_receiver.glsl): a depth the shadow map holds, at most the light's
/// far plane, extrapolated by at most PLANE_LIMIT (5 %); 0.1 % more for the rounding of
/// the stored depths. Its penumbra's half-width t (1 - b / z_r) is then at most
/// t (1 - b / Z), and every fragment beyond is discarded, so the inner smoothies are drawn
/// only that far (`Extent`; the same image up to the rounding of the interpolated t and
/// 1/b).
fn inner_extent_depth(light: &LightView) -> f32 {
    light.far * (1.0 + regions::INNER_PLANE_LIMIT) * 1.001
}

/// The smoothie widths: the fixed knob when given, else calibrated per silhouette vertex
/// from the light radius and the vertex's depth (see the module header).
pub fn smoothie_widths(fixed: Option<f32>, light: &LightView, radius: f32) -> Width {
    match fixed {
        Some(t) => Width::Fixed(t),
        None => Width::Calibrated {
            radius,
            tan_half_fov: (light.fov_deg.to_radians() * 0.5).tan(),
        },
    }
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

/// One attachment of the smoothie pass, MIN-blended (each texel keeps the darkest
/// smoothie).
struct SmoothieTarget {
    /// `--buffers` file and `Renderer::read_technique_buffer` name, and debug label.
    name: &'static str,
    format: Format,
    clear: [f32; 4],
    /// What each channel holds, for `--buffers`.
    channels: &'static [&'static str],
}

/// The smoothie pass's attachments. The paper's smoothie buffer is one RG32F target: MIN
/// blends each channel on its own, as two targets would, and one target halves the blend
/// work and lets the final pass's two gathers share one texel address computation. The
/// centred form keeps its depth apart from its penumbra values, which RGBA16F holds.
fn smoothie_targets(form: Form) -> &'static [SmoothieTarget] {
    match form {
        Form::Paper => &[SmoothieTarget {
            name: "smoothie_buffer",
            format: Format::R32G32_SFLOAT,
            clear: [FAR_DEPTH, 1.0, 0.0, 0.0],
            // The nearest smoothie's linear depth b (1e30: no smoothie); the remapped alpha
            // alpha / (1 - b/r), MIN over smoothies (1: none).
            channels: &["depth", "alpha"],
        }],
        Form::Centred => &[
            SmoothieTarget {
                name: "smoothie_depth",
                format: Format::R32_SFLOAT,
                clear: [FAR_DEPTH; 4],
                // The nearest outer smoothie's linear depth (1e30: none).
                channels: &["depth"],
            },
            SmoothieTarget {
                name: "smoothie_penumbra",
                format: Format::R16G16B16A16_SFLOAT,
                clear: [1.0; 4],
                // The darkest outer visibility (1 = lit), the least inner occlusion (1 =
                // umbra) and 1 - the farthest inner receiver depth / far, all MIN
                // (smoothies_centred.rs).
                channels: &[
                    "outer_visibility",
                    "inner_occlusion",
                    "inner_receiver_nearness",
                    "unused",
                ],
            },
        ],
    }
}

/// The smoothie pass's pipelines, both drawing `SmoothieVertex` triangle lists (the GPU
/// path's from its compute passes, the CPU path's expanded from the records) through
/// glsl/smoothies/smoothie.vert into `smoothie_targets` with MIN blending: the outer
/// smoothies' (the paper's, or the centred form's outer fragment shader) and the centred
/// form's inner ones.
struct SmoothiePipelines {
    outer: Pipeline,
    inner: Option<Pipeline>,
}

impl SmoothiePipelines {
    fn new(init: &TechniqueInit<'_>, form: Form, smoothie_set: &DescriptorSet) -> Result<Self> {
        let name = form.smoothie_names().smoothie;
        let (outer, inner) = match form {
            Form::Paper => {
                let paper = init.settings.spirv.pick(
                    shaders::SMOOTHIES_SMOOTHIE_FRAG,
                    shaders::SMOOTHIES_SMOOTHIE_FRAG_SPVASM,
                );
                (paper, None)
            }
            Form::Centred => (
                shaders::SMOOTHIES_CENTRED_OUTER_FRAG,
                Some(shaders::SMOOTHIES_CENTRED_INNER_FRAG),
            ),
        };
        let colors: Vec<_> = smoothie_targets(form)
            .iter()
            .map(|target| (target.format, Blend::Min))
            .collect();
        let pipeline = |fragment: &[u8]| {
            Pipeline::graphics(
                init.ctx,
                &GraphicsPipelineDesc {
                    name,
                    vertex: shaders::SMOOTHIES_SMOOTHIE_VERT,
                    fragment: Some(fragment),
                    vertex_stride: SMOOTHIE_VERTEX_BYTES,
                    attributes: SMOOTHIE_ATTRIBUTES,
                    topology: PrimitiveTopology::TRIANGLE_LIST,
                    // Smoothie quads and fans are built in 2-D with either winding.
                    cull: CullModeFlags::NONE,
                    colors: &colors,
                    depth: None,
                    push_constant_bytes: 0,
                    sets: &[smoothie_set],
                },
            )
        };
        Ok(Self {
            outer: pipeline(outer)?,
            inner: inner.map(pipeline).transpose()?,
        })
    }
}

/// One caster's smoothies on the CPU path: records rebuilt when it or the light moves,
/// triangles also when the extent they were expanded with changes.
struct CasterSmoothies {
    /// The compact construction (`silhouette::smoothie::records`), which the regions
    /// bound (`SmoothieRecords::uv_support`, `holds_caster`).
    records: SmoothieRecords,
    /// Its triangle lists (`SmoothieRecords::expand_side`): the outer side (the paper
    /// form's shortened by `outer_extent`), then (centred form; empty in the paper form)
    /// the inner side, shortened by `inner_extent_depth`.
    sides: [Vec<SmoothieVertex>; 2],
    /// The outer and inner extents `sides` were expanded with; `None` after a rebuild.
    expanded: Option<[Extent; 2]>,
    /// The full-width smoothies' light-uv box (`SmoothieRecords::uv_bounds`), from the
    /// records: where `outer_extent` looks for the deepest surface.
    full_box: Option<(Vec2, Vec2)>,
    /// The box and the support (`regions::directions`) of the triangles in `sides`' outer
    /// side, from the records and its extent: where the smoothie pass draws
    /// (`light_areas`) and the final pass looks (`shadow_regions`). Kept with `sides`, so
    /// a frame that moves nothing computes neither.
    drawn_box: Option<(Vec2, Vec2)>,
    drawn_support: Option<regions::Support>,
}

pub struct Smoothies {
    form: Form,
    shadow: ShadowMap,
    /// The smoothie pass's attachments, as `smoothie_targets(form)` lists them: the paper's
    /// RG32F smoothie buffer (depth, alpha); the centred form's depth and penumbra values.
    smoothie: Vec<Image>,
    /// The outer smoothies' pipeline (both paths; the paper's smoothies), drawing
    /// `SmoothieVertex`es.
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
    /// CPU path: per object, the geometry and what it was built for (model, light key), so
    /// that a frame rebuilds only the casters that moved.
    cpu_cache: CasterCacheOf<GeometryKey, CasterSmoothies>,
    /// CPU path: every caster's outer smoothie triangles, then (centred form) every
    /// caster's inner ones, in host-visible vertex buffers.
    vertices: [DynamicVertices; 2],
    /// GPU path: silhouettes and geometry by compute, drawn indirectly.
    gpu_silhouettes: Option<GpuSilhouettes>,
    /// Whether the smoothie pass draws anything (false at t = 0).
    draw_smoothies: bool,
    /// The texels the last smoothie pass may have drawn; the next pass clears them with its
    /// own (`light_areas`).
    smoothie_drawn: regions::LastDrawn,
    /// The same for the last shadow-map pass.
    map_drawn: regions::LastDrawn,
    /// Where the final pass's visibility can be below 1, from where the last light passes
    /// can have left r or the smoothie buffer holding anything but the clear value
    /// (`shadow_regions`, `regions::shadowed`; `Everywhere`: not known).
    shadowed: Shadowed,
}

impl Smoothies {
    pub(crate) fn create(init: &TechniqueInit<'_>, form: Form) -> Result<Box<dyn Technique>> {
        let ctx = init.ctx;
        let res = init.settings.shadow_res;
        let names = form.smoothie_names();
        let shadow = ShadowMap::new(ctx, init.ubo, res, names.shadow_map)?;
        let smoothie = Self::smoothie_images(ctx, form, res)?;
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
        let pipelines = SmoothiePipelines::new(init, form, &smoothie_set)?;
        let final_set =
            Self::final_set(init, form, &shadow, &smoothie, &falloff, &nearest, &linear)?;
        let mut final_pass = FinalPass::split(
            ctx,
            names.final_pass,
            Self::final_shader(init, form),
            &final_set,
        )?;
        if form == Form::Paper {
            final_pass = final_pass.with_bands(PAPER_SPLIT_BANDS);
        }
        let adjacency = silhouette::caster_adjacency(init.scene, |_| true)?;
        let path = form.silhouette_path(init);
        let gpu_silhouettes = match path {
            SilhouettePath::Cpu | SilhouettePath::Auto => None,
            SilhouettePath::Gpu => Self::gpu_silhouettes(init, &adjacency)?,
        };
        Ok(Box::new(Self {
            form,
            shadow,
            smoothie,
            smoothie_pipeline: pipelines.outer,
            inner_pipeline: pipelines.inner,
            smoothie_set,
            final_pass,
            final_set,
            _falloff: falloff,
            _nearest: nearest,
            _linear: linear,
            cpu_cache: CasterCacheOf::new(adjacency.len()),
            adjacency,
            path,
            vertices: [
                DynamicVertices::new("smoothie vertices"),
                DynamicVertices::new("inner smoothie vertices"),
            ],
            gpu_silhouettes,
            draw_smoothies: false,
            smoothie_drawn: regions::LastDrawn::default(),
            map_drawn: regions::LastDrawn::default(),
            shadowed: Shadowed::Everywhere,
        }))
    }

    /// The smoothie pass's attachments (`smoothie_targets`), each checked for MIN blending.
    fn smoothie_images(ctx: &Context, form: Form, res: u32) -> Result<Vec<Image>> {
        let usage = ImageUsageFlags::COLOR_ATTACHMENT
            | ImageUsageFlags::SAMPLED
            | ImageUsageFlags::TRANSFER_SRC;
        smoothie_targets(form)
            .iter()
            .map(|target| {
                let technique = form.smoothie_names().technique;
                ctx.require_blend(target.format, Blend::Min, technique)?;
                Image::new_2d(ctx, res, res, target.format, usage, target.name)
            })
            .collect()
    }

    /// The final pass's bindings: the shadow map and the smoothie pass's targets, plus the
    /// paper's falloff curve (the centred form's disc-chord profile is computed in the
    /// shader).
    fn final_set(
        init: &TechniqueInit<'_>,
        form: Form,
        shadow: &ShadowMap,
        smoothie: &[Image],
        falloff: &Image,
        nearest: &Sampler,
        linear: &Sampler,
    ) -> Result<DescriptorSet> {
        let mut bindings = vec![
            ("frame", Resource::Uniform(init.ubo)),
            ("shadow_map", Resource::Sampled(&shadow.depth, nearest)),
        ];
        match (form, smoothie) {
            (Form::Paper, [buffer]) => {
                bindings.push(("smoothie_buffer", Resource::Sampled(buffer, nearest)));
                bindings.push(("falloff", Resource::Sampled(falloff, linear)));
            }
            (Form::Centred, [depth, penumbra]) => {
                bindings.push(("smoothie_depth", Resource::Sampled(depth, nearest)));
                bindings.push(("smoothie_penumbra", Resource::Sampled(penumbra, nearest)));
            }
            _ => anyhow::bail!("{} smoothie targets for {form:?}", smoothie.len()),
        }
        DescriptorSet::new(init.ctx, &bindings, form.smoothie_names().final_pass)
    }

    /// The final pass's fragment shader: the paper's (hand-tuned SPIR-V under `--spirv
    /// tuned`) or the centred form's.
    fn final_shader(init: &TechniqueInit<'_>, form: Form) -> FinalShader {
        match form {
            Form::Paper => init.settings.spirv.pick(
                FinalShader {
                    color: shaders::SMOOTHIES_FINAL_FRAG,
                    aov: shaders::SMOOTHIES_FINAL_FRAG_AOV,
                    count: shaders::SMOOTHIES_FINAL_FRAG_COUNT,
                },
                FinalShader {
                    color: shaders::SMOOTHIES_FINAL_FRAG_SPVASM,
                    aov: shaders::SMOOTHIES_FINAL_FRAG_SPVASM_AOV,
                    // The hand-tuned module has no counting build: glslang's counts the
                    // same lookups (it is the same source).
                    count: shaders::SMOOTHIES_FINAL_FRAG_COUNT,
                },
            ),
            Form::Centred => FinalShader {
                color: shaders::SMOOTHIES_CENTRED_FINAL_FRAG,
                aov: shaders::SMOOTHIES_CENTRED_FINAL_FRAG_AOV,
                count: shaders::SMOOTHIES_CENTRED_FINAL_FRAG_COUNT,
            },
        }
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

    /// CPU path: uploads every cached caster's triangles, the outer sides into one vertex
    /// buffer and the inner ones into another.
    fn upload_vertices(&mut self, ctx: &Context) -> Result<()> {
        for (side, buffer) in self.vertices.iter_mut().enumerate() {
            buffer.upload(ctx, &self.cpu_cache.concat_by(|c| &c.sides[side]))?;
        }
        Ok(())
    }

    /// CPU path: silhouettes and smoothie records of every caster that moved (or of all of
    /// them when the light changed) for this light, then the triangles of every caster
    /// rebuilt or whose extents changed; returns how many were rebuilt.
    fn build_geometry(&mut self, frame: &FrameInput<'_>, width: Width, force: bool) -> usize {
        let light = frame.light;
        let rebuilt = self.cpu_cache.update(
            &frame.scene.objects,
            &self.adjacency,
            GeometryKey::new(light, width),
            force,
            |adj, model| {
                let sil = silhouette::extract(adj, model, light.position);
                let records = build_records(adj, &sil, model, light, width);
                CasterSmoothies {
                    full_box: records.uv_bounds(Extent::FULL),
                    records,
                    sides: Default::default(),
                    expanded: None,
                    drawn_box: None,
                    drawn_support: None,
                }
            },
        );
        let res = self.smoothie.first().map_or(1, |i| i.extent.width);
        let pad = 1.0 / res as f32;
        let areas = frame.settings.light_areas;
        let outer = match self.form {
            Form::Paper if areas => self.outer_extent(frame, pad),
            _ => Extent::FULL,
        };
        let inner = if areas {
            Extent::at_most(inner_extent_depth(light), pad)
        } else {
            Extent::FULL
        };
        let extents = [outer, inner];
        let form = self.form;
        self.cpu_cache.par_values_mut().for_each(|c| {
            if c.expanded == Some(extents) {
                return;
            }
            let [outer, inner_side] = &mut c.sides;
            outer.clear();
            inner_side.clear();
            c.records.expand_side(Side::Outer, extents[0], outer);
            if form == Form::Centred {
                c.records.expand_side(Side::Inner, extents[1], inner_side);
            }
            c.expanded = Some(extents);
            c.drawn_box = c.records.uv_bounds(extents[0]);
            c.drawn_support = c.records.uv_support(&regions::directions(), extents[0]);
        });
        rebuilt
    }

    /// The paper form's outer smoothies, shortened to where Eq. 1 saturates for the
    /// deepest receiver they can find (`records::Extent`): the deepest surface under the
    /// full-width smoothies' box (`regions::deepest_surface`), 0.1 % more for the rounding
    /// of the stored depths, rounded up to its grid (`Extent::at_most`) so that a moving
    /// object leaves the other casters' triangles alone while the bound holds. Where that
    /// depth is not known, the full width.
    fn outer_extent(&self, frame: &FrameInput<'_>, pad: f32) -> Extent {
        // Each caster's full-width box inside the map (a caster outside the light's view
        // adds nothing, culled or not).
        let full = self
            .cpu_cache
            .iter()
            .filter_map(|c| c.full_box)
            .map(|(lo, hi)| (lo.max(Vec2::ZERO), hi.min(Vec2::ONE)))
            .filter(|(lo, hi)| lo.cmple(*hi).all())
            .reduce(|(a, b), (c, d)| (a.min(c), b.max(d)));
        let Some(deepest) = full.and_then(|(lo, hi)| {
            // The texel a fragment's centre lies in, beyond the box by rounding.
            regions::deepest_surface(frame, lo - pad, hi + pad)
        }) else {
            return Extent::FULL;
        };
        Extent::at_most(deepest * 1.001, pad)
    }

    /// Caster `i`'s smoothies this frame, when they are drawn from the cache (CPU path,
    /// t > 0: otherwise the cache may be another light's, and is not in the buffer).
    fn caster(&self, i: usize) -> Option<&CasterSmoothies> {
        self.cpu_cache.get(i).filter(|_| self.draw_smoothies)
    }

    /// The texels of r the casters can write outside their smoothies' (which the shadow
    /// map's area holds anyway): the projected box of each caster whose records do not
    /// hold it (`SmoothieRecords::holds_caster`).
    fn casters_texels(&self, corners: &[(usize, [Vec2; 8])], res: u32) -> PixelBox {
        let beyond: Vec<_> = corners
            .iter()
            .filter(|(i, _)| !self.caster(*i).is_some_and(|c| c.records.holds_caster()))
            .copied()
            .collect();
        regions::casters_box(&beyond, res)
    }

    /// Per caster, the light-uv polygon its texels in r and the smoothie buffer lie in: the
    /// support of its smoothies (`SmoothieRecords::uv_support`; every caster's are drawn),
    /// which holds the caster's own texels too when every silhouette edge was kept
    /// (`SmoothieRecords::holds_caster`: the convex hull of a projected mesh is its
    /// silhouette vertices'), and else of its world box's corners projected by the light
    /// (the r texels; casters in the light's frustum) as well. On `bunny` that takes the
    /// lookups from 48 % to 38 % of the area drawn (full-width smoothies): it fills little
    /// of its box.
    fn shadow_regions(&self, corners: &[(usize, [Vec2; 8])]) -> Vec<regions::Support> {
        corners
            .iter()
            .filter_map(|(i, uvs)| {
                let caster = self.caster(*i);
                let smoothies = caster.and_then(|c| c.drawn_support);
                if caster.is_some_and(|c| c.records.holds_caster()) {
                    return smoothies;
                }
                match (regions::support_of(uvs), smoothies) {
                    (Some(a), Some(b)) => Some(regions::union(a, b)),
                    (a, b) => a.or(b),
                }
            })
            .collect()
    }

    /// Where the two light-space passes clear and draw (`regions::silhouette_areas`): the
    /// smoothie pass where this frame's smoothies can reach, on the CPU path
    /// (`SmoothieRecords::uv_bounds`; the GPU path builds its geometry on the device and
    /// clears the whole buffer); the shadow map over the casters' texels of r beyond their
    /// smoothies' (`casters_texels`) and where the smoothie pass reads g: the smoothies'
    /// texels, for the centred form grown by `regions::INNER_RECEIVER_TEXELS` (its inner
    /// fragments read the hidden receiver just outside their edge). Also sets where the
    /// final pass's shader can give less than 1 (`shadow_regions`).
    fn light_areas(&mut self, frame: &FrameInput<'_>) -> (MapArea, Rect2D) {
        let res = self.smoothie.first().map_or(1, |i| i.extent.width);
        let corners = regions::caster_corner_uvs(frame);
        let smoothies = if !self.draw_smoothies {
            Some(PixelBox::EMPTY)
        } else if self.gpu_silhouettes.is_some() {
            None
        } else {
            Some(
                self.cpu_cache
                    .iter()
                    .filter_map(|c| c.drawn_box)
                    .fold(PixelBox::EMPTY, |b, (lo, hi)| {
                        b.union(PixelBox::of_uv(res, lo, hi))
                    }),
            )
        };
        self.shadowed = match (smoothies, &corners) {
            (Some(_), Some(c)) => {
                let supports = self.shadow_regions(c);
                regions::shadowed(frame, &supports, self.shadow.resolution, 0.0)
            }
            _ => Shadowed::Everywhere,
        };
        let casters = corners.as_ref().map(|c| self.casters_texels(c, res));
        let grow = match self.form {
            Form::Paper => 0,
            Form::Centred => regions::INNER_RECEIVER_TEXELS,
        };
        regions::silhouette_areas(
            frame,
            res,
            smoothies,
            casters,
            grow,
            [&mut self.smoothie_drawn, &mut self.map_drawn],
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
        // The GPU silhouette passes' fixed width, or -1 for the calibrated one.
        c[k::SMOOTHIE_FIXED_T] = frame.settings.smoothie_t.unwrap_or(-1.0);
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
        if !self.draw_smoothies {
            rec.skip(names.silhouettes, "light radius 0: hard shadows");
        } else if let Some(gpu) = self.gpu_silhouettes.as_mut() {
            let emit = Emit::Smoothies(frame.light, width);
            let objects = &frame.scene.objects;
            gpu.frame_pass(ctx, rec, names.silhouettes, casters, force, objects, emit)?;
        } else if self.path == SilhouettePath::Cpu {
            let rebuilt = rec.cpu(names.silhouettes, || {
                self.build_geometry(frame, width, force)
            });
            rec.rebuilt(names.silhouettes, rebuilt, casters);
            self.upload_vertices(ctx)?;
        }

        let (map_area, area) = self.light_areas(frame);
        self.shadow.pass_in(rec, frame.gpu, &map_area)?;
        rec.pass(names.smoothie, |rec| {
            let targets: Vec<_> = self
                .smoothie
                .iter()
                .zip(smoothie_targets(self.form))
                .map(|(image, target)| (image, Clear::Float(target.clear)))
                .collect();
            rec.begin_rendering_in(&targets, None, Some(area));
            if self.draw_smoothies {
                let pipelines = [Some(&self.smoothie_pipeline), self.inner_pipeline.as_ref()];
                match (&self.gpu_silhouettes, self.path) {
                    (Some(gpu), _) => {
                        rec.bind_pipeline(&self.smoothie_pipeline);
                        rec.bind_sets(&self.smoothie_pipeline, &[&self.smoothie_set]);
                        gpu.draw(rec);
                    }
                    (None, SilhouettePath::Cpu) => {
                        for (pipeline, vertices) in pipelines.into_iter().zip(&self.vertices) {
                            if let Some(pipeline) = pipeline.filter(|_| !vertices.is_empty()) {
                                rec.bind_pipeline(pipeline);
                                rec.bind_sets(pipeline, &[&self.smoothie_set]);
                                vertices.draw(rec);
                            }
                        }
                    }
                    // No caster edge: nothing to draw.
                    _ => {}
                }
            }
            rec.end_rendering();
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
        [shadow_map_buffer("shadow_map", &self.shadow)]
            .into_iter()
            .chain(
                self.smoothie
                    .iter()
                    .zip(smoothie_targets(self.form))
                    .map(|(image, target)| LightBuffer {
                        name: target.name,
                        image,
                        channels: target.channels,
                    }),
            )
            .collect()
    }

    fn gpu_silhouettes(&self) -> Option<&GpuSilhouettes> {
        self.gpu_silhouettes.as_ref()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::silhouette::smoothie::MAX_CALIBRATED_T;

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
