//! # ssm-bitmask — soft shadow maps with exact occlusion
//! Port sheet: docs/port/ssm-bitmask.md
//! Speed layer: speed::ssm (the micro-patch step, pass 4, kept under --plain; the receiver
//! tiles and the quad list, pass 6, off under --plain), speed::regions (the split final
//! pass, off under --plain).
//! Over 400 lines because the header (about 150 lines) carries both lights' projections
//! onto the light samples and the occluder blocks' rules, which a porter reads here and not
//! in the shaders alone.
//!
//! Atty et al. 2006 (`ssm`, src/technique/ssm.rs, whose header this one builds on) back-
//! project one micro-patch per occluder-map texel onto the light and ADD the hidden areas:
//! where two back-projections overlap the light is counted twice (too dark), where
//! neighbouring patches at different depths leave a gap between their back-projections
//! light leaks through (their Sec. 5.1.2, Eq. 1-3). This form takes the *union* of what the
//! micro-patches hide instead of the sum — bitmask soft shadows (Schwarz & Stamminger,
//! *Bitmask Soft Shadows*, CGF 26(3) 2007): per soft-shadow-map texel one bit per light
//! sample, set when some micro-patch hides that sample, OR-combined; micro-quads that join
//! neighbouring texels close the gaps. Same occluder, receiver and bound passes as `ssm`
//! (shared code: `ssm_common::LightInputs`, its passes 1-4 but the back occluder map of the
//! two-sided `ssm2`).
//!
//! ## Light samples and the edge table (src/technique/ssm_bitmask_table.rs)
//! 128 samples on the disc light, one bit each in a `uvec4` (R32G32B32A32_UINT): visibility
//! = 1 - popcount(mask) / 128. A storage buffer built once on the CPU (`edge_table`) holds,
//! per quantised directed line, the mask of the samples left of it; a triangle's samples
//! are the AND of its three edges' masks.
//!
//! ## The light
//! The disc of docs/DESIGN.md, radius R, **facing the receiver point** (`ssm` uses a square
//! parallel to the map). Each micro-quad corner is projected from the receiver onto the
//! disc's plane; lines stay lines, so each of the quad's two triangles is a triangle on the
//! disc and its samples are the AND of three half-planes.
//!
//! ## Under a sun
//! A sun (every direction within theta of its axis, orthographic map of world texel E / N;
//! ssm.rs, "Under a sun") is a disc of directions: from the receiver p (light frame = the
//! map's world xy and linear depth z), a quad corner q lies in the direction of tangent
//! (q - p).xy / (z_R - z_q) off the axis, and the disc is tan(theta) wide in tangent units.
//! In disc units a corner is (q - p).xy / ((z_R - z_q) tan theta): a projection from p onto
//! the plane one unit towards the light, which keeps lines lines, so the two triangles, the
//! edge table and the 128 samples (now directions, uniform over the disc of tangents, the
//! solid angle's to O(theta^2)) are unchanged. The extent grows by h = EXTENT_MARGIN
//! tan(theta) (z_max - z_near) / (E / N) texels (no stretch: the disc of directions is as
//! wide from every receiver), the penumbra linear in the blocker-to-receiver distance
//! (w = 2 (d_r - d_b) tan theta); pass 4 takes the same h. Under the orthographic map a
//! plane's depth is affine across texels, so a corner takes the arithmetic (not harmonic)
//! mean; the connect test, the guard and the final lookup's offset take the world texel,
//! the final depth the orthographic clip z (`clip_linear_depth`). theta = 0 renders `hard`
//! as R = 0 does. `frame.technique2` holds (tan theta, EXTENT_MARGIN tan theta, ...).
//!
//! ## R = 0
//! A point light has no penumbra to sample (the masks would hold a hard shadow at the
//! occluder map's resolution), so at R = 0 (the radius in effect at creation) this form
//! *is* `hard` (src/technique/hard.rs, under this technique's name:
//! `ssm-bitmask/shadow_map`, `ssm-bitmask/final`), as every accurate form is at R = 0
//! (tests/ssm_bitmask.rs).
//!
//! ## Micro-quads (the gap closing), and the dilation constant
//! The micro-quad of texel (i, j) spans the texel's square of the map, as the paper's
//! micro-patch, but each corner has its own depth: the harmonic mean of the up to four
//! texels around the corner that are one surface with (i, j), i.e. whose depths differ by
//! at most `CONNECT_TEXELS` = 4 texels of depth slope (surfaces up to ~76 degrees from the
//! map's image plane). Neighbouring quads of one surface share corners, so their
//! back-projections meet exactly; at a silhouette or a larger depth step the corner keeps
//! the texel's depth, so the quad ends at the texel's edge (the occluder is not eroded by
//! half a texel). The dilation constant is 0: the shared corners and the table's
//! complementary halves close the gaps.
//!
//! ## Occluder blocks (a hierarchical occluder map)
//! Each micro-quad's penumbra extent grows by the same h texels whatever its size, so the
//! pass shades about (1 + 2h)^2 fragments a texel, where a block of s x s texels drawn as
//! one quad shades (s + 2h)^2 for all of them. Where the micro-quads of a block form one
//! flat quad, that quad is their union and hides the same samples: `occluder_blocks.comp`
//! finds, per aligned block of 2, 4, 8 or 16 texels (within the 16x16 tiles), whether every
//! texel of it is drawn, every corner of its micro-quads (each as its micro-quad takes it,
//! from the texels one surface with its own) lies within `SSMB_MERGE_FLATNESS` (1)
//! self-occlusion guard of depth of the block quad's two triangles (a receiver that close
//! behind it is its own surface anyway), whose corners are the corner micro-quads' outer
//! ones, and those span at most `SSMB_MERGE_GUARDS` (4) self-occlusion guards of depth
//! (the block quad takes its farthest corner's guard, so a receiver between its nearest
//! and farthest corners loses what the nearer texels alone would hide: a band of
//! receivers a few guards deep behind the block). The largest such
//! block holding a texel is drawn as one quad by its first texel; the others draw none. A
//! block may end at a silhouette, where its micro-quads end too; depth steps and curved
//! patches keep one micro-quad a texel. The image moves by at most 3e-4 of mae_lit on the
//! built-in scenes, the micro-quad fragments fall by 41-92 %: BENCHMARKS.md.
//!
//! ## Passes, in order
//! 1-3. As ssm's (src/technique/ssm_common.rs; one-sided, so no pass 2):
//!    `ssm-bitmask/maps` (one draw of every object into the occluder map, nearest caster
//!    depth, and the receiver map, two R32_SFLOAT layers: nearest receiver, nearest pure
//!    receiver) and `ssm-bitmask/receiver_bound` (z_max).
//! 4. `ssm-bitmask/micro_patch_step` — as ssm's (speed::ssm) with this form's extents:
//!    the side s of the texel blocks drawn as one micro-quad, 1 unless the quads would
//!    shade more than N^4 / 64 fragments (then a `warning:` line names the bound); and the
//!    receiver tiles, per 16x16 texels the deepest receiver a pass-7 fragment there stands
//!    at.
//! 5. `ssm-bitmask/occluder_blocks` — compute `glsl/ssm_bitmask/occluder_blocks.comp`, a
//!    16x16 workgroup per tile of the occluder map (its depths and a ring of one texel,
//!    then each texel's micro-quad corners, in shared memory; three barriers; the speed
//!    layer runs only the tiles that hold a drawn texel, `PatchStep::drawn`): the occluder
//!    blocks above. Writes two storage buffers, per texel the side of the quad it begins
//!    (u32: s, 0 inside another's block, 1 its own micro-quad) and at a block's first texel
//!    the block quad's corner depths (vec4).
//! 6. `ssm-bitmask/micro_quads` (speed layer, `speed::ssm::QuadList`; not run under
//!    `--plain`) — compute `glsl/ssm_bitmask/micro_quads.comp`, one invocation per instance
//!    of pass 7 on the tiles that hold a drawn texel (an indirect dispatch over
//!    `PatchStep::drawn`): the instance's quad (`micro_quad`,
//!    `glsl/ssm_bitmask/micro_quad.glsl`, the function the plain vertex shader runs) once,
//!    appended to a list with an atomic counter that is the instance count of pass 7's
//!    indirect draw, when it reaches a receiver. The quads stop at the deepest receiver
//!    under their extents: the receiver tiles of pass 4 (`glsl/ssm/tiles.glsl`), which hold
//!    the frame's z_max under `--plain`.
//! 7. `ssm-bitmask/soft_shadow` — two instanced draws of N^2 instances, no vertex buffer:
//!    the quads as **point sprites** (1 vertex, point list: a square quad no wider than
//!    the device's largest point, `largePoints`), then the others as triangle strips (4
//!    vertices); each draw's vertex shader puts the other's quads outside clip space
//!    (`glsl/ssm_bitmask/quad_vertex.glsl`, push constants: the largest point, which draw).
//!    A point is one square primitive where a strip's two triangles each shade the pixel
//!    blocks along their diagonal: 21-32 % fewer fragments on lavapipe, the same image
//!    (tests/ssm_bitmask.rs). The speed layer draws the listed quads instead, two indirect
//!    draws (`glsl/ssm_bitmask/soft_shadow_list.vert`; the same quads, the same image). Two
//!    colour attachments R32G32B32A32_UINT (layer 0, layer 1), clear 0, **logic op OR**
//!    (the `logicOp` device feature; blending off). `glsl/ssm_bitmask/soft_shadow.vert`
//!    (`micro_quad`) reads the texel's side from pass 5 (none drawn at 0; at s > 1 the
//!    block quad, its corner depths from pass 5, its guard depth the farthest corner's),
//!    else the occluder map's 3x3 neighbourhood, and writes the quad's first texel, its
//!    four corner depths and its reach (flat), drawing the penumbra extent grown by h = R'
//!    N / (2 tan(fov/2)) (1/z_near - 1/z_max) texels. R' = `EXTENT_MARGIN` R / cos(alpha):
//!    a disc facing the receiver is R wide across the line to the light's centre and R /
//!    cos(alpha) in the map's plane, alpha that line's angle to the light's axis, bounded
//!    over the receivers the quad can reach (at most sqrt(1 + 2 tan^2(fov/2)) at the
//!    frustum's corner). `glsl/ssm_bitmask/soft_shadow.frag` reads both receiver layers at
//!    its texel, the bound and the edge table; per layer it skips quads within the self-
//!    occlusion guard (as ssm: 1.5 texels of slope) and receivers beyond the reach at their
//!    own depth, projects the four corners onto the disc facing the receiver and writes the
//!    mask of the samples inside the two triangles. With a micro-patch step s > 1 (pass 4;
//!    the occluder blocks are then not read) instance k draws block k of
//!    s x s texels: the bounding rectangle of its occupied texels, each corner at the depth
//!    of the occupied texel nearest it, its guard depth the block's farthest.
//! 8. `ssm-bitmask/resolve` — one triangle over the map (`glsl/common/fullscreen.vert`,
//!    `glsl/ssm_bitmask/resolve.frag`): per texel and layer the count c of samples its mask
//!    hides, turned into the **edge offset** d in [-1, 1]: the signed distance (disc radii)
//!    of the straight edge whose segment hides c / 128 of the disc (a 129-entry storage
//!    buffer, `edge_offsets` in ssm_bitmask_table.rs), quantised to 12 bits; 4096 front +
//!    pure (an integer below 2^24, exact in a float) into `edge offsets` = R32_SFLOAT,
//!    clear 0 (every texel is then written), no blend. The final pass gathers this one
//!    channel where it would fetch two 128-bit masks per texel of its footprint.
//! 9. `ssm-bitmask/final` — `FinalPass` with `glsl/ssm_bitmask/final.frag`: as
//!    ssm's (2x2 footprint of the receiver map and the edge offsets, layer 0 for the
//!    texel's own receiver, layer 1 behind it, bilinear weights) but read at the point
//!    itself, **not at a normal-offset point**: a mask holds the visibility at its texel's
//!    centre (ssm's offset shifts every penumbra: most of its error on `fence`). Only the
//!    depth that picks the layer is the offset point's. The weights interpolate the edge
//!    offset d, and occlusion = disc_chord(d) (glsl/common/penumbra.glsl), visibility = 1 -
//!    it: behind a straight edge d is linear across a receiver where the hidden share bends
//!    at both ends of the penumbra, so interpolated shares would start a penumbra up to a
//!    texel early and end it a texel late (a higher mae_lit on every built-in scene, and
//!    more false edges). The speed layer runs it only within a micro-
//!    quad's reach of a caster's texels (`FinalPass::split`, `regions::AroundCasters`,
//!    `quad_reach_texels`): elsewhere every mask is clear and the visibility exactly 1.
//!
//! ## Frame constants
//! `frame.technique` as ssm's but its first slot holds 1 / `SAMPLES`; `frame.technique2` =
//! (R, R' = `EXTENT_MARGIN` R sqrt(1 + 2 tan^2(fov/2)), connect texels, unused):
//! glsl/ssm_bitmask/constants.glsl, the shaders' only source of `SAMPLES` and
//! `EXTENT_MARGIN`. The edge table's rows and columns are shader constants there
//! (`SSMB_LUT_ROWS`, `SSMB_LUT_COLUMNS`), which ssm_bitmask_table.rs builds it with.
//!
//! ## Cost
//! As ssm's: up to N^2 quads times their extents in `soft_shadow` (fewer where the occluder
//! blocks draw one quad for many texels), each fragment up to ten table reads (five edges
//! per receiver layer, one when both layers are the same surface). Accuracy is limited by
//! the occluder map's resolution (`--occluder-res`, shared with ssm): at 512 mae_lit falls
//! by 30-60 % on cylinder, bunny, primitives and fence (tests/ssm_bitmask.rs), but the
//! micro-quad pass grows as N^4, which pass 4 bounds. Measured figures: BENCHMARKS.md.
//!
//! ## Known artefacts
//! - Only what the light's centre sees of the occluders is discretised (ssm's Sec. 5.1.1):
//!   behind a depth discontinuity (an ear in front of the body) nothing is known, so light
//!   seen from the disc's edge through that unknown region passes. A two-sided form
//!   (`ssm2-bitmask`, the back faces' micro-quads ORed into the same masks) filled part of
//!   it and was removed for its cost (README).
//!   Where one caster rests on another (a box on a box), a thin line of light crosses the
//!   umbra behind the upper one's outline, through the lower one's top that the map lacks.
//!   Bridging every step between two casters closes it but fills real gaps alike (a
//!   torus's hole before a wall) and breaks occluder blocks at every outline.
//! - A depth step smaller than `CONNECT_TEXELS` is bridged by a "skirt" between the two
//!   surfaces: a little too much occlusion behind small steps.
//! - A mask is exact at its texel's centre. The occluder map's texels step a blocker's
//!   outline (a thin rail's shadow beads), and between texel centres the edge offset is
//!   exact only behind one straight edge: each penumbra starts and ends up to a texel of
//!   the occluder map early and late. On the built-in scenes this is most of the error
//!   against the reference, less at a finer `--occluder-res` ("Cost" above).
//! - 128 samples: visibility in steps of 1/128, the same pattern everywhere (no noise,
//!   faint 1/128 contours in wide penumbrae).
//! - Occluder-map aliasing at small R, the receiver layers and the guard: as ssm.
//! - The disc faces each receiver texel's centre, not the camera pixel's point.
//! - At small R > 0, on a caster's own surface near its terminator (n.l < 0.2), the point
//!   looked up without an offset can read the texel of the caster's nearer part and go dark
//!   where `hard`'s offset point is lit (docs/DESIGN.md's mae_lit leaves these pixels out).

use super::hard::{self, Names as HardNames};
use super::regions;
use super::speed::ssm::{PatchStepReport, QuadBuffers, QuadList};
pub use super::ssm_bitmask_table::{edge_offsets, edge_table, light_samples, SAMPLES};
use super::ssm_common::{ssm_uniforms, LightInputs, BOUND_GROUP, MAP_USAGE, SELF_GUARD_TEXELS};
use super::{FrameInput, LightBuffer, Packing, Technique, TechniqueInfo, TechniqueInit};
use crate::gpu::passes::{FinalPass, FinalShader, Shadowed};
use crate::shaders::{self, constants as k};
use crate::vk::{
    Blend, Buffer, BufferUsageFlags, Clear, Context, CullModeFlags, DescriptorSet, Filter, Format,
    GraphicsPipelineDesc, Image, MemoryLocation, Pipeline, PrimitiveTopology, Recorder, Resource,
    Sampler,
};
use anyhow::{bail, Context as _, Result};

pub const INFO: TechniqueInfo = TechniqueInfo {
    name: "ssm-bitmask",
    summary: "soft shadow map with exact occlusion: micro-quads OR a 128-sample light bitmask (Schwarz & Stamminger 2007)",
    create: create_either,
};

/// Neighbouring occluder texels whose depths differ by at most this many texels of depth
/// slope are one surface, and their micro-quads share corners.
const CONNECT_TEXELS: f32 = 4.0;

/// Margin on the disc's reach on the map's image plane (the extents must cover it); the
/// shaders read it only through `SSMB_EXTENT_RADIUS`.
const EXTENT_MARGIN: f32 = 1.05;

/// The disc's reach on the map's image plane at the frustum's corner
/// (`SSMB_EXTENT_RADIUS`): R / cos(alpha) there, with a margin. A sun's disc of directions
/// is tan(theta) wide from every receiver: its reach is tan(theta) with the margin, no
/// stretch.
fn extent_radius(frame: &FrameInput<'_>) -> f32 {
    if let Some(sun) = frame.light.sun {
        return EXTENT_MARGIN * sun.tan_angle;
    }
    let t = (frame.light.fov_deg.to_radians() * 0.5).tan();
    EXTENT_MARGIN * frame.light_radius * (1.0 + 2.0 * t * t).sqrt()
}

/// The light's spread: R, or a sun's tan(theta) (`SSMB_RADIUS`); 0 renders `hard`.
fn spread(frame: &FrameInput<'_>) -> f32 {
    match frame.light.sun {
        Some(sun) => sun.tan_angle,
        None => frame.light_radius,
    }
}

/// How far beyond its casters' texels a micro-quad can hide a sample, in occluder texels,
/// for the split final pass (speed layer): `reach` (texels per unit of 1/z_near - 1/z_max,
/// as `record_light` passes it) over the nearest caster's box corner (at least the light's
/// near plane) and the far plane, plus the fragment test's texel of slack. `None` under a
/// sun (`regions::shadowed` runs the shader everywhere there) or without a caster in the
/// light.
fn quad_reach_texels(frame: &FrameInput<'_>, reach: f32) -> Option<f32> {
    if frame.light.sun.is_some() {
        return None;
    }
    let nearest = frame
        .gpu
        .objects
        .iter()
        .filter(|o| o.in_light && o.role.casts())
        .flat_map(|o| o.world_corners())
        .map(|c| frame.light.linear_depth(c))
        .fold(f32::INFINITY, f32::min);
    let near = nearest.max(frame.light.near);
    near.is_finite()
        .then(|| reach * (1.0 / near - 1.0 / frame.light.far).max(0.0) + 1.0)
}

/// The mask format: 128 bits.
const MASK_FORMAT: Format = Format::R32G32B32A32_UINT;

/// At R = 0 `hard` under this technique's name (module header, "R = 0"), else the soft
/// shadow map.
fn create_either(init: &TechniqueInit<'_>) -> Result<Box<dyn Technique>> {
    let spread = match init.scene.light.sun_angle_deg() {
        Some(angle) => angle,
        None => init.settings.radius_for(init.scene),
    };
    if spread == 0.0 {
        let names = super::pass_names!(
            HardNames {
                shadow_map: "shadow_map",
                final_pass: "final"
            },
            "ssm-bitmask"
        );
        return Ok(Box::new(hard::Hard::create(init, names)?));
    }
    Ok(Box::new(SsmBitmask::create(init)?))
}

/// The buffers of `OccluderBlocks`, made before the micro-quad set that binds them.
struct BlockBuffers {
    /// Per occluder texel (u32) the side of the quad it begins.
    side: Buffer,
    /// Per occluder texel (vec4) the corner depths of the block quad it begins.
    corners: Buffer,
}

impl BlockBuffers {
    fn new(ctx: &Context, res: u32, name: &str) -> Result<Self> {
        let texels = u64::from(res) * u64::from(res);
        let buffer = |bytes: u64, what: &str| {
            Buffer::new(
                ctx,
                bytes * texels,
                BufferUsageFlags::STORAGE_BUFFER,
                MemoryLocation::GpuOnly,
                &format!("{name} {what}"),
            )
        };
        Ok(Self {
            side: buffer(4, "sides")?,
            corners: buffer(16, "corners")?,
        })
    }

    /// The bindings the micro-quad set takes last: `blocks`, `block_corners`.
    fn bindings(&self) -> [(&'static str, Resource<'_>); 2] {
        [
            ("blocks", Resource::Storage(&self.side)),
            ("block_corners", Resource::Storage(&self.corners)),
        ]
    }
}

/// Pass 5, `ssm-bitmask/occluder_blocks` (module header, "Occluder blocks"):
/// `glsl/ssm_bitmask/occluder_blocks.comp` over the micro-quad set.
struct OccluderBlocks {
    _buffers: BlockBuffers,
    pipeline: Pipeline,
    name: String,
    res: u32,
}

impl OccluderBlocks {
    fn new(ctx: &Context, buffers: BlockBuffers, set: &DescriptorSet, res: u32) -> Result<Self> {
        let name = format!("{}/occluder_blocks", INFO.name);
        let spirv = shaders::SSM_BITMASK_OCCLUDER_BLOCKS_COMP;
        let pipeline = Pipeline::compute(ctx, &name, spirv, &[set], 4)?;
        Ok(Self {
            _buffers: buffers,
            pipeline,
            name,
            res,
        })
    }

    /// One workgroup per `BOUND_GROUP`² texels of the occluder map; with `drawn` (the speed
    /// layer, `PatchStep::drawn`) only per tile that holds a drawn texel, whose sides alone
    /// a micro-quad reads.
    fn record(
        &self,
        rec: &mut Recorder<'_>,
        set: &DescriptorSet,
        drawn: Option<&Buffer>,
    ) -> Result<()> {
        rec.pass(&self.name, |rec| {
            rec.bind_pipeline(&self.pipeline);
            rec.bind_sets(&self.pipeline, &[set]);
            rec.push_constants(&self.pipeline, &u32::from(drawn.is_some()).to_ne_bytes());
            let groups = self.res.div_ceil(BOUND_GROUP);
            match drawn {
                Some(args) => rec.dispatch_indirect(args, 0, [groups * groups, 1, 1]),
                None => rec.dispatch(groups, groups, 1),
            }
            Ok(())
        })
    }
}

/// Pass 8, `ssm-bitmask/resolve`: per soft-shadow-map texel each layer's edge offset (the
/// straight edge that hides as many samples as its mask), 4096 * front + pure quantised in
/// one R32F texel, which the final pass gathers.
struct Resolve {
    offsets: Image,
    _table: Buffer,
    set: DescriptorSet,
    pipeline: Pipeline,
    name: String,
}

impl Resolve {
    fn new(ctx: &Context, masks: &[Image; 2], nearest: &Sampler, res: u32) -> Result<Self> {
        let name = format!("{}/resolve", INFO.name);
        let offsets = Image::new_2d(
            ctx,
            res,
            res,
            Format::R32_SFLOAT,
            MAP_USAGE,
            &format!("{} edge offsets", INFO.name),
        )?;
        let table = Buffer::with_data(
            ctx,
            bytemuck::cast_slice(&edge_offsets()),
            BufferUsageFlags::STORAGE_BUFFER,
            &format!("{} edge-offset table", INFO.name),
        )?;
        let set = DescriptorSet::new(
            ctx,
            &[
                ("mask_front", Resource::Sampled(&masks[0], nearest)),
                ("mask_pure", Resource::Sampled(&masks[1], nearest)),
                ("offsets", Resource::Storage(&table)),
            ],
            &name,
        )?;
        let pipeline = Pipeline::graphics(
            ctx,
            &GraphicsPipelineDesc {
                name: &name,
                vertex: shaders::COMMON_FULLSCREEN_VERT,
                fragment: Some(shaders::SSM_BITMASK_RESOLVE_FRAG),
                vertex_stride: 0,
                attributes: &[],
                topology: PrimitiveTopology::TRIANGLE_LIST,
                cull: CullModeFlags::NONE,
                // Every texel is written once: one triangle over the map.
                colors: &[(Format::R32_SFLOAT, Blend::None)],
                depth: None,
                push_constant_bytes: 0,
                sets: &[&set],
            },
        )?;
        Ok(Self {
            offsets,
            _table: table,
            set,
            pipeline,
            name,
        })
    }

    fn record(&self, rec: &mut Recorder<'_>) -> Result<()> {
        rec.pass(&self.name, |rec| {
            rec.begin_rendering(&[(&self.offsets, Clear::Float([0.0; 4]))], None);
            rec.bind_pipeline(&self.pipeline);
            rec.bind_sets(&self.pipeline, &[&self.set]);
            rec.draw(3, 1);
            rec.end_rendering();
            Ok(())
        })
    }
}

/// One occluder map's micro-quads into the two mask layers.
struct QuadPass {
    set: DescriptorSet,
    name: String,
}

/// The micro-quad pass's two pipelines for one vertex shader: the quads drawn as point
/// sprites, then the others as triangle strips (`glsl/ssm_bitmask/quad_vertex.glsl`).
struct QuadPipelines {
    points: Pipeline,
    strips: Pipeline,
    /// The widest point the device draws, in texels (0 without `largePoints`).
    max_point: f32,
}

/// The micro-quad vertex shaders' push constants (`QuadDraw`).
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct QuadDraw {
    max_point: f32,
    points: u32,
}

impl QuadPipelines {
    fn new(ctx: &Context, pass: &QuadPass, vertex: &[u8]) -> Result<Self> {
        let pipeline = |topology, what: &str| {
            Pipeline::graphics(
                ctx,
                &GraphicsPipelineDesc {
                    name: &format!("{} ({what})", pass.name),
                    vertex,
                    fragment: Some(shaders::SSM_BITMASK_SOFT_SHADOW_FRAG),
                    vertex_stride: 0,
                    attributes: &[],
                    topology,
                    cull: CullModeFlags::NONE,
                    // OR: the union of the samples the micro-quads hide.
                    colors: &[(MASK_FORMAT, Blend::Or), (MASK_FORMAT, Blend::Or)],
                    depth: None,
                    push_constant_bytes: std::mem::size_of::<QuadDraw>() as u32,
                    sets: &[&pass.set],
                },
            )
            .context("ssm-bitmask micro-quad pipeline")
        };
        Ok(Self {
            points: pipeline(PrimitiveTopology::POINT_LIST, "points")?,
            strips: pipeline(PrimitiveTopology::TRIANGLE_STRIP, "strips")?,
            max_point: if ctx.large_points {
                ctx.limits.point_size_range[1]
            } else {
                0.0
            },
        })
    }

    fn push(&self, points: bool) -> QuadDraw {
        QuadDraw {
            max_point: self.max_point,
            points: u32::from(points),
        }
    }
}

pub struct SsmBitmask {
    name: &'static str,
    res: u32,
    inputs: LightInputs,
    /// Layer 0 (nearest receiver) and layer 1 (pure receiver): the hidden light samples.
    masks: [Image; 2],
    _table: Buffer,
    blocks: OccluderBlocks,
    front: QuadPass,
    /// The paper's draw: N^2 instances, each vertex deriving its quad.
    plain_pipelines: QuadPipelines,
    /// The speed layer's: the quads `list` computed, indirect draws.
    list: QuadList,
    list_pipelines: QuadPipelines,
    final_pass: FinalPass,
    /// Where the masks can hold a hidden sample (the speed layer's split final pass).
    shadowed: Shadowed,
    /// The casters' outlines `shadowed` is built from.
    around: regions::AroundCasters,
    resolve: Resolve,
    final_set: DescriptorSet,
    _nearest: Sampler,
}

impl SsmBitmask {
    fn create(init: &TechniqueInit<'_>) -> Result<Self> {
        let ctx = init.ctx;
        let res = init.settings.occluder_res;
        let name = INFO.name;
        if !ctx.logic_op {
            bail!(
                "{name} needs the logicOp device feature (OR-combining the light-sample masks), which {} does not offer",
                ctx.device_name
            );
        }
        let nearest = Sampler::new(ctx, Filter::Nearest).context("ssm-bitmask sampler")?;

        // Passes 1-4, as ssm's; one-sided: the back occluder map of the two-sided ssm2 is
        // not drawn. The micro-quads read the receiver tiles.
        let inputs = LightInputs::new(init, name, false, true, &nearest)?;
        let LightInputs {
            occluder,
            receivers,
            ..
        } = &inputs;

        // Pass 7: the micro-quads of the occluder map into one pair of masks.
        let mask = |what: &str| {
            Image::new_2d(
                ctx,
                res,
                res,
                MASK_FORMAT,
                MAP_USAGE,
                &format!("{name} light-sample mask ({what})"),
            )
            .context("ssm-bitmask masks")
        };
        let masks = [mask("front")?, mask("pure")?];
        let table = Buffer::with_data(
            ctx,
            bytemuck::cast_slice(edge_table()),
            BufferUsageFlags::STORAGE_BUFFER,
            &format!("{name} edge table"),
        )
        .context("ssm-bitmask edge table")?;
        let list_name = format!("{name}/micro_quads");
        let list_buffers =
            QuadBuffers::new(ctx, res, &list_name).context("ssm-bitmask quad list")?;
        let block_buffers = BlockBuffers::new(ctx, res, &format!("{name}/occluder_blocks"))
            .context("ssm-bitmask occluder blocks")?;
        let quads = |map: &Image, pass: &str| -> Result<QuadPass> {
            let name = format!("{name}/{pass}");
            let mut extra = vec![("table", Resource::Storage(&table))];
            extra.extend(list_buffers.bindings());
            extra.extend(block_buffers.bindings());
            extra.push(("drawn_tiles", Resource::Storage(&inputs.step.drawn)));
            let set = inputs.patch_set(init, map, &nearest, extra, &name)?;
            Ok(QuadPass { set, name })
        };
        let front = quads(&occluder.depth, "soft_shadow").context("ssm-bitmask micro-quads")?;
        let blocks = OccluderBlocks::new(ctx, block_buffers, &front.set, res)
            .context("ssm-bitmask occluder blocks pipeline")?;
        // The plain draw's vertex shader derives each quad; the speed layer's list draw
        // reads the quads `list` computed. The same quads, the same fragment shader.
        let plain_pipelines =
            QuadPipelines::new(ctx, &front, shaders::SSM_BITMASK_SOFT_SHADOW_VERT)?;
        let list_pipelines =
            QuadPipelines::new(ctx, &front, shaders::SSM_BITMASK_SOFT_SHADOW_LIST_VERT)?;
        let list = QuadList::new(ctx, list_buffers, &front.set, res, &list_name)
            .context("ssm-bitmask quad list pipeline")?;

        // Passes 8 and 9.
        let resolve = Resolve::new(ctx, &masks, &nearest, res).context("ssm-bitmask resolve")?;
        let final_name = format!("{name}/final");
        let final_set = DescriptorSet::new(
            ctx,
            &[
                ("frame", Resource::Uniform(init.ubo)),
                (
                    "receiver_front",
                    Resource::Sampled(&receivers.layers[0], &nearest),
                ),
                (
                    "edge_offsets",
                    Resource::Sampled(&resolve.offsets, &nearest),
                ),
            ],
            &final_name,
        )?;
        // Split: the shader runs only within a micro-quad's reach of a caster
        // (speed/regions.rs): elsewhere every mask is clear and the visibility exactly 1.
        let final_pass = FinalPass::split(
            ctx,
            &final_name,
            FinalShader {
                color: shaders::SSM_BITMASK_FINAL_FRAG,
                aov: shaders::SSM_BITMASK_FINAL_FRAG_AOV,
                count: shaders::SSM_BITMASK_FINAL_FRAG_COUNT,
            },
            &final_set,
        )
        .context("ssm-bitmask final pass")?;
        Ok(Self {
            name,
            res,
            inputs,
            masks,
            _table: table,
            blocks,
            front,
            plain_pipelines,
            list,
            list_pipelines,
            final_pass,
            shadowed: Shadowed::Everywhere,
            around: regions::AroundCasters::default(),
            resolve,
            final_set,
            _nearest: nearest,
        })
    }

    /// Draws the occluder map's micro-quads into the cleared masks: those `list` listed
    /// (`listed`), else one instance per texel.
    fn record_quads(&self, rec: &mut Recorder<'_>, quads: &QuadPass, listed: bool) {
        let clear = Clear::Uint([0; 4]);
        rec.begin_rendering(&[(&self.masks[0], clear), (&self.masks[1], clear)], None);
        let pipelines = if listed {
            &self.list_pipelines
        } else {
            &self.plain_pipelines
        };
        // The quads as points, then the rest as strips (glsl/ssm_bitmask/quad_vertex.glsl).
        for (k, (pipeline, vertices)) in [(&pipelines.points, 1), (&pipelines.strips, 4)]
            .into_iter()
            .enumerate()
        {
            rec.bind_pipeline(pipeline);
            rec.bind_sets(pipeline, &[&quads.set]);
            rec.push_constants(pipeline, bytemuck::bytes_of(&pipelines.push(k == 0)));
            match listed {
                true => rec.draw_indirect(
                    &self.list.buffers.command,
                    k as u64 * QuadBuffers::COMMAND_BYTES,
                ),
                false => rec.draw(vertices, self.res * self.res),
            }
        }
        rec.end_rendering();
    }
}

impl Technique for SsmBitmask {
    fn name(&self) -> &'static str {
        self.name
    }

    fn uniforms(&self, frame: &FrameInput<'_>) -> [[f32; 4]; 2] {
        let [mut first, _] = ssm_uniforms(self.res, frame);
        debug_assert_eq!(first[k::SSM_SELF_GUARD_TEXELS], SELF_GUARD_TEXELS);
        first[k::SSMB_INV_SAMPLES] = 1.0 / SAMPLES as f32;
        let mut second = [0.0; 4];
        second[k::SSMB_RADIUS - 4] = spread(frame);
        second[k::SSMB_EXTENT_RADIUS - 4] = extent_radius(frame);
        second[k::SSMB_CONNECT_TEXELS - 4] = CONNECT_TEXELS;
        [first, second]
    }

    fn record_light(
        &mut self,
        _ctx: &Context,
        rec: &mut Recorder<'_>,
        frame: &FrameInput<'_>,
    ) -> Result<()> {
        // soft_shadow.vert grows each quad by at most SSMB_EXTENT_RADIUS N / (2 tan(fov/2))
        // (1/z_near - 1/z_max) texels; under a sun by SSMB_EXTENT_RADIUS / texel
        // (z_max - z_near).
        let reach = match frame.light.sun {
            Some(_) => extent_radius(frame) / frame.light.texel_world(0.0, self.res),
            None => {
                let t = (frame.light.fov_deg.to_radians() * 0.5).tan();
                extent_radius(frame) * self.res as f32 / (2.0 * t)
            }
        };
        let spread = spread(frame);
        if spread.is_nan() || spread <= 0.0 {
            // The micro-quads project onto a disc of radius R; at R = 0 the technique is
            // built as `hard` (`create_either`), so a frame at R = 0 is a radius that
            // changed after creation.
            bail!(
                "{}: light radius (or sun tan) {} after the technique was created for R > 0 (R = 0 renders hard: create it again)",
                self.name,
                spread
            );
        }
        self.inputs.record(rec, frame, reach)?;
        self.shadowed = match quad_reach_texels(frame, reach) {
            Some(texels) => self.around.shadowed(frame, self.res, texels),
            None => Shadowed::Everywhere,
        };
        let listed = frame.settings.light_areas && self.list.buffers.fits;
        let drawn = listed.then_some(&self.inputs.step.drawn);
        self.blocks.record(rec, &self.front.set, drawn)?;
        let list_name = format!("{}/micro_quads", self.name);
        if listed {
            rec.pass(&list_name, |rec| {
                self.list
                    .record(rec, &self.front.set, &self.inputs.step.drawn);
                Ok(())
            })?;
        }
        rec.pass(&self.front.name, |rec| {
            self.record_quads(rec, &self.front, listed);
            Ok(())
        })?;
        self.resolve.record(rec)
    }

    fn frame_warning(&mut self) -> Result<Option<String>> {
        self.inputs.step_warning()
    }

    fn micro_patch_step(&self) -> Option<PatchStepReport> {
        self.inputs.step_report().ok()
    }

    fn light_passes(&self) -> Vec<String> {
        let mut names = self.inputs.pass_names();
        names.push(self.blocks.name.clone());
        names.push(format!("{}/micro_quads", self.name));
        names.push(self.front.name.clone());
        names.push(self.resolve.name.clone());
        names
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
        let mut out = vec![self.inputs.occluder.buffer()];
        out.extend(self.inputs.receivers.buffers());
        // The masks, read back as the fraction of the 128 samples hidden
        // (`Renderer::read_technique_buffer` decodes an RGBA32UI mask so).
        let mask = |name, image| LightBuffer {
            name,
            image,
            channels: &["occluded_fraction"],
            packing: Packing::Plain,
        };
        out.push(mask("soft_shadow", &self.masks[0]));
        out.push(mask("soft_shadow_pure", &self.masks[1]));
        out
    }
}
