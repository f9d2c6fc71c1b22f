//! # plateaus — Haines 2001, *Soft Planar Shadows Using Plateaus*
//! Port sheet: docs/port/plateaus.md
//! Speed layer: speed::plateaus (light-pass areas, split final pass) — off under --plain.
//!
//! A soft shadow texture for ONE planar receiver, rendered from straight above the plane: the
//! casters' hard drop shadow, then "plateau" geometry around it — a cone at every silhouette
//! vertex and a sheet along the outer side of every silhouette edge — whose depth is its
//! intensity, so the LESS depth test keeps the darkest primitive (Parker et al.'s "darkest
//! wins"). The texture is projected onto the plane as a light map through the sine falloff.
//! The planar receiver, the texture's square and the cone and sheet tessellation are in
//! src/technique/plateaus_common.rs, which `plateaus-centred` shares.
//!
//! The paper numbers no equations; sections and figures are cited, and the relations this
//! port derives are numbered (P1)-(P4) below.
//!
//! ## Geometry (per frame, world units)
//! Plane frame (O, u, v, n), u x v = n, n towards the light; the light centre L sits at height
//! H = n . (L - O). A point x at height h = n . (x - O) < H projects from L onto the plane at
//!
//! (P1)  P(x) = L + (x - L) H / (H - h) = (H x - h L) / (H - h),
//!
//! a projective map (Blinn 1988): a 4x4 matrix with w = H - h, used for the drop shadow.
//! Moving the light point by d parallel to the plane moves P(x) by -d h / (H - h), so a disc
//! light of radius R parallel to the plane spreads the shadow of x over a disc of radius
//!
//! (P2)  r(x) = R h / (H - h)
//!
//! around P(x): the outer penumbra half-width, the cone radius (Sec. 3: "proportional to the
//! height above the ground"; this port takes the similar-triangles constant instead of the
//! paper's fixed 0.1). The cone apex sits at P(x) at depth 0, its base circle at depth 1.
//! Sheets join two cones (c1, r1), (c2, r2) of an edge at their outer tangent (Fig. 4): with
//! e = (c2 - c1) / |c2 - c1| and p the right-hand perpendicular of e (the outside, see the
//! orientation convention of `silhouette::SilhouetteEdge`, which the central projection keeps),
//!
//! (P3)  m = a e + sqrt(1 - a^2) p,  a = (r1 - r2) / |c2 - c1|,  tangent points ci + ri m;
//!
//! the sheet runs from the edge (depth 0) to the tangent line (depth 1).
//!
//! (P2) is the radius across the light's azimuth. The disc the reference integrates faces
//! the point (docs/DESIGN.md), so the rays from its rim through x form a cone around the ray
//! from L, which meets the plane at cos(angle) = (H - h) / |L - x| to its normal: an ellipse
//! with (P2)'s r across the azimuth and
//!
//! (P2e) k r along it, k = |L - x| / (H - h) (a sun: k = 1 / (n . s)),
//!
//! the paper's "cones with elliptical bases, with the major axis of the ellipse pointing
//! towards the light" for a light near the horizon (Sec. 3). This form keeps the basic
//! algorithm's circles (k = 1); `plateaus-centred` draws the ellipses (`Disc`,
//! src/technique/plateaus_common.rs): its cones are stretched by k along the azimuth (k at
//! most `MAX_STRETCH`, 4: below a ray 14.5 degrees over the plane the ray cone's section is
//! no ellipse around P(x)) and each sheet solves (P3) where its two discs' mean stretch is
//! undone.
//!
//! ## Under a sun
//! A sun is every direction within its angular radius theta of its unit direction s
//! (towards it). Its rays are parallel, so the drop shadow is a parallel projection along s
//! and a point's shadow spreads over the directions' disc, whose radius grows linearly with
//! the distance h / (n . s) along the ray from x to the plane:
//!
//! (P1s) P(x) = x - s h / (n . s)   (affine, w = 1: `PlaneFrame::drop_shadow`),
//!
//! (P2s) r(x) = h tan(theta) / (n . s)   (`PlaneFrame::vertex_disc` with radius tan theta),
//!
//! the cone's aperture theta at every height: a straight edge at height h over the plane
//! throws the full penumbra 2 h tan(theta) under an overhead sun. (P3) is unchanged.
//! Silhouettes are taken from a point `SUN_DISTANCE` plane diagonals along s (the facing
//! test only needs the direction). A low sun stretches the true penumbra along its azimuth
//! by 1 / (n . s) ((P2e)); this form keeps the circle across it, as it keeps the
//! spotlight's (Known artefacts). The speed layer's regions follow the central projection
//! and are not planned for a sun: its final pass runs everywhere and its textures are drawn
//! whole.
//!
//! ## Passes, in order
//! 0. CPU `plateaus/silhouettes` (only when R > 0) — per caster (not the plane) silhouette
//!    edges from the light centre (`silhouette::extract` over an `Adjacency` built once),
//!    then cones and sheets in the texture's clip space (x, y, depth), 12 bytes a vertex,
//!    uploaded to a host-visible vertex buffer.
//! 1. `plateaus/drop_shadow` — casters (every caster but the plane) through the matrix of (P1)
//!    then the top-down orthographic map, clip z = 0. Attachments: the plateau texture,
//!    R32_SFLOAT penumbra fraction, clear 1.0 (lit), no blend; its z-buffer D32_SFLOAT,
//!    clear 1.0, LESS, write.
//!    `glsl/plateaus/drop_shadow.vert` reads the scene vertices, the model push constant and
//!    the plane UBO; `drop_shadow.frag` writes 0 and discards the parts of casters below the
//!    plane (height interpolated perspective-correctly). With the light not above the plane
//!    nothing is drawn: the cleared texture, all lit.
//! 2. `plateaus/plateaus` (skipped when there is nothing to draw: R = 0, the light not
//!    above the plane, no silhouette edge) — the cones and sheets into the same two
//!    attachments (loaded; the z-buffer is not stored after it): `plateau.vert` passes the
//!    clip position through, `plateau.frag` writes its own depth as colour (Sec. 3: "use
//!    the Z-buffer depth values directly as grayscale"), so colour and depth test agree
//!    exactly. Only the OUTER penumbra is drawn:
//!    inside the drop shadow, depth 0 always wins (Sec. 2).
//! 3. `plateaus/shadow_map` — `ShadowMap::casters`: R32_SFLOAT, the nearest caster's linear
//!    depth, clear 1e30, blend MIN, no depth attachment, casters only (fragment
//!    `glsl/common/caster_depth.frag`), for receivers other than the plane.
//! 4. `plateaus/final` — `FinalPass` with `glsl/plateaus/final.frag`: a point ON the plane
//!    (|height| <= `ON_PLANE_TOLERANCE` x the diagonal of the plane's part in the light, plus
//!    its rounding, and its normal within ~11 deg of the plane's) takes the bilinear filter
//!    of the 4 nearest texels of the fraction f and returns the sine falloff
//!    0.5 - 0.5 cos(pi f) from the 256-texel 1-D LUT (Sec. 3, Fig. 5); (P4) v = falloff(f).
//!    Every other point (other receivers, and on-plane points outside the texture's square,
//!    e.g. a coplanar second ground tile) gets the 2x2 bilinear comparison of the shadow
//!    map's r (`textureGather`, `lit_test`, `bilinear` of glsl/common/shadow.glsl: the
//!    filter `hard` gets from its comparison sampler). Points outside the light frustum get
//!    1, as in `hard`. Where neither lookup finds anything but clear values, v is exactly 1.
//!
//! ## Equations: what a porter ports
//! - (P1) the drop shadow's projection: `PlaneFrame::drop_shadow`.
//! - (P2) the cone radius (and (P2e)'s stretch, which this form sets to 1):
//!   `PlaneFrame::vertex_disc`.
//! - (P3) the sheets and the cones' fans: `PlateauBuilder::sheet` and `cone`, per
//!   silhouette `PlateauBuilder::silhouette`.
//! - (P4) and the on-plane test: `visibility` (glsl/plateaus/final.frag).
//!
//! Where the speed layer may change these functions' inputs: the plateau texture, its
//! z-buffer and the shadow map are cleared and drawn only over the texels the final pass
//! can read; `FinalPass::split` gives 1 without a lookup where every texel read holds its
//! clear value; culling leaves out objects that write no texel read and no pixel; reuse
//! skips the light passes when nothing moved. Each keeps the whole passes' image bit for
//! bit (src/technique/speed/plateaus.rs).
//!
//! ## Known artefacts
//! Umbrae are the full hard shadow at any light size: no inner penumbra, shadows too dark and
//! too large for big lights (Sec. 4). Cones are the basic algorithm's circles: a low light
//! stretches the true penumbra into (P2e)'s ellipses (Sec. 3), which `plateaus-centred`
//! draws and this form does not (the tip of `cylinder`'s long shadow is too sharp). Sharp
//! creases where silhouette edges meet in a concavity (Sec. 4). Overlapping penumbrae take the
//! darkest, not the product. Edges with a vertex above 0.99 H are dropped (their shadow runs to
//! infinity). Only the chosen plane is soft: other receivers get hard shadows, and a second
//! plane (a table top) gets them too. R = 0 gives the drop shadow alone, which matches `hard`
//! on the plane up to each method's one-texel edge aliasing (the texel grids differ).

use super::plateaus_common::{PlateauCommon, PLATEAU_ATTRIBUTES, PLATEAU_VERTEX_BYTES};
use super::{
    shadow_map_buffer, FrameInput, LightBuffer, Packing, Technique, TechniqueInfo, TechniqueInit,
};
use crate::gpu::gpu_scene::{DRAW_PUSH_BYTES, SCENE_ATTRIBUTES, SCENE_VERTEX_STRIDE};
use crate::gpu::passes::{falloff_lut, FinalPass, FinalShader, Shadowed};
use crate::shaders;
use crate::vk::{
    Blend, Clear, CompareOp, Context, CullModeFlags, DepthState, DescriptorSet, Filter, Format,
    GraphicsPipelineDesc, Image, Pipeline, PrimitiveTopology, Recorder, Resource, Sampler,
};
use anyhow::Result;

pub const INFO: TechniqueInfo = TechniqueInfo {
    name: "plateaus",
    summary: "Haines 2001: planar receiver, drop shadow + cones and sheets (darkest wins by depth), sine falloff",
    create: |init| Ok(Box::new(Plateaus::create(init)?)),
};

/// The pass names (= timestamp and debug labels).
struct Names {
    technique: &'static str,
    silhouettes: &'static str,
    drop_shadow: &'static str,
    plateaus: &'static str,
    shadow_map: &'static str,
    final_pass: &'static str,
}

const NAMES: Names = super::pass_names!(
    Names {
        silhouettes: "silhouettes",
        drop_shadow: "drop_shadow",
        plateaus: "plateaus",
        shadow_map: "shadow_map",
        final_pass: "final",
    },
    "plateaus"
);

/// Darkest wins: intensity is depth, the nearest is the darkest (Sec. 2).
pub(crate) const DARKEST_WINS: DepthState = DepthState {
    format: Format::D32_SFLOAT,
    test: true,
    write: true,
    compare: CompareOp::LESS,
};

pub struct Plateaus {
    /// The receiver, plane uniforms, texture, z-buffer, shadow map and plateau geometry.
    common: PlateauCommon,
    drop_pipeline: Pipeline,
    plateau_pipeline: Pipeline,
    final_pass: FinalPass,
    final_set: DescriptorSet,
    _falloff: Image,
    _linear: Sampler,
}

/// Pass 1's pipeline: the casters through (P1) into `color` (and `depth`).
pub(crate) fn drop_shadow_pipeline(
    ctx: &Context,
    name: &str,
    set: &DescriptorSet,
    color: Format,
    depth: Option<DepthState>,
) -> Result<Pipeline> {
    Pipeline::graphics(
        ctx,
        &GraphicsPipelineDesc {
            name,
            vertex: shaders::PLATEAUS_DROP_SHADOW_VERT,
            fragment: Some(shaders::PLATEAUS_DROP_SHADOW_FRAG),
            vertex_stride: SCENE_VERTEX_STRIDE,
            // Only the position; an unread normal is a validation warning.
            attributes: &SCENE_ATTRIBUTES[..1],
            topology: PrimitiveTopology::TRIANGLE_LIST,
            // A projected triangle's winding depends on its facing; both sides shadow.
            cull: CullModeFlags::NONE,
            colors: &[(color, Blend::None)],
            depth,
            push_constant_bytes: DRAW_PUSH_BYTES,
            sets: &[set],
        },
    )
}

/// Pass 2's pipeline: cones and sheets, their depth as colour, darkest wins.
pub(crate) fn plateau_pipeline(ctx: &Context, name: &str) -> Result<Pipeline> {
    Pipeline::graphics(
        ctx,
        &GraphicsPipelineDesc {
            name,
            vertex: shaders::PLATEAUS_PLATEAU_VERT,
            fragment: Some(shaders::PLATEAUS_PLATEAU_FRAG),
            vertex_stride: PLATEAU_VERTEX_BYTES,
            attributes: PLATEAU_ATTRIBUTES,
            topology: PrimitiveTopology::TRIANGLE_LIST,
            // Cones and sheets are built in 2-D with either winding.
            cull: CullModeFlags::NONE,
            colors: &[(Format::R32_SFLOAT, Blend::None)],
            depth: Some(DARKEST_WINS),
            push_constant_bytes: 0,
            sets: &[],
        },
    )
}

impl Plateaus {
    fn create(init: &TechniqueInit<'_>) -> Result<Self> {
        let ctx = init.ctx;
        let common = PlateauCommon::new(init, NAMES.drop_shadow, NAMES.shadow_map)?;
        let drop_pipeline = drop_shadow_pipeline(
            ctx,
            NAMES.drop_shadow,
            &common.drop_set,
            Format::R32_SFLOAT,
            Some(DARKEST_WINS),
        )?;
        let plateau_pipeline = plateau_pipeline(ctx, NAMES.plateaus)?;
        let linear = Sampler::new(ctx, Filter::Linear)?;
        let falloff = falloff_lut(ctx)?;
        let nearest = &common.nearest;
        let final_set = DescriptorSet::new(
            ctx,
            &[
                ("frame", Resource::Uniform(init.ubo)),
                ("plane", Resource::Uniform(&common.plane_ubo)),
                ("plateau_tex", Resource::Sampled(&common.texture, nearest)),
                (
                    "shadow_map",
                    Resource::Sampled(&common.shadow.depth, nearest),
                ),
                ("falloff", Resource::Sampled(&falloff, &linear)),
            ],
            NAMES.final_pass,
        )?;
        let final_shader = FinalShader {
            color: shaders::PLATEAUS_FINAL_FRAG,
            aov: shaders::PLATEAUS_FINAL_FRAG_AOV,
            count: shaders::PLATEAUS_FINAL_FRAG_COUNT,
        };
        let final_pass = FinalPass::split(ctx, NAMES.final_pass, final_shader, &final_set)?;
        Ok(Self {
            common,
            drop_pipeline,
            plateau_pipeline,
            final_pass,
            final_set,
            _falloff: falloff,
            _linear: linear,
        })
    }
}

impl Technique for Plateaus {
    fn name(&self) -> &'static str {
        NAMES.technique
    }

    fn record_light(
        &mut self,
        ctx: &Context,
        rec: &mut Recorder<'_>,
        frame: &FrameInput<'_>,
    ) -> Result<()> {
        // Pass 0, and where the speed layer lets passes 1-3 draw.
        let p = self
            .common
            .prepare(ctx, rec, frame, NAMES.silhouettes, false)?;
        let c = &self.common;
        rec.pass(NAMES.drop_shadow, |rec| {
            rec.begin_rendering_in(
                &[(&c.texture, Clear::Float([1.0; 4]))],
                Some((&c.zbuffer, Some(1.0))),
                p.areas.texture,
            );
            if p.lit_plane {
                c.draw_drop_shadow(rec, frame, &self.drop_pipeline);
            }
            rec.end_rendering();
            Ok(())
        })?;
        match c.vertices.is_empty() {
            false => rec.pass(NAMES.plateaus, |rec| {
                // Load: the drop shadow's colour and depth stay in place under the plateaus.
                rec.begin_rendering_in(
                    &[(&c.texture, Clear::Load)],
                    Some((&c.zbuffer, None)),
                    p.areas.texture,
                );
                rec.discard_after(&c.zbuffer);
                rec.bind_pipeline(&self.plateau_pipeline);
                c.vertices.draw(rec);
                rec.end_rendering();
                Ok(())
            })?,
            _ if !p.lit_plane => rec.skip(NAMES.plateaus, "light not above the plane"),
            _ if !p.soft => rec.skip(NAMES.plateaus, "point light (R = 0)"),
            _ => rec.skip(NAMES.plateaus, "no silhouette edge"),
        }
        c.shadow.pass_in(rec, frame.gpu, &p.areas.map)
    }

    fn light_passes(&self) -> Vec<String> {
        [NAMES.drop_shadow, NAMES.plateaus, NAMES.shadow_map]
            .map(String::from)
            .to_vec()
    }

    fn record_final(
        &mut self,
        _ctx: &Context,
        rec: &mut Recorder<'_>,
        frame: &FrameInput<'_>,
    ) -> Result<()> {
        let shadowed = self.common.speed.shadowed();
        self.final_pass
            .pass_in(rec, frame, &self.final_set, shadowed)
    }

    fn shadowed(&self) -> Option<&Shadowed> {
        Some(self.common.speed.shadowed())
    }

    fn light_buffers(&self) -> Vec<LightBuffer<'_>> {
        vec![
            // The top-down plateau texture: penumbra fraction f, 0 in the drop shadow, 1 lit.
            LightBuffer {
                name: "plateaus",
                image: &self.common.texture,
                channels: &["fraction"],
                packing: Packing::Plain,
            },
            shadow_map_buffer("shadow_map", &self.common.shadow),
        ]
    }
}
