//! The reference smoothie construction (Chan & Durand 2003, Sec. 3 step 3 and Sec. 3.1;
//! Volokh, Sec. 3.1): screen-space quads outside each silhouette edge and fans around
//! silhouette vertices, emitted as one triangle list of [`SmoothieVertex`] for the smoothie
//! pass. **This is the construction to port**: [`build_smoothies_width`] follows the rules
//! below one by one and its output is the geometry the smoothie pass is specified to draw.
//!
//! The renderer draws two optimisations of it, each held to it by a test:
//! - CPU path, [`records`] (`build_records`): compact records (a vertex record per
//!   silhouette vertex, an edge record per quad, a fan record per corner, a word per fan
//!   segment), expanded per caster into this triangle list (`expand_side`) and kept until
//!   the caster or the light moves; no atan2 per corner, no cos per fan. The same edge
//!   quads bit for bit, the
//!   same two-edge corners (fan vertices within 1e-5 t), the same pairs at vertices where
//!   an even number of edges meet, and the same discs where an odd number meet, drawn as
//!   one fan instead of one per gap between spokes; the smoothie pass discards alpha >= 1,
//!   where the two differ, so both draw the same texels. Test:
//!   `silhouette::smoothie::equivalence` (`cargo test --lib equivalence`), which also holds
//!   this module's parallel split and [`super::extract`] to the serial references.
//! - GPU path, glsl/silhouette/{edges,corners}.comp (`silhouette::gpu`): these rules, rule
//!   for rule, one thread per edge and per welded vertex, writing expanded `SmoothieVertex`es
//!   (this module also sizes their buffer). Tests: tests/gpu_silhouettes.rs
//!   (`gpu_finds_exactly_the_cpu_silhouette_edges`, `gpu_and_cpu_paths_render_the_same_image`:
//!   the same edges, the same image as the records within one 8-bit level).
//!
//! # Spaces and units
//! Everything is built in light-screen uv (`LightView::project`: uv = ndc * 0.5 + 0.5, x
//! right, y up, \[0,1\]^2 inside the frustum). The smoothie width `t` is in those uv units,
//! i.e. a fraction of the shadow map's width (the paper's "normalized screen space"; it
//! suggests 0.02 to 0.2). Each vertex carries `1 / linear depth` of the silhouette vertex it
//! belongs to (extruded vertices keep their silhouette vertex's depth, so a smoothie lies at
//! its blocker's depth); the shader must interpolate it without perspective correction
//! (`noperspective`) and invert it per fragment.
//!
//! # Smoothie edges
//! Silhouette edge a -> b projects to s0, s1. `d` is the unit perpendicular of s1 - s0 that
//! points away from the blocker. Following Volokh, the adjacent (non-degenerate) faces'
//! world normals are projected into screen space at the edge midpoint
//! (uv(m + eps n) - uv(m), eps = 1e-3 of the midpoint's linear depth, so the probe scales
//! with the scene) and summed; `d` is flipped when it disagrees with that sum. When the sum
//! is (nearly) perpendicular to the edge, when the unit normals themselves nearly cancel
//! (`NORMALS_CANCEL`: faces folded onto each other, three pages of a spine), and always for
//! boundary edges, the side is decided instead by the faces' third vertices: the outside is
//! the side where the adjacent faces are not (for an open rim the shadow grows away from
//! the surface; at a fold both faces lie on the blocker's side).
//! The quad is s0, s1, s1 + t d, s0 + t d as two triangles (s0, s1, s1 + t d) and
//! (s0, s1 + t d, s0 + t d); all four vertices have `kind = 0`, `anchor = s0`, `dir = d`, so
//! alpha = dot(uv - s0, d) / t is 0 on the silhouette and 1 on the outer side.
//!
//! # Smoothie corners
//! Per silhouette vertex, with its incident (kept) silhouette edges' outward directions:
//! - two edges, d1 and d2: a fan centred on the vertex over the shorter arc from d1 to d2,
//!   in segments of at most 30 degrees whose outer vertices sit at radius t / cos(segment/2),
//!   so the fan covers the disc sector of radius t. Nearly opposite d1, d2 (a hairpin, arc
//!   about 180 degrees): the half turn away from the two edges (which leave the vertex in
//!   nearly the same direction); the projected vertex normal decides only if that is
//!   ambiguous, because a light-facing face's projected normal need not point outward.
//!   Equal (closer than `MIN_CORNER_ANGLE`, i.e. a cosine of 1 in f32): no corner, the two
//!   quads already meet.
//! - an even number of four and more (two silhouette curves through one vertex, e.g. a
//!   saddle of a bumpy blob: one silhouette vertex in seven on `dense`): the edges paired
//!   by nearest outward directions (`pair_corner_edges`: sorted by angle, each paired with
//!   a neighbour, of the two such pairings the one with the smaller summed arcs), and each
//!   pair's corner built as two edges' above. A curve's own two edges turn by the small arc
//!   between their directions, and that gap is what its fan must fill, as at any two-edge
//!   corner; the arcs between the curves lie over the other curve's quads or inside the
//!   blocker. The full disc below drew a quarter of the smoothie pass's fragments on
//!   `dense` and moved no error measurably (mae_lit by at most 2e-4, smaller with the
//!   pairs, at 0.5x to 3x the scene's radius on `dense` and `bunny`;
//!   tests/centred_counts.rs
//!   `paired_corners_shade_fewer_light_pass_fragments_than_whole_discs_and_cones`). More
//!   than MAX_PAIRED_EDGES edges: the full disc.
//! - one edge (chain end, e.g. the next edge was behind the light) or another odd number
//!   (the paper's special case): n = sum of the adjacent faces' normals (faces of the
//!   incident silhouette edges), projected into screen space and scaled to length t. The
//!   paper draws triangles (s, s + t d_i, s + n_t); we instead emit a fan over the whole
//!   disc of radius t, with spokes at every d_i and at n_t (gaps split into <= 30 degree
//!   segments). That fan contains each of the paper's triangles (its chord lies inside the
//!   sector between its spokes), so it covers the paper's area plus the gaps between edges.
//!   Wedges pointing into the blocker are not skipped: there the receiver is the blocker
//!   itself, b ~ r, and the alpha correction alpha / (1 - b/r) saturates to 1 (no extra
//!   shadow); min blending makes the overdraw harmless. The spokes place only the polygon's
//!   overshoot beyond radius t, which the smoothie pass discards (alpha >= 1); the records
//!   path draws the same disc as one fan.
//!
//! Corner vertices have `kind = 1`, `anchor = s` (vertex uv), `dir = [0, 0]`:
//! alpha = |uv - s| / t.
//!
//! # Inner smoothies (`Side::Inner`, smoothies-centred; not in the paper)
//! The same construction reflected into the hard shadow: every edge quad extruded by -d
//! instead of d (s0, s1, s1 - t d, s0 - t d, `dir` = -d, so alpha = dot(uv - s0, -d) / t is
//! the distance inside the hard-edge line), and every corner fan reflected through its
//! vertex (the arc from -d1 over the same sweep; the hairpin's direction, the pairs and a
//! special vertex's spokes decided as for the outer fan, then reflected). Inner quads
//! overlap at convex vertices and leave the gap at reflex ones, where the reflected fan
//! lies; the edges, their order, the corners and the counts are those of the outer
//! construction. The records path draws the same geometry (`SmoothieRecords::mirrored`),
//! held to this by `silhouette::smoothie::equivalence`.
//!
//! # Output layout
//! `vertices` is a plain triangle list: first `6 * edges` vertices for the edge quads (in
//! silhouette order), then the corners ordered by welded vertex index. Windings are mixed:
//! draw with culling off.
//!
//! # Cost (of this expanded form; `records` for the renderer's)
//! Each silhouette vertex is transformed and projected once (its edges and its corner share
//! it); incidences are grouped through arrays over the welded vertices instead of a sort;
//! output goes into one preallocated vector; silhouettes below `PAR_CHUNK` edges (every
//! object of the built-in scenes) run on the calling thread. What is left is mostly libm:
//! one atan2 per corner (cached per edge), one cos per fan and one sin/cos per fan spoke.
//! The corner thresholds compare the cosine with +-1 rather than acos with
//! `MIN_CORNER_ANGLE`: the same decision for every float (`acos_thresholds_are_exact`).
//!
//! # Robustness
//! An edge with a vertex at linear depth <= near (behind or too close to the light) or with
//! a non-finite projection is dropped and counted in `skipped_edges`; so is an edge whose
//! ends project to the same uv (Volokh: "A and B at the same position"). No vertex is ever
//! NaN or infinite.

#[cfg(test)]
mod equivalence;
pub mod records;

use super::{pair_corner_edges, Adjacency, EdgeKind, Side, SilhouetteEdge};
use crate::scene::LightView;
use glam::{Mat3, Mat4, Vec2, Vec3};
use rayon::prelude::*;

/// One smoothie vertex; the GPU vertex layout (36 bytes, tightly packed f32s).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct SmoothieVertex {
    /// Light-screen uv of this vertex (LightView::project).
    pub uv: [f32; 2],
    /// 1 / linear depth of the silhouette vertex this smoothie vertex belongs to: a smoothie lies at its
    /// blocker's depth; interpolated linearly in screen space, then inverted in the fragment shader.
    pub inv_depth: f32,
    /// 0 = edge: alpha = dot(uv - anchor, dir) / t.  1 = corner: alpha = |uv - anchor| / t.
    pub kind: f32,
    /// Light-screen uv of the silhouette point alpha is measured from (edge: its first vertex; corner: the silhouette vertex).
    pub anchor: [f32; 2],
    /// Edge: unit outward extrusion direction in uv space. Corner: [0, 0].
    pub dir: [f32; 2],
    /// Smoothie width t (uv units) at this vertex: alpha divides by it. Constant for a fixed
    /// t; with `Width::Calibrated` it follows the silhouette vertex's depth, so an edge whose
    /// ends lie at different depths is a trapezoid with t interpolated along it.
    pub width: f32,
}

/// Largest calibrated width: the paper's largest t (0.2 of the map). A silhouette vertex
/// close to the light asks for t ~ R / b, up to the whole map; such a blocker is about the
/// light's size, casts no umbra and a faint penumbra, which a full-strength outer smoothie
/// cannot imitate at any width (stress cases `blocker-near-light`, `near-far-1e-4`: without
/// the clamp the map-wide smoothies darken everything, mae_shadow 0.65).
pub const MAX_CALIBRATED_T: f32 = 0.2;

/// How wide smoothies are, in light-uv units.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Width {
    /// The paper's screen-space knob t, the same for every silhouette vertex.
    Fixed(f32),
    /// t at a silhouette vertex of linear depth b: R / (2 b tan(fov/2)), the width whose
    /// remapped alpha (Eq. 1) spans the outer penumbra R (r - b) / b of a disc light of
    /// radius R on every receiver depth r (see src/technique/smoothies.rs).
    Calibrated { radius: f32, tan_half_fov: f32 },
}

impl Width {
    /// t at linear depth `depth`. The calibrated width is clamped to `MAX_CALIBRATED_T`.
    /// The one width formula: the CPU paths call it per silhouette vertex, reports take it
    /// at the casters' centre (`technique::smoothies::smoothie_width`), and the GPU path's
    /// `width_at` (glsl/silhouette/silhouette.glsl) is its transcription.
    pub fn at(self, depth: f32) -> f32 {
        match self {
            Width::Fixed(t) => t,
            Width::Calibrated {
                radius,
                tan_half_fov,
            } => (radius / (2.0 * depth.max(1e-30) * tan_half_fov)).clamp(0.0, MAX_CALIBRATED_T),
        }
    }
}

/// What the smoothie geometry of an object depends on besides its model matrix: a cache
/// keyed by this and the model rebuilds only the casters that moved.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GeometryKey {
    /// Not the projection: uv and linear depth do not depend on `far`, which moves with
    /// every object (`frustum::fit_light`); `near` drops edges, so it is part of the key.
    view: Mat4,
    fov_deg: f32,
    near: f32,
    width: Width,
    /// A sun's map side (its uv scale) and angle; `None` for a spotlight.
    sun: Option<crate::scene::SunView>,
}

impl GeometryKey {
    pub fn new(light: &LightView, width: Width) -> Self {
        Self {
            view: light.view,
            fov_deg: light.fov_deg,
            near: light.near,
            width,
            sun: light.sun,
        }
    }
}

/// Smoothies of one object for one light.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SmoothieGeometry {
    /// Triangle list: `6 * edges` edge-quad vertices, then the corner fans.
    pub vertices: Vec<SmoothieVertex>,
    /// Smoothie edges (quads) emitted.
    pub edges: usize,
    /// Silhouette vertices that got corner geometry (two-edge corners and special vertices).
    pub corners: usize,
    /// Silhouette vertices with one or with three or more incident silhouette edges: built
    /// in pairs where the count is even, else with the paper's special case.
    pub special_vertices: usize,
    /// Triangles in the corner fans: `vertices.len() / 3 == 2 * edges + corner_triangles`.
    pub corner_triangles: usize,
    /// Silhouette edges dropped: behind or too close to the light, or zero length on screen.
    pub skipped_edges: usize,
}

/// Largest angle of one fan segment: 30 degrees keeps the overshoot t / cos(15 deg) within
/// 3.5 % of t while costing at most 12 triangles for a full disc.
pub(crate) const MAX_SEGMENT: f32 = std::f32::consts::PI / 6.0;
/// Below this angle between d1 and d2 the two quads' outer sides coincide. Anything larger
/// needs a corner: even a 1-degree wedge is almost a texel wide at the outer side of a
/// 50-texel smoothie, and an uncovered texel reads as alpha 1 (a lit speckle in the penumbra).
// Only the tests read it: `build_corner` compares the cosine (`acos_thresholds_are_exact`).
#[cfg_attr(not(test), allow(dead_code))]
pub(crate) const MIN_CORNER_ANGLE: f32 = 1e-3 * std::f32::consts::PI / 180.0;
/// Relative size of the normal probe (of the point's linear depth).
pub(crate) const PROBE: f32 = 1e-3;

/// Extra angle a fan reaches past each of its edges' directions. The fan's spokes and the
/// edge quads' sides are collinear but share no vertices (T-junctions), so without overlap
/// the rasteriser leaves single-texel cracks that show as lit speckles inside penumbrae.
/// The overlap is harmless: inside an edge quad the radial alpha |p - s| / t is never below
/// the quad's own alpha, and MIN blending keeps the quad's.
pub(crate) const FAN_OVERLAP: f32 = 2.0 * std::f32::consts::PI / 180.0;

/// Silhouettes with at least this many edges are split over rayon in chunks of this size;
/// smaller ones (every object of the built-in scenes) run on the calling thread, where the
/// whole object takes less time than a hand-off to the pool.
const PAR_CHUNK: usize = 4096;

/// Projects object-space geometry of one object for one light.
pub(super) struct Projector<'a> {
    pub(super) model: Mat4,
    pub(super) normal_matrix: Mat3,
    pub(super) light: &'a LightView,
}

impl<'a> Projector<'a> {
    /// `model`'s normal matrix, or zero for a singular model (the third-vertex test takes
    /// over where normals cannot be transformed).
    pub(super) fn new(model: Mat4, light: &'a LightView) -> Self {
        let normal_matrix = Mat3::from_mat4(model).inverse().transpose();
        let normal_matrix = if normal_matrix.is_finite() {
            normal_matrix
        } else {
            Mat3::ZERO
        };
        Self {
            model,
            normal_matrix,
            light,
        }
    }

    pub(super) fn world(&self, p_obj: Vec3) -> Vec3 {
        self.model.transform_point3(p_obj)
    }

    /// uv and linear depth, or None when the point is at or behind the near plane or the
    /// result is not finite (so callers never see NaN/Inf).
    pub(super) fn project(&self, p_world: Vec3) -> Option<(Vec2, f32)> {
        let (uv, depth) = self.light.project(p_world);
        (depth > self.light.near && uv.is_finite() && depth.is_finite()).then_some((uv, depth))
    }

    /// Screen-space direction (not normalized, per unit world length) of object-space normal
    /// `n_obj` at world point `p`; zero when it cannot be measured.
    fn project_normal(&self, p: Vec3, depth: f32, uv: Vec2, n_obj: Vec3) -> Vec2 {
        let n = (self.normal_matrix * n_obj).normalize_or_zero();
        if n == Vec3::ZERO {
            return Vec2::ZERO;
        }
        let eps = PROBE * depth;
        let (uv2, d2) = self.light.project(p + n * eps);
        let v = (uv2 - uv) / eps;
        if d2 > 0.0 && v.is_finite() {
            v
        } else {
            Vec2::ZERO
        }
    }
}

/// A silhouette vertex, transformed and projected once for all its edges and its corner.
#[derive(Clone, Copy)]
pub(super) struct SilVertex {
    /// Welded vertex index.
    pub(super) v: u32,
    /// World position.
    pub(super) p: Vec3,
    /// `None` when `Projector::project` rejects the point: its edges are skipped.
    pub(super) proj: Option<Projected>,
}

#[derive(Clone, Copy)]
pub(super) struct Projected {
    pub(super) s: Vec2,
    pub(super) z: f32,
    pub(super) inv: f32,
    pub(super) t: f32,
}

fn vertex(
    uv: Vec2,
    inv_depth: f32,
    kind: f32,
    anchor: Vec2,
    dir: Vec2,
    width: f32,
) -> SmoothieVertex {
    SmoothieVertex {
        uv: uv.to_array(),
        inv_depth,
        kind,
        anchor: anchor.to_array(),
        dir: dir.to_array(),
        width,
    }
}

/// Which side of the line s0 -> s1 the valid faces' third vertices lie on: the sum of
/// signed areas' signs (>0: left).
fn third_vertex_side(
    adj: &Adjacency,
    pr: &Projector,
    e: &SilhouetteEdge,
    s0: Vec2,
    s1: Vec2,
) -> f32 {
    let mut side = 0.0;
    for ef in adj.edge_faces(e.edge as usize) {
        if adj.degenerate[ef.face as usize] {
            continue;
        }
        let t = adj.triangles[ef.face as usize];
        let Some(&c) = t.iter().find(|&&v| v != e.a && v != e.b) else {
            continue;
        };
        if let Some((sc, _)) = pr.project(pr.world(adj.positions[c as usize])) {
            let cr = (s1 - s0).perp_dot(sc - s0);
            if cr.abs() > 1e-12 {
                side += cr.signum();
            }
        }
    }
    side
}

/// Appends the quad of silhouette edge `e` (ends `va`, `vb`) on `side` to `out`; returns its
/// extrusion direction (outward, or inward for `Side::Inner`), or `None` (nothing appended)
/// when the edge is skipped.
fn build_edge(
    adj: &Adjacency,
    pr: &Projector,
    e: &SilhouetteEdge,
    va: &SilVertex,
    vb: &SilVertex,
    side: Side,
    out: &mut Vec<SmoothieVertex>,
) -> Option<Vec2> {
    let d = side.sign() * edge_dir(adj, pr, e, va, vb)?;
    let (a, b) = (va.proj?, vb.proj?);
    let (s0, s1) = (a.s, b.s);
    let (o0, o1) = (s0 + a.t * d, s1 + b.t * d);
    let v = |uv: Vec2, inv: f32, t: f32| vertex(uv, inv, 0.0, s0, d, t);
    out.extend_from_slice(&[
        v(s0, a.inv, a.t),
        v(s1, b.inv, b.t),
        v(o1, b.inv, b.t),
        v(s0, a.inv, a.t),
        v(o1, b.inv, b.t),
        v(o0, a.inv, a.t),
    ]);
    Some(d)
}

/// The outward unit direction of silhouette edge `e` (ends `va`, `vb`) in light uv, or
/// `None` when the edge is skipped (an end rejected by the projection, zero length).
pub(super) fn edge_dir(
    adj: &Adjacency,
    pr: &Projector,
    e: &SilhouetteEdge,
    va: &SilVertex,
    vb: &SilVertex,
) -> Option<Vec2> {
    let (pa, pb) = (va.p, vb.p);
    let (a, b) = (va.proj?, vb.proj?);
    let (s0, s1) = (a.s, b.s);
    let along = s1 - s0;
    let len = along.length();
    // Also catches NaN.
    if len.is_nan() || len <= 1e-9 {
        return None;
    }
    // Left perpendicular of a -> b; flipped below when the blocker is on the right.
    let mut d = along.perp() / len;
    let mut decided = false;
    if e.kind != EdgeKind::Boundary && normals_pick_a_side(adj, e) {
        let m = (pa + pb) * 0.5;
        if let Some((sm, zm)) = pr.project(m) {
            let mut avg = Vec2::ZERO;
            for ef in adj.edge_faces(e.edge as usize) {
                if !adj.degenerate[ef.face as usize] {
                    avg += pr.project_normal(m, zm, sm, adj.face_normals[ef.face as usize]);
                }
            }
            let dot = d.dot(avg);
            // Only trust the normals when they clearly pick a side (> ~0.5 degree).
            if dot.abs() > 1e-2 * avg.length() {
                if dot < 0.0 {
                    d = -d;
                }
                decided = true;
            }
        }
    }
    if !decided {
        d = undecided_dir(adj, pr, e, pa, pb, s0, s1, d);
    }
    Some(d)
}

/// The length below which the sum of an edge's unit face normals
/// (`Adjacency::edge_normals`) is taken to cancel: faces folded back onto each other
/// (normals more than about 177 degrees apart) or three pages of a non-manifold spine.
/// Their projected sum is then rounding noise whose sign no test can trust (the CPU and GPU
/// paths disagreed on one such spine), so the third-vertex test decides (`undecided_dir`).
pub(super) const NORMALS_CANCEL: f32 = 0.05;

/// Whether the face normals of edge `e` may pick its outward side (`NORMALS_CANCEL`).
pub(super) fn normals_pick_a_side(adj: &Adjacency, e: &SilhouetteEdge) -> bool {
    adj.edge_normals[e.edge as usize].length() >= NORMALS_CANCEL
}

/// The outward direction of edge `e` (world ends `pa`, `pb`, projected `s0`, `s1`, left
/// perpendicular `d`) when the face normals do not decide: the side away from the faces'
/// third vertices, else the orientation convention's right side (for a boundary edge, the
/// front face's projected normal has the last word).
#[allow(clippy::too_many_arguments)]
pub(super) fn undecided_dir(
    adj: &Adjacency,
    pr: &Projector,
    e: &SilhouetteEdge,
    pa: Vec3,
    pb: Vec3,
    s0: Vec2,
    s1: Vec2,
    mut d: Vec2,
) -> Vec2 {
    let side = third_vertex_side(adj, pr, e, s0, s1);
    if side > 0.0 {
        d = -d;
    } else if side == 0.0 {
        // No usable evidence: the orientation convention puts the outside on the right.
        d = -d;
        if e.kind == EdgeKind::Boundary {
            let fi = e.front_face as usize;
            let m = (pa + pb) * 0.5;
            if let Some((sm, zm)) = pr.project(m) {
                let n = pr.project_normal(m, zm, sm, adj.face_normals[fi]);
                if d.dot(n) < 0.0 {
                    d = -d;
                }
            }
        }
    }
    d
}

/// Fan from the vertex at `s` over directions `from` .. `from + sweep` (radians, signed).
fn fan(out: &mut Vec<SmoothieVertex>, s: Vec2, inv: f32, t: f32, from: f32, sweep: f32) -> usize {
    let pad = FAN_OVERLAP.copysign(sweep);
    let (from, sweep) = (from - pad, sweep + 2.0 * pad);
    let k = ((sweep.abs() / MAX_SEGMENT).ceil() as usize).max(1);
    let phi = sweep / k as f32;
    let r = t / (phi * 0.5).cos();
    let at = |i: usize| s + r * Vec2::from_angle(from + phi * i as f32);
    let cv = |uv: Vec2| vertex(uv, inv, 1.0, s, Vec2::ZERO, t);
    let centre = cv(s);
    // Each inner spoke is shared by two segments: one sin/cos per spoke.
    let mut prev = cv(at(0));
    for i in 0..k {
        let next = cv(at(i + 1));
        out.extend_from_slice(&[centre, prev, next]);
        prev = next;
    }
    k
}

/// Projected vertex normal: sum of the faces adjacent to the vertex's silhouette edges.
pub(super) fn vertex_normal_screen<'a>(
    adj: &Adjacency,
    pr: &Projector,
    edges: impl Iterator<Item = &'a SilhouetteEdge>,
    p: Vec3,
    s: Vec2,
    z: f32,
) -> Vec2 {
    let mut n = Vec3::ZERO;
    for e in edges {
        for ef in adj.edge_faces(e.edge as usize) {
            n += adj.face_normals[ef.face as usize];
        }
    }
    pr.project_normal(p, z, s, n.normalize_or_zero())
}

/// Whether the half-turn fan of a hairpin corner at `vtx` (incident silhouette edges
/// `edges`, the first one's outward direction `d1`) sweeps counter-clockwise from `d1`: the
/// way that leads away from the edges' other ends, or the projected vertex normal's way
/// when those cancel out.
pub(super) fn hairpin_ccw<'a>(
    adj: &Adjacency,
    pr: &Projector,
    vtx: &SilVertex,
    edges: impl Iterator<Item = &'a SilhouetteEdge> + Clone,
    d1: Vec2,
) -> bool {
    let Some(Projected { s, z, .. }) = vtx.proj else {
        return true;
    };
    let mut away = Vec2::ZERO;
    for e in edges.clone() {
        let other = if e.a == vtx.v { e.b } else { e.a };
        if let Some((so, _)) = pr.project(pr.world(adj.positions[other as usize])) {
            away -= (so - s).normalize_or_zero();
        }
    }
    if away.length() < 1e-3 {
        away = vertex_normal_screen(adj, pr, edges, vtx.p, s, z);
    }
    away.dot(d1.perp()) >= 0.0
}

/// Appends the corner fan of silhouette vertex `vtx` on `side`, whose kept incident edges
/// are `sil[i]` with extrusion direction `dirs[i]` (that side's) for `i` in `inc`
/// (ascending). Returns whether it is a special vertex (its count is not two), or `None`
/// when it needs no corner. `angles` is scratch;
/// `angle_of[i]` caches `dirs[i].to_angle()` (NaN: not yet computed), since most edges
/// need it at both of their corners and atan2 is one of the costliest steps here.
#[allow(clippy::too_many_arguments)]
fn build_corner(
    adj: &Adjacency,
    pr: &Projector,
    vtx: &SilVertex,
    inc: &[u32],
    sil: &[SilhouetteEdge],
    dirs: &[Option<Vec2>],
    side: Side,
    out: &mut Vec<SmoothieVertex>,
    angles: &mut Vec<f32>,
    angle_of: &mut [f32],
) -> Option<bool> {
    let p = vtx.p;
    let Projected { s, z, inv, t } = vtx.proj?;
    let dir = |i: u32| dirs[i as usize].unwrap_or(Vec2::ZERO);
    let mut angle = |i: u32| {
        let a = &mut angle_of[i as usize];
        if a.is_nan() {
            *a = dir(i).to_angle();
        }
        *a
    };
    // A two-edge corner of edges i1, i2 (ascending): the shorter arc from d1 to d2, or the
    // hairpin's half turn; none when they are equal. False when it needs no fan.
    let mut two_edge = |i1: u32, i2: u32, out: &mut Vec<SmoothieVertex>| {
        let (d1, d2) = (dir(i1), dir(i2));
        let cos = d1.dot(d2).clamp(-1.0, 1.0);
        // acos(cos) < MIN_CORNER_ANGLE exactly when cos == 1, and acos(cos) > PI -
        // MIN_CORNER_ANGLE exactly when cos == -1: the neighbours of +-1 (1 - 2^-24,
        // -1 + 2^-24) are already 3.4e-4 rad away (`acos_thresholds_are_exact` checks every
        // float near +-1), so the comparisons need no acos.
        if cos >= 1.0 {
            return false;
        }
        let a1 = angle(i1);
        let mut sweep = d1.angle_to(d2);
        if cos <= -1.0 {
            // Hairpin: both edges leave the vertex in almost the same screen direction, so
            // the outside is the opposite way. The projected vertex normal (Volokh) only
            // decides when that is ambiguous: for faces facing the light it points radially
            // from the light's axis, not necessarily away from the blocker.
            // Decided on the outward d1: an inner fan is the outer one reflected through
            // the vertex, same sweep from -d1.
            let pair = [&sil[i1 as usize], &sil[i2 as usize]];
            let ccw = hairpin_ccw(adj, pr, vtx, pair.into_iter(), side.sign() * d1);
            sweep = if ccw {
                std::f32::consts::PI
            } else {
                -std::f32::consts::PI
            };
        }
        fan(out, s, inv, t, a1, sweep);
        true
    };
    if let [i1, i2] = *inc {
        return two_edge(i1, i2, out).then_some(false);
    }
    // An even number of edges: the two-edge corners of its pairs (`pair_corner_edges`).
    let outward: Vec<Vec2> = inc.iter().map(|&i| side.sign() * dir(i)).collect();
    if let Some(pairs) = pair_corner_edges(&outward) {
        for [a, b] in pairs {
            two_edge(inc[a], inc[b], out);
        }
        return Some(true);
    }
    let edges = || inc.iter().map(|&i| &sil[i as usize]);
    // Special case: spokes at every d_i and at the projected vertex normal; full disc.
    angles.clear();
    angles.extend(inc.iter().map(|&i| angle(i)));
    let n = side.sign() * vertex_normal_screen(adj, pr, edges(), p, s, z);
    if n.length() > 1e-9 {
        angles.push(n.to_angle());
    }
    angles.sort_by(f32::total_cmp);
    angles.dedup_by(|x, y| (*x - *y).abs() < 1e-6);
    for (i, &a) in angles.iter().enumerate() {
        let next = if i + 1 < angles.len() {
            angles[i + 1]
        } else {
            angles[0] + std::f32::consts::TAU
        };
        let gap = next - a;
        if gap > 1e-6 {
            fan(out, s, inv, t, a, gap);
        }
    }
    Some(true)
}

/// Smoothie edges and corners of one object (`model`: object -> world) for `light`, from
/// its silhouette `sil` (as returned by `extract`); `t` is the smoothie width in uv units.
/// Silhouettes of `PAR_CHUNK` edges or more are split over rayon; the output is the same.
pub fn build_smoothies(
    adj: &Adjacency,
    sil: &[SilhouetteEdge],
    model: Mat4,
    light: &LightView,
    t: f32,
) -> SmoothieGeometry {
    build_smoothies_width(adj, sil, model, light, Width::Fixed(t))
}

/// `build_smoothies` with a width per silhouette vertex (`Width::Calibrated`) or fixed.
pub fn build_smoothies_width(
    adj: &Adjacency,
    sil: &[SilhouetteEdge],
    model: Mat4,
    light: &LightView,
    width: Width,
) -> SmoothieGeometry {
    build_smoothies_side(adj, sil, model, light, width, Side::Outer)
}

/// `build_smoothies_width` on `side`: `Side::Inner` gives the inner smoothies of
/// smoothies-centred (see "Inner smoothies" in the module doc).
pub fn build_smoothies_side(
    adj: &Adjacency,
    sil: &[SilhouetteEdge],
    model: Mat4,
    light: &LightView,
    width: Width,
    side: Side,
) -> SmoothieGeometry {
    build_impl(adj, sil, model, light, width, PAR_CHUNK, side)
}

/// Corners (and the triangle counts) appended by `corners_into`.
#[derive(Default)]
struct CornerStats {
    corners: usize,
    special: usize,
}

/// Corners of the silhouette vertices `order` (compact indices, by welded index).
#[allow(clippy::too_many_arguments)]
fn corners_into(
    adj: &Adjacency,
    pr: &Projector,
    sil: &[SilhouetteEdge],
    dirs: &[Option<Vec2>],
    verts: &[SilVertex],
    inc_start: &[u32],
    inc: &[u32],
    order: &[u32],
    side: Side,
    out: &mut Vec<SmoothieVertex>,
) -> CornerStats {
    let mut st = CornerStats::default();
    let mut angles = Vec::new();
    let mut angle_of = vec![f32::NAN; sil.len()];
    for &c in order {
        let c = c as usize;
        let list = &inc[inc_start[c] as usize..inc_start[c + 1] as usize];
        if let Some(special) = build_corner(
            adj,
            pr,
            &verts[c],
            list,
            sil,
            dirs,
            side,
            out,
            &mut angles,
            &mut angle_of,
        ) {
            st.corners += 1;
            st.special += usize::from(special);
        }
    }
    st
}

/// Silhouette vertices, numbered compactly in order of first use and each transformed and
/// projected once for all its edges and its corner.
struct Numbering {
    /// Welded vertex v's number, when bit v of `used` is set.
    slot: Vec<u32>,
    /// One bit per welded vertex: it is a silhouette vertex. Lists them in welded order.
    used: Vec<u64>,
    verts: Vec<SilVertex>,
    /// Per silhouette edge, the numbers of its ends a, b.
    ends: Vec<[u32; 2]>,
}

/// Numbers the ends of `sil`. Dense arrays over the welded vertices group the incidences
/// without sorting.
fn number_vertices(
    adj: &Adjacency,
    pr: &Projector,
    sil: &[SilhouetteEdge],
    width: Width,
) -> Numbering {
    let nv = adj.positions.len();
    let mut slot = vec![0u32; nv];
    let mut used = vec![0u64; nv.div_ceil(64)];
    let mut verts: Vec<SilVertex> = Vec::with_capacity(sil.len() + 8);
    let mut ends: Vec<[u32; 2]> = Vec::with_capacity(sil.len());
    for e in sil {
        let mut number = |v: u32| {
            let (w, bit) = ((v / 64) as usize, 1u64 << (v % 64));
            if used[w] & bit == 0 {
                used[w] |= bit;
                slot[v as usize] = verts.len() as u32;
                let p = pr.world(adj.positions[v as usize]);
                let proj = pr.project(p).map(|(s, z)| Projected {
                    s,
                    z,
                    inv: 1.0 / z,
                    t: width.at(z),
                });
                verts.push(SilVertex { v, p, proj });
            }
            slot[v as usize]
        };
        ends.push([number(e.a), number(e.b)]);
    }
    Numbering {
        slot,
        used,
        verts,
        ends,
    }
}

/// Appends the edge quads of `sil` to `out` in silhouette order, over rayon in chunks of
/// `chunk` edges when `parallel`; returns each edge's outward direction (`None`: skipped).
#[allow(clippy::too_many_arguments)]
fn edge_quads(
    adj: &Adjacency,
    pr: &Projector,
    sil: &[SilhouetteEdge],
    numbering: &Numbering,
    parallel: bool,
    chunk: usize,
    side: Side,
    out: &mut Vec<SmoothieVertex>,
) -> Vec<Option<Vec2>> {
    let verts = &numbering.verts;
    let quads = |sil: &[SilhouetteEdge],
                 ends: &[[u32; 2]],
                 out: &mut Vec<SmoothieVertex>,
                 dirs: &mut Vec<Option<Vec2>>| {
        for (e, &[a, b]) in sil.iter().zip(ends) {
            dirs.push(build_edge(
                adj,
                pr,
                e,
                &verts[a as usize],
                &verts[b as usize],
                side,
                out,
            ));
        }
    };
    let mut dirs: Vec<Option<Vec2>> = Vec::with_capacity(sil.len());
    if parallel {
        let parts: Vec<(Vec<SmoothieVertex>, Vec<Option<Vec2>>)> = sil
            .par_chunks(chunk)
            .zip(numbering.ends.par_chunks(chunk))
            .map(|(s, e)| {
                let (mut out, mut d) = (Vec::with_capacity(6 * s.len()), Vec::new());
                quads(s, e, &mut out, &mut d);
                (out, d)
            })
            .collect();
        out.reserve(parts.iter().map(|p| p.0.len()).sum());
        for (o, d) in parts {
            out.extend_from_slice(&o);
            dirs.extend_from_slice(&d);
        }
    } else {
        // One allocation for the quads and (usually) the corners, about three fan segments
        // per silhouette vertex: growing it later copies megabytes on big silhouettes.
        out.reserve(6 * sil.len() + 10 * verts.len());
        quads(sil, &numbering.ends, out, &mut dirs);
    }
    dirs
}

/// The kept incident edges of each of the `n` silhouette vertices, as CSR: vertex c's are
/// `inc[start[c]..start[c + 1]]`, in ascending silhouette index.
fn incidences(ends: &[[u32; 2]], dirs: &[Option<Vec2>], n: usize) -> (Vec<u32>, Vec<u32>) {
    let mut start = vec![0u32; n + 1];
    for (&[a, b], d) in ends.iter().zip(dirs) {
        if d.is_some() {
            start[a as usize + 1] += 1;
            start[b as usize + 1] += 1;
        }
    }
    for c in 0..n {
        start[c + 1] += start[c];
    }
    let mut inc = vec![0u32; start[n] as usize];
    let mut fill = start.clone();
    for (i, (&[a, b], d)) in ends.iter().zip(dirs).enumerate() {
        if d.is_some() {
            for c in [a, b] {
                inc[fill[c as usize] as usize] = i as u32;
                fill[c as usize] += 1;
            }
        }
    }
    (start, inc)
}

/// The silhouette vertices where a kept edge ends, by welded vertex index: the order of
/// the corners in the output.
fn corner_order(numbering: &Numbering, inc_start: &[u32]) -> Vec<u32> {
    let mut order: Vec<u32> = Vec::with_capacity(numbering.verts.len());
    for (w, &bits) in numbering.used.iter().enumerate() {
        let mut bits = bits;
        while bits != 0 {
            let v = w * 64 + bits.trailing_zeros() as usize;
            bits &= bits - 1;
            let c = numbering.slot[v];
            if inc_start[c as usize + 1] > inc_start[c as usize] {
                order.push(c);
            }
        }
    }
    order
}

/// The construction on `side`, in four steps: number and project the silhouette vertices,
/// build the edge quads, group the kept edges by vertex, build the corners. Silhouettes of `chunk`
/// edges or more run the quads and the corners over rayon; the output is the same.
pub(super) fn build_impl(
    adj: &Adjacency,
    sil: &[SilhouetteEdge],
    model: Mat4,
    light: &LightView,
    width: Width,
    chunk: usize,
    side: Side,
) -> SmoothieGeometry {
    let pr = Projector::new(model, light);
    let parallel = sil.len() >= chunk;
    let numbering = number_vertices(adj, &pr, sil, width);

    let mut geo = SmoothieGeometry::default();
    let dirs = edge_quads(
        adj,
        &pr,
        sil,
        &numbering,
        parallel,
        chunk,
        side,
        &mut geo.vertices,
    );
    geo.edges = geo.vertices.len() / 6;
    geo.skipped_edges = sil.len() - geo.edges;

    let verts = &numbering.verts;
    let (inc_start, inc) = incidences(&numbering.ends, &dirs, verts.len());
    let order = corner_order(&numbering, &inc_start);
    let quad_vertices = geo.vertices.len();
    let corners = |order: &[u32], out: &mut Vec<SmoothieVertex>| {
        corners_into(
            adj, &pr, sil, &dirs, verts, &inc_start, &inc, order, side, out,
        )
    };
    let mut stats = Vec::new();
    if parallel {
        let parts: Vec<(Vec<SmoothieVertex>, CornerStats)> = order
            .par_chunks(chunk)
            .map(|o| {
                let mut out = Vec::with_capacity(9 * o.len());
                let st = corners(o, &mut out);
                (out, st)
            })
            .collect();
        geo.vertices.reserve(parts.iter().map(|p| p.0.len()).sum());
        for (out, st) in parts {
            geo.vertices.extend_from_slice(&out);
            stats.push(st);
        }
    } else {
        stats.push(corners(&order, &mut geo.vertices));
    }
    for st in stats {
        geo.corners += st.corners;
        geo.special_vertices += st.special;
    }
    geo.corner_triangles = (geo.vertices.len() - quad_vertices) / 3;
    geo
}

#[cfg(test)]
mod tests {
    use super::super::test_meshes::{bowtie, cube, sphere};
    use super::super::{extract, extract_serial};
    use super::*;
    use crate::scene::Light;

    fn light_at(position: Vec3, target: Vec3) -> LightView {
        LightView::new(
            &Light {
                position,
                target,
                fov_deg: 60.0,
                radius: 0.2,
                kind: crate::scene::LightKind::Spot,
            },
            0.1,
            50.0,
        )
    }

    fn all_finite(g: &SmoothieGeometry) -> bool {
        g.vertices.iter().all(|v| {
            v.uv.iter()
                .chain(&v.anchor)
                .chain(&v.dir)
                .chain([&v.inv_depth, &v.kind])
                .all(|x| x.is_finite())
        })
    }

    fn check_counts(g: &SmoothieGeometry) {
        assert_eq!(g.vertices.len() % 3, 0);
        assert_eq!(g.vertices.len() / 3, 2 * g.edges + g.corner_triangles);
        assert!(g.vertices[..6 * g.edges].iter().all(|v| v.kind == 0.0));
        assert!(g.vertices[6 * g.edges..]
            .iter()
            .all(|v| v.kind == 1.0 && v.dir == [0.0, 0.0]));
    }

    #[test]
    fn vertex_is_36_bytes() {
        assert_eq!(std::mem::size_of::<SmoothieVertex>(), 36);
    }

    #[test]
    fn calibrated_width_follows_depth() {
        let adj = Adjacency::build(&cube()).unwrap();
        let lv = light_at(Vec3::new(3.0, 5.0, 2.0), Vec3::ZERO);
        let sil = extract(&adj, Mat4::IDENTITY, lv.position);
        let width = Width::Calibrated {
            radius: 0.2,
            tan_half_fov: (lv.fov_deg.to_radians() * 0.5).tan(),
        };
        let g = build_smoothies_width(&adj, &sil, Mat4::IDENTITY, &lv, width);
        assert!(g.edges > 0);
        for v in &g.vertices {
            // Each vertex carries the width of its own silhouette vertex's depth.
            let expect = width.at(1.0 / v.inv_depth);
            assert!(
                (v.width - expect).abs() < 1e-6 * expect.max(1.0),
                "{} vs {expect}",
                v.width
            );
        }
        // Nearer silhouette vertices get wider smoothies (the penumbra R (r - b) / b grows as b shrinks).
        let near = g
            .vertices
            .iter()
            .max_by(|a, b| a.inv_depth.total_cmp(&b.inv_depth))
            .unwrap();
        let far = g
            .vertices
            .iter()
            .min_by(|a, b| a.inv_depth.total_cmp(&b.inv_depth))
            .unwrap();
        assert!(near.width > far.width);
    }

    #[test]
    fn cube_smoothies() {
        let adj = Adjacency::build(&cube()).unwrap();
        let model = Mat4::from_translation(Vec3::new(0.0, 1.0, 0.0));
        let centre = Vec3::new(0.0, 1.0, 0.0);
        let lv = light_at(Vec3::new(3.0, 4.5, 2.2), centre);
        let sil = extract(&adj, model, lv.position);
        assert_eq!(sil.len(), 6);
        let t = 0.05;
        let g = build_smoothies(&adj, &sil, model, &lv, t);
        assert!(all_finite(&g));
        assert_eq!(g.edges, 6);
        assert_eq!(g.skipped_edges, 0);
        check_counts(&g);
        // Convex loop: a corner at each of the 6 silhouette vertices, none special.
        assert_eq!(g.corners, 6);
        assert_eq!(g.special_vertices, 0);
        let (c, _) = lv.project(centre);
        for (q, e) in g.vertices[..6 * g.edges].chunks_exact(6).zip(&sil) {
            let d = Vec2::from(q[0].dir);
            assert!((d.length() - 1.0).abs() < 1e-5);
            let (s0, s1) = (Vec2::from(q[0].uv), Vec2::from(q[1].uv));
            // Width t: the outer vertices are t away from the silhouette line along d.
            assert!((Vec2::from(q[2].uv) - s1 - t * d).length() < 1e-6);
            assert!((Vec2::from(q[5].uv) - s0 - t * d).length() < 1e-6);
            assert!(d.dot(s1 - s0).abs() < 1e-5);
            // Away from the projected centre.
            assert!(d.dot((s0 + s1) * 0.5 - c) > 0.0);
            // Matches the extract convention: the outside is right of a -> b.
            assert!(d.perp_dot(s1 - s0) > 0.0, "edge {e:?}");
            // Depth attributes and anchors.
            let za = lv.linear_depth(model.transform_point3(adj.positions[e.a as usize]));
            assert!((q[0].inv_depth - 1.0 / za).abs() < 1e-5);
            assert_eq!(q[5].inv_depth, q[0].inv_depth);
            assert_eq!(q[2].inv_depth, q[1].inv_depth);
            assert!(q.iter().all(|v| v.anchor == q[0].uv));
        }
        // Corner fans: every vertex within t / cos(15 deg) of its anchor, outer ones beyond t.
        for v in &g.vertices[6 * g.edges..] {
            let r = (Vec2::from(v.uv) - Vec2::from(v.anchor)).length();
            assert!(r <= t / (15f32.to_radians()).cos() + 1e-6);
        }
    }

    #[test]
    fn inner_smoothies_reflect_the_outer_ones_into_the_hard_shadow() {
        let adj = Adjacency::build(&cube()).unwrap();
        let model = Mat4::from_translation(Vec3::new(0.0, 1.0, 0.0));
        let centre = Vec3::new(0.0, 1.0, 0.0);
        let lv = light_at(Vec3::new(3.0, 4.5, 2.2), centre);
        let sil = extract(&adj, model, lv.position);
        let t = 0.05;
        let outer = build_smoothies(&adj, &sil, model, &lv, t);
        let inner = build_smoothies_side(&adj, &sil, model, &lv, Width::Fixed(t), Side::Inner);
        assert!(all_finite(&inner));
        check_counts(&inner);
        assert_eq!(
            [inner.edges, inner.corners, inner.corner_triangles],
            [outer.edges, outer.corners, outer.corner_triangles]
        );
        let (c, _) = lv.project(centre);
        let quads = 6 * inner.edges;
        for (qi, qo) in inner.vertices[..quads]
            .chunks_exact(6)
            .zip(outer.vertices[..quads].chunks_exact(6))
        {
            // The same silhouette edge, extruded by -d: into the hard shadow.
            assert_eq!([qi[0].uv, qi[1].uv], [qo[0].uv, qo[1].uv]);
            let d = Vec2::from(qo[0].dir);
            assert_eq!(Vec2::from(qi[0].dir), -d);
            let (s0, s1) = (Vec2::from(qi[0].uv), Vec2::from(qi[1].uv));
            assert!((Vec2::from(qi[2].uv) - (s1 - t * d)).length() < 1e-6);
            assert!((Vec2::from(qi[5].uv) - (s0 - t * d)).length() < 1e-6);
            assert!(Vec2::from(qi[0].dir).dot((s0 + s1) * 0.5 - c) < 0.0);
        }
        // Each corner fan is the outer one reflected through its vertex.
        for (fi, fo) in inner.vertices[quads..].iter().zip(&outer.vertices[quads..]) {
            assert_eq!(fi.anchor, fo.anchor);
            let a = Vec2::from(fi.anchor);
            let reflected = a - (Vec2::from(fo.uv) - a);
            assert!((Vec2::from(fi.uv) - reflected).length() < 1e-6);
        }
    }

    #[test]
    fn bowtie_special_vertex() {
        let adj = Adjacency::build(&bowtie()).unwrap();
        let lv = light_at(Vec3::new(0.0, 0.0, 10.0), Vec3::ZERO);
        let sil = extract(&adj, Mat4::IDENTITY, lv.position);
        let g = build_smoothies(&adj, &sil, Mat4::IDENTITY, &lv, 0.03);
        assert!(g.special_vertices >= 1);
        assert!(all_finite(&g));
        check_counts(&g);
        assert_eq!(g.edges, 6);
        // Four edges meet at the origin, paired by nearest outward directions
        // (`pair_corner_edges`): the two notches above and below the pinch (53 degrees
        // each, two segments each), not the full disc.
        let (o, _) = lv.project(Vec3::ZERO);
        let at_origin: Vec<_> = g.vertices[6 * g.edges..]
            .iter()
            .filter(|v| Vec2::from(v.anchor) == o)
            .collect();
        assert_eq!(at_origin.len(), 3 * 4);
        for v in at_origin.iter().filter(|v| Vec2::from(v.uv) != o) {
            let d = (Vec2::from(v.uv) - o).normalize();
            assert!(d.y.abs() > 0.85, "spoke {d}");
        }
    }

    #[test]
    fn open_quad_extrudes_outward() {
        let mesh = crate::scene::Mesh {
            positions: vec![
                Vec3::new(-1.0, 0.0, -1.0),
                Vec3::new(1.0, 0.0, -1.0),
                Vec3::new(1.0, 0.0, 1.0),
                Vec3::new(-1.0, 0.0, 1.0),
            ],
            normals: vec![Vec3::Y; 4],
            indices: vec![0, 2, 1, 0, 3, 2],
        };
        let adj = Adjacency::build(&mesh).unwrap();
        // From above and from below (and off to the side), the rim grows outward.
        for pos in [
            Vec3::new(0.3, 5.0, 0.2),
            Vec3::new(0.3, -5.0, 0.2),
            Vec3::new(4.0, 3.0, 0.0),
        ] {
            let lv = light_at(pos, Vec3::ZERO);
            let sil = extract(&adj, Mat4::IDENTITY, pos);
            let g = build_smoothies(&adj, &sil, Mat4::IDENTITY, &lv, 0.04);
            assert_eq!(g.edges, 4);
            assert_eq!(g.corners, 4);
            check_counts(&g);
            let (c, _) = lv.project(Vec3::ZERO);
            for q in g.vertices[..24].chunks_exact(6) {
                let mid = (Vec2::from(q[0].uv) + Vec2::from(q[1].uv)) * 0.5;
                assert!(Vec2::from(q[0].dir).dot(mid - c) > 0.0, "light {pos}");
            }
        }
    }

    #[test]
    fn behind_light_is_skipped_without_nan() {
        // A long bar reaching behind the light: its far end is behind the near plane.
        let mut mesh = cube();
        for p in &mut mesh.positions {
            p.z *= 20.0;
        }
        let adj = Adjacency::build(&mesh).unwrap();
        let lv = light_at(Vec3::new(0.0, 2.0, 0.0), Vec3::new(0.0, 0.0, -5.0));
        let sil = extract(&adj, Mat4::IDENTITY, lv.position);
        let g = build_smoothies(&adj, &sil, Mat4::IDENTITY, &lv, 0.05);
        assert!(g.skipped_edges > 0);
        assert_eq!(g.edges + g.skipped_edges, sil.len());
        assert!(all_finite(&g));
        check_counts(&g);
        // A zero-length screen edge: an open quad in a plane through the light, one rim
        // edge pointing straight at it.
        let quad = crate::scene::Mesh {
            positions: vec![
                Vec3::new(0.0, 0.0, 0.0),
                Vec3::new(0.0, 0.0, 1.0),
                Vec3::new(0.0, 1.0, 1.0),
                Vec3::new(0.0, 1.0, 0.0),
            ],
            normals: vec![Vec3::X; 4],
            indices: vec![0, 1, 2, 0, 2, 3],
        };
        let adj2 = Adjacency::build(&quad).unwrap();
        let lv2 = light_at(Vec3::new(0.0, 0.0, 30.0), Vec3::new(0.0, 0.0, 0.0));
        let sil2 = extract(&adj2, Mat4::IDENTITY, lv2.position);
        assert_eq!(sil2.len(), 4);
        let g2 = build_smoothies(&adj2, &sil2, Mat4::IDENTITY, &lv2, 0.05);
        assert!(g2.skipped_edges >= 1);
        assert!(all_finite(&g2));
        check_counts(&g2);
    }

    #[test]
    fn hairpin_tip_corner_points_away_from_the_blade() {
        // A thin horizontal blade (tip angle ~0.1 degree) lit from above, with the light's
        // axis beyond the tip so the face normal projects towards the base.
        let mesh = crate::scene::Mesh {
            positions: vec![
                Vec3::new(0.0, 0.0, 0.0),
                Vec3::new(-2.0, 0.0, -0.002),
                Vec3::new(-2.0, 0.0, 0.002),
            ],
            normals: vec![Vec3::Y; 3],
            indices: vec![0, 1, 2],
        };
        let adj = Adjacency::build(&mesh).unwrap();
        let lv = light_at(Vec3::new(1.5, 4.0, 0.3), Vec3::new(1.5, 0.0, 0.0));
        let sil = extract(&adj, Mat4::IDENTITY, lv.position);
        assert_eq!(sil.len(), 3);
        let t = 0.05;
        let g = build_smoothies(&adj, &sil, Mat4::IDENTITY, &lv, t);
        assert!(all_finite(&g));
        check_counts(&g);
        let (tip, _) = lv.project(Vec3::ZERO);
        let (base, _) = lv.project(Vec3::new(-2.0, 0.0, 0.0));
        let axis = (tip - base).normalize();
        let fan: Vec<Vec2> = g.vertices[6 * g.edges..]
            .iter()
            .filter(|v| Vec2::from(v.anchor) == tip)
            .map(|v| Vec2::from(v.uv) - tip)
            .collect();
        assert!(fan.len() >= 3 * 6, "a half-disc fan");
        // The fan's tip (beyond the blade) reaches t along the blade's axis...
        assert!(fan.iter().any(|p| p.dot(axis) > 0.99 * t));
        // ...and never reaches back over the blade beyond the crack-closing overlap.
        let back = t / (MAX_SEGMENT * 0.5).cos() * FAN_OVERLAP.sin() + 1e-4;
        assert!(fan.iter().all(|p| p.dot(axis) > -back));
    }

    #[test]
    fn sphere_deterministic_and_parallel_matches_serial() {
        let adj = Adjacency::build(&sphere(60, 120, 0.1)).unwrap();
        let model = Mat4::from_translation(Vec3::new(0.0, 2.0, 0.0));
        let lv = light_at(Vec3::new(2.0, 7.0, 1.0), Vec3::new(0.0, 2.0, 0.0));
        let sil = extract(&adj, model, lv.position);
        let sil_s = extract_serial(&adj, model, lv.position);
        assert_eq!(sil, sil_s);
        let g = build_smoothies(&adj, &sil, model, &lv, 0.05);
        let g2 = build_smoothies(&adj, &sil_s, model, &lv, 0.05);
        assert_eq!(g, g2);
        let g3 = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap()
            .install(|| build_smoothies(&adj, &sil, model, &lv, 0.05));
        assert_eq!(g, g3);
        assert!(all_finite(&g));
        check_counts(&g);
        assert!(g.edges > 50);
        assert_eq!(g.skipped_edges, 0);
        // On a smooth sphere (a single convex loop) the extrusion points away from the
        // projected centre.
        let adj = Adjacency::build(&sphere(60, 120, 0.0)).unwrap();
        let sil = extract(&adj, model, lv.position);
        let g = build_smoothies(&adj, &sil, model, &lv, 0.05);
        assert_eq!(g.special_vertices, 0);
        let (c, _) = lv.project(Vec3::new(0.0, 2.0, 0.0));
        let outward = g.vertices[..6 * g.edges]
            .chunks_exact(6)
            .filter(|q| Vec2::from(q[0].dir).dot(Vec2::from(q[0].uv) - c) > 0.0)
            .count();
        assert_eq!(outward, g.edges);
    }
}
