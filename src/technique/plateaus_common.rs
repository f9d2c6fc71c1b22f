//! The building blocks both plateaus forms (`plateaus`, src/technique/plateaus.rs, and
//! `plateaus-centred`, src/technique/plateaus_centred.rs) share: the planar receiver, the
//! plane frame with the relations (P1)-(P3) of plateaus.rs's header, the cone and sheet
//! builder, and `PlateauCommon`, the GPU objects and per-frame work both forms make alike.
//!
//! ## The planar receiver
//! At creation, every receiving object whose triangles all lie in one plane within
//! `PLANAR_TOLERANCE` x its bounds diagonal (object space; the normal is taken from its
//! largest triangle) is a candidate; the one with the largest world area is THE plane. None:
//! `create` fails with "plateaus needs a planar receiver: scene 'X' has none". Each frame the
//! plane follows its object's transform; its normal n is flipped to the light's side.
//!
//! ## The texture's square
//! The plane object's bounding rectangle (in the plane) clipped to the light frustum
//! (Sutherland-Hodgman against its four sides and near plane), its bounding square in plane
//! coordinates plus one texel each side, at `Settings::shadow_res`^2 texels. It depends on
//! the plane's transform, the light (position, target, fov) and the resolution, not on the
//! casters: the frustum's sides do not move with the fitted near/far, and
//! `frustum::fit_light` puts near 1 % in front of every object it sees, the plane included,
//! so the near plane never cuts the lit part of the plane (only its far * 1e-4 floor could,
//! for a plane almost touching the light).
//!
//! ## Cones and sheets
//! Cones are fans of clamp(2 r / texel, 8, 64) segments (chord sagitta under ~0.3 texel).
//! Sheets are the bilinear (Coons) patch S(s, t) = c(s) + t r(s) m of (P3), depth t,
//! tessellated into an N x N grid with N = ceil(sqrt(|r1 - r2| / texel)) (the bilinear
//! cross term then bends less than 1/4 texel inside a cell). No sheet when one disc holds
//! the other (|a| >= 1): its cone covers the other. Each silhouette vertex gets one cone per
//! caster build (the paper's mailbox, a build stamp per welded vertex of that caster, one
//! mailbox per caster build so that casters build in parallel; a vertex belongs to one
//! caster, so per-caster builds keep "one cone per vertex per frame").
//!
//! ## Reuse
//! Cones and sheets are kept per caster (`gpu::passes::CasterCacheOf`) with the key
//! (`PlaneFrame`, R): a caster whose model matrix changed rebuilds only its own silhouette
//! and geometry, the others are reused and everything is concatenated in object order (the
//! same vertex buffer a full rebuild makes, so the same image bit for bit). `--plain`
//! (without `cache_light_passes`) rebuilds every caster every frame. The GPU passes redraw
//! every caster whenever anything moved: the texture's texels hold the darkest of all
//! casters' plateaus, so a moved caster's old plateaus cannot be taken out alone.

use super::speed::plateaus::{Areas, PlateauAreas};
use super::{FrameInput, TechniqueInit};
use crate::gpu::gpu_scene::GpuObject;
use crate::gpu::passes::{CasterCacheOf, DynamicVertices, ShadowMap};
use crate::scene::{normal_matrix, Aabb, LightView, Mesh, Scene};
use crate::silhouette::{self, Adjacency, Side, SilhouetteEdge};
use crate::technique::regions::{self, Support};
use crate::vk::{
    Buffer, BufferUsageFlags, Context, DescriptorSet, Filter, Format, Image, ImageUsageFlags,
    MemoryLocation, Pipeline, Recorder, Resource, Sampler,
};
use anyhow::{anyhow, Result};
use bytemuck::{Pod, Zeroable};
use glam::{Mat4, Vec2, Vec3, Vec4};
use std::collections::HashMap;
use std::sync::Arc;

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
pub(crate) const MAX_HEIGHT_FRACTION: f32 = 0.99;

/// A sun's stand-in light point for the silhouettes' facing test, in plane diagonals
/// along its direction: the rays to it stray from the sun's direction by under a
/// millionth of a radian over the plane, and f32 still holds it with the plane's points.
const SUN_DISTANCE: f32 = 1e6;

/// One plateau vertex: texture clip-space x, y and the depth (= penumbra fraction).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct PlateauVertex {
    pub clip: [f32; 3],
}

pub(crate) const PLATEAU_VERTEX_BYTES: u32 = std::mem::size_of::<PlateauVertex>() as u32;
pub(crate) const PLATEAU_ATTRIBUTES: &[crate::vk::Attribute] = &[(0, Format::R32G32B32_SFLOAT, 0)];

/// A vertex of plateaus-centred's inner cones and sheets: the plateau vertex and
/// `from_edge`, the clip-space step from the point of the hard edge (a cone's apex, a
/// sheet's edge point) whose spoke or ruling reaches it, 0 at depth 0. Interpolated, it
/// leads every fragment back to its own edge point, which t's gradient does not where a
/// sheet's rim is not parallel to its edge (the inner pass's hidden-edge test).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct PlateauEdgeVertex {
    pub clip: [f32; 3],
    pub from_edge: [f32; 2],
}

pub(crate) const PLATEAU_EDGE_VERTEX_BYTES: u32 = std::mem::size_of::<PlateauEdgeVertex>() as u32;
pub(crate) const PLATEAU_EDGE_ATTRIBUTES: &[crate::vk::Attribute] = &[
    (0, Format::R32G32B32_SFLOAT, 0),
    (1, Format::R32G32_SFLOAT, 12),
];

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
    /// The light centre; a sun's: a point `SUN_DISTANCE` plane diagonals away towards it,
    /// which only the silhouettes' facing test reads.
    pub light: Vec3,
    /// H: the light centre's height above the plane.
    pub light_height: f32,
    /// A sun: its unit direction towards the light, (P1s)-(P2s) in place of (P1)-(P2).
    pub sun: Option<Vec3>,
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
        // A sun's view looks along -(its direction): the view's z row.
        let sun = light
            .sun
            .map(|_| light.view.row(2).truncate().normalize_or(Vec3::Y));
        let towards = sun.unwrap_or(light.position - origin);
        if n.dot(towards) < 0.0 {
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
        let light_pos = match sun {
            Some(d) => origin + d * (SUN_DISTANCE * diag.max(f32::MIN_POSITIVE)),
            None => light.position,
        };
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
            light: light_pos,
            light_height: n.dot(light_pos - origin),
            sun,
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

    /// Where `x` lands on the plane seen from the light centre (P1), with its cone's base:
    /// the radius across the light's azimuth for a light of radius `radius` (P2) and the
    /// stretch along it (P2e); `None` above `MAX_HEIGHT_FRACTION` of the light. A sun:
    /// (P1s), (P2s) with `radius` = tan(theta), and its stretch.
    pub fn vertex_disc(&self, x: Vec3, radius: f32) -> Option<Disc> {
        let big_h = self.light_height;
        let h = self.height(x);
        if let Some(d) = self.sun {
            let dn = self.n.dot(d);
            if h.is_nan() || dn <= 0.0 {
                return None;
            }
            let c = self.coords(x - d * (h / dn));
            // The shadow moves away from the sun's azimuth as h grows.
            let away = -Vec2::new(d.dot(self.u), d.dot(self.v));
            return Some(Disc::new(c, radius * h.max(0.0) / dn, away, 1.0 / dn));
        }
        if h.is_nan() || h >= big_h * MAX_HEIGHT_FRACTION {
            return None;
        }
        let p = self.light + (x - self.light) * (big_h / (big_h - h));
        let c = self.coords(p);
        // The ray from the light through x meets the plane at cos(angle) = (H - h) / |L - x|
        // to its normal: 1 / that is the stretch, along the ray's azimuth on the plane.
        let away = c - self.coords(self.light);
        let stretch = (x - self.light).length() / (big_h - h);
        Some(Disc::new(
            c,
            radius * h.max(0.0) / (big_h - h),
            away,
            stretch,
        ))
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
        let to_clip = Mat4::from_cols(
            Vec4::new(2.0, 0.0, 0.0, 0.0),
            Vec4::new(0.0, 2.0, 0.0, 0.0),
            Vec4::ZERO,
            Vec4::new(-1.0, -1.0, 0.0, 1.0),
        );
        if let Some(d) = self.sun {
            // (P1s): x -> x - d h(x) / (n . d), affine (w = 1).
            let dn = n.dot(d);
            let col = |j: usize| (Vec3::AXES[j] - d * (n[j] / dn)).extend(0.0);
            let along = Mat4::from_cols(col(0), col(1), col(2), (d * (n_o / dn)).extend(1.0));
            return to_clip * self.to_texture() * along;
        }
        // (x, 1) -> (H x - h(x) L, H - h(x)) with h(x) = n.x - n.O.
        let col = |j: usize| {
            let mut e = Vec3::ZERO;
            e[j] = big_h;
            (e - l * n[j]).extend(-n[j])
        };
        let blinn = Mat4::from_cols(col(0), col(1), col(2), (l * n_o).extend(big_h + n_o));
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

/// The largest stretch drawn: (P2e) is the ray cone's section for a light disc small
/// against the ray's angle to the plane. Lower (k > 4: a ray within 14.5 degrees of the
/// plane), its section is no longer near an ellipse around P(x): the side away from the
/// light runs out towards where the disc meets the horizon, the side towards it stays short.
const MAX_STRETCH: f32 = 4.0;

/// A cone's base on the plane (plane coordinates): an ellipse around `c` whose semi-axis
/// across the light's azimuth is `r` ((P2) or (P2s)) and along it `k r` ((P2e): the disc
/// light's cone of rays through a point meets the plane at the angle of the ray from the
/// light, which stretches the paper's circle, Sec. 3's "cones with elliptical bases, with
/// the major axis of the ellipse pointing towards the light").
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Disc {
    pub c: Vec2,
    pub r: f32,
    /// Unit azimuth (plane coordinates) the ellipse is stretched along; zero: a circle.
    pub a: Vec2,
    /// The stretch, >= 1.
    pub k: f32,
}

impl Disc {
    fn new(c: Vec2, r: f32, away: Vec2, stretch: f32) -> Self {
        let a = away.normalize_or_zero();
        let k = if stretch.is_finite() {
            stretch.clamp(1.0, MAX_STRETCH)
        } else {
            1.0
        };
        Disc { c, r, a, k }
    }

    /// The ellipse's frame applied to `p` (relative to its centre): `p` stretched by k
    /// along a.
    fn stretch(&self, p: Vec2, k: f32) -> Vec2 {
        p + self.a * ((k - 1.0) * p.dot(self.a))
    }

    /// Its reach along the unit direction `dir`: the support of the ellipse.
    pub fn support(&self, dir: Vec2) -> f32 {
        dir.dot(self.c) + self.r * self.stretch(dir, self.k).length()
    }
}

/// One silhouette edge at a vertex (`Turn`): its plane direction from its first vertex to
/// its second, whether it arrives at the vertex, and the cone radius at its other end.
#[derive(Clone, Copy, Debug, Default)]
struct EdgeEnd {
    along: Vec2,
    arriving: bool,
    r_other: f32,
}

/// The most edges at one vertex whose corners `PlateauBuilder::sheets_cover` judges; a
/// vertex with more keeps its cones.
const MAX_TURN_EDGES: usize = 8;

/// The silhouette's edges at one vertex (`PlateauBuilder::sheets_cover`): the first
/// `MAX_TURN_EDGES` of them, how many there are, and the cone radius at the vertex.
#[derive(Clone, Copy, Debug, Default)]
struct Turn {
    count: usize,
    r: f32,
    edges: [EdgeEnd; MAX_TURN_EDGES],
}

impl Turn {
    fn push(&mut self, end: EdgeEnd, r: f32) {
        if let Some(slot) = self.edges.get_mut(self.count) {
            *slot = end;
        }
        self.count += 1;
        self.r = r;
    }
}

/// Radians by which two sheets must overlap at a vertex before its cone is left out: their
/// ends are solved in each edge's own stretch (`sheet`), which `sheets_cover`'s lean test
/// ignores.
const TRIM_MARGIN: f32 = 0.05;

/// Cones and sheets of one frame, in texture clip space.
pub struct PlateauBuilder<'a> {
    plane: &'a PlaneFrame,
    radius: f32,
    /// Which side of the edges the sheets open to: outward (the paper's), or inward into
    /// the drop shadow (plateaus-centred's inner sheets).
    side: Side,
    /// Cone bases: the paper's basic circles, or Sec. 3's ellipses (`Disc`).
    ellipses: bool,
    /// Draw a vertex's cone only where the sheets on `side` leave a gap at it (`silhouette`).
    trim_cones: bool,
    pub vertices: Vec<PlateauVertex>,
    /// Per vertex of `vertices`, its `PlateauEdgeVertex::from_edge`; kept on the inner side
    /// only (`edge_vertices`).
    from_edge: Vec<[f32; 2]>,
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
            ellipses: false,
            trim_cones: false,
            vertices: Vec::new(),
            from_edge: Vec::new(),
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

    /// The same builder with elliptical cone bases (`Disc`): plateaus-centred's. The paper
    /// form keeps its basic algorithm's circles.
    pub fn with_ellipses(mut self) -> Self {
        self.ellipses = true;
        self
    }

    /// The same builder drawing a vertex's cone only where its side's sheets leave a gap
    /// (`silhouette`): plateaus-centred's. The paper form draws one at every vertex.
    pub fn with_trimmed_cones(mut self) -> Self {
        self.trim_cones = true;
        self
    }

    /// The inner side's vertices with their `from_edge` (plateaus-centred's inner pass).
    pub fn edge_vertices(&self) -> Vec<PlateauEdgeVertex> {
        self.vertices
            .iter()
            .zip(&self.from_edge)
            .map(|(v, &from_edge)| PlateauEdgeVertex {
                clip: v.clip,
                from_edge,
            })
            .collect()
    }

    /// A point in texture clip space with its depth.
    fn clip(&self, p: Vec2, depth: f32) -> [f32; 3] {
        let c = self.plane.uv(p) * 2.0 - Vec2::ONE;
        [c.x, c.y, depth]
    }

    /// A cone with its apex at the disc's centre (depth 0) and its base ellipse (depth 1).
    pub fn cone(&mut self, disc: &Disc) {
        let (c, r) = (disc.c, disc.r);
        let texels = r * disc.k / self.plane.texel();
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
                .map(|&d| self.clip(c + disc.stretch(d * r, disc.k), 1.0)),
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
        if self.side == Side::Inner {
            // Along each spoke from the apex.
            let step = |w: [f32; 3]| [w[0] - apex.clip[0], w[1] - apex.clip[1]];
            for w in points.windows(2) {
                self.from_edge
                    .extend_from_slice(&[[0.0; 2], step(w[0]), step(w[1])]);
            }
        }
        self.points = points;
        self.cones += 1;
    }

    /// The sheet on the outer (right-hand) side of the edge between the discs' centres (the
    /// inner side for `Side::Inner`), (P3). Two ellipses have no common tangent in closed
    /// form: the sheet takes one stretch for both, the radius-weighted mean of theirs (the
    /// larger disc's where the other is a point), and solves (P3) where that stretch is
    /// undone, so it is tangent to both cones where their stretches agree.
    pub fn sheet(&mut self, d1: &Disc, d2: &Disc) {
        let texel = self.plane.texel();
        let (r1, r2) = (d1.r, d2.r);
        if r1.max(r2).is_nan() || r1.max(r2) <= texel * 1e-3 {
            return;
        }
        let axis = d1.a * (r1 * d1.k) + d2.a * (r2 * d2.k);
        let k = (r1 * d1.k + r2 * d2.k) / (r1 + r2);
        let frame = Disc::new(Vec2::ZERO, 0.0, axis, k);
        // (P3) in the frame where the sheet's ellipses are circles.
        let (c1, c2) = (
            frame.stretch(d1.c, 1.0 / frame.k),
            frame.stretch(d2.c, 1.0 / frame.k),
        );
        let d = c2 - c1;
        let len = d.length();
        if len.is_nan() || len <= texel * 1e-3 {
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
                let p = c1 + d * s + m * (t * (r1 + (r2 - r1) * s));
                points.push(self.clip(frame.stretch(p, frame.k), t));
            }
        }
        let point = |i: u32, j: u32| points[(i * (n + 1) + j) as usize];
        let inner = self.side == Side::Inner;
        self.vertices.reserve(6 * (n * n) as usize);
        for i in 0..n {
            for j in 0..n {
                let q = [(i, j), (i + 1, j), (i + 1, j + 1), (i, j + 1)];
                for k in [0, 1, 2, 0, 2, 3] {
                    let (qi, qj) = q[k];
                    let p = point(qi, qj);
                    self.vertices.push(PlateauVertex { clip: p });
                    if inner {
                        // Along the ruling from row qi's edge point (j = 0).
                        let e = point(qi, 0);
                        self.from_edge.push([p[0] - e[0], p[1] - e[1]]);
                    }
                }
            }
        }
        self.points = points;
        self.sheets += 1;
    }

    /// Whether the sheets on this builder's side cover all a cone at `vertex` would. Where
    /// the silhouette turns away from that side by psi (convex corners for the inner side,
    /// reflex ones for the outer), the two edges' strips overlap there; each sheet's end
    /// leans off the edge's normal by asin(a), a = (P3)'s (r1 - r2) / |c2 - c1|, and they
    /// still meet while the outgoing sheet's lean less the incoming one's stays below psi
    /// (by `TRIM_MARGIN`). Every point of the side near the vertex then lies in a sheet at a
    /// t no larger than the cone's, so the cone loses everywhere (the outer side's LESS,
    /// the inner side's MAX of disc_chord(t)).
    ///
    /// Where two silhouette curves pass through one vertex (four or six edges, at the
    /// saddles of a bumpy blob), the edges' rays from the vertex, in angular order,
    /// alternate between arriving and leaving, and so do the sectors between them: inside
    /// counter-clockwise of a leaving ray (the inside lies left of each edge), outside
    /// counter-clockwise of an arriving one. Each of this side's sectors is the corner of
    /// the arriving and the leaving edge that bound it, judged as above; the cone is left
    /// out when every one is covered (the other side's sectors are the other pass's). A
    /// vertex with an odd number of edges (a chain's end), whose rays do not alternate (a
    /// fold of the projected silhouette, where the inside is not left of every edge), or
    /// with more than `MAX_TURN_EDGES` edges keeps its cone.
    fn sheets_cover(&self, turns: &HashMap<u32, Turn>, vertex: u32) -> bool {
        let Some(t) = turns.get(&vertex) else {
            return false;
        };
        let n = t.count;
        if !(2..=MAX_TURN_EDGES).contains(&n) || !n.is_multiple_of(2) {
            return false;
        }
        let edges = &t.edges[..n];
        if !edges.iter().all(|e| e.along.length() > 0.0) {
            return false;
        }
        let ray = |e: &EdgeEnd| if e.arriving { -e.along } else { e.along };
        let mut order: [usize; MAX_TURN_EDGES] = std::array::from_fn(|i| i);
        order[..n].sort_unstable_by(|&a, &b| {
            let (a, b) = (ray(&edges[a]), ray(&edges[b]));
            a.y.atan2(a.x).total_cmp(&b.y.atan2(b.x))
        });
        let lean = |a: f32| a.clamp(-1.0, 1.0).asin();
        (0..n).all(|k| {
            let (first, next) = (&edges[order[k]], &edges[order[(k + 1) % n]]);
            if first.arriving == next.arriving {
                return false;
            }
            // Counter-clockwise of an arriving ray lies the outside.
            if first.arriving != (self.side == Side::Outer) {
                return true;
            }
            let (into, out) = if first.arriving {
                (first, next)
            } else {
                (next, first)
            };
            // The left turn from the arriving edge to the leaving one: psi for the inner
            // side, -psi for the outer (pi less the sector's angle, either way).
            let left = into
                .along
                .perp_dot(out.along)
                .atan2(into.along.dot(out.along));
            let psi = match self.side {
                Side::Inner => left,
                Side::Outer => -left,
            };
            let a_in = (into.r_other - t.r) / into.along.length();
            let a_out = (t.r - out.r_other) / out.along.length();
            psi > 0.0 && lean(a_out) - lean(a_in) <= psi - TRIM_MARGIN
        })
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
        let (plane, radius, ellipses) = (self.plane, self.radius, self.ellipses);
        let disc = |i: u32| {
            let x = model.transform_point3(*adj.positions.get(i as usize)?);
            let d = plane.vertex_disc(x, radius)?;
            Some(if ellipses { d } else { Disc { k: 1.0, ..d } })
        };
        // Each edge's two discs, once: the turns and the geometry below both read them.
        let discs: Vec<_> = sil.iter().map(|e| (disc(e.a), disc(e.b))).collect();
        let mut turns: HashMap<u32, Turn> = HashMap::new();
        if self.trim_cones {
            for (e, ends) in sil.iter().zip(&discs) {
                let &(Some(da), Some(db)) = ends else {
                    continue;
                };
                let along = db.c - da.c;
                let leaving = EdgeEnd {
                    along,
                    arriving: false,
                    r_other: db.r,
                };
                turns.entry(e.a).or_default().push(leaving, da.r);
                let arriving = EdgeEnd {
                    along,
                    arriving: true,
                    r_other: da.r,
                };
                turns.entry(e.b).or_default().push(arriving, db.r);
            }
        }
        for (e, &(da, db)) in sil.iter().zip(&discs) {
            self.reach = match (self.reach, da, db) {
                (Some(s), Some(a), Some(b)) => Some(std::array::from_fn(|k| {
                    s[k].max(a.support(dirs[k])).max(b.support(dirs[k]))
                })),
                _ => None,
            };
            for (i, d) in [(e.a, da), (e.b, db)] {
                let (Some(disc), Some(slot)) = (d, mailbox.get_mut(i as usize)) else {
                    continue;
                };
                if *slot != stamp {
                    *slot = stamp;
                    if !(self.trim_cones && self.sheets_cover(&turns, i)) {
                        self.cone(&disc);
                    }
                }
            }
            if let (Some(a), Some(b)) = (da, db) {
                self.sheet(&a, &b);
            }
        }
    }
}

/// The light's spread that (P2) or (P2s) scales: a spotlight's radius R, a sun's
/// tan(theta).
fn spread(frame: &FrameInput<'_>) -> f32 {
    match frame.light.sun {
        Some(sun) => sun.tan_angle,
        None => frame.light_radius,
    }
}

/// One caster's plateaus.
struct CasterPlateaus {
    /// Its cones and outer sheets.
    outer: Vec<PlateauVertex>,
    /// Its cones and inner sheets (the centred form; empty in the paper form).
    inner: Vec<PlateauEdgeVertex>,
    /// `PlateauBuilder::reach`: where on the plane its plateaus, and its drop shadow, lie.
    reach: Option<Support>,
}

/// What a caster's cones and sheets depend on besides its model: the plane frame (the
/// plane, the light centre, the texture square and resolution) and the light radius.
#[derive(Clone, Copy, Debug, PartialEq)]
struct GeometryKey {
    plane: PlaneFrame,
    radius: f32,
}

/// What both forms make alike: the planar receiver and its plane uniforms, the plateau
/// texture and its z-buffer, the drop shadow pass's set, the casters-only shadow map, the
/// casters' cones and sheets, and the speed layer's state.
pub(crate) struct PlateauCommon {
    pub receiver: PlanarReceiver,
    /// R32_SFLOAT, the outer penumbra fraction f (the paper form: 0 in the drop shadow).
    pub texture: Image,
    /// D32_SFLOAT, the plateaus' depth: darkest wins (LESS).
    pub zbuffer: Image,
    /// `Plane` of glsl/plateaus/plane.glsl, written at every light frame.
    pub plane_ubo: Buffer,
    /// The drop shadow pass's set: `frame`, `plane`.
    pub drop_set: DescriptorSet,
    /// Every caster's cones and outer sheets.
    pub vertices: DynamicVertices,
    /// The casters-only shadow map, for receivers other than the plane.
    pub shadow: ShadowMap,
    pub nearest: Sampler,
    /// Edge adjacency per object (None for non-casters and the plane), built once per mesh
    /// and shared by the objects that instance it (`silhouette::caster_adjacency`).
    adjacency: Vec<Option<Arc<Adjacency>>>,
    /// Casters (objects with an adjacency).
    casters: usize,
    /// Per caster, its cones and sheets and the key they were built for.
    cache: CasterCacheOf<GeometryKey, CasterPlateaus>,
    /// Speed layer: speed::plateaus (light-pass areas, the split final pass).
    pub speed: PlateauAreas,
}

/// What one light frame's passes need to know (`PlateauCommon::prepare`).
pub(crate) struct PlateauFrame {
    /// The light is above the plane: it can cast something onto it.
    pub lit_plane: bool,
    /// ... and R > 0: the frame draws plateaus.
    pub soft: bool,
    /// The cones and inner sheets (the centred form; empty otherwise).
    pub inner: Vec<PlateauEdgeVertex>,
    /// Where the light passes clear and draw (speed layer; whole under `--plain`).
    pub areas: Areas,
}

impl PlateauCommon {
    /// `drop_shadow` and `shadow_map`: the form's pass names of its drop shadow set and
    /// shadow map.
    pub fn new(init: &TechniqueInit<'_>, drop_shadow: &str, shadow_map: &str) -> Result<Self> {
        let ctx = init.ctx;
        let res = init.settings.shadow_res;
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
        let drop_set = DescriptorSet::new(
            ctx,
            &[
                ("frame", Resource::Uniform(init.ubo)),
                ("plane", Resource::Uniform(&plane_ubo)),
            ],
            drop_shadow,
        )?;
        let shadow = ShadowMap::casters(ctx, init.ubo, res, shadow_map)?;
        let nearest = Sampler::new(ctx, Filter::Nearest)?;
        // The plane is never a caster of its own plateaus.
        let adjacency = silhouette::caster_adjacency(init.scene, |i| i != receiver.object)?;
        Ok(Self {
            receiver,
            texture,
            zbuffer,
            plane_ubo,
            drop_set,
            vertices: DynamicVertices::new("plateau vertices"),
            shadow,
            nearest,
            cache: CasterCacheOf::new(adjacency.len()),
            casters: adjacency.iter().flatten().count(),
            adjacency,
            speed: PlateauAreas::new(),
        })
    }

    /// The frame's plane (its uniforms written), every caster's plateaus (CPU pass
    /// `silhouettes`, only when soft; the cones and inner sheets too when `inner`), the
    /// outer ones uploaded to `vertices`, and the speed layer's plan.
    pub fn prepare(
        &mut self,
        ctx: &Context,
        rec: &mut Recorder<'_>,
        frame: &FrameInput<'_>,
        silhouettes: &str,
        inner: bool,
    ) -> Result<PlateauFrame> {
        let obj = frame
            .scene
            .objects
            .get(self.receiver.object)
            .ok_or_else(|| anyhow!("plateaus: the scene lost its planar receiver"))?;
        let plane = PlaneFrame::new(
            &self.receiver,
            obj.transform,
            frame.light,
            self.texture.extent.width,
        );
        self.plane_ubo
            .write(0, bytemuck::bytes_of(&plane.uniforms()))?;
        // A light in (or under) the plane's level casts nothing onto it that it could light.
        let lit_plane = plane.light_height > plane.texel() * 1e-3;
        let soft = lit_plane && spread(frame) > 0.0;
        let (outer, inner) = if soft {
            // Without pass caching every frame rebuilds everything (the bench's baseline).
            let force = !frame.settings.cache_light_passes;
            let rebuilt = rec.cpu(silhouettes, || {
                self.build_geometry(frame, &plane, inner, force)
            });
            rec.rebuilt(silhouettes, rebuilt, self.casters);
            (
                self.cache.concat_by(|c| &c.outer),
                self.cache.concat_by(|c| &c.inner),
            )
        } else {
            (Vec::new(), Vec::new())
        };
        self.vertices.upload(ctx, &outer)?;
        let cache = &self.cache;
        let areas = self
            .speed
            .plan(frame, &plane, self.receiver.object, soft, |i| {
                cache.get(i).map(|c| c.reach)
            });
        Ok(PlateauFrame {
            lit_plane,
            soft,
            inner,
            areas,
        })
    }

    /// Silhouettes, cones and sheets (inner ones too when `inner`) of every caster that
    /// moved since theirs were built (of all when the plane frame or the radius changed,
    /// or when `force`); returns how many were rebuilt.
    fn build_geometry(
        &mut self,
        frame: &FrameInput<'_>,
        plane: &PlaneFrame,
        inner: bool,
        force: bool,
    ) -> usize {
        let radius = spread(frame);
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
                    if inner {
                        b = b.with_ellipses().with_trimmed_cones();
                    }
                    // Each caster's own mailbox: the casters build in parallel.
                    let mut mailbox = vec![0u64; adj.positions.len()];
                    b.silhouette(adj, &sil, model, &mut mailbox, 1);
                    b
                };
                // Both sides' discs are the same silhouette vertices'.
                let outer = build(Side::Outer);
                let inner = match inner {
                    false => Vec::new(),
                    true => build(Side::Inner).edge_vertices(),
                };
                CasterPlateaus {
                    outer: outer.vertices,
                    inner,
                    reach: outer.reach,
                }
            },
        )
    }

    /// Draws every caster but the plane (which cannot shadow itself) with `pipeline`, the
    /// drop shadow's, and `drop_set`.
    pub fn draw_drop_shadow(
        &self,
        rec: &mut Recorder<'_>,
        frame: &FrameInput<'_>,
        pipeline: &Pipeline,
    ) {
        let plane_gpu: Option<&GpuObject> = frame.gpu.objects.get(self.receiver.object);
        rec.bind_pipeline(pipeline);
        rec.bind_sets(pipeline, &[&self.drop_set]);
        frame.gpu.draw(rec, pipeline, |o| {
            o.role.casts() && plane_gpu.is_none_or(|p| !std::ptr::eq(o, p))
        });
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
            let p = pf.vertex_disc(x, 0.0).expect("below the light").c;
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
        let r = pf
            .vertex_disc(Vec3::new(1.0, 2.0, 0.0), 0.5)
            .expect("below the light")
            .r;
        // Rays from the disc's rim through the point: R h / (H - h).
        assert!((r - 0.5 * 2.0 / 3.0).abs() < 1e-5, "{r}");
        let r0 = pf
            .vertex_disc(Vec3::new(1.0, 0.0, 0.0), 0.5)
            .expect("on the plane")
            .r;
        assert_eq!(r0, 0.0);
        assert!(pf.vertex_disc(Vec3::new(0.0, 5.5, 0.0), 0.5).is_none());
    }

    /// (P2e): a small disc light facing the point x, radius R, at L; the rays from its rim
    /// through x, traced to the plane, land on an ellipse whose half-axes are measured here
    /// against the disc's.
    fn traced_half_axes(pf: &PlaneFrame, l: Vec3, x: Vec3, radius: f32) -> (Vec2, f32, f32) {
        let axis = (x - l).normalize();
        let (e1, e2) = axis.any_orthonormal_pair();
        let hit = |q: Vec3| {
            let d = x - q;
            let t = -pf.height(q) / d.dot(pf.n);
            pf.coords(q + d * t)
        };
        let centre = hit(l);
        let rim: Vec<Vec2> = (0..720)
            .map(|i| {
                let a = std::f32::consts::TAU * i as f32 / 720.0;
                hit(l + (e1 * a.cos() + e2 * a.sin()) * radius) - centre
            })
            .collect();
        let away = (centre - pf.coords(l)).normalize();
        let along = rim.iter().map(|p| p.dot(away).abs()).fold(0.0f32, f32::max);
        let across = rim
            .iter()
            .map(|p| p.perp_dot(away).abs())
            .fold(0.0f32, f32::max);
        (centre, along, across)
    }

    #[test]
    fn a_low_light_stretches_the_cone_base_towards_the_light() {
        // Light low over the ground, far to the side: the rays meet the plane at a slant.
        let l = light(Vec3::new(-6.0, 3.0, 1.0), Vec3::ZERO);
        let pf = PlaneFrame::new(&ground_receiver(), Mat4::IDENTITY, &l, 256);
        let x = Vec3::new(0.5, 1.2, -0.3);
        let radius = 1e-3;
        let disc = pf.vertex_disc(x, radius).expect("below the light");
        let (centre, along, across) = traced_half_axes(&pf, l.position, x, radius);
        assert!((disc.c - centre).length() < 1e-4, "{} vs {centre}", disc.c);
        // Across the azimuth the half-axis is (P2)'s radius, along it k times that.
        assert!(
            (disc.r - across).abs() < 0.01 * across,
            "{} vs {across}",
            disc.r
        );
        assert!(
            (disc.r * disc.k - along).abs() < 0.01 * along,
            "{} vs {along}",
            disc.r * disc.k
        );
        assert!(disc.k > 1.5, "the slant stretches: k {}", disc.k);
        let away = (centre - pf.coords(l.position)).normalize();
        assert!(disc.a.dot(away) > 0.9999, "major axis along the azimuth");
        // Straight below the light the base is a circle.
        let below = pf
            .vertex_disc(Vec3::new(-6.0, 1.0, 1.0), radius)
            .expect("below");
        assert!((below.k - 1.0).abs() < 1e-5, "{}", below.k);
        // The support along the azimuth reaches k r, across it r.
        assert!((disc.support(disc.a) - disc.a.dot(disc.c) - disc.r * disc.k).abs() < 1e-6);
        let perp = disc.a.perp();
        assert!((disc.support(perp) - perp.dot(disc.c) - disc.r).abs() < 1e-6);
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
                .map(|d| d.c)
                .sum::<Vec2>()
                / sil.len() as f32;
            for e in &sil {
                let (Some(d1), Some(d2)) = (disc(e.a), disc(e.b)) else {
                    panic!("cube below the light");
                };
                let (c1, c2) = (d1.c, d2.c);
                let mut b = PlateauBuilder::new(&pf, 0.5);
                b.sheet(&d1, &d2);
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
                inner.sheet(&d1, &d2);
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
    fn inner_vertices_lead_back_to_their_edge_points() {
        let l = light(Vec3::new(0.3, 6.0, -0.2), Vec3::ZERO);
        let pf = PlaneFrame::new(&ground_receiver(), Mat4::IDENTITY, &l, 256);
        // Two silhouette points at different heights: discs of two sizes and stretches, so
        // the sheet's rim is not parallel to its edge.
        let d1 = pf.vertex_disc(Vec3::new(0.0, 1.0, 0.0), 0.5).unwrap();
        let d2 = pf.vertex_disc(Vec3::new(0.6, 2.5, 0.2), 0.5).unwrap();
        assert!((d1.r - d2.r).abs() > 0.05, "{} {}", d1.r, d2.r);
        let clip = |p: Vec2| (p - pf.min) / pf.side * 2.0 - Vec2::ONE;
        let (e1, e2) = (clip(d1.c), clip(d2.c));
        let mut b = PlateauBuilder::new(&pf, 0.5)
            .with_side(Side::Inner)
            .with_ellipses();
        b.sheet(&d1, &d2);
        let sheet = b.edge_vertices();
        b.cone(&d2);
        let all = b.edge_vertices();
        assert_eq!(all.len(), b.vertices.len());
        assert!(sheet.len() >= 6 && all.len() > sheet.len());
        let start =
            |v: &PlateauEdgeVertex| Vec2::new(v.clip[0], v.clip[1]) - Vec2::from(v.from_edge);
        let side = (e2 - e1).length();
        let mut slanted = 0;
        for v in &sheet {
            // Its ruling starts on the edge between the two centres.
            let e = start(v);
            let along = (e - e1).dot(e2 - e1) / (side * side);
            let off = (e - e1).perp_dot(e2 - e1).abs() / side;
            assert!(
                off < 1e-5 && (-1e-5..=1.0 + 1e-5).contains(&along),
                "{v:?}: {along} {off}"
            );
            if v.clip[2] == 0.0 {
                assert_eq!(v.from_edge, [0.0; 2]);
            } else {
                // Leaning off the edge's normal (the rim is not parallel to the edge).
                let step = Vec2::from(v.from_edge).normalize();
                slanted += usize::from(step.dot((e2 - e1) / side).abs() > 1e-3);
            }
        }
        assert!(slanted > 0, "every ruling is square to the edge");
        // The cone's spokes start at its apex.
        for v in &all[sheet.len()..] {
            assert!((start(v) - e2).length() < 1e-5, "{v:?}");
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
