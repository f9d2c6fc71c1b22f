//! # plateaus — Haines 2001, *Soft Planar Shadows Using Plateaus*
//! Port sheet: docs/port/plateaus.md
//!
//! A soft shadow texture for ONE planar receiver, rendered from straight above the plane: the
//! casters' hard drop shadow, then "plateau" geometry around it — a cone at every silhouette
//! vertex and a sheet along the outer side of every silhouette edge — whose depth is its
//! intensity, so the LESS depth test keeps the darkest primitive (Parker et al.'s "darkest
//! wins"). The texture is projected onto the plane as a light map through the sine falloff.
//! (`plateaus-centred`, src/technique/plateaus_centred.rs, is this struct with
//! `Form::Centred`: inner sheets too, the penumbra centred on the hard edge.)
//!
//! The paper numbers no equations; sections and figures are cited, and the relations this
//! port derives are numbered (P1)-(P4) below.
//!
//! ## The planar receiver
//! At creation, every receiving object whose triangles all lie in one plane within
//! `PLANAR_TOLERANCE` x its bounds diagonal (object space; the normal is taken from its
//! largest triangle) is a candidate; the one with the largest world area is THE plane. None:
//! `create` fails with "plateaus needs a planar receiver: scene 'X' has none". Each frame the
//! plane follows its object's transform; its normal n is flipped to the light's side.
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
//! the sheet is the bilinear (Coons) patch S(s, t) = c(s) + t r(s) m, depth t, tessellated
//! into an N x N grid with N = ceil(sqrt(|r1 - r2| / texel)) (the bilinear cross term then
//! bends less than 1/4 texel inside a cell). No sheet when one disc holds the other
//! (|a| >= 1): its cone covers the other. Cones are fans of clamp(2 r / texel, 8, 64) segments
//! (chord sagitta under ~0.3 texel). Each silhouette vertex gets one cone per caster build
//! (the paper's mailbox, a build stamp per welded vertex of that caster, one mailbox per
//! caster build so that casters build in parallel; a vertex belongs to one caster, so
//! per-caster builds keep "one cone per vertex per frame").
//!
//! Texture region: the plane object's bounding rectangle (in the plane) clipped to the light
//! frustum (Sutherland-Hodgman against its four sides and near plane), its bounding square
//! in plane coordinates plus one texel each side, at `Settings::shadow_res`^2 texels. It
//! depends on the plane's transform, the light (position, target, fov) and the resolution,
//! not on the casters: the frustum's sides do not move with the fitted near/far, and
//! `frustum::fit_light` puts near 1 % in front of every object it sees, the plane included,
//! so the near plane never cuts the lit part of the plane (only its far * 1e-4 floor could,
//! for a plane almost touching the light).
//!
//! ## What a frame rebuilds
//! Cones and sheets are cached per caster (`gpu::passes::CasterCache`) with the key
//! (`PlaneFrame`, R): a caster whose model matrix changed rebuilds only its own silhouette
//! and geometry, the others are reused and everything is concatenated in object order and
//! uploaded (the same vertex buffer a full rebuild makes, so the same image bit for bit). A
//! change of the key — light moved or resized, plane moved, `shadow_res` — rebuilds every
//! caster. `--timings` and the bench report print `cpu plateaus/silhouettes ... (rebuilt K
//! of N casters)` (`render --timings` rebuilds every pass of its timed frames: N of N). The
//! GPU passes redraw every caster whenever anything moved: the texture is one image whose
//! texels hold the darkest of all casters' plateaus, so a moved caster's old plateaus cannot
//! be taken out without redrawing the others (likewise the shadow map). A frame whose light
//! and casters did not move skips all three light passes (`render::Renderer::render`).
//!
//! ## Passes, in order
//! 0. CPU `plateaus/silhouettes` (only when R > 0) — per caster (not the plane) that moved
//!    (see above) silhouette edges from the light centre (`silhouette::extract` over an
//!    `Adjacency` built once), then cones and sheets in the texture's clip space (x, y,
//!    depth), 12 bytes a vertex; every caster's cached geometry is uploaded to a host-visible
//!    vertex buffer.
//! 1. `plateaus/drop_shadow` — casters (every caster but the plane) through the matrix of (P1)
//!    then the top-down orthographic map, clip z = 0. Attachments: `plateaus` R32_SFLOAT
//!    penumbra fraction, clear 1.0 (lit), no blend; D32_SFLOAT, clear 1.0, LESS, write.
//!    `glsl/plateaus/drop_shadow.vert` reads the scene vertices, the model push constant and
//!    the plane UBO; `drop_shadow.frag` writes 0 and discards the parts of casters below the
//!    plane (height interpolated perspective-correctly). At R > 0 both attachments are
//!    cleared and drawn only over the texels the final pass can read (`texture_texels`: its
//!    regions taken back onto the plane, which hold every drop shadow, cone and sheet),
//!    joined with last frame's, as are pass 2's and the centred form's coverage and inner
//!    images: every texel outside holds the clear value, as in whole passes (a porter can
//!    clear and draw the whole texture: same image).
//! 2. `plateaus/plateaus` (skipped when R = 0) — the cones and sheets into the same two
//!    attachments (loaded): `plateau.vert` passes the clip position through, `plateau.frag`
//!    writes its own depth as colour (Sec. 3: "use the Z-buffer depth values directly as
//!    grayscale"), so colour and depth test agree exactly. Only the OUTER penumbra is drawn:
//!    inside the drop shadow, depth 0 always wins (Sec. 2).
//! 3. `plateaus/shadow_map` — `ShadowMap::casters`: R32_SFLOAT, the nearest caster's linear
//!    depth, clear 1e30, blend MIN, no depth attachment, casters only (fragment
//!    `glsl/common/caster_depth.frag`), for receivers other than the plane.
//!    Cleared and drawn only over the casters' projected boxes, joined with last frame's
//!    (`regions::AroundCasters::map_area`): every texel outside holds the clear value, as in
//!    a whole map (a porter can clear and draw the whole map: same image).
//! 4. `plateaus/final` — `FinalPass` with `glsl/plateaus/final.frag`: a point ON the plane
//!    (|height| <= `ON_PLANE_TOLERANCE` x the diagonal of the plane's part in the light, plus
//!    its rounding, and its normal within ~11 deg
//!    of the plane's) takes the bilinear filter of the 4 nearest texels of the fraction f and
//!    returns the sine falloff 0.5 - 0.5 cos(pi f) from the 256-texel 1-D LUT (Sec. 3, Fig. 5);
//!    (P4) v = falloff(f). Every other point (other receivers, and on-plane points outside
//!    the texture's square, e.g. a coplanar second ground tile) gets the 2x2 bilinear
//!    comparison of the shadow map's r (`textureGather`, `lit_test`, `bilinear` of
//!    glsl/common/shadow.glsl: the filter `hard` gets from its comparison sampler). Points
//!    outside the light frustum get 1, as in `hard`.
//!    Where neither lookup can find anything but the clear values, v is exactly 1. So at
//!    R > 0 the timed pass (`FinalPass::split`) takes per caster a 16-sided polygon in
//!    light uv (`shadow_regions`): on the plane, the hull of its silhouette vertices' discs
//!    (P1, P2), which holds its drop shadow (the central projection of a mesh below the
//!    light is its silhouette vertices' hull) and its cones and sheets (each in the hull of
//!    its discs), grown by the bilinear footprint and by the parallax of points up to the
//!    on-plane tolerance off the plane, its corners taken to light uv (`plane_region`);
//!    joined, for a caster in the light, with its outline there (`regions::AroundCasters`),
//!    which the shadow map's lookups see. It draws this shader only over the receivers'
//!    parts in the light frustum over those polygons, and glsl/common/unshadowed.frag
//!    elsewhere: the whole pass's image bit for bit (tests/avoided_work.rs). On lavapipe
//!    the lookups then run on 24-35 % of the area drawn on `cylinder`, `overlap` and
//!    `bunny`; a CPU driver pays both of the shader's paths on every pixel. On a GPU a
//!    porter can draw the whole pass with this shader: same image.
//!
//! ## Equations: what a porter ports
//! - (P1) the drop shadow's projection: `PlaneFrame::drop_shadow`.
//! - (P2) the cone radius: `PlaneFrame::vertex_disc`.
//! - (P3) the sheets and the cones' fans: `PlateauBuilder::sheet` and `cone`, per
//!   silhouette `PlateauBuilder::silhouette`.
//! - (P4) and the on-plane test: `visibility` (glsl/plateaus/final.frag).
//!
//! Where the speed layer (`--plain` turns it off, `Settings::effective`) may change
//! these functions' inputs:
//! - The plateau texture and its z-buffer are cleared and drawn only over the texels the
//!   final pass can read (`texture_texels`), the shadow map over the casters' boxes: every
//!   texel read holds what the whole passes write.
//! - `FinalPass::split` chooses which pixels run the final shader and which get 1 without
//!   a lookup; where the shader runs its inputs are the whole pass's (bit for bit).
//! - Culling leaves out objects outside the light's frustum (light passes) and the
//!   camera's (final pass): they write no texel a lookup reads and no pixel.
//! - Reuse skips the light passes when the light, its radius and every object are
//!   unchanged: the buffers then hold what the same passes wrote.
//!
//! ## Known artefacts
//! Umbrae are the full hard shadow at any light size: no inner penumbra, shadows too dark and
//! too large for big lights (Sec. 4). Cones are circles, exact only for a disc light parallel
//! to the plane: a low light should stretch them into ellipses (Sec. 3) and does not. Sharp
//! creases where silhouette edges meet in a concavity (Sec. 4). Overlapping penumbrae take the
//! darkest, not the product. Edges with a vertex above 0.99 H are dropped (their shadow runs to
//! infinity). Only the chosen plane is soft: other receivers get hard shadows, and a second
//! plane (a table top) gets them too. R = 0 gives the drop shadow alone, which matches `hard`
//! on the plane up to each method's one-texel edge aliasing (the texel grids differ).

use super::regions::{self, Support};
use super::{
    shadow_map_buffer, Form, FrameInput, LightBuffer, Technique, TechniqueInfo, TechniqueInit,
};
use crate::frustum::PixelBox;
use crate::gpu::gpu_scene::{GpuObject, DRAW_PUSH_BYTES, SCENE_ATTRIBUTES, SCENE_VERTEX_STRIDE};
use crate::gpu::passes::{
    falloff_lut, CasterCacheOf, DynamicVertices, FinalPass, FinalShader, ShadowMap, Shadowed,
};
use crate::scene::{normal_matrix, Aabb, LightView, Mesh, Scene};
use crate::shaders;
use crate::silhouette::{self, Adjacency, Side, SilhouetteEdge};
use crate::vk::{
    Blend, Buffer, BufferUsageFlags, Clear, CompareOp, Context, CullModeFlags, DepthState,
    DescriptorSet, Filter, Format, GraphicsPipelineDesc, Image, ImageUsageFlags, MemoryLocation,
    Pipeline, PrimitiveTopology, Recorder, Resource, Sampler,
};
use anyhow::{anyhow, Result};
use bytemuck::{Pod, Zeroable};
use glam::{Mat4, Vec2, Vec3, Vec4};
use std::sync::Arc;

pub const INFO: TechniqueInfo = TechniqueInfo {
    name: "plateaus",
    summary: "Haines 2001: planar receiver, drop shadow + cones and sheets (darkest wins by depth), sine falloff",
    create: |init| Plateaus::create(init, Form::Paper),
};

/// The names of one form's passes (= timestamp and debug labels).
struct Names {
    technique: &'static str,
    silhouettes: &'static str,
    drop_shadow: &'static str,
    plateaus: &'static str,
    inner: &'static str,
    shadow_map: &'static str,
    final_pass: &'static str,
}

impl Form {
    fn plateau_names(self) -> Names {
        super::pass_names!(
            Names {
                silhouettes: "silhouettes",
                drop_shadow: "drop_shadow",
                plateaus: "plateaus",
                inner: "inner",
                shadow_map: "shadow_map",
                final_pass: "final",
            },
            match self {
                Form::Paper => "plateaus",
                Form::Centred => "plateaus-centred",
            }
        )
    }
}

/// A receiver is planar when every vertex lies within this fraction of its bounds diagonal
/// from the plane of its largest triangle (1e-4: exact planes pass, terrain with visible
/// relief does not).
pub const PLANAR_TOLERANCE: f32 = 1e-4;

/// A camera point is "on the plane" within this fraction of the diagonal of the plane's part in
/// the light (its whole diagonal when the light holds it): twice the detection tolerance, so
/// every point of the detected object passes. The part in the light, not the whole plane: on
/// a ground 1e5 wide, 2e-4 of its diagonal is 28 units, and every caster shorter than that
/// would count as lying on the plane and drop no shadow.
pub const ON_PLANE_TOLERANCE: f32 = 2e-4;

/// Plus this fraction of the plane corners' largest coordinate: rasterised positions lie off
/// their plane by a few f32 ulps of its vertices' coordinates (8 ulps here).
const PLANE_ROUNDING: f32 = 1.0 / (1u32 << 20) as f32;

/// |cos| between a surface normal and the plane's above which an on-plane point reads the
/// plateau texture (~11 degrees): the vertical faces of a box resting on the plane do not.
const ON_PLANE_COS: f32 = 0.98;

/// Silhouette vertices higher than this fraction of the light's height are not projected:
/// (P1) and (P2) blow up as h -> H.
const MAX_HEIGHT_FRACTION: f32 = 0.99;

/// One plateau vertex: texture clip-space x, y and the depth (= penumbra fraction).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct PlateauVertex {
    pub clip: [f32; 3],
}

const PLATEAU_VERTEX_BYTES: u32 = std::mem::size_of::<PlateauVertex>() as u32;
const PLATEAU_ATTRIBUTES: &[crate::vk::Attribute] = &[(0, Format::R32G32B32_SFLOAT, 0)];

/// Mirrors `Plane` in glsl/plateaus/plane.glsl (std140: mat4 and vec4 only).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct PlaneUniforms {
    drop_shadow: [f32; 16],
    to_texture: [f32; 16],
    params: [f32; 4],
    normal: [f32; 4],
}

/// The receiver the texture is made for, in its object space.
#[derive(Clone, Debug)]
pub struct PlanarReceiver {
    /// Index into `Scene::objects`.
    pub object: usize,
    origin: Vec3,
    normal: Vec3,
    /// The rectangle in the plane that holds every vertex.
    corners: [Vec3; 4],
    /// World area at creation (the "largest" criterion).
    pub area: f32,
}

/// The plane of `mesh` (a point, unit normal, bounding rectangle in the plane) when all its
/// used vertices lie within `PLANAR_TOLERANCE` of the diagonal from it.
fn plane_of(mesh: &Mesh) -> Option<(Vec3, Vec3, [Vec3; 4])> {
    let pts: Vec<Vec3> = mesh
        .indices
        .iter()
        .filter_map(|&i| mesh.positions.get(i as usize).copied())
        .collect();
    let size = Aabb::from_points(pts.iter().copied()).radius() * 2.0;
    if !size.is_finite() || size <= 0.0 {
        return None;
    }
    // The largest triangle has the best-conditioned normal.
    let mut best = (Vec3::ZERO, Vec3::ZERO, 0.0f32);
    for t in pts.chunks_exact(3) {
        let c = (t[1] - t[0]).cross(t[2] - t[0]);
        if c.length() > best.2 {
            best = (t[0], c, c.length());
        }
    }
    // A line or a point has no plane.
    if best.2 <= size * size * 1e-9 {
        return None;
    }
    let (origin, n) = (best.0, best.1 / best.2);
    let tol = PLANAR_TOLERANCE * size;
    if pts.iter().any(|p| (*p - origin).dot(n).abs() > tol) {
        return None;
    }
    let u = n.any_orthonormal_vector();
    let v = n.cross(u);
    let (mut lo, mut hi) = (Vec2::splat(f32::MAX), Vec2::splat(f32::MIN));
    for p in &pts {
        let q = Vec2::new((*p - origin).dot(u), (*p - origin).dot(v));
        lo = lo.min(q);
        hi = hi.max(q);
    }
    let at = |s: f32, t: f32| origin + u * s + v * t;
    Some((
        origin,
        n,
        [
            at(lo.x, lo.y),
            at(hi.x, lo.y),
            at(hi.x, hi.y),
            at(lo.x, hi.y),
        ],
    ))
}

/// The largest planar receiver of `scene`, or the error this technique gives without one.
pub fn find_planar_receiver(scene: &Scene) -> Result<PlanarReceiver> {
    let mut best: Option<PlanarReceiver> = None;
    for (i, o) in scene.objects.iter().enumerate() {
        if !o.role.receives() {
            continue;
        }
        let Some((origin, normal, corners)) = plane_of(&o.mesh) else {
            continue;
        };
        let area: f32 = o
            .world_triangles()
            .map(|[a, b, c]| (b - a).cross(c - a).length() * 0.5)
            .sum();
        if best.as_ref().is_none_or(|b| area > b.area) {
            best = Some(PlanarReceiver {
                object: i,
                origin,
                normal,
                corners,
                area,
            });
        }
    }
    best.ok_or_else(|| {
        anyhow!(
            "plateaus needs a planar receiver: scene '{}' has none (no receiving object has all its triangles in one plane)",
            scene.name
        )
    })
}

/// The plane in world space for one frame, and the square of it the texture covers.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlaneFrame {
    pub origin: Vec3,
    pub u: Vec3,
    pub v: Vec3,
    /// Unit normal, on the light's side.
    pub n: Vec3,
    pub light: Vec3,
    /// H: the light centre's height above the plane.
    pub light_height: f32,
    /// Lower corner of the texture's square in plane coordinates (u, v).
    pub min: Vec2,
    /// Side of that square (world units).
    pub side: f32,
    pub res: u32,
    /// On-plane height tolerance (world units).
    pub tolerance: f32,
}

/// Sutherland-Hodgman: the part of the convex polygon `poly` where `plane . (x, 1) >= 0`.
fn clip_polygon(poly: &[Vec3], plane: Vec4) -> Vec<Vec3> {
    let mut out = Vec::with_capacity(poly.len() + 1);
    for (i, &a) in poly.iter().enumerate() {
        let b = poly[(i + 1) % poly.len()];
        let (da, db) = (plane.dot(a.extend(1.0)), plane.dot(b.extend(1.0)));
        if da >= 0.0 {
            out.push(a);
        }
        if (da >= 0.0) != (db >= 0.0) {
            out.push(a + (b - a) * (da / (da - db)));
        }
    }
    out
}

impl PlaneFrame {
    pub fn new(recv: &PlanarReceiver, model: Mat4, light: &LightView, res: u32) -> Self {
        let origin = model.transform_point3(recv.origin);
        let mut n = (normal_matrix(model) * recv.normal).normalize_or(Vec3::Y);
        if n.dot(light.position - origin) < 0.0 {
            n = -n;
        }
        let u = n.any_orthonormal_vector();
        let v = n.cross(u);
        let corners = recv.corners.map(|c| model.transform_point3(c));
        // The light frustum's sides and near plane (Vulkan clip: -w <= x, y <= w, 0 <= z).
        let m = light.view_proj;
        let (r0, r1, r2, r3) = (m.row(0), m.row(1), m.row(2), m.row(3));
        let mut poly = corners.to_vec();
        for p in [r3 + r0, r3 - r0, r3 + r1, r3 - r1, r2] {
            if poly.len() < 3 {
                break;
            }
            poly = clip_polygon(&poly, p);
        }
        // Nothing of the plane in the light: any square will do, nothing there is shadowed.
        if poly.len() < 3 {
            poly = corners.to_vec();
        }
        let coord = |x: Vec3| Vec2::new((x - origin).dot(u), (x - origin).dot(v));
        let (mut lo, mut hi) = (Vec2::splat(f32::MAX), Vec2::splat(f32::MIN));
        for &p in &poly {
            lo = lo.min(coord(p));
            hi = hi.max(coord(p));
        }
        let diag = (corners[2] - corners[0])
            .length()
            .max((corners[3] - corners[1]).length());
        let res = res.max(1);
        // Square texels; one texel of margin each side so the border texels stay inside.
        let side = (hi - lo)
            .max_element()
            .max(diag * 1e-6)
            .max(f32::MIN_POSITIVE)
            * (1.0 + 2.0 / res as f32);
        Self {
            origin,
            u,
            v,
            n,
            light: light.position,
            light_height: n.dot(light.position - origin),
            min: (lo + hi) * 0.5 - Vec2::splat(side * 0.5),
            side,
            res,
            tolerance: ON_PLANE_TOLERANCE * diag.min((hi - lo).length())
                + PLANE_ROUNDING
                    * corners
                        .iter()
                        .fold(0.0f32, |m, c| m.max(c.abs().max_element())),
        }
    }

    /// World size of one texel.
    pub fn texel(&self) -> f32 {
        self.side / self.res as f32
    }

    /// Plane coordinates (u, v) of a world point.
    pub fn coords(&self, x: Vec3) -> Vec2 {
        Vec2::new((x - self.origin).dot(self.u), (x - self.origin).dot(self.v))
    }

    /// Height of a world point above the plane.
    pub fn height(&self, x: Vec3) -> f32 {
        (x - self.origin).dot(self.n)
    }

    /// Texture uv in \[0,1\]^2 of plane coordinates.
    pub fn uv(&self, p: Vec2) -> Vec2 {
        (p - self.min) / self.side
    }

    /// Where `x` lands on the plane seen from the light centre (P1), with its cone radius for
    /// a light of radius `radius` (P2); `None` above `MAX_HEIGHT_FRACTION` of the light.
    pub fn vertex_disc(&self, x: Vec3, radius: f32) -> Option<(Vec2, f32)> {
        let big_h = self.light_height;
        let h = self.height(x);
        if h.is_nan() || h >= big_h * MAX_HEIGHT_FRACTION {
            return None;
        }
        let p = self.light + (x - self.light) * (big_h / (big_h - h));
        Some((self.coords(p), radius * h.max(0.0) / (big_h - h)))
    }

    /// World -> (u, v, height, 1), u and v the texture coordinates.
    pub fn to_texture(&self) -> Mat4 {
        let row = |axis: Vec3, offset: f32| axis.extend(offset - axis.dot(self.origin));
        let s = 1.0 / self.side;
        Mat4::from_cols(
            row(self.u * s, -self.min.x * s),
            row(self.v * s, -self.min.y * s),
            row(self.n, 0.0),
            Vec4::W,
        )
        .transpose()
    }

    /// World -> texture clip space through the central projection onto the plane (P1), z = 0.
    pub fn drop_shadow(&self) -> Mat4 {
        let (n, l, big_h) = (self.n, self.light, self.light_height);
        let n_o = n.dot(self.origin);
        // (x, 1) -> (H x - h(x) L, H - h(x)) with h(x) = n.x - n.O.
        let col = |j: usize| {
            let mut e = Vec3::ZERO;
            e[j] = big_h;
            (e - l * n[j]).extend(-n[j])
        };
        let blinn = Mat4::from_cols(col(0), col(1), col(2), (l * n_o).extend(big_h + n_o));
        let to_clip = Mat4::from_cols(
            Vec4::new(2.0, 0.0, 0.0, 0.0),
            Vec4::new(0.0, 2.0, 0.0, 0.0),
            Vec4::ZERO,
            Vec4::new(-1.0, -1.0, 0.0, 1.0),
        );
        to_clip * self.to_texture() * blinn
    }

    fn uniforms(&self) -> PlaneUniforms {
        PlaneUniforms {
            drop_shadow: self.drop_shadow().to_cols_array(),
            to_texture: self.to_texture().to_cols_array(),
            params: [self.tolerance, ON_PLANE_COS, 0.0, 0.0],
            normal: self.n.extend(0.0).to_array(),
        }
    }
}

/// The light-uv polygon around the plane's texels that a caster's drop shadow and
/// plateaus can darken, from the support `reach` of its silhouette vertices' discs in
/// plane coordinates (`PlateauBuilder::reach`), grown by what the final pass reads around
/// a point: the 2x2 bilinear footprint (within 1.5 texels; 2 here), and the parallax of an
/// on-plane point up to `tolerance` off the plane, which reads the texture at its foot f
/// while the light sees it at f + (f - foot of the light) h / (H - h). The plane polygon's
/// corners go to the light's uv, whose projective map keeps the polygon convex in front of
/// the light. `None` when unbounded or not all in front of the light.
fn plane_region(frame: &FrameInput<'_>, plane: &PlaneFrame, reach: Support) -> Option<Support> {
    let grow = |s: Support, by: f32| s.map(|x| x + by);
    let footprint = grow(reach, 2.0 * plane.texel());
    let foot = plane.coords(plane.light);
    let far = regions::support_corners(&footprint)?
        .iter()
        .map(|c| c.distance(foot))
        .fold(0.0, f32::max);
    let room = plane.light_height - plane.tolerance;
    // Also false for NaN.
    if room.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
        return None;
    }
    let corners = regions::support_corners(&grow(footprint, far * plane.tolerance / room))?;
    let uvs = corners
        .iter()
        .map(|c| regions::light_uv(frame, plane.origin + plane.u * c.x + plane.v * c.y))
        .collect::<Option<Vec<_>>>()?;
    regions::support_of(&uvs)
}

/// The plateau texture's texels (side `plane.res`) that the final pass's shader can read
/// in the regions around `supports` (light uv polygons, widened by `margin` as
/// `regions::shadowed` widens them): each polygon's corners taken back onto the plane
/// along the light's rays (a projective map: the polygon's points land in their corners'
/// hull), grown by the on-plane parallax (a point up to `tolerance` off the plane reads at
/// its foot, up to |f - foot of the light| tolerance / H from where its ray meets the
/// plane) and the bilinear footprint. Every drop shadow, cone and sheet lies inside (each
/// caster's `plane_region` is in its polygon), so clearing and drawing the plateau textures
/// there only gives the texels the whole passes give wherever the shader reads. `None` (the
/// whole texture) where a corner's ray does not meet the plane in front of the light.
fn texture_texels(
    frame: &FrameInput<'_>,
    plane: &PlaneFrame,
    supports: &[Support],
    margin: f32,
) -> Option<PixelBox> {
    let to_world = frame.light.view_proj.inverse();
    let foot = plane.coords(plane.light);
    let mut texels = PixelBox::EMPTY;
    for support in supports {
        let corners = regions::support_corners(&support.map(|s| s + margin))?;
        let (mut lo, mut hi, mut far) = (Vec2::INFINITY, Vec2::NEG_INFINITY, 0.0f32);
        for uv in corners {
            let ndc = uv * 2.0 - Vec2::ONE;
            let dir = to_world.project_point3(ndc.extend(1.0)) - plane.light;
            // The ray L + t dir meets the plane at t = -H / (n . dir), in front if t > 0.
            let down = plane.n.dot(dir);
            if down.partial_cmp(&0.0) != Some(std::cmp::Ordering::Less) {
                return None;
            }
            let at = plane.coords(plane.light - dir * (plane.light_height / down));
            far = far.max(at.distance(foot));
            lo = lo.min(at);
            hi = hi.max(at);
        }
        let grow = far * plane.tolerance / plane.light_height + 2.0 * plane.texel();
        let (lo, hi) = (plane.uv(lo - grow), plane.uv(hi + grow));
        if !(lo.is_finite() && hi.is_finite()) {
            return None;
        }
        texels = texels.union(PixelBox::of_uv(plane.res, lo, hi));
    }
    Some(texels)
}

/// Cones and sheets of one frame, in texture clip space.
pub struct PlateauBuilder<'a> {
    plane: &'a PlaneFrame,
    radius: f32,
    /// Which side of the edges the sheets open to: outward (the paper's), or inward into
    /// the drop shadow (plateaus-centred's inner sheets).
    side: Side,
    pub vertices: Vec<PlateauVertex>,
    pub cones: usize,
    pub sheets: usize,
    /// The support, in plane coordinates, of every silhouette vertex's disc (P1, P2) seen
    /// by `silhouette` (`regions::directions()`); `None` once a vertex got no disc (above
    /// `MAX_HEIGHT_FRACTION` of the light). Cones and sheets lie in the discs' hull.
    pub reach: Option<Support>,
    /// `spokes[n]`: the unit directions (cos, sin) of angle TAU i / n, i = 0..=n, for a cone
    /// of n segments; filled on first use, so a build takes its sines and cosines once per
    /// segment count instead of twice per cone triangle.
    spokes: Vec<Vec<Vec2>>,
    /// Scratch: one cone's or sheet's points in clip space (x, y) with their depth.
    points: Vec<[f32; 3]>,
}

/// Segments of a cone: at least this many...
const MIN_CONE_SEGMENTS: u32 = 8;
/// ... and at most this many (two per texel of radius in between).
const MAX_CONE_SEGMENTS: u32 = 64;

impl<'a> PlateauBuilder<'a> {
    pub fn new(plane: &'a PlaneFrame, radius: f32) -> Self {
        Self {
            plane,
            radius,
            side: Side::Outer,
            vertices: Vec::new(),
            cones: 0,
            sheets: 0,
            reach: Some([f32::NEG_INFINITY; regions::DIRECTIONS]),
            spokes: vec![Vec::new(); MAX_CONE_SEGMENTS as usize + 1],
            points: Vec::new(),
        }
    }

    /// The same builder with its sheets on `side`.
    pub fn with_side(mut self, side: Side) -> Self {
        self.side = side;
        self
    }

    /// A point in texture clip space with its depth.
    fn clip(&self, p: Vec2, depth: f32) -> [f32; 3] {
        let c = self.plane.uv(p) * 2.0 - Vec2::ONE;
        [c.x, c.y, depth]
    }

    /// A cone with its apex at `c` (depth 0) and base circle of radius `r` (depth 1).
    pub fn cone(&mut self, c: Vec2, r: f32) {
        let texels = r / self.plane.texel();
        // Below a thousandth of a texel the cone covers no sample.
        if texels.is_nan() || texels <= 1e-3 {
            return;
        }
        let segments = (2.0 * texels)
            .ceil()
            .clamp(MIN_CONE_SEGMENTS as f32, MAX_CONE_SEGMENTS as f32)
            as u32;
        let spokes = &mut self.spokes[segments as usize];
        if spokes.is_empty() {
            spokes.extend((0..=segments).map(|i| {
                let a = std::f32::consts::TAU * i as f32 / segments as f32;
                Vec2::new(a.cos(), a.sin())
            }));
        }
        // Each base point once, shared by its two triangles.
        let mut points = std::mem::take(&mut self.points);
        points.clear();
        points.extend(
            self.spokes[segments as usize]
                .iter()
                .map(|&d| self.clip(c + d * r, 1.0)),
        );
        let apex = PlateauVertex {
            clip: self.clip(c, 0.0),
        };
        self.vertices.reserve(3 * segments as usize);
        for w in points.windows(2) {
            self.vertices.extend_from_slice(&[
                apex,
                PlateauVertex { clip: w[0] },
                PlateauVertex { clip: w[1] },
            ]);
        }
        self.points = points;
        self.cones += 1;
    }

    /// The sheet on the outer (right-hand) side of the edge c1 -> c2 (the inner side for
    /// `Side::Inner`) between the cones
    /// (c1, r1) and (c2, r2), (P3).
    pub fn sheet(&mut self, c1: Vec2, r1: f32, c2: Vec2, r2: f32) {
        let texel = self.plane.texel();
        let d = c2 - c1;
        let len = d.length();
        if len.is_nan() || len <= texel * 1e-3 || r1.max(r2).is_nan() || r1.max(r2) <= texel * 1e-3
        {
            return;
        }
        let e = d / len;
        // Inner sheets: the other common tangent of the two discs, (P3) with p -> -p.
        let p = Vec2::new(e.y, -e.x) * self.side.sign();
        let a = (r1 - r2) / len;
        // One disc holds the other: its cone already covers where the sheet would be.
        if a.abs() >= 1.0 {
            return;
        }
        let m = e * a + p * (1.0 - a * a).sqrt();
        let n = ((r1 - r2).abs() / texel).sqrt().ceil().clamp(1.0, 16.0) as u32;
        // The (n + 1)^2 grid points once each, row i (along the edge) after row i - 1.
        let mut points = std::mem::take(&mut self.points);
        points.clear();
        for i in 0..=n {
            let s = i as f32 / n as f32;
            for j in 0..=n {
                let t = j as f32 / n as f32;
                points.push(self.clip(c1 + d * s + m * (t * (r1 + (r2 - r1) * s)), t));
            }
        }
        let at = |i: u32, j: u32| PlateauVertex {
            clip: points[(i * (n + 1) + j) as usize],
        };
        self.vertices.reserve(6 * (n * n) as usize);
        for i in 0..n {
            for j in 0..n {
                let q = [at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)];
                for k in [0, 1, 2, 0, 2, 3] {
                    self.vertices.push(q[k]);
                }
            }
        }
        self.points = points;
        self.sheets += 1;
    }

    /// Cones at the vertices and sheets along the edges of one object's silhouette. `mailbox`
    /// (one entry per welded vertex) holds the stamp of the frame that last drew its cone.
    pub fn silhouette(
        &mut self,
        adj: &Adjacency,
        sil: &[SilhouetteEdge],
        model: Mat4,
        mailbox: &mut [u64],
        stamp: u64,
    ) {
        let dirs = regions::directions();
        for e in sil {
            let disc = |i: u32| {
                adj.positions.get(i as usize).and_then(|&x| {
                    self.plane
                        .vertex_disc(model.transform_point3(x), self.radius)
                })
            };
            let (da, db) = (disc(e.a), disc(e.b));
            self.reach = match (self.reach, da, db) {
                (Some(s), Some((ca, ra)), Some((cb, rb))) => Some(std::array::from_fn(|k| {
                    s[k].max(dirs[k].dot(ca) + ra).max(dirs[k].dot(cb) + rb)
                })),
                _ => None,
            };
            for (i, d) in [(e.a, da), (e.b, db)] {
                let (Some((c, r)), Some(slot)) = (d, mailbox.get_mut(i as usize)) else {
                    continue;
                };
                if *slot != stamp {
                    *slot = stamp;
                    self.cone(c, r);
                }
            }
            if let (Some((c1, r1)), Some((c2, r2))) = (da, db) {
                self.sheet(c1, r1, c2, r2);
            }
        }
    }
}

/// One caster's plateaus.
struct CasterPlateaus {
    /// Its cones and outer sheets, then (centred form; empty in the paper form) its cones
    /// and inner sheets.
    sides: [Vec<PlateauVertex>; 2],
    /// `PlateauBuilder::reach`: where on the plane its plateaus, and its drop shadow, lie.
    reach: Option<Support>,
}

/// The centred form's extra images and pipeline (plateaus_centred.rs).
struct Centred {
    /// R16F, clear 1: 0 where a caster's drop shadow falls.
    coverage: Image,
    /// R16F, clear 0, MAX: the lightest inner visibility.
    inner: Image,
    inner_pipeline: Pipeline,
    inner_set: DescriptorSet,
    inner_vertices: DynamicVertices,
}

pub struct Plateaus {
    form: Form,
    receiver: PlanarReceiver,
    texture: Image,
    zbuffer: Image,
    plane_ubo: Buffer,
    drop_pipeline: Pipeline,
    drop_set: DescriptorSet,
    plateau_pipeline: Pipeline,
    centred: Option<Centred>,
    shadow: ShadowMap,
    final_pass: FinalPass,
    final_set: DescriptorSet,
    _falloff: Image,
    _nearest: Sampler,
    _linear: Sampler,
    /// Edge adjacency per object (None for non-casters and the plane), built once per mesh
    /// and shared by the objects that instance it (`silhouette::caster_adjacency`).
    adjacency: Vec<Option<Arc<Adjacency>>>,
    /// Casters (objects with an adjacency).
    casters: usize,
    /// Per caster, its cones and sheets and the plane frame and radius they were built for:
    /// a moved caster rebuilds only its own.
    cache: CasterCacheOf<GeometryKey, CasterPlateaus>,
    vertices: DynamicVertices,
    /// The casters' outlines in the light, for the shadow map's part of the final pass.
    around: regions::AroundCasters,
    /// Where the final pass's visibility can be below 1 (`shadow_regions`; `Everywhere`:
    /// not known).
    shadowed: Shadowed,
    /// The plateau textures' texels the last light passes may have drawn: the next ones
    /// clear them with their own (`texture_texels`).
    texture_drawn: regions::LastDrawn,
}

/// What a caster's cones and sheets depend on besides its model: the plane frame (the
/// plane, the light centre, the texture square and resolution) and the light radius.
#[derive(Clone, Copy, Debug, PartialEq)]
struct GeometryKey {
    plane: PlaneFrame,
    radius: f32,
}

impl Plateaus {
    pub(crate) fn create(init: &TechniqueInit<'_>, form: Form) -> Result<Box<dyn Technique>> {
        let ctx = init.ctx;
        let res = init.settings.shadow_res;
        let names = form.plateau_names();
        let receiver = find_planar_receiver(init.scene)?;
        let usage = ImageUsageFlags::COLOR_ATTACHMENT
            | ImageUsageFlags::SAMPLED
            | ImageUsageFlags::TRANSFER_SRC;
        let texture = Image::new_2d(ctx, res, res, Format::R32_SFLOAT, usage, "plateau texture")?;
        let zbuffer = Image::new_2d(
            ctx,
            res,
            res,
            Format::D32_SFLOAT,
            ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT,
            "plateau z-buffer",
        )?;
        let plane_ubo = Buffer::new(
            ctx,
            std::mem::size_of::<PlaneUniforms>() as u64,
            BufferUsageFlags::UNIFORM_BUFFER,
            MemoryLocation::CpuToGpu,
            "plateau plane uniforms",
        )?;
        let depth_state = DepthState {
            format: Format::D32_SFLOAT,
            test: true,
            write: true,
            // Darkest wins: intensity is depth, the nearest is the darkest (Sec. 2).
            compare: CompareOp::LESS,
        };
        let drop_set = DescriptorSet::new(
            ctx,
            &[
                ("frame", Resource::Uniform(init.ubo)),
                ("plane", Resource::Uniform(&plane_ubo)),
            ],
            names.drop_shadow,
        )?;
        // The centred form draws the drop shadow into its own coverage image, without the
        // z-buffer: the outer plateaus of other casters must stay visible inside it.
        let (drop_color, drop_depth) = match form {
            Form::Paper => (Format::R32_SFLOAT, Some(depth_state)),
            Form::Centred => (Format::R16_SFLOAT, None),
        };
        let drop_pipeline = Pipeline::graphics(
            ctx,
            &GraphicsPipelineDesc {
                name: names.drop_shadow,
                vertex: shaders::PLATEAUS_DROP_SHADOW_VERT,
                fragment: Some(shaders::PLATEAUS_DROP_SHADOW_FRAG),
                vertex_stride: SCENE_VERTEX_STRIDE,
                // Only the position; an unread normal is a validation warning.
                attributes: &SCENE_ATTRIBUTES[..1],
                topology: PrimitiveTopology::TRIANGLE_LIST,
                // A projected triangle's winding depends on its facing; both sides shadow.
                cull: CullModeFlags::NONE,
                colors: &[(drop_color, Blend::None)],
                depth: drop_depth,
                push_constant_bytes: DRAW_PUSH_BYTES,
                sets: &[&drop_set],
            },
        )?;
        let plateau_pipeline = Pipeline::graphics(
            ctx,
            &GraphicsPipelineDesc {
                name: names.plateaus,
                vertex: shaders::PLATEAUS_PLATEAU_VERT,
                fragment: Some(shaders::PLATEAUS_PLATEAU_FRAG),
                vertex_stride: PLATEAU_VERTEX_BYTES,
                attributes: PLATEAU_ATTRIBUTES,
                topology: PrimitiveTopology::TRIANGLE_LIST,
                // Cones and sheets are built in 2-D with either winding.
                cull: CullModeFlags::NONE,
                colors: &[(Format::R32_SFLOAT, Blend::None)],
                depth: Some(depth_state),
                push_constant_bytes: 0,
                sets: &[],
            },
        )?;
        // Both forms' final passes read r alone (the centred form's inner plateaus are
        // built on the plane, from the drop shadow's coverage, not from receiver depths).
        let shadow = ShadowMap::casters(ctx, init.ubo, res, names.shadow_map)?;
        let nearest = Sampler::new(ctx, Filter::Nearest)?;
        let linear = Sampler::new(ctx, Filter::Linear)?;
        let falloff = falloff_lut(ctx)?;
        let centred = match form {
            Form::Paper => None,
            Form::Centred => Some(Self::centred(init, &names, &nearest)?),
        };
        let mut bindings = vec![
            ("frame", Resource::Uniform(init.ubo)),
            ("plane", Resource::Uniform(&plane_ubo)),
            ("plateau_tex", Resource::Sampled(&texture, &nearest)),
            ("shadow_map", Resource::Sampled(&shadow.depth, &nearest)),
        ];
        match &centred {
            None => bindings.push(("falloff", Resource::Sampled(&falloff, &linear))),
            Some(c) => {
                bindings.push(("coverage", Resource::Sampled(&c.coverage, &nearest)));
                bindings.push(("inner_tex", Resource::Sampled(&c.inner, &nearest)));
            }
        }
        let final_set = DescriptorSet::new(ctx, &bindings, names.final_pass)?;
        let final_shader = match form {
            Form::Paper => FinalShader {
                color: shaders::PLATEAUS_FINAL_FRAG,
                aov: shaders::PLATEAUS_FINAL_FRAG_AOV,
                count: shaders::PLATEAUS_FINAL_FRAG_COUNT,
            },
            Form::Centred => FinalShader {
                color: shaders::PLATEAUS_CENTRED_FINAL_FRAG,
                aov: shaders::PLATEAUS_CENTRED_FINAL_FRAG_AOV,
                count: shaders::PLATEAUS_CENTRED_FINAL_FRAG_COUNT,
            },
        };
        let final_pass = FinalPass::split(ctx, names.final_pass, final_shader, &final_set)?;
        let adjacency = // The plane is never a caster of its own plateaus.
        silhouette::caster_adjacency(init.scene, |i| i != receiver.object)?;
        let casters = adjacency.iter().flatten().count();
        Ok(Box::new(Self {
            form,
            receiver,
            texture,
            zbuffer,
            plane_ubo,
            drop_pipeline,
            drop_set,
            plateau_pipeline,
            centred,
            shadow,
            final_pass,
            final_set,
            _falloff: falloff,
            _nearest: nearest,
            _linear: linear,
            cache: CasterCacheOf::new(adjacency.len()),
            adjacency,
            casters,
            vertices: DynamicVertices::new("plateau vertices"),
            around: regions::AroundCasters::default(),
            shadowed: Shadowed::Everywhere,
            texture_drawn: regions::LastDrawn::default(),
        }))
    }

    /// The centred form's coverage and inner images and its inner pipeline.
    fn centred(init: &TechniqueInit<'_>, names: &Names, nearest: &Sampler) -> Result<Centred> {
        let ctx = init.ctx;
        let res = init.settings.shadow_res;
        ctx.require_blend(Format::R16_SFLOAT, Blend::Max, names.technique)?;
        let usage = ImageUsageFlags::COLOR_ATTACHMENT
            | ImageUsageFlags::SAMPLED
            | ImageUsageFlags::TRANSFER_SRC;
        let coverage = Image::new_2d(ctx, res, res, Format::R16_SFLOAT, usage, "plateau coverage")?;
        let inner = Image::new_2d(ctx, res, res, Format::R16_SFLOAT, usage, "plateau inner")?;
        let inner_set = DescriptorSet::new(
            ctx,
            &[("coverage", Resource::Sampled(&coverage, nearest))],
            names.inner,
        )?;
        let inner_pipeline = Pipeline::graphics(
            ctx,
            &GraphicsPipelineDesc {
                name: names.inner,
                vertex: shaders::PLATEAUS_PLATEAU_VERT,
                fragment: Some(shaders::PLATEAUS_CENTRED_INNER_FRAG),
                vertex_stride: PLATEAU_VERTEX_BYTES,
                attributes: PLATEAU_ATTRIBUTES,
                topology: PrimitiveTopology::TRIANGLE_LIST,
                cull: CullModeFlags::NONE,
                // Lightest inner estimate wins.
                colors: &[(Format::R16_SFLOAT, Blend::Max)],
                depth: None,
                push_constant_bytes: 0,
                sets: &[&inner_set],
            },
        )?;
        Ok(Centred {
            coverage,
            inner,
            inner_pipeline,
            inner_set,
            inner_vertices: DynamicVertices::new("plateau inner vertices"),
        })
    }

    fn plane(&self, frame: &FrameInput<'_>) -> Result<PlaneFrame> {
        let obj = frame
            .scene
            .objects
            .get(self.receiver.object)
            .ok_or_else(|| anyhow!("plateaus: the scene lost its planar receiver"))?;
        Ok(PlaneFrame::new(
            &self.receiver,
            obj.transform,
            frame.light,
            self.texture.extent.width,
        ))
    }

    /// Per caster, the light-uv polygon outside which the final pass gives exactly 1: the
    /// plane's texels under its drop shadow and plateaus (`plane_region`), joined, for a
    /// caster in the light, with its outline there (`regions::AroundCasters`), where the
    /// shadow map's lookups can see it. `None` where one is not bounded, or a caster has no
    /// plateaus built for this frame. The caller's geometry must be this frame's (R > 0).
    fn shadow_regions(
        &mut self,
        frame: &FrameInput<'_>,
        plane: &PlaneFrame,
    ) -> Option<Vec<Support>> {
        let mut outlines: Vec<Option<Support>> = vec![None; frame.scene.objects.len()];
        for (i, s) in self.around.outlines(frame)? {
            outlines[i] = Some(s);
        }
        let mut supports = Vec::with_capacity(outlines.len());
        for (i, o) in frame.gpu.objects.iter().enumerate() {
            if !o.role.casts() {
                continue;
            }
            let outline = outlines[i];
            if i == self.receiver.object {
                // The plane casts no plateaus; a casting plane is in the shadow map only.
                supports.extend(outline);
                continue;
            }
            // The drop shadow is the central projection of the caster, bounded by its
            // silhouette vertices' only while every point of it is below the light (h < H).
            let below = o
                .world_corners()
                .iter()
                .all(|&c| plane.height(c) < plane.light_height * MAX_HEIGHT_FRACTION);
            if !below {
                return None;
            }
            let on_plane = plane_region(frame, plane, self.cache.get(i)?.reach?)?;
            supports.push(match outline {
                Some(s) => regions::union(s, on_plane),
                None => on_plane,
            });
        }
        Some(supports)
    }

    /// Silhouettes, cones and sheets of every caster that moved since theirs were built (of
    /// all when the plane frame or the radius changed, or when `force`); returns how many
    /// were rebuilt.
    fn build_geometry(&mut self, frame: &FrameInput<'_>, plane: &PlaneFrame, force: bool) -> usize {
        let radius = frame.light_radius;
        let form = self.form;
        let key = GeometryKey {
            plane: *plane,
            radius,
        };
        self.cache.update(
            &frame.scene.objects,
            &self.adjacency,
            key,
            force,
            |adj, model| {
                let sil = silhouette::extract(adj, model, plane.light);
                let build = |side: Side| {
                    let mut b = PlateauBuilder::new(plane, radius).with_side(side);
                    // Each caster's own mailbox: the casters build in parallel.
                    let mut mailbox = vec![0u64; adj.positions.len()];
                    b.silhouette(adj, &sil, model, &mut mailbox, 1);
                    (b.vertices, b.reach)
                };
                // Both sides' discs are the same silhouette vertices'.
                let (outer, reach) = build(Side::Outer);
                let inner = match form {
                    Form::Paper => Vec::new(),
                    Form::Centred => build(Side::Inner).0,
                };
                CasterPlateaus {
                    sides: [outer, inner],
                    reach,
                }
            },
        )
    }
}

impl Technique for Plateaus {
    fn name(&self) -> &'static str {
        self.form.plateau_names().technique
    }

    fn record_light(
        &mut self,
        ctx: &Context,
        rec: &mut Recorder<'_>,
        frame: &FrameInput<'_>,
    ) -> Result<()> {
        let plane = self.plane(frame)?;
        self.plane_ubo
            .write(0, bytemuck::bytes_of(&plane.uniforms()))?;
        // A light in (or under) the plane's level casts nothing onto it that it could light.
        let lit_plane = plane.light_height > plane.texel() * 1e-3;
        let soft = lit_plane && frame.light_radius > 0.0;
        let names = self.form.plateau_names();
        let (vertices, inner_vertices) = if soft {
            // Without pass caching every frame rebuilds everything (the bench's baseline).
            let force = !frame.settings.cache_light_passes;
            let rebuilt = rec.cpu(names.silhouettes, || {
                self.build_geometry(frame, &plane, force)
            });
            rec.rebuilt(names.silhouettes, rebuilt, self.casters);
            let side = |s: usize| self.cache.concat_by(|c| &c.sides[s]);
            (side(0), side(1))
        } else {
            (Vec::new(), Vec::new())
        };
        self.vertices.upload(ctx, &vertices)?;
        let res = self.shadow.resolution;
        let supports = soft.then(|| self.shadow_regions(frame, &plane)).flatten();
        self.shadowed = supports.as_ref().map_or(Shadowed::Everywhere, |supports| {
            regions::shadowed(frame, supports, res, 0.0)
        });
        // The plateau textures' texels the final pass can read, joined with last frame's.
        let read = supports.as_ref().and_then(|supports| {
            let margin = regions::lookup_margin(frame, res, 0.0)?;
            texture_texels(frame, &plane, supports, margin)
        });
        // The casters-only map's texels, joined with last frame's (both forms).
        let map_area = self.around.map_area(frame, res);
        let area = Some(self.texture_drawn.area(read))
            .filter(|_| frame.settings.light_areas)
            .flatten()
            .map(regions::render_area);
        if let Some(c) = self.centred.as_mut() {
            c.inner_vertices.upload(ctx, &inner_vertices)?;
        }

        let plane_gpu: Option<&GpuObject> = frame.gpu.objects.get(self.receiver.object);
        let draw_drop = |rec: &mut Recorder<'_>| {
            rec.bind_pipeline(&self.drop_pipeline);
            rec.bind_sets(&self.drop_pipeline, &[&self.drop_set]);
            // The plane cannot shadow itself.
            frame.gpu.draw(rec, &self.drop_pipeline, |o| {
                o.role.casts() && plane_gpu.is_none_or(|p| !std::ptr::eq(o, p))
            });
        };
        if let Some(c) = &self.centred {
            rec.pass(names.drop_shadow, |rec| {
                rec.begin_rendering_in(&[(&c.coverage, Clear::Float([1.0; 4]))], None, area);
                if lit_plane {
                    draw_drop(rec);
                }
                rec.end_rendering();
                Ok(())
            })?;
            // Outer plateaus over a cleared texture and z-buffer (no drop shadow in them),
            // then the inner ones; both passes run at R = 0 too, so that the final pass
            // always reads written images.
            rec.pass(names.plateaus, |rec| {
                rec.begin_rendering_in(
                    &[(&self.texture, Clear::Float([1.0; 4]))],
                    Some((&self.zbuffer, Some(1.0))),
                    area,
                );
                rec.discard_after(&self.zbuffer);
                if !self.vertices.is_empty() {
                    rec.bind_pipeline(&self.plateau_pipeline);
                    self.vertices.draw(rec);
                }
                rec.end_rendering();
                Ok(())
            })?;
            rec.pass(names.inner, |rec| {
                rec.begin_rendering_in(&[(&c.inner, Clear::Float([0.0; 4]))], None, area);
                if !c.inner_vertices.is_empty() {
                    rec.bind_pipeline(&c.inner_pipeline);
                    rec.bind_sets(&c.inner_pipeline, &[&c.inner_set]);
                    c.inner_vertices.draw(rec);
                }
                rec.end_rendering();
                Ok(())
            })?;
            self.shadow.pass_in(rec, frame.gpu, &map_area)?;
            return Ok(());
        }
        rec.pass(names.drop_shadow, |rec| {
            rec.begin_rendering_in(
                &[(&self.texture, Clear::Float([1.0; 4]))],
                Some((&self.zbuffer, Some(1.0))),
                area,
            );
            if lit_plane {
                draw_drop(rec);
            }
            rec.end_rendering();
            Ok(())
        })?;
        match self.vertices.is_empty() {
            false => rec.pass(names.plateaus, |rec| {
                // Load: the drop shadow's colour and depth stay in place under the plateaus.
                rec.begin_rendering_in(
                    &[(&self.texture, Clear::Load)],
                    Some((&self.zbuffer, None)),
                    area,
                );
                rec.discard_after(&self.zbuffer);
                rec.bind_pipeline(&self.plateau_pipeline);
                self.vertices.draw(rec);
                rec.end_rendering();
                Ok(())
            })?,
            _ if !lit_plane => rec.skip(names.plateaus, "light not above the plane"),
            _ if !soft => rec.skip(names.plateaus, "point light (R = 0)"),
            _ => rec.skip(names.plateaus, "no silhouette edge"),
        }
        self.shadow.pass_in(rec, frame.gpu, &map_area)?;
        Ok(())
    }

    fn light_passes(&self) -> Vec<String> {
        let names = self.form.plateau_names();
        let mut passes = vec![names.drop_shadow, names.plateaus, names.shadow_map];
        if self.centred.is_some() {
            passes.insert(2, names.inner);
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
        let mut buffers = vec![
            // The top-down plateau texture: penumbra fraction f, 0 in the drop shadow, 1 lit
            // (the centred form: the outer plateaus' fraction only, no drop shadow).
            LightBuffer {
                name: "plateaus",
                image: &self.texture,
                channels: &["fraction"],
            },
            shadow_map_buffer("shadow_map", &self.shadow),
        ];
        if let Some(c) = &self.centred {
            // 0 under a caster's drop shadow, 1 elsewhere.
            buffers.push(LightBuffer {
                name: "coverage",
                image: &c.coverage,
                channels: &["drop_shadow_visibility"],
            });
            // The lightest inner visibility in [0, 1]: disc_chord(s) in [0, 0.5] plus, for a
            // thin blocker, the share beyond its far edge (0: umbra, and where none was drawn).
            buffers.push(LightBuffer {
                name: "inner",
                image: &c.inner,
                channels: &["inner_visibility"],
            });
        }
        buffers
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{primitives, Light, Object, Role};
    use crate::silhouette::test_meshes::cube;
    use std::sync::Arc;

    fn light(position: Vec3, target: Vec3) -> LightView {
        LightView::new(
            &Light {
                position,
                target,
                fov_deg: 90.0,
                radius: 0.5,
                kind: crate::scene::LightKind::Spot,
            },
            0.1,
            50.0,
        )
    }

    fn ground_receiver() -> PlanarReceiver {
        let mesh = primitives::plane(Vec2::splat(10.0), 4);
        let (origin, normal, corners) = plane_of(&mesh).expect("the ground is planar");
        PlanarReceiver {
            object: 0,
            origin,
            normal,
            corners,
            area: 100.0,
        }
    }

    #[test]
    fn planar_detection() {
        assert!(plane_of(&primitives::plane(Vec2::splat(4.0), 3)).is_some());
        assert!(plane_of(&primitives::sphere(1.0, 16, 8)).is_none());
        assert!(plane_of(&cube()).is_none());
        let mut bumpy = primitives::plane(Vec2::splat(4.0), 3);
        bumpy.positions[5].y += 0.01;
        assert!(plane_of(&bumpy).is_none());
    }

    #[test]
    fn drop_shadow_matrix_is_the_central_projection() {
        let l = light(Vec3::new(1.0, 6.0, 0.5), Vec3::ZERO);
        let pf = PlaneFrame::new(&ground_receiver(), Mat4::IDENTITY, &l, 256);
        assert!((pf.light_height - 6.0).abs() < 1e-5, "{}", pf.light_height);
        let m = pf.drop_shadow();
        for x in [
            Vec3::new(0.3, 1.0, -0.2),
            Vec3::new(-1.0, 2.5, 1.0),
            Vec3::new(0.5, 0.0, 0.5),
        ] {
            let c = m * x.extend(1.0);
            let got = Vec2::new(c.x, c.y) / c.w;
            assert!(c.z.abs() < 1e-6);
            let (p, _) = pf.vertex_disc(x, 0.0).expect("below the light");
            let want = pf.uv(p) * 2.0 - Vec2::ONE;
            assert!((got - want).length() < 1e-4, "{got} vs {want}");
            // The projection lies on the line from the light through x, on the plane.
            let world = pf.origin + pf.u * p.x + pf.v * p.y;
            assert!(world.y.abs() < 1e-4);
            assert!(
                (world - l.position)
                    .normalize()
                    .dot((x - l.position).normalize())
                    > 0.99999
            );
        }
        let t = pf.to_texture() * Vec3::new(0.2, 0.7, -0.4).extend(1.0);
        assert!((t.z - 0.7).abs() < 1e-5);
    }

    #[test]
    fn cone_radius_is_the_outer_penumbra_of_a_parallel_disc() {
        let l = light(Vec3::new(0.0, 5.0, 0.0), Vec3::ZERO);
        let pf = PlaneFrame::new(&ground_receiver(), Mat4::IDENTITY, &l, 256);
        let (_, r) = pf
            .vertex_disc(Vec3::new(1.0, 2.0, 0.0), 0.5)
            .expect("below the light");
        // Rays from the disc's rim through the point: R h / (H - h).
        assert!((r - 0.5 * 2.0 / 3.0).abs() < 1e-5, "{r}");
        let (_, r0) = pf
            .vertex_disc(Vec3::new(1.0, 0.0, 0.0), 0.5)
            .expect("on the plane");
        assert_eq!(r0, 0.0);
        assert!(pf.vertex_disc(Vec3::new(0.0, 5.5, 0.0), 0.5).is_none());
    }

    #[test]
    fn region_is_the_frustum_footprint() {
        // A narrow light straight down sees a small part of a large ground.
        let l = LightView::new(
            &Light {
                position: Vec3::new(0.0, 4.0, 0.0),
                target: Vec3::ZERO,
                fov_deg: 30.0,
                radius: 0.1,
                kind: crate::scene::LightKind::Spot,
            },
            0.1,
            10.0,
        );
        let pf = PlaneFrame::new(&ground_receiver(), Mat4::IDENTITY, &l, 128);
        let half = 4.0 * (15.0f32).to_radians().tan();
        assert!(
            (pf.side - 2.0 * half * (1.0 + 2.0 / 128.0)).abs() < 1e-3,
            "{}",
            pf.side
        );
    }

    #[test]
    fn sheets_open_away_from_the_drop_shadow_and_inner_ones_into_it() {
        let l = light(Vec3::new(0.3, 6.0, -0.2), Vec3::ZERO);
        let pf = PlaneFrame::new(&ground_receiver(), Mat4::IDENTITY, &l, 256);
        for model in [
            Mat4::from_translation(Vec3::new(0.0, 1.5, 0.0)),
            // Mirrored: the silhouette swaps a and b, sheets must still open outwards.
            Mat4::from_translation(Vec3::new(0.5, 2.0, 0.0))
                * Mat4::from_scale(Vec3::new(-1.0, 1.0, 1.0)),
        ] {
            let adj = Adjacency::build(&cube()).expect("cube adjacency");
            let sil = silhouette::extract(&adj, model, l.position);
            assert!(sil.len() >= 4);
            let disc =
                |i: u32| pf.vertex_disc(model.transform_point3(adj.positions[i as usize]), 0.5);
            let centre = sil
                .iter()
                .filter_map(|e| disc(e.a))
                .map(|d| d.0)
                .sum::<Vec2>()
                / sil.len() as f32;
            for e in &sil {
                let (Some((c1, r1)), Some((c2, r2))) = (disc(e.a), disc(e.b)) else {
                    panic!("cube below the light");
                };
                let mut b = PlateauBuilder::new(&pf, 0.5);
                b.sheet(c1, r1, c2, r2);
                assert_eq!(b.sheets, 1);
                // Depth-1 vertices (the outer rim) lie farther from the shadow's centre.
                let to_plane = |v: &PlateauVertex| {
                    (Vec2::new(v.clip[0], v.clip[1]) + Vec2::ONE) * 0.5 * pf.side + pf.min
                };
                let mid = (c1 + c2) * 0.5;
                for v in b.vertices.iter().filter(|v| v.clip[2] == 1.0) {
                    let rim = to_plane(v);
                    assert!(
                        (rim - mid).dot(mid - centre) > 0.0,
                        "sheet of edge {e:?} opens inwards"
                    );
                }
                // plateaus-centred's inner sheet: the same edge (depth 0), its rim inside.
                let mut inner = PlateauBuilder::new(&pf, 0.5).with_side(Side::Inner);
                inner.sheet(c1, r1, c2, r2);
                assert_eq!(inner.vertices.len(), b.vertices.len());
                for (vi, vo) in inner.vertices.iter().zip(&b.vertices) {
                    assert_eq!(vi.clip[2], vo.clip[2]);
                    if vi.clip[2] == 0.0 {
                        assert_eq!(vi.clip, vo.clip);
                    }
                }
                for v in inner.vertices.iter().filter(|v| v.clip[2] == 1.0) {
                    let rim = to_plane(v);
                    assert!(
                        (rim - mid).dot(mid - centre) < 0.0,
                        "inner sheet of edge {e:?} opens outwards"
                    );
                }
            }
        }
    }

    #[test]
    fn one_cone_per_vertex_per_frame() {
        let l = light(Vec3::new(0.3, 6.0, -0.2), Vec3::ZERO);
        let pf = PlaneFrame::new(&ground_receiver(), Mat4::IDENTITY, &l, 256);
        let adj = Adjacency::build(&cube()).expect("cube adjacency");
        let model = Mat4::from_translation(Vec3::new(0.0, 1.5, 0.0));
        let sil = silhouette::extract(&adj, model, l.position);
        let mut mailbox = vec![0u64; adj.positions.len()];
        let mut b = PlateauBuilder::new(&pf, 0.5);
        b.silhouette(&adj, &sil, model, &mut mailbox, 1);
        // A closed silhouette loop has as many vertices as edges.
        assert_eq!(b.cones, sil.len());
        assert_eq!(b.sheets, sil.len());
        let mut again = PlateauBuilder::new(&pf, 0.5);
        again.silhouette(&adj, &sil, model, &mut mailbox, 1);
        assert_eq!(again.cones, 0, "same frame stamp: cones already drawn");
    }

    #[test]
    fn sphere_only_scene_has_no_planar_receiver() {
        let s = Scene {
            name: "balls".into(),
            objects: vec![Object::new(
                "ball",
                Arc::new(primitives::sphere(1.0, 16, 8)),
                Mat4::IDENTITY,
                Role::Both,
                Vec3::ONE,
            )],
            light: Light {
                position: Vec3::new(0.0, 5.0, 0.0),
                target: Vec3::ZERO,
                fov_deg: 60.0,
                radius: 0.2,
                kind: crate::scene::LightKind::Spot,
            },
            camera: crate::scene::Camera {
                position: Vec3::new(0.0, 2.0, 6.0),
                target: Vec3::ZERO,
                up: Vec3::Y,
                fov_deg: 45.0,
            },
        };
        let err = find_planar_receiver(&s).expect_err("no plane").to_string();
        assert!(
            err.contains("planar receiver") && err.contains("balls"),
            "{err}"
        );
    }
}
