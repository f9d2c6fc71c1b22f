//! CPU penumbra-map geometry (Wyman & Hansen 2003, Sec. 3, Fig. 4): a cone at every
//! silhouette vertex and a sheet along every silhouette edge, in world space, emitted as one
//! triangle list of [`PenumbraVertex`] that the penumbra pass draws from the light. The GPU
//! path (`silhouette::gpu::GpuSilhouettes::new_penumbra`, glsl/silhouette/penumbra*.glsl,
//! penumbra_*.comp) mirrors every rule below; keep the two in step.
//!
//! # Spaces
//! Built in the light's view space (light centre at the origin, looking down -z, x right and
//! y up like light-screen uv), then moved to world space. The light is a disc of radius
//! `Lr` centred on the origin in the plane z = 0 (perpendicular to the view axis, the
//! paper's spherical light seen from the receivers). `Z` is linear light depth (-z).
//!
//! # Cones (paper, Sec. 3 third bullet)
//! The lines from the light disc through silhouette vertex v (depth Zv) form a cone with its
//! tip at v; at depth Z its cross-section is a disc of radius (Z - Zv) Lr / Zv centred on the
//! light ray through v. At the base depth `z_far` that is the paper's C_r = (Z_far - Zv) Lr / Zv.
//! Each cone is [`CONE_SEGMENTS`] triangles (tip, two base vertices). The base polygon is
//! circumscribed (vertices at C_r / cos(pi / segments)) so the faceted cone contains the
//! round one and leaves no lit notch next to a sheet; the price is up to 2 % too dark.
//! Exactly one cone per distinct silhouette vertex, whatever its number of silhouette edges
//! (1 at the end of an open chain, 3 or more at the paper's "pathological" vertices). Where
//! exactly two sheets meet, only the arc between their normals is drawn (the rest lies
//! under the sheets), reaching `ARC_OVERLAP` past each so that no texel centre falls
//! between a sheet and its cone. Where an even number of four and more meet (two
//! silhouette curves through the vertex), the arc of each pair of nearest normals
//! (`pair_corner_edges`, as the smoothies' corners): each curve's own turn; the whole cone
//! there drew about a tenth of penumbra-map-centred's penumbra-pass fragments on `dense`
//! and moved no error measurably. Any other count, or a hairpin pair: the whole cone.
//!
//! # Sheets (paper, Sec. 3 fourth bullet)
//! The sheet of edge a -> b is the plane through the edge that is tangent to the light disc on
//! the side opposite the outside (Akenine-Moller & Assarsson's outer wedge plane). It touches
//! both cones along a line, so at the base depth it meets the base discs along their common
//! external tangent: with centres ca, cb, radii ra, rb, u = (cb - ca) / |cb - ca| and w the
//! outward (right, see `SilhouetteEdge`) perpendicular of u, the tangent normal is
//! n = alpha u + sqrt(1 - alpha^2) w with alpha = (ra - rb) / |cb - ca|, and the sheet is the
//! quad (a, b, cb + rb n, ca + ra n) as triangles (a, b, tb) and (a, tb, ta). The paper
//! offsets perpendicular to the edge, which makes the quad non-planar when ra != rb and
//! needs subdivision; the exact tangent quad is planar by construction (all four corners
//! and the disc's tangent point T = -Lr n lie in one plane), so it is never subdivided. When
//! one base disc contains the other (|alpha| >= 1: the edge points almost at the light) the
//! bigger cone covers the sheet's place and no sheet is emitted.
//!
//! # Inner cones and sheets (`Side::Inner`, penumbra-map-centred; not in the paper)
//! The same construction mirrored into the hard shadow: the plane through the edge tangent
//! to the light disc on the OUTSIDE (n = alpha u - sqrt(1 - alpha^2) w, the other common
//! external tangent of the base discs), so the sheet opens inward from the edge, and the
//! cone arcs between the inner normals. Seen from the light centre a point of either sheet
//! at depth Z lies Lr (1/Zv - 1/Z) (tangent units) from the edge's hard-edge line: the half
//! width of the penumbra a receiver at depth Z gets from a disc of radius Lr.
//!
//! # Zv per fragment (Eq. 1's Z_vi)
//! Every vertex carries `zv_h = (Zv * k, k)` and the shader uses Zv = x / y after
//! perspective-correct interpolation. Cone vertices have k = 1 (Zv constant). On a sheet the
//! tips have k = 1 and the base corners k = Z_base / Zv of their cone (Z_base = z_far, or
//! the depth the sheet is cut at): a sheet point P lies on the line from T through the edge
//! point e, and P = T + k (e - T) with k affine in P, so the ratio of the two interpolated
//! (world-affine) attributes is exactly depth(e). The paper interpolates Zv linearly, which
//! is exact only along the edge itself.
//!
//! # Blocker size (case `blocker-near-light`, `near-far-1e-4`)
//! Every vertex also carries `reach`: the radius, in light-screen tangent units (lateral offset
//! over linear depth), of the bounding circle of the object's silhouette vertices as the light
//! centre sees them (`BLOCKER_REACH_UNKNOWN` when a vertex was skipped). The penumbra shader
//! uses it to bound how much light the object can hide from a receiver point (see
//! glsl/penumbra_map/penumbra.frag); the paper has no such bound.
//!
//! # Under a sun (orthographic map, `light.sun`)
//! A sun is every direction within theta of its axis; the map is orthographic (linear depth
//! Z = -z from the map's eye plane, xy in world units). The lines through silhouette vertex
//! v along those directions form a cone of half-angle theta with its tip at v and its axis
//! along the view axis, so at depth Z its cross-section is a disc of radius (Z - Zv) tan theta
//! (world units) centred on v's own xy, not (Z - Zv) Lr / Zv around the ray through v: at
//! the base C_r = (z_far - Zv) tan theta, centre = v's view xy (no z_far / Zv scaling). The
//! penumbra a straight edge throws onto a receiver at Z_P grows linearly, (Z_P - Zv) tan theta
//! on each side of its hard edge (the full w = 2 (d_r - d_b) tan theta). Every sun cone is
//! the same cone translated, so the plane through an edge tangent to the cone at a is tangent
//! to the one at b too: the sheet is the same common-external-tangent quad of the base discs
//! (alpha = (ra - rb) / |cb - ca|, planar), with the tangent point T at infinity: its ruling
//! lines are parallel (one direction of the disc's rim), so the edge point a sheet point P
//! belongs to is affine in P and k = 1 at every corner, (Zv, 1) at the base corners too.
//! Eq. 1, I = (Z_F - Z_v) / (Z_P - Z_v), is exact under a sun: F on the same map ray as P lies
//! (Z_F - Zv) tan theta from v's ray, P's penumbra reaches (Z_P - Zv) tan theta. `reach` is in
//! world units across the map (the bounding circle of the silhouette vertices' view xy).
//! Silhouettes are taken from the stand-in point far towards the sun
//! (`silhouette::light_point`). The spread the cones are built with is `cone_spread`: Lr
//! for a spotlight, tan theta for a sun (`--light-radius` is refused for a sun).
//!
//! # Robustness
//! A vertex at linear depth <= near (behind or too close to the light) or >= z_far gets no
//! cone and its edges no sheet (counted in `skipped_vertices` / `skipped_edges`); so does an
//! edge whose base centres coincide. No emitted value is NaN or infinite. Windings are
//! mixed: draw with culling off.

use super::{pair_corner_edges, Adjacency, SilhouetteEdge};
use crate::scene::LightView;
use glam::{Mat4, Vec2, Vec3};
use rayon::prelude::*;

/// One penumbra-geometry vertex; the GPU vertex layout (24 bytes, tightly packed f32s).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct PenumbraVertex {
    /// World position.
    pub position: [f32; 3],
    /// (Zv * k, k): Zv of the silhouette point this vertex belongs to, homogeneous (see the
    /// module doc); the shader interpolates both perspective-correctly and divides.
    pub zv_h: [f32; 2],
    /// The caster's angular radius from the light centre (see "Blocker size" in the module
    /// doc), the same for every vertex of one object.
    pub reach: f32,
}

/// Cones and sheets of one object for one light.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PenumbraGeometry {
    /// Triangle list: `3 * cone_triangles` cone vertices, then `6 * sheets`.
    pub vertices: Vec<PenumbraVertex>,
    pub cones: usize,
    /// Triangles of all (partial) cones.
    pub cone_triangles: usize,
    pub sheets: usize,
    /// Silhouette vertices with one, or three and more, silhouette edges (still one cone each).
    pub special_vertices: usize,
    /// Silhouette vertices at or behind the near plane, or beyond `z_far`: no cone.
    pub skipped_vertices: usize,
    /// Edges without a sheet: a skipped end, coincident base centres or one cone inside the other.
    pub skipped_edges: usize,
}

/// What an object's cones and sheets depend on besides its model matrix: a cache keyed by
/// this and the model rebuilds only the casters that moved (the CPU path's `CasterCache`, the
/// GPU path's per-caster regions).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PenumbraKey {
    pub view_proj: Mat4,
    pub near: f32,
    /// The light radius Lr.
    pub radius: f32,
    /// The cone bases' linear depth.
    pub z_far: f32,
}

impl PenumbraKey {
    /// The key of `light` with light radius `radius` (a sun's `radius` field is its
    /// `cone_spread`, tan theta, instead).
    pub fn new(light: &LightView, radius: f32, z_far: f32) -> Self {
        Self {
            view_proj: light.view_proj,
            near: light.near,
            radius: cone_spread(light, radius),
            z_far,
        }
    }
}

/// What a cone's radius grows by per unit of depth beyond its tip, in the cone's own units:
/// a spotlight's light radius Lr (the radius at depth Z is (Z - Zv) Lr / Zv), a sun's tan
/// theta (world units, (Z - Zv) tan theta; `radius` unused). 0: no cone, the result is `hard`.
pub fn cone_spread(light: &LightView, radius: f32) -> f32 {
    light.sun.map_or(radius, |s| s.tan_angle)
}

/// `reach` of an object whose extent is unknown (a silhouette vertex was skipped): so large
/// that the shader's bound never lightens anything.
pub const BLOCKER_REACH_UNKNOWN: f32 = 1e6;

/// Triangles per cone: 16 keeps the circumscribed polygon within 2 % of the round cone.
pub const CONE_SEGMENTS: usize = 16;

pub use super::Side;

/// One silhouette vertex in light view space.
#[derive(Clone, Copy)]
struct ConeData {
    world: Vec3,
    /// Linear depth Zv.
    zv: f32,
    /// Base disc centre (xy at depth z_far) and radius.
    centre: Vec2,
    radius: f32,
}

/// `spread`: `cone_spread` (Lr, or a sun's tan theta).
fn cone_data(p_world: Vec3, light: &LightView, spread: f32, z_far: f32) -> Option<ConeData> {
    let pv = light.view.transform_point3(p_world);
    let zv = -pv.z;
    if !(zv > light.near && zv < z_far && pv.is_finite()) {
        return None;
    }
    let (centre, radius) = match light.sun {
        // Parallel rays: the axis through v, radius (z_far - Zv) tan theta.
        Some(_) => (pv.truncate(), (z_far - zv) * spread),
        None => (pv.truncate() * (z_far / zv), (z_far - zv) * spread / zv),
    };
    (centre.is_finite() && radius.is_finite()).then_some(ConeData {
        world: p_world,
        zv,
        centre,
        radius,
    })
}

/// Cone triangles around `c` over the base-plane arc `arc` (from unit direction `first` to
/// unit direction `last`, TAU and `last == first` for the whole cone), `arc.segments` of
/// them. Returns the triangle count.
fn emit_cone(
    out: &mut Vec<PenumbraVertex>,
    c: &ConeData,
    reach: f32,
    view_inv: Mat4,
    z_far: f32,
    arc: ConeArc,
) -> usize {
    let ConeArc {
        ends: [first, last],
        sweep,
        segments: k,
    } = arc;
    let step = sweep / k as f32;
    // Circumscribed: the polygon's edges touch the round base circle.
    let r = c.radius / (step * 0.5).cos();
    let zv_h = [c.zv, 1.0];
    let tip = PenumbraVertex {
        position: c.world.to_array(),
        zv_h,
        reach,
    };
    // Each base vertex once, shared by its two triangles. The inner spokes turn by rotation
    // (one sin/cos per cone, not one per spoke; after at most CONE_SEGMENTS turns a spoke is
    // off by a few ulps, far inside the 2 % circumscription margin); the end spokes are
    // `first` and `last` themselves, so an arc ends where `cone_arc` put its ends and a
    // whole cone closes.
    let turn = Vec2::from_angle(step);
    let mut dir = first;
    let mut base = [tip; CONE_SEGMENTS + 1];
    for (i, b) in base[..=k].iter_mut().enumerate() {
        let d = if i == k { last } else { dir };
        let p = c.centre + r * d;
        b.position = view_inv.transform_point3(p.extend(-z_far)).to_array();
        dir = turn.rotate(dir);
    }
    for w in base[..=k].windows(2) {
        out.extend_from_slice(&[tip, w[0], w[1]]);
    }
    k
}

/// The part of a vertex's cone to draw: end directions and signed sweep (radians) in the
/// base plane, and its triangle count (steps of at most TAU / CONE_SEGMENTS), known before
/// any is written so that the output can be reserved exactly.
#[derive(Clone, Copy)]
struct ConeArc {
    ends: [Vec2; 2],
    sweep: f32,
    segments: usize,
}

impl ConeArc {
    fn new(ends: [Vec2; 2], sweep: f32) -> Self {
        let max_step = std::f32::consts::TAU / CONE_SEGMENTS as f32;
        let segments = ((sweep.abs() / max_step).ceil() as usize).clamp(1, CONE_SEGMENTS);
        Self {
            ends,
            sweep,
            segments,
        }
    }
}

/// A sheet: its two triangles and its tangent normal n in the base plane.
struct SheetOut {
    verts: [PenumbraVertex; 6],
    n: Vec2,
}

impl SheetOut {
    /// Where in `verts` its tips (a, b) and bases (b, a), the quad's corners, lie.
    const CORNERS: [usize; 4] = [0, 1, 2, 5];

    /// World positions of its corners (`CORNERS`).
    fn corners(&self) -> [Vec3; 4] {
        Self::CORNERS.map(|i| Vec3::from_array(self.verts[i].position))
    }
}

/// `s` cut at linear depth `z`: each base moved along its ruling line (tip -> base) to `z`,
/// the position and the homogeneous (Zv k, k) interpolated as the rasteriser would, so both
/// triangles keep their planes and every fragment left its value. Uncut where `z` is not
/// between both tips and the bases.
fn cut_sheet(mut s: SheetOut, light: &LightView, z: f32) -> SheetOut {
    let corners = s.corners();
    let [za, zb, z_base_b, z_base_a] = corners.map(|p| light.linear_depth(p));
    if !(z > za.max(zb) && z < z_base_a.min(z_base_b)) {
        return s;
    }
    // The vertex at depth `z` on the ruling line from tip `t` to base `b` (corners' indices).
    let along = |t: usize, b: usize, z_tip: f32, z_base: f32| {
        let (tip, base) = (
            &s.verts[SheetOut::CORNERS[t]],
            &s.verts[SheetOut::CORNERS[b]],
        );
        let mu = (z - z_tip) / (z_base - z_tip);
        let lerp = |x: f32, y: f32| x + (y - x) * mu;
        PenumbraVertex {
            position: corners[t].lerp(corners[b], mu).to_array(),
            zv_h: [
                lerp(tip.zv_h[0], base.zv_h[0]),
                lerp(tip.zv_h[1], base.zv_h[1]),
            ],
            reach: tip.reach,
        }
    };
    let (a, b) = (along(0, 3, za, z_base_a), along(1, 2, zb, z_base_b));
    // [tip a, tip b, base b, tip a, base b, base a] (`sheet`).
    s.verts[2] = b;
    s.verts[4] = b;
    s.verts[5] = a;
    s
}

/// The sheet quad of edge a -> b on `side` as two triangles, or None (see the module doc).
fn sheet(
    a: &ConeData,
    b: &ConeData,
    view_inv: Mat4,
    z_far: f32,
    reach: f32,
    side: Side,
    sun: bool,
) -> Option<SheetOut> {
    let along = b.centre - a.centre;
    let d = along.length();
    if d.is_nan() || d <= 1e-7 * z_far {
        return None;
    }
    let u = along / d;
    // Right of a -> b in light uv: the outside of the silhouette (`SilhouetteEdge`).
    let right = Vec2::new(u.y, -u.x);
    let w = match side {
        Side::Outer => right,
        Side::Inner => -right,
    };
    let alpha = (a.radius - b.radius) / d;
    if alpha.abs() >= 1.0 - 1e-6 {
        return None;
    }
    let n = alpha * u + (1.0 - alpha * alpha).sqrt() * w;
    let base = |c: &ConeData| PenumbraVertex {
        position: view_inv
            .transform_point3((c.centre + c.radius * n).extend(-z_far))
            .to_array(),
        // k = z_far / Zv: (Zv * k, k) = (z_far, k); a sun's k = 1 (T at infinity).
        zv_h: if sun {
            [c.zv, 1.0]
        } else {
            [z_far, z_far / c.zv]
        },
        reach,
    };
    let tip = |c: &ConeData| PenumbraVertex {
        position: c.world.to_array(),
        zv_h: [c.zv, 1.0],
        reach,
    };
    let (ta, tb) = (base(a), base(b));
    Some(SheetOut {
        verts: [tip(a), tip(b), tb, tip(a), tb, ta],
        n,
    })
}

/// Radius (tangent units) of the bounding circle, about the bounding box's centre, of the
/// silhouette vertices as seen from the light centre (a sun's: world units across the map);
/// `BLOCKER_REACH_UNKNOWN` when any was skipped (its position is not trustworthy) or there
/// is none.
fn blocker_reach(cones: &[Option<ConeData>], z_far: f32, sun: bool) -> f32 {
    let scale = if sun { 1.0 } else { 1.0 / z_far };
    let mut pts = Vec::with_capacity(cones.len());
    for c in cones {
        match c {
            // The base centre is the vertex's light ray at depth z_far (a sun's: its xy).
            Some(c) => pts.push(c.centre * scale),
            None => return BLOCKER_REACH_UNKNOWN,
        }
    }
    let (lo, hi) = pts.iter().fold(
        (Vec2::splat(f32::MAX), Vec2::splat(f32::MIN)),
        |(lo, hi), p| (lo.min(*p), hi.max(*p)),
    );
    let mid = (lo + hi) * 0.5;
    let r = pts
        .iter()
        .map(|p| (*p - mid).length())
        .fold(0.0f32, f32::max);
    if pts.is_empty() || !r.is_finite() {
        BLOCKER_REACH_UNKNOWN
    } else {
        r.min(BLOCKER_REACH_UNKNOWN)
    }
}

/// The part of a vertex's cone to draw, from how many sheets meet there (saturating) and
/// the first two's tangent normals. A vertex with exactly two sheets draws an arc (from the
/// first normal to the second, `ARC_OVERLAP` past each), one with an even number of four
/// and more an arc per pair (`paired_arcs`, chosen by the caller), the rest the whole cone.
fn cone_arc(sheets: u8, [n1, n2]: [Vec2; 2]) -> ConeArc {
    let full = ConeArc::new([Vec2::X; 2], std::f32::consts::TAU);
    if sheets != 2 {
        return full;
    }
    let sweep = n1.angle_to(n2);
    // Hairpin: which side is outside is ambiguous; draw the whole cone.
    if !sweep.is_finite() || sweep.abs() > std::f32::consts::PI - HAIRPIN {
        return full;
    }
    // As glsl/silhouette/penumbra_emit.comp: a sweep of -0 turns the positive way.
    let e = if sweep < 0.0 {
        -ARC_OVERLAP
    } else {
        ARC_OVERLAP
    };
    ConeArc::new(
        [
            Vec2::from_angle(-e).rotate(n1),
            Vec2::from_angle(e).rotate(n2),
        ],
        sweep + 2.0 * e,
    )
}

/// Where an even number of four and more sheets meet, the arc of each pair of nearest
/// tangent normals (`pair_corner_edges`), as `cone_arc` draws two sheets' arc; `None` (the
/// whole cone) for any other count, or where a pair is a hairpin. `normals` in silhouette
/// order.
fn paired_arcs(normals: &[Vec2]) -> Option<Vec<ConeArc>> {
    let pairs = pair_corner_edges(normals)?;
    pairs
        .into_iter()
        .map(|[a, b]| {
            let arc = cone_arc(2, [normals[a], normals[b]]);
            (arc.sweep.abs() < std::f32::consts::TAU).then_some(arc)
        })
        .collect()
}

/// How far (radians) an arc reaches past each of its two sheets' normals. A sheet's side
/// edge and its cone's end spoke lie on one line from the tip in light uv, with ends at
/// different depths (each is cut at the deepest receiver under its own box); the rasteriser
/// snaps the two ends apart, and a texel centre on that line could fall outside both. Past
/// the normal the cone overlaps the sheet, so such a centre lies inside a cone triangle.
/// On that line the cone's faceted surface and the sheet's plane give nearly the same Eq. 1
/// value; off it the facet can be darker, and MIN keeps the darker, so the overlap is only
/// a little wider than the rasteriser's snapping of a spoke a few texels long.
const ARC_OVERLAP: f32 = 0.002;

/// Within this angle (1 degree) of a half turn, two sheet normals form a hairpin.
const HAIRPIN: f32 = std::f32::consts::PI / 180.0;

/// Cones and sheets of one object (`model`: object -> world) for `light` with disc radius
/// `light_radius` (a sun: its own angle, `cone_spread`), from its silhouette `sil` (as returned by `extract`); cone bases lie at
/// linear depth `z_far`, which must be beyond every receiver. Cones come in welded-vertex
/// order, then sheets in silhouette order. Objects with at least `PAR_EDGES` silhouette edges
/// compute their cones and sheets on rayon; the output is the same either way.
pub fn build_penumbra(
    adj: &Adjacency,
    sil: &[SilhouetteEdge],
    model: Mat4,
    light: &LightView,
    light_radius: f32,
    z_far: f32,
) -> PenumbraGeometry {
    let [outer] = build_penumbra_sides(
        adj,
        sil,
        model,
        light,
        light_radius,
        z_far,
        [Side::Outer],
        &no_bound,
    );
    outer
}

/// A bound on the depth of the receivers a side's fragment can find over a light-uv box:
/// `None` where nothing is known.
pub type DepthBound<'a> = &'a (dyn Fn(Side, Vec2, Vec2) -> Option<f32> + Sync);

/// No bound: every cone to `z_far`, the paper's construction.
pub fn no_bound(_: Side, _: Vec2, _: Vec2) -> Option<f32> {
    None
}

/// `build_penumbra` for each of `sides` from one pass over the silhouette vertices (the
/// cones' tips, bases and the blocker reach are the same on both sides), each cone and each
/// sheet cut at its own base depth: the smaller of `z_far` and `deepest` over the light-uv
/// box of its full geometry (`no_bound`: everything to `z_far`). A cone's or a sheet's
/// triangles are planar and each base point moves along its ruling line towards the tip
/// (`cut_sheet`), so the cut keeps the same planes, and a fragment beyond it lies deeper
/// than every receiver in that box: Eq. 1 discards it (an inner fragment's s is at least 1
/// there). The same image up to the rounding of the interpolation over the shorter
/// triangles. A sheet's side edge and its cone arc's end spoke, cut at different depths,
/// meet on one line with different ends: the arcs overlap their sheets (`ARC_OVERLAP`), or
/// a texel centre on that line can be left uncovered (it was on `primitives` and `bunny`).
#[allow(clippy::too_many_arguments)]
pub fn build_penumbra_sides<const N: usize>(
    adj: &Adjacency,
    sil: &[SilhouetteEdge],
    model: Mat4,
    light: &LightView,
    light_radius: f32,
    z_far: f32,
    sides: [Side; N],
    deepest: DepthBound<'_>,
) -> [PenumbraGeometry; N] {
    let view_inv = light.view.inverse();
    let spread = cone_spread(light, light_radius);
    let sun = light.sun.is_some();
    let par = sil.len() >= PAR_EDGES;
    // Distinct silhouette vertices in welded-vertex order (a bit per welded vertex, then
    // the set bits in order: no sort), `slot[v]` their number, and per vertex how many
    // silhouette edges meet there.
    let nv = adj.positions.len();
    let mut used = vec![0u64; nv.div_ceil(64)];
    for e in sil {
        for v in [e.a, e.b] {
            used[(v / 64) as usize] |= 1 << (v % 64);
        }
    }
    let mut slot = vec![0u32; nv];
    let mut verts: Vec<u32> = Vec::with_capacity(sil.len() + 8);
    for (w, &bits) in used.iter().enumerate() {
        let mut bits = bits;
        while bits != 0 {
            let v = w * 64 + bits.trailing_zeros() as usize;
            bits &= bits - 1;
            slot[v] = verts.len() as u32;
            verts.push(v as u32);
        }
    }
    let mut edges_at = vec![0u32; verts.len()];
    for e in sil {
        edges_at[slot[e.a as usize] as usize] += 1;
        edges_at[slot[e.b as usize] as usize] += 1;
    }
    let special_vertices = edges_at.iter().filter(|&&n| n != 2).count();
    let cones: Vec<Option<ConeData>> = map_maybe_par(&verts, par, |&v| {
        let p = model.transform_point3(adj.positions[v as usize]);
        cone_data(p, light, spread, z_far)
    });
    let reach = blocker_reach(&cones, z_far, sun);
    let cone_of = |v: u32| cones[slot[v as usize] as usize].as_ref();
    // The base depth a side's cone cuts at, from the world points of its full geometry.
    let cut = |side: Side, points: &[Vec3]| -> f32 {
        let (mut lo, mut hi) = (Vec2::splat(f32::INFINITY), Vec2::splat(f32::NEG_INFINITY));
        for &p in points {
            let c = light.view_proj * p.extend(1.0);
            let uv = c.truncate().truncate() / c.w * 0.5 + 0.5;
            if !(c.w > 0.0 && uv.is_finite()) {
                return z_far;
            }
            (lo, hi) = (lo.min(uv), hi.max(uv));
        }
        deepest(side, lo, hi).map_or(z_far, |d| d.min(z_far))
    };
    // `c` cut at `z` where that still leaves it a cone (its tip in front of the cut).
    let at = |c: &ConeData, z: f32| {
        (z < z_far)
            .then(|| cone_data(c.world, light, spread, z))
            .flatten()
            .map(|c| (c, z))
    };
    sides.map(|side| {
        let sheets: Vec<Option<SheetOut>> = map_maybe_par(sil, par, |e| {
            let s = sheet(
                cone_of(e.a)?,
                cone_of(e.b)?,
                view_inv,
                z_far,
                reach,
                side,
                sun,
            )?;
            let z = cut(side, &s.corners());
            Some(cut_sheet(s, light, z))
        });
        let cone_cut = |c: &ConeData| {
            // The circumscribed polygon's corners (`emit_cone`) reach past the round base.
            let r = c.radius / (std::f32::consts::PI / CONE_SEGMENTS as f32).cos();
            let corner = |x: f32, y: f32| {
                let q = c.centre + r * Vec2::new(x, y);
                view_inv.transform_point3(q.extend(-z_far))
            };
            let points = [
                c.world,
                corner(-1.0, -1.0),
                corner(1.0, 1.0),
                corner(1.0, -1.0),
                corner(-1.0, 1.0),
            ];
            at(c, cut(side, &points)).unwrap_or((*c, z_far))
        };
        let mut geo = emit(&cones, &slot, sil, sheets, reach, view_inv, &cone_cut);
        geo.special_vertices = special_vertices;
        geo
    })
}

/// One side's cones (arcs between its sheets' normals) and sheets as a triangle list.
fn emit(
    cones: &[Option<ConeData>],
    slot: &[u32],
    sil: &[SilhouetteEdge],
    sheets: Vec<Option<SheetOut>>,
    reach: f32,
    view_inv: Mat4,
    cone_cut: &dyn Fn(&ConeData) -> (ConeData, f32),
) -> PenumbraGeometry {
    let mut geo = PenumbraGeometry::default();
    // Per vertex, how many sheets it has (saturating at 3) and the tangent normals of the
    // first two, in silhouette order: all `cone_arc` needs; the rest, where more meet, in
    // `extra` (vertex, normal), for `paired_arcs`.
    let mut normals: Vec<(u8, [Vec2; 2])> = vec![(0, [Vec2::ZERO; 2]); cones.len()];
    let mut extra: Vec<(u32, Vec2)> = Vec::new();
    for (e, s) in sil.iter().zip(&sheets) {
        let Some(s) = s else { continue };
        for v in [e.a, e.b] {
            let i = slot[v as usize];
            let (n, first) = &mut normals[i as usize];
            match first.get_mut(usize::from(*n)) {
                Some(x) => *x = s.n,
                None => extra.push((i, s.n)),
            }
            *n = (*n + 1).min(3);
        }
    }
    // By vertex, each vertex's in silhouette order (the sort is stable).
    extra.sort_by_key(|&(i, _)| i);
    let mut extra = &extra[..];
    // Every cone's arc and segment count first, so the output is reserved once (exactly
    // but for paired vertices, whose arcs draw fewer than the whole cone counted here; the
    // cache keeps each caster's vector; most cones are short arcs of one or two segments).
    let arcs: Vec<Option<ConeArc>> = cones
        .iter()
        .zip(&normals)
        .map(|(c, &(n, first))| c.as_ref().map(|_| cone_arc(n, first)))
        .collect();
    let cone_tris: usize = arcs.iter().flatten().map(|a| a.segments).sum();
    let sheet_count = sheets.iter().flatten().count();
    geo.vertices.reserve(3 * cone_tris + 6 * sheet_count);
    for (i, ((c, arc), &(n, first))) in cones.iter().zip(&arcs).zip(&normals).enumerate() {
        let more = extra.partition_point(|&(x, _)| x == i as u32);
        let (rest, others) = extra.split_at(more);
        extra = others;
        match (c, arc) {
            (Some(c), Some(arc)) => {
                geo.cones += 1;
                let (c, z) = cone_cut(c);
                // Three and more sheets: the first two, then `rest`.
                let paired = if n > 2 {
                    let all: Vec<Vec2> =
                        first.into_iter().chain(rest.iter().map(|r| r.1)).collect();
                    paired_arcs(&all)
                } else {
                    None
                };
                for arc in paired.as_deref().unwrap_or(std::slice::from_ref(arc)) {
                    geo.cone_triangles +=
                        emit_cone(&mut geo.vertices, &c, reach, view_inv, z, *arc);
                }
            }
            _ => geo.skipped_vertices += 1,
        }
    }
    for s in sheets {
        match s {
            Some(q) => {
                geo.sheets += 1;
                geo.vertices.extend_from_slice(&q.verts);
            }
            None => geo.skipped_edges += 1,
        }
    }
    geo
}

/// Silhouette edges from which `build_penumbra` computes cones and sheets on rayon: below
/// this a caster's work is shorter than the hand-off to the pool.
const PAR_EDGES: usize = 4096;

/// `f` over `items`, on rayon when `par`, in order.
fn map_maybe_par<T: Sync, U: Send>(
    items: &[T],
    par: bool,
    f: impl Fn(&T) -> U + Sync + Send,
) -> Vec<U> {
    if par {
        items.par_iter().with_min_len(256).map(f).collect()
    } else {
        items.iter().map(f).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::super::test_meshes::{bowtie, cube};
    use super::super::{extract, Adjacency};
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

    fn all_finite(g: &PenumbraGeometry) -> bool {
        g.vertices.iter().all(|v| {
            v.position
                .iter()
                .chain(&v.zv_h)
                .chain([&v.reach])
                .all(|x| x.is_finite())
        })
    }

    fn check_counts(g: &PenumbraGeometry) {
        assert_eq!(g.vertices.len(), 3 * g.cone_triangles + 6 * g.sheets);
    }

    #[test]
    fn vertex_is_24_bytes() {
        assert_eq!(std::mem::size_of::<PenumbraVertex>(), 24);
    }

    #[test]
    fn cube_cones_and_planar_tangent_sheets() {
        let adj = Adjacency::build(&cube()).unwrap();
        let model = Mat4::from_translation(Vec3::new(0.0, 1.0, 0.0));
        let lv = light_at(Vec3::new(3.0, 4.5, 2.2), Vec3::new(0.0, 1.0, 0.0));
        let sil = extract(&adj, model, lv.position);
        assert_eq!(sil.len(), 6);
        let (lr, z_far) = (0.3, 20.0);
        let g = build_penumbra(&adj, &sil, model, &lv, lr, z_far);
        assert!(all_finite(&g));
        check_counts(&g);
        assert_eq!((g.cones, g.sheets, g.special_vertices), (6, 6, 0));
        let (c, _) = lv.project(Vec3::new(0.0, 1.0, 0.0));
        let to_view = |p: [f32; 3]| lv.view.transform_point3(Vec3::from(p));
        // Cones: the tip at the vertex, the base at z_far between C_r and C_r / cos(pi / N)
        // from the centre. A convex loop's corners only need the arcs between adjacent
        // sheets: about one full turn over the whole loop, not 6.
        assert!(g.cone_triangles < 2 * CONE_SEGMENTS, "{}", g.cone_triangles);
        for tri in g.vertices[..3 * g.cone_triangles].chunks_exact(3) {
            let tip = to_view(tri[0].position);
            let zv = -tip.z;
            assert!((tri[0].zv_h[0] - zv).abs() < 1e-4 && tri[0].zv_h[1] == 1.0);
            let centre = tip.truncate() * (z_far / zv);
            let cr = (z_far - zv) * lr / zv;
            for v in &tri[1..] {
                let p = to_view(v.position);
                assert!((p.z + z_far).abs() < 1e-3);
                let r = (p.truncate() - centre).length();
                let most = cr / (std::f32::consts::PI / CONE_SEGMENTS as f32).cos();
                assert!(r > cr - 1e-3 && r < most + 1e-3, "{r} vs {cr}..{most}");
            }
        }
        // Sheets: planar, tangent to both base circles, on the outside (away from the centre).
        for q in g.vertices[3 * g.cone_triangles..].chunks_exact(6) {
            let [a, b, tb, _, _, ta] = [0, 1, 2, 3, 4, 5].map(|i| to_view(q[i].position));
            let n = (b - a).cross(tb - a).normalize();
            assert!(n.dot(ta - a).abs() < 1e-4 * (ta - a).length(), "planar");
            // ta = ca + ra n_base: the plane also holds the light disc's rim point T = -Lr n_base.
            let nb = (ta.truncate() - a.truncate() * (z_far / -a.z)).normalize();
            let t = (-lr * nb).extend(0.0);
            assert!(n.dot(t - a).abs() < 1e-3, "tangent to the light disc");
            // n_base points away from the cube's projected centre.
            let (sa, _) = lv.project(view_to_world(&lv, a));
            let (sb, _) = lv.project(view_to_world(&lv, b));
            assert!(nb.dot((sa + sb) * 0.5 - c) > 0.0, "outside");
            // zv_h: exact Zv at every corner.
            assert!((q[5].zv_h[0] / q[5].zv_h[1] - (-a.z)).abs() < 1e-3);
            assert!((q[2].zv_h[0] / q[2].zv_h[1] - (-b.z)).abs() < 1e-3);
        }
    }

    #[test]
    fn inner_sheets_mirror_the_outer_ones_into_the_hard_shadow() {
        let adj = Adjacency::build(&cube()).unwrap();
        let model = Mat4::from_rotation_y(0.3) * Mat4::from_translation(Vec3::new(0.0, 1.0, 0.0));
        let lv = light_at(Vec3::new(3.0, 4.5, 2.2), Vec3::new(0.0, 1.0, 0.0));
        let sil = extract(&adj, model, lv.position);
        let (lr, z_far) = (0.3, 20.0);
        let [outer, inner] = build_penumbra_sides(
            &adj,
            &sil,
            model,
            &lv,
            lr,
            z_far,
            [Side::Outer, Side::Inner],
            &no_bound,
        );
        assert_eq!(outer, build_penumbra(&adj, &sil, model, &lv, lr, z_far));
        assert!(all_finite(&inner));
        check_counts(&inner);
        assert_eq!((inner.cones, inner.sheets), (outer.cones, outer.sheets));
        let (c, _) = lv.project(Vec3::new(0.0, 1.0, 0.0));
        let to_view = |p: [f32; 3]| lv.view.transform_point3(Vec3::from(p));
        for (q, o) in inner.vertices[3 * inner.cone_triangles..]
            .chunks_exact(6)
            .zip(outer.vertices[3 * outer.cone_triangles..].chunks_exact(6))
        {
            let [a, b, tb, _, _, ta] = [0, 1, 2, 3, 4, 5].map(|i| to_view(q[i].position));
            // The same edge as the outer sheet, planar, through the disc's rim on the far side.
            assert_eq!(q[0].position, o[0].position);
            assert_eq!(q[1].position, o[1].position);
            let n = (b - a).cross(tb - a).normalize();
            assert!(n.dot(ta - a).abs() < 1e-4 * (ta - a).length(), "planar");
            let nb = (ta.truncate() - a.truncate() * (z_far / -a.z)).normalize();
            let t = (-lr * nb).extend(0.0);
            assert!(n.dot(t - a).abs() < 1e-3, "tangent to the light disc");
            // Opens towards the cube's projected centre: into the hard shadow.
            let (sa, _) = lv.project(view_to_world(&lv, a));
            let (sb, _) = lv.project(view_to_world(&lv, b));
            assert!(nb.dot((sa + sb) * 0.5 - c) < 0.0, "inside");
        }
    }

    fn view_to_world(lv: &LightView, p: Vec3) -> Vec3 {
        lv.view.inverse().transform_point3(p)
    }

    #[test]
    fn sheet_zv_interpolation_is_exact() {
        // Any point of a sheet triangle, with world-barycentric weights (what perspective-
        // correct interpolation gives), must get the depth of the edge point its ruling
        // line from T passes through.
        let adj = Adjacency::build(&cube()).unwrap();
        let model = Mat4::from_rotation_y(0.4) * Mat4::from_translation(Vec3::new(0.0, 1.0, 0.0));
        let lv = light_at(Vec3::new(2.0, 5.0, 3.0), Vec3::ZERO);
        let sil = extract(&adj, model, lv.position);
        let (lr, z_far) = (0.5, 15.0);
        let g = build_penumbra(&adj, &sil, model, &lv, lr, z_far);
        assert!(g.sheets > 0);
        for q in g.vertices[3 * g.cone_triangles..].chunks_exact(6) {
            let w = [0.2f32, 0.3, 0.5];
            let tri = &q[..3];
            let p: Vec3 = tri
                .iter()
                .zip(w)
                .map(|(v, w)| Vec3::from(v.position) * w)
                .sum();
            let num: f32 = tri.iter().zip(w).map(|(v, w)| v.zv_h[0] * w).sum();
            let den: f32 = tri.iter().zip(w).map(|(v, w)| v.zv_h[1] * w).sum();
            let (a, b, tb) = (
                lv.view.transform_point3(Vec3::from(tri[0].position)),
                lv.view.transform_point3(Vec3::from(tri[1].position)),
                lv.view.transform_point3(Vec3::from(tri[2].position)),
            );
            // T from tb = T + kb (b - T): T = (tb - kb b) / (1 - kb).
            let kb = tri[2].zv_h[1];
            let t = (tb - kb * b) / (1.0 - kb);
            assert!(t.z.abs() < 1e-3, "T lies on the light disc plane");
            assert!(
                (t.truncate().length() - lr).abs() < 1e-3,
                "T is on the disc rim"
            );
            // Intersect the line T -> P with the edge line a -> b (closest point).
            let pv = lv.view.transform_point3(p);
            let (d1, d2) = (pv - t, b - a);
            let r = a - t;
            let (aa, bb, cc, dd, ee) = (d1.dot(d1), d1.dot(d2), d2.dot(d2), d1.dot(r), d2.dot(r));
            let s = (aa * ee - bb * dd) / (bb * bb - aa * cc);
            let e = a + s * d2;
            assert!(
                (num / den - (-e.z)).abs() < 1e-3 * (-e.z),
                "{} vs {}",
                num / den,
                -e.z
            );
        }
    }

    /// Under a sun the cone at v grows (Z - Zv) tan theta about v's own axis, every corner
    /// carries k = 1 (Zv affine on a sheet: parallel ruling lines), the sheets are planar and
    /// tangent to the cone of directions at both ends, and `reach` is in world units.
    #[test]
    fn sun_cones_grow_linearly_about_each_vertex_with_planar_tangent_sheets() {
        let adj = Adjacency::build(&cube()).unwrap();
        let model = Mat4::from_rotation_y(0.3) * Mat4::from_translation(Vec3::new(0.0, 1.0, 0.0));
        let sun = Light::sun(Vec3::new(1.0, 3.0, 0.5), Vec3::ZERO, 2.0, 10.0);
        let eye = Vec3::ZERO + sun.direction() * 8.0;
        let lv = LightView::sun(&sun, eye, 4.0, 0.5, 20.0);
        let tan = lv.sun.unwrap().tan_angle;
        let sil = extract(&adj, model, crate::silhouette::light_point(&lv));
        let z_far = 19.0;
        // The radius argument is a spotlight's: a sun's cones take its own angle.
        let g = build_penumbra(&adj, &sil, model, &lv, 123.0, z_far);
        assert!(all_finite(&g));
        check_counts(&g);
        assert!(g.cones > 0 && g.sheets > 0 && g.skipped_vertices == 0);
        let to_view = |p: [f32; 3]| lv.view.transform_point3(Vec3::from(p));
        for tri in g.vertices[..3 * g.cone_triangles].chunks_exact(3) {
            let tip = to_view(tri[0].position);
            let zv = -tip.z;
            let cr = (z_far - zv) * tan;
            let most = cr / (std::f32::consts::PI / CONE_SEGMENTS as f32).cos();
            for v in &tri[1..] {
                let p = to_view(v.position);
                assert!((p.z + z_far).abs() < 1e-3);
                let r = (p.truncate() - tip.truncate()).length();
                assert!(r > cr - 1e-3 && r < most + 1e-3, "{r} vs {cr}..{most}");
            }
        }
        // A cube under 3 units across: its reach (world units) is about its half-diagonal.
        let reach = g.vertices[0].reach;
        assert!(reach > 0.5 && reach < 1.0, "{reach}");
        for q in g.vertices[3 * g.cone_triangles..].chunks_exact(6) {
            let [a, b, tb, _, _, ta] = [0, 1, 2, 3, 4, 5].map(|i| to_view(q[i].position));
            assert!(q.iter().all(|v| v.zv_h[1] == 1.0), "k = 1 at every corner");
            assert!((q[5].zv_h[0] + a.z).abs() < 1e-4 && (q[2].zv_h[0] + b.z).abs() < 1e-4);
            let n = (b - a).cross(tb - a).normalize();
            assert!(n.dot(ta - a).abs() < 1e-4 * (ta - a).length(), "planar");
            // Tangent to the cone of directions: the plane's normal is theta off
            // perpendicular to the axis, ta - a and tb - b are one ruling direction.
            assert!(
                (n.z.abs() - theta_sin(tan)).abs() < 1e-4,
                "{} vs {}",
                n.z,
                theta_sin(tan)
            );
            let (da, db) = ((ta - a).normalize(), (tb - b).normalize());
            assert!((da - db).length() < 1e-4, "parallel ruling lines");
        }
    }

    fn theta_sin(tan: f32) -> f32 {
        tan.atan().sin()
    }

    /// The origin, where four silhouette edges meet, gets one cone, drawn as the arcs of
    /// the two pairs of nearest sheet normals (`pair_corner_edges`: the notches above and
    /// below the pinch), not whole.
    #[test]
    fn bowtie_special_vertex_gets_one_cone_of_two_arcs() {
        let adj = Adjacency::build(&bowtie()).unwrap();
        let lv = light_at(Vec3::new(0.0, 0.0, 10.0), Vec3::ZERO);
        let sil = extract(&adj, Mat4::IDENTITY, lv.position);
        let g = build_penumbra(&adj, &sil, Mat4::IDENTITY, &lv, 0.3, 20.0);
        assert!(all_finite(&g));
        check_counts(&g);
        // 6 silhouette edges over 5 distinct vertices (the origin has 4 edges).
        assert_eq!(g.cones, 5);
        assert_eq!(g.special_vertices, 1);
        assert_eq!(g.sheets, 6);
        let at_origin: Vec<_> = g.vertices[..3 * g.cone_triangles]
            .chunks_exact(3)
            .filter(|t| Vec3::from(t[0].position).length() < 1e-6)
            .collect();
        assert!(!at_origin.is_empty() && at_origin.len() < CONE_SEGMENTS / 2);
        // Every base vertex lies above or below the pinch, none beside it.
        for t in &at_origin {
            for v in &t[1..] {
                let p = Vec3::from(v.position);
                assert!(p.y.abs() > p.x.abs(), "base vertex {p}");
            }
        }
    }

    #[test]
    fn behind_light_and_zero_radius_are_finite() {
        let mut mesh = cube();
        for p in &mut mesh.positions {
            p.z *= 20.0;
        }
        let adj = Adjacency::build(&mesh).unwrap();
        let lv = light_at(Vec3::new(0.0, 2.0, 0.0), Vec3::new(0.0, 0.0, -5.0));
        let sil = extract(&adj, Mat4::IDENTITY, lv.position);
        for lr in [0.0, 0.2] {
            let g = build_penumbra(&adj, &sil, Mat4::IDENTITY, &lv, lr, 40.0);
            assert!(g.skipped_vertices > 0);
            assert!(g.skipped_edges > 0);
            assert_eq!(g.sheets + g.skipped_edges, sil.len());
            assert!(all_finite(&g));
            check_counts(&g);
        }
    }
}
