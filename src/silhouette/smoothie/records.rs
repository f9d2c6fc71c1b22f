//! Compact smoothie records, expanded into triangles ([`SmoothieRecords::expand_side`]):
//! what the renderer's CPU path (`--silhouettes cpu`) builds and draws. An optimisation of the
//! reference construction in smoothie.rs ([`super::build_smoothies_width`]), held to it by
//! `silhouette::smoothie::equivalence` (what agrees how: below and there). The GPU path
//! (`silhouette::gpu`) writes expanded [`SmoothieVertex`]es and draws them with
//! glsl/smoothies/smoothie.vert.
//!
//! The expanded triangle list of [`super::build_smoothies_width`] costs, per light on
//! `dense`, 145k 36-byte vertices (5.2 MB) and ~57k libm calls (atan2 per corner, cos per
//! fan, sin/cos per spoke). Here the decisions (which edges, which side, which arc, how
//! many segments) are taken once into 16-byte records (~0.6 MB on `dense`), and the
//! expansion is plain per-vertex arithmetic and one sin/cos per spoke.
//!
//! # Records (16-byte units)
//! Per caster, four arrays, in this order (`words` counts them back to back):
//! - [`VertexRecord`] per silhouette vertex, projected once: uv, 1 / linear depth, width t
//!   (bit for bit `build_smoothies_width`'s). Vertices the projection rejects (at or
//!   behind the near plane) get zeros and are never referenced.
//! - [`EdgeRecord`] per kept silhouette edge: its two vertex records' indices and the unit
//!   outward direction d. Expands to 6 vertices: (s0, s1, s1 + t1 d) and
//!   (s0, s1 + t1 d, s0 + t0 d), all with kind 0, anchor s0, dir d, each end's own 1/depth
//!   and t: bit for bit `build_edge`'s quad when d is the same.
//! - [`FanRecord`] per fan: the centre vertex record's index, the unit direction `from`
//!   of the first spoke and the signed sweep in radians (> 0: counter-clockwise in uv).
//!   Two-edge corner: one fan from d1 (the first incident edge in silhouette order) over
//!   the shorter arc to d2, or the hairpin half turn (+-PI), decided as `build_corner`
//!   decides. An even number of four and more kept edges: the two-edge fan of each pair
//!   `pair_corner_edges` makes, several fans at one centre. One edge or another odd number
//!   (a full-disc special vertex): one fan over the full
//!   disc from d1 (sweep 2 PI, 13 segments). `build_corner` splits the same disc at every
//!   d_i and at the projected vertex normal n_t, one fan per gap (the paper's triangles
//!   (s, s + t d_i, s + n_t) lie inside it). The two polygons differ only in where they
//!   overshoot the disc of radius t (out to t / cos(phi / 2)), and there alpha >= 1, which
//!   glsl/smoothies/smoothie.frag discards: both draw the same smoothie texels
//!   (tests/gpu_silhouettes.rs renders both paths and compares the images).
//! - one `u32` per fan segment: `fan << 8 | n << 4 | k` (segment k of the fan's n;
//!   n <= 13, 4 bits each; fewer than 2^24 fans per caster), four to a unit, the last unit
//!   padded with zeros. Expands to 3 vertices: the centre, spoke k, spoke k + 1.
//!
//! Spoke i of a fan of sweep S points at angle -P + phi i from `from` (P = FAN_OVERLAP
//! with S's sign, phi = (S + 2P) / n), at radius t / cos(phi / 2) so that every segment's
//! chord stays outside the disc of radius t. n = ceil(|S + 2P| / MAX_SEGMENT) >= 1, the
//! count of `build_smoothies_width`. Fan vertices: kind 1, anchor = centre uv, dir 0,
//! 1/depth and t of the centre. Adjacent segments compute their shared spoke from the
//! same expression, so a fan is watertight; fans still overlap the edge quads by
//! FAN_OVERLAP (T-junctions).
//!
//! # Cost (per light, one core; BENCHMARKS.md)
//! No libm: a two-edge corner's arc is [`fast_atan2`] of the cross and dot products (a
//! degree-11 odd polynomial, |error| < 2e-6 rad: the last spoke moves by 2e-6 t, far below
//! a texel); n is a ceil by truncation and one compare. The Volokh normal test takes the
//! projection's derivative instead of three projections (see `edge_dir`), with the
//! clip-space normal matrix precomputed for rigid and uniformly scaled models. Every
//! silhouette vertex is numbered in one loop and projected in the next; a corner needs only
//! its first two incident edges and a count, gathered while the edges are built (the rest,
//! where more meet, in a list of their own, sorted by vertex once). The
//! two-edge arcs are computed for every vertex in a loop of their own, with no pushes or
//! branches (consecutive vertices' divisions and polynomials overlap; it does not
//! vectorise), before the loop that writes the fans. A full-disc special vertex is one fan
//! from its first edge: no spoke angles, no sort, no n_t. On `dense` (one silhouette
//! vertex in seven is special) the split disc took about a fifth of the time per light,
//! which one fan saves (BENCHMARKS.md). The working arrays live per thread between calls
//! (`Scratch`). The numbering, projection and edge loops reach them through slices,
//! `extend` or a local `Vec`, not by pushing into and indexing the fields of `Scratch` or
//! of the records being built: a store into a `Vec`'s buffer may, for all the compiler
//! knows, change that `Vec`'s own pointer and length, so it reloaded both (and redid the
//! bounds checks) after every store.
//!
//! Not done, because measured slower (BENCHMARKS.md): plain two-edge fans written
//! branch-free at a running count, numbering in branch-free passes with a scatter, both
//! `Incident` slots written per edge. Each adds a store whose address waits on a recent
//! load.
//!
//! # Draw
//! [`SmoothieRecords::expand_side`] writes each caster's triangle list once per build
//! (edges' quads, then fan segments), and the renderer draws every caster's in one draw
//! through glsl/smoothies/smoothie.vert, as the GPU path's. Vertex shaders pulling these
//! records from a storage buffer (6 invocations per edge, 3 per fan segment) ran the
//! smoothie pass 1.3-1.6x longer on lavapipe, whose vertex shading is the same CPU with
//! a bounds-checked gather per load; on a GPU they would save the upload's bandwidth.

use super::{
    hairpin_ccw, normals_pick_a_side, undecided_dir, Projected, Projector, SilVertex,
    SmoothieVertex, Width, FAN_OVERLAP, MAX_SEGMENT,
};
use crate::scene::LightView;
use crate::silhouette::{pair_corner_edges, Adjacency, EdgeKind, Side, SilhouetteEdge};
use glam::{Mat4, Vec2, Vec4, Vec4Swizzles};
use std::f32::consts::{FRAC_PI_2, PI, TAU};

/// A silhouette vertex: light uv, 1 / linear depth, smoothie width t (16 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct VertexRecord {
    pub uv: [f32; 2],
    pub inv_depth: f32,
    pub width: f32,
}

/// A smoothie edge: vertex record indices of its ends and its unit outward direction.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct EdgeRecord {
    pub a: u32,
    pub b: u32,
    pub dir: [f32; 2],
}

/// A corner fan: centre vertex record index, unit first spoke, signed sweep (radians).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct FanRecord {
    pub centre: u32,
    pub from: [f32; 2],
    pub sweep: f32,
}

impl VertexRecord {
    /// Whether the projection kept the vertex: a kept one has 1 / depth > 0 (depth finite,
    /// beyond the near plane), a rejected one is all zeros.
    fn projected(&self) -> bool {
        self.inv_depth > 0.0
    }
}

/// Largest fan index a segment word can hold (24 bits).
pub const MAX_FANS: usize = 1 << 24;

/// Smoothies of one object for one light, as records.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SmoothieRecords {
    pub vertices: Vec<VertexRecord>,
    pub edges: Vec<EdgeRecord>,
    pub fans: Vec<FanRecord>,
    /// `fan << 8 | n << 4 | k` per fan segment.
    pub segments: Vec<u32>,
    /// Silhouette vertices that got a corner (two-edge corners and special vertices).
    pub corners: usize,
    /// Silhouette vertices with one or three and more kept edges (paired fans where the
    /// count is even, else a full-disc fan).
    pub special_vertices: usize,
    /// Silhouette edges dropped: behind or too close to the light, or zero length on screen.
    pub skipped_edges: usize,
}

/// atan2(y, x) in [-PI, PI] without libm: |error| < 2e-6 rad (checked against libm by
/// `fast_atan2_accuracy`), monotonic in the angle. atan2(0, 0) = 0, and never NaN.
/// Branch-free (the quadrant fix-ups are selects): in a loop, one call's division and
/// polynomial overlap the next's, with no quadrant branch to mispredict.
pub fn fast_atan2(y: f32, x: f32) -> f32 {
    let (ax, ay) = (x.abs(), y.abs());
    // 0 / 0 (and inf / inf) give a NaN ratio, mapped to 0 at the end.
    let a = ax.min(ay) / ax.max(ay);
    let s = a * a;
    let r = a
        * (0.999_977_26
            + s * (-0.332_623_47
                + s * (0.193_543_46
                    + s * (-0.116_432_87 + s * (0.052_653_32 + s * -0.011_721_2)))));
    let r = if ay > ax { FRAC_PI_2 - r } else { r };
    let r = if x < 0.0 { PI - r } else { r };
    let r = if y < 0.0 { -r } else { r };
    if r.is_nan() {
        0.0
    } else {
        r
    }
}

/// The padding of a fan of sweep `sweep`: FAN_OVERLAP on the side the fan turns to.
/// (glsl/silhouette/corners.comp's `sweep < 0.0 ? -FAN_OVERLAP : FAN_OVERLAP`, the GPU path.)
fn pad_of(sweep: f32) -> f32 {
    if sweep < 0.0 {
        -FAN_OVERLAP
    } else {
        FAN_OVERLAP
    }
}

/// Segments of a fan of sweep `sweep` (the padded sweep in <= MAX_SEGMENT pieces, >= 1).
pub fn segment_count(sweep: f32) -> u32 {
    // A multiply by the rounded reciprocal, not a division (half the corner loop's latency
    // chain): q can differ from the quotient in its last bit, so the count differs from the
    // reference's ceil (smoothie.rs `fan`) only for a sweep within ~1e-7 rad of a segment
    // boundary, where either count covers the arc (`equivalence` compares such fans by
    // coverage).
    // |sweep + 2 pad| = |sweep| + 2 FAN_OVERLAP exactly (pad has the sweep's sign, and
    // rounding is symmetric): no select.
    let q = (sweep.abs() + 2.0 * FAN_OVERLAP) * (1.0 / MAX_SEGMENT);
    // ceil(q) clamped to [1, 15] by truncation: q is first clamped to [0, 15] (NaN to 0),
    // which lets the compiler drop most of the conversion's saturation checks, and the
    // compare adds one exactly when q has a fraction: ceil, with no libm `ceilf` (the
    // baseline x86-64 target has no `roundss`). About ten instructions; the 14 compares
    // against 1..14 it replaced did not vectorise and cost ~30 a fan (BENCHMARKS.md).
    // NaN gives 1.
    let q = if q > 0.0 { q.min(15.0) } else { 0.0 };
    let t = q as i32;
    (t + i32::from((t as f32) < q)).max(1) as u32
}

impl SmoothieRecords {
    /// Vertices the draw expands to: 6 per edge, 3 per fan segment.
    pub fn draw_vertices(&self) -> u32 {
        (6 * self.edges.len() + 3 * self.segments.len()) as u32
    }

    /// Per vertex record, how far from its uv the triangles `expand_side` makes with
    /// `extent` reach, for either side (`mirrored` turns the directions, not the vertices):
    /// a fan's spokes `Extent::of` / cos(phi / 2) with phi <= MAX_SEGMENT, an edge quad
    /// `Extent::of_edge` along its unit direction. With `Extent::FULL`, t / cos(MAX_SEGMENT
    /// / 2) for every record. Not finite for a non-finite uv or width.
    fn reaches(&self, extent: Extent) -> Vec<f32> {
        let spoke = 1.0 / (MAX_SEGMENT * 0.5).cos();
        let mut r: Vec<f32> = self
            .vertices
            .iter()
            .map(|v| {
                let uv = Vec2::from(v.uv);
                if uv.is_finite() && v.width.is_finite() {
                    extent.of(v).abs() * spoke
                } else {
                    f32::INFINITY
                }
            })
            .collect();
        if extent.depth > 0.0 {
            for e in &self.edges {
                let (a, b) = (e.a as usize, e.b as usize);
                let (ea, eb) = extent.of_edge(&self.vertices[a], &self.vertices[b]);
                r[a] = r[a].max(ea.abs());
                r[b] = r[b].max(eb.abs());
            }
        }
        r
    }

    /// The light-uv box every vertex `expand_side` makes with `extent` lies in: every
    /// vertex record's uv plus and minus its reach (`reaches`), i.e. `uv_support` towards
    /// the axes. A non-finite uv or width gives the infinite box; no vertex record, `None`.
    pub fn uv_bounds(&self, extent: Extent) -> Option<(Vec2, Vec2)> {
        // The support towards +x, +y, -x, -y: x + reach and -x + reach, exactly.
        let s = self.uv_support(&[Vec2::X, Vec2::Y, Vec2::NEG_X, Vec2::NEG_Y], extent)?;
        Some((Vec2::new(-s[2], -s[3]), Vec2::new(s[0], s[1])))
    }

    /// Per unit direction d, the largest d · p over the points p the smoothies `expand_side`
    /// makes with `extent` can cover: each vertex record's uv plus its reach towards d
    /// (`reaches`); +inf for a non-finite uv or width. `None` without vertex records.
    pub fn uv_support<const N: usize>(&self, dirs: &[Vec2; N], extent: Extent) -> Option<[f32; N]> {
        let reaches = self.reaches(extent);
        self.vertices
            .iter()
            .zip(reaches)
            .fold(None, |acc, (v, reach)| {
                let uv = Vec2::from(v.uv);
                let s = dirs.map(|d| {
                    if reach.is_finite() {
                        d.dot(uv) + reach
                    } else {
                        f32::INFINITY
                    }
                });
                Some(acc.map_or(s, |a: [f32; N]| std::array::from_fn(|k| a[k].max(s[k]))))
            })
    }

    /// Whether `uv_support` (at any width t >= 0) holds every texel the caster itself
    /// covers in the light's view, not only its smoothies': when every silhouette edge was
    /// kept, as its vertex records then hold every silhouette vertex, and those bound the
    /// caster's projection ("The silhouette bounds the projection" in `crate::silhouette`).
    /// An edge is dropped for a vertex at or behind the near plane, where the projection is
    /// unbounded, or for no length on screen; then a pass must take the caster's box too.
    pub fn holds_caster(&self) -> bool {
        self.skipped_edges == 0 && !self.vertices.is_empty()
    }

    /// 32-bit words of the records laid back to back (module header): a multiple of 4,
    /// the segment words padded to whole 16-byte units.
    pub fn words(&self) -> usize {
        4 * (self.vertices.len() + self.edges.len() + self.fans.len())
            + self.segments.len().next_multiple_of(4)
    }

    /// The inner smoothies (`Side::Inner`, smoothies-centred) of the same silhouette: each
    /// edge's direction and each fan's first spoke negated, the rest shared. The inner
    /// reference construction (`build_smoothies_side`) reflects the outer one the same way.
    pub fn mirrored(&self) -> SmoothieRecords {
        let mut m = self.clone();
        for e in &mut m.edges {
            e.dir = (-Vec2::from(e.dir)).to_array();
        }
        for f in &mut m.fans {
            f.from = (-Vec2::from(f.from)).to_array();
        }
        m
    }

    /// Appends a fan of sweep `sweep` and its `n` (= `segment_count(sweep)`) segment words.
    /// The caller computes n, so that the count's latency chain overlaps the caller's own
    /// work. Most fans (two-edge corners) have one or two segments: two words are written,
    /// else all 16 possible ones, and the length is set after, so that no loop runs n times
    /// (a trip count the branch predictor cannot guess). Inlined into both callers: fewer
    /// instructions per light than the call (BENCHMARKS.md).
    #[inline(always)]
    fn push_fan(&mut self, centre: u32, from: Vec2, sweep: f32, n: u32) {
        debug_assert_eq!(n, segment_count(sweep));
        let fan = self.fans.len();
        if fan >= MAX_FANS {
            return;
        }
        self.fans.push(FanRecord {
            centre,
            from: from.to_array(),
            sweep,
        });
        let word = (fan as u32) << 8 | n << 4;
        let len = self.segments.len();
        if n <= 2 {
            self.segments.extend_from_slice(&[word, word | 1]);
        } else {
            let words: [u32; 16] = std::array::from_fn(|k| word | k as u32);
            self.segments.extend_from_slice(&words);
        }
        self.segments.truncate(len + n as usize);
    }

    /// The triangle list the smoothie pass draws (`expand_side` of the outer side at full
    /// width).
    pub fn expand(&self) -> Vec<SmoothieVertex> {
        let mut out = Vec::with_capacity(self.draw_vertices() as usize);
        self.expand_side(Side::Outer, Extent::FULL, &mut out);
        out
    }

    /// Appends the triangle list of one side's smoothies to `out`: per edge its quad's 6
    /// vertices, then per fan segment the centre, spoke k and spoke k + 1 (module header).
    /// `Side::Inner` expands `mirrored()` without building it; `extent` shortens how far
    /// each vertex record's quads and fans reach (the centred form's inner side), the
    /// varyings staying the full-width geometry's.
    pub fn expand_side(&self, side: Side, extent: Extent, out: &mut Vec<SmoothieVertex>) {
        self.expand_side_within(side, extent, |_, _| None, out);
    }

    /// `expand_side`, each edge quad and fan shortened further by `deepest(lo, hi)`: a
    /// bound on the receiver depth anywhere in the light-uv box of its full-width geometry
    /// (`None`: `extent`'s alone).
    pub fn expand_side_within(
        &self,
        side: Side,
        extent: Extent,
        deepest: impl Fn(Vec2, Vec2) -> Option<f32>,
        out: &mut Vec<SmoothieVertex>,
    ) {
        // The bound over the box of the geometry `extent` draws: a fragment beyond the
        // reach it gives lies inside that box, where no receiver is deeper.
        let local = |bounds: &dyn Fn(Extent) -> (Vec2, Vec2)| {
            if extent.depth <= 0.0 {
                return extent;
            }
            let (lo, hi) = bounds(extent);
            deepest(lo, hi).map_or(extent, |d| extent.within(d))
        };
        let sign = match side {
            Side::Outer => 1.0,
            Side::Inner => -1.0,
        };
        out.reserve(self.draw_vertices() as usize);
        let vtx = |uv: Vec2, r: &VertexRecord, kind: f32, anchor: Vec2, dir: Vec2| SmoothieVertex {
            uv: uv.to_array(),
            inv_depth: r.inv_depth,
            kind,
            anchor: anchor.to_array(),
            dir: dir.to_array(),
            width: r.width,
        };
        for e in &self.edges {
            let (a, b) = (&self.vertices[e.a as usize], &self.vertices[e.b as usize]);
            let (s0, s1, d) = (Vec2::from(a.uv), Vec2::from(b.uv), sign * Vec2::from(e.dir));
            let extent = local(&|x: Extent| {
                let (e0, e1) = x.of_edge(a, b);
                let (f0, f1) = (s0 + e0 * d, s1 + e1 * d);
                (s0.min(s1).min(f0.min(f1)), s0.max(s1).max(f0.max(f1)))
            });
            let (e0, e1) = extent.of_edge(a, b);
            let (o0, o1) = (s0 + e0 * d, s1 + e1 * d);
            out.extend_from_slice(&[
                vtx(s0, a, 0.0, s0, d),
                vtx(s1, b, 0.0, s0, d),
                vtx(o1, b, 0.0, s0, d),
                vtx(s0, a, 0.0, s0, d),
                vtx(o1, b, 0.0, s0, d),
                vtx(o0, a, 0.0, s0, d),
            ]);
        }
        for &w in &self.segments {
            let (fan, n, k) = (w >> 8, (w >> 4) & 15, w & 15);
            let f = &self.fans[fan as usize];
            let c = &self.vertices[f.centre as usize];
            let s = Vec2::from(c.uv);
            let from = sign * Vec2::from(f.from);
            let pad = pad_of(f.sweep);
            let phi = (f.sweep + 2.0 * pad) / n as f32;
            let extent = local(&|x: Extent| {
                let r = Vec2::splat(x.of(c) / (phi * 0.5).cos());
                (s - r, s + r)
            });
            let r = extent.of(c) / (phi * 0.5).cos();
            let spoke = |i: u32| {
                let a = -pad + phi * i as f32;
                let (sin, cos) = a.sin_cos();
                s + r * (from * cos + from.perp() * sin)
            };
            let z = Vec2::ZERO;
            out.extend_from_slice(&[
                vtx(s, c, 1.0, s, z),
                vtx(spoke(k), c, 1.0, s, z),
                vtx(spoke(k + 1), c, 1.0, s, z),
            ]);
        }
    }
}

/// How far a side's smoothies reach from the silhouette (`SmoothieRecords::expand_side`):
/// each vertex record's width t, or shortened to where the smoothie pass discards every
/// fragment further out. A fragment x from the silhouette, where the interpolated width
/// and blocker depth are t and b and the receiver depth it finds is z_r, is kept only when
/// x < t (1 - b / z_r): for the paper form's outer smoothies past that Eq. 1 reaches
/// alpha' = 1 (glsl/smoothies/alpha.glsl), for the centred form's inner ones that is its
/// penumbra's half-width. When z_r is at most `depth`, the quads and fans may stop at
/// t (1 - b / depth) plus `pad`.
///
/// Along an edge t is linear but b = 1 / (interpolated 1 / b) is convex, so t (1 - b /
/// depth) is not linear and the line between the two ends' values would cut into it. An
/// edge therefore takes the smaller b of its two ends at both (`of_edge`): each end's t
/// times one factor, linear along the edge and at least the bound everywhere on it. A fan
/// has one b, its centre's (`of`).
///
/// Under a sun (`span` > 0, the map's depth range) Eq. 1's factor is (z_r - b) / span
/// (src/technique/smoothies.rs, "Under a sun") and b is interpolated linearly: the same
/// bound with (depth - b) / span, again largest at the smaller b.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Extent {
    /// The farthest receiver depth a fragment can find; 0: the full width t.
    pub depth: f32,
    /// Light uv added to a shortened extent (a rasterisation margin: one texel).
    pub pad: f32,
    /// A sun's depth range far - near (Eq. 1s's span); 0: a spotlight's 1 - b / depth.
    pub span: f32,
}

impl Extent {
    pub const FULL: Extent = Extent {
        depth: 0.0,
        pad: 0.0,
        span: 0.0,
    };

    /// This extent for a sun whose map spans `span` in depth (`None`: a spotlight's).
    pub fn for_sun(self, span: Option<f32>) -> Extent {
        match span {
            Some(span) if self.depth > 0.0 && span > 0.0 && span.is_finite() => {
                Extent { span, ..self }
            }
            // No usable span: the full width, never a cut.
            Some(_) => Extent::FULL,
            None => self,
        }
    }

    /// The extent for receivers at most `depth` deep, with `pad`: the depth rounded up to a
    /// grid of 1/64 octave (1.1 %), so that a bound that moves a little (an object moving,
    /// and the light's far plane with it) keeps the triangles already expanded. Not
    /// positive or not finite: the full width.
    pub fn at_most(depth: f32, pad: f32) -> Extent {
        let grid = (depth.log2() * 64.0).ceil() / 64.0;
        let depth = grid.exp2().max(depth);
        if depth > 0.0 && depth.is_finite() {
            Extent {
                depth,
                pad,
                span: 0.0,
            }
        } else {
            Extent::FULL
        }
    }

    /// This extent, shortened for receivers at most `depth` deep where that is less (not
    /// rounded to `at_most`'s grid: a caster's triangles are expanded again whenever the
    /// bounds move).
    fn within(self, depth: f32) -> Extent {
        if depth > 0.0 && depth < self.depth {
            Extent { depth, ..self }
        } else {
            self
        }
    }

    /// 1 - b / depth for the largest 1 / b, at least 0; a sun's (depth - b) / span.
    fn factor(self, inv_depth: f32) -> f32 {
        if self.span > 0.0 {
            return ((self.depth - 1.0 / inv_depth) / self.span).max(0.0);
        }
        (1.0 - 1.0 / (inv_depth * self.depth)).max(0.0)
    }

    /// The reach of a fan centred on vertex record `v`.
    fn of(self, v: &VertexRecord) -> f32 {
        self.reach(v.width, v.inv_depth)
    }

    /// The reach of a smoothie of width `width` whose blocker lies at 1 / `inv_depth`.
    pub fn reach(self, width: f32, inv_depth: f32) -> f32 {
        if self.depth <= 0.0 {
            return width;
        }
        width.min(width * self.factor(inv_depth) + self.pad)
    }

    /// The reach of edge a -> b's quad at its two ends.
    fn of_edge(self, a: &VertexRecord, b: &VertexRecord) -> (f32, f32) {
        if self.depth <= 0.0 {
            return (a.width, b.width);
        }
        let k = self.factor(a.inv_depth.max(b.inv_depth));
        let end = |v: &VertexRecord| v.width.min(v.width * k + self.pad);
        (end(a), end(b))
    }
}

/// Smoothie records of one object (`model`: object -> world) for `light` from its
/// silhouette `sil` (as returned by `extract`): the same edges and directions, and corners
/// covering the same discs, as `build_smoothies_width`; serial (cheap enough for one
/// thread).
pub fn build_records(
    adj: &Adjacency,
    sil: &[SilhouetteEdge],
    model: Mat4,
    light: &LightView,
    width: Width,
) -> SmoothieRecords {
    SCRATCH.with_borrow_mut(|scratch| build_with(adj, sil, model, light, width, scratch))
}

/// Silhouette-vertex number of a welded vertex not (yet) numbered.
const UNNUMBERED: u32 = u32::MAX;

/// `build_records`' working arrays, kept per thread between calls: a light's ~36 casters on
/// `dense` made ~300 allocations and cleared a slot per welded vertex each time.
#[derive(Default)]
struct Scratch {
    /// Per welded vertex, its silhouette-vertex number or UNNUMBERED: all UNNUMBERED
    /// between calls (a call resets the entries it numbered).
    slot: Vec<u32>,
    /// Set while a call runs: a call that finds it set (the last one unwound) clears `slot`.
    dirty: bool,
    welded: Vec<u32>,
    ends: Vec<[u32; 2]>,
    clips: Vec<Vec4>,
    incident: Vec<Incident>,
    /// The kept edges after a vertex's first two (silhouette vertex, silhouette index,
    /// outward direction), in silhouette order: only vertices where more than two meet.
    extra: Vec<(u32, u32, Vec2)>,
    arcs: Vec<f32>,
}

thread_local! {
    static SCRATCH: std::cell::RefCell<Scratch> = std::cell::RefCell::default();
}

/// The construction, in four steps over the per-thread working arrays: number the
/// silhouette vertices, project them, build the edges, build the corners. Each step is one
/// tight loop (or two) over arrays the previous steps filled, which is what makes this path
/// faster than the reference; the decisions are the reference's.
fn build_with(
    adj: &Adjacency,
    sil: &[SilhouetteEdge],
    model: Mat4,
    light: &LightView,
    width: Width,
    scratch: &mut Scratch,
) -> SmoothieRecords {
    let pr = Projector::new(model, light);
    let normals = NormalProjector::new(&pr);
    let mut rec = SmoothieRecords::default();
    scratch.number(adj.positions.len(), sil);
    rec.vertices = project(adj, &pr, light, width, &scratch.welded, &mut scratch.clips);
    rec.edges = kept_edges(adj, &pr, &normals, sil, scratch, &rec.vertices);
    rec.skipped_edges = sil.len() - rec.edges.len();
    build_corners(adj, &pr, sil, scratch, &mut rec);
    scratch.release();
    rec
}

impl Scratch {
    /// Numbers the silhouette vertices in order of first use (as `build_impl`): fills
    /// `welded` (the welded vertex of each silhouette vertex) and `ends` (each silhouette
    /// edge's two silhouette-vertex numbers), and marks the numbered entries of `slot`
    /// until `release`. Numbering first and projecting afterwards keeps the bookkeeping
    /// and the arithmetic in separate tight loops.
    fn number(&mut self, nv: usize, sil: &[SilhouetteEdge]) {
        let Scratch {
            slot,
            dirty,
            welded,
            ends,
            ..
        } = self;
        if *dirty {
            slot.fill(UNNUMBERED);
        }
        *dirty = true;
        if slot.len() < nv {
            slot.resize(nv, UNNUMBERED);
        }
        welded.clear();
        welded.resize(2 * sil.len(), 0);
        ends.clear();
        ends.resize(sil.len(), [0; 2]);
        let mut numbered = 0usize;
        {
            // Through slices, not the `Vec`s: for all the compiler knows, a store into a
            // `Vec`'s buffer may overwrite that `Vec`'s own pointer and length (both live in
            // `scratch`), so it reloaded them and redid the bounds checks after every store:
            // ~60 instructions per edge, 34 with slices (BENCHMARKS.md). The same holds in
            // the later steps.
            let (slot, uses) = (&mut slot[..], &mut welded[..]);
            for (e, end) in sil.iter().zip(ends.iter_mut()) {
                // Branch-free: every vertex is new at exactly one of its (usually two)
                // uses, so "is it new" is a coin toss to the branch predictor; `uses` is
                // written at every use and advanced only at the first.
                let mut number = |v: u32| {
                    let old = slot[v as usize];
                    let new = old == UNNUMBERED;
                    uses[numbered] = v;
                    let id = if new { numbered as u32 } else { old };
                    slot[v as usize] = id;
                    numbered += usize::from(new);
                    id
                };
                *end = [number(e.a), number(e.b)];
            }
        }
        welded.truncate(numbered);
    }

    /// Returns `slot` to all UNNUMBERED, so that the next call starts from a clean table
    /// without clearing a slot per welded vertex.
    fn release(&mut self) {
        for &v in self.welded.iter() {
            self.slot[v as usize] = UNNUMBERED;
        }
        self.dirty = false;
    }
}

/// The vertex records, one per silhouette vertex (`welded`), and their clip coordinates
/// in `clips`. The clip coordinates are kept because they are linear in the world point:
/// an edge's midpoint needs no projection of its own (`edge_dir`). The later steps read
/// only these two arrays per vertex (32 bytes); the world point is recomputed where the
/// rare fallbacks need it (`edge_dir`, hairpins). `LightView::project` and
/// `Projector::project`, operation for operation.
fn project(
    adj: &Adjacency,
    pr: &Projector,
    light: &LightView,
    width: Width,
    welded: &[u32],
    clips: &mut Vec<Vec4>,
) -> Vec<VertexRecord> {
    // Each array by an `extend` of a mapped slice iterator, whose length is known: one
    // reservation and plain stores, no capacity test or length update per element.
    clips.clear();
    clips.extend(
        welded
            .iter()
            .map(|&v| light.view_proj * pr.world(adj.positions[v as usize]).extend(1.0)),
    );
    let mut vertices = Vec::new();
    vertices.extend(clips.iter().zip(welded).map(|(&c, &v)| {
        // x / w, y / w and 1 / w in one division (each lane rounds as its own would).
        let q = Vec4::new(c.x, c.y, 1.0, 1.0) / c.w;
        let s = q.xy() * 0.5 + Vec2::splat(0.5);
        // A sun's clip w is 1: its linear depth is the view's, as `LightView::project`'s.
        let (z, inv_depth) = match light.sun {
            None => (c.w, q.z),
            Some(_) => {
                let z = light.linear_depth(pr.world(adj.positions[v as usize]));
                (z, 1.0 / z)
            }
        };
        let ok = z > light.near && s.is_finite() && z.is_finite();
        if ok {
            VertexRecord {
                uv: s.to_array(),
                inv_depth,
                width: width.at(z),
            }
        } else {
            VertexRecord::default()
        }
    }));
    vertices
}

/// The edge records, in silhouette order (edges `edge_dir` drops are left out), and per
/// silhouette vertex in `scratch.incident` the number of kept incident edges (saturating)
/// and the first two of them in silhouette order, the rest in `scratch.extra`: all a
/// corner needs, gathered here so that the corner step never looks at the edges again.
fn kept_edges(
    adj: &Adjacency,
    pr: &Projector,
    normals: &NormalProjector,
    sil: &[SilhouetteEdge],
    scratch: &mut Scratch,
    vertices: &[VertexRecord],
) -> Vec<EdgeRecord> {
    let Scratch {
        ends,
        clips,
        incident,
        extra,
        welded,
        ..
    } = scratch;
    incident.clear();
    incident.resize(welded.len(), Incident::default());
    extra.clear();
    // Pushed into a local `Vec` (one that only this loop can reach, unlike the records'
    // fields), reading the other arrays through slices.
    let mut edges = Vec::with_capacity(sil.len());
    let (clips, incident) = (&clips[..], &mut incident[..]);
    for (i, (e, &[a, b])) in sil.iter().zip(ends.iter()).enumerate() {
        let ends = [&vertices[a as usize], &vertices[b as usize]];
        let clip = [clips[a as usize], clips[b as usize]];
        if let Some(d) = edge_dir(adj, pr, normals.clip(adj, pr, e), e, ends, clip) {
            edges.push(EdgeRecord {
                a,
                b,
                dir: d.to_array(),
            });
            for c in [a, b] {
                let inc = &mut incident[c as usize];
                if inc.count >= 2 {
                    extra.push((c, i as u32, d));
                }
                inc.add(i as u32, d);
            }
        }
    }
    edges
}

/// The fan records and segment words, and the corner counts, in silhouette-vertex order
/// (the order of first use), so that every per-vertex array is read front to back.
/// `build_smoothies_width` goes by welded vertex index; the fans are the same, in another
/// order, which the smoothie pass cannot see (both of its attachments blend with MIN).
fn build_corners(
    adj: &Adjacency,
    pr: &Projector,
    sil: &[SilhouetteEdge],
    scratch: &mut Scratch,
    rec: &mut SmoothieRecords,
) {
    let Scratch {
        welded,
        clips,
        incident,
        extra,
        arcs,
        ..
    } = scratch;
    // By vertex, each vertex's in silhouette order (the sort is stable).
    extra.sort_by_key(|&(c, _, _)| c);
    let mut extra = &extra[..];
    // Every vertex's arc from its first to its second edge (used by two-edge corners), in a
    // loop of its own: no pushes and no branches, so that the vertices' divisions and
    // polynomials overlap.
    arcs.clear();
    arcs.extend(incident.iter().map(|inc| {
        let [(_, d1), (_, d2)] = inc.edges;
        fast_atan2(d1.perp_dot(d2), d1.dot(d2).clamp(-1.0, 1.0))
    }));
    // One fan per vertex for most, and the 16 words a fan's segments may write past the
    // end (13 for a full disc's).
    rec.fans.reserve(welded.len());
    rec.segments.reserve(4 * welded.len() + 16);
    let per_vertex = welded
        .iter()
        .zip(clips.iter())
        .zip(incident.iter().zip(arcs.iter()));
    for (c, ((&v, &clip), (inc, &arc))) in per_vertex.enumerate() {
        if inc.count == 0 {
            continue;
        }
        let more = extra.partition_point(|&(x, _, _)| x == c as u32);
        let corner = Corner {
            c: c as u32,
            v,
            clip,
            inc,
            extra: &extra[..more],
            arc,
        };
        extra = &extra[more..];
        if let Some(special) = corner.build(adj, pr, sil, rec) {
            rec.corners += 1;
            rec.special_vertices += usize::from(special);
        }
    }
}

/// A silhouette vertex's kept incident edges: how many (saturating at 3) and the first two
/// (silhouette index, outward direction) in silhouette order.
#[derive(Clone, Copy, Default)]
struct Incident {
    count: u8,
    edges: [(u32, Vec2); 2],
}

impl Incident {
    /// Counts the edge and keeps it when it is one of the first two.
    fn add(&mut self, edge: u32, d: Vec2) {
        if let Some(slot) = self.edges.get_mut(self.count as usize) {
            *slot = (edge, d);
        }
        self.count = (self.count + 1).min(3);
    }
}

/// `smoothie::edge_dir` with the normals' screen direction by the projection's derivative
/// instead of finite differences: Volokh's sum of the adjacent faces' projected normals at
/// the edge midpoint m is J(m) sum(n_i), J the Jacobian of uv(p) = 0.5 + 0.5 c.xy / c.w,
/// c = VP (p, 1): J n = 0.5 (cn.xy c.w - c.xy cn.w) / c.w^2 with cn = VP (n, 0). Only its
/// direction matters (sign of d . avg, and |d . avg| against 1e-2 |avg|), so the positive
/// factor 0.5 / c.w^2 is dropped; c(m) is the mean of the ends' clip coordinates. One 4x4
/// product per edge instead of three projections: the finite differences (a probe of 1e-3
/// of the depth) agree to about 1e-3 relative, so the decision can differ only where
/// |d . avg| / |avg| is within 1e-3 relative of the 1e-2 threshold, and there the
/// third-vertex test decides instead (`equivalence` compares every edge with the reference).
fn edge_dir(
    adj: &Adjacency,
    pr: &Projector,
    cn: Vec4,
    e: &SilhouetteEdge,
    [ra, rb]: [&VertexRecord; 2],
    [ca, cb]: [Vec4; 2],
) -> Option<Vec2> {
    if !ra.projected() || !rb.projected() {
        return None;
    }
    let (s0, s1) = (Vec2::from(ra.uv), Vec2::from(rb.uv));
    let along = s1 - s0;
    let len = along.length();
    // Also catches NaN.
    if len.is_nan() || len <= 1e-9 {
        return None;
    }
    let d = along.perp() / len;
    if e.kind != EdgeKind::Boundary && normals_pick_a_side(adj, e) {
        // Both ends lie beyond the near plane, so does the midpoint.
        let cm = (ca + cb) * 0.5;
        let avg = cn.xy() * cm.w - cm.xy() * cn.w;
        let dot = d.dot(avg);
        // Only trust the normals when they clearly pick a side (> ~0.5 degree):
        // |dot| > 1e-2 |avg|, squared (no square root).
        if dot * dot > 1e-4 * avg.length_squared() {
            // The side is a coin toss per edge: a sign copy, not a branch (dot != 0 here).
            return Some(d * 1f32.copysign(dot));
        }
    }
    let [pa, pb] = [e.a, e.b].map(|v| pr.world(adj.positions[v as usize]));
    Some(undecided_dir(adj, pr, e, pa, pb, s0, s1, d))
}

/// Clip-space direction of the sum of an edge's adjacent unit world normals (up to a
/// positive factor).
enum NormalProjector {
    /// The normal matrix N is a rotation times a uniform scale s (any rigid or uniformly
    /// scaled model, mirrored or not): every unit face normal maps to length s, so
    /// sum(normalize(N n_i)) = N sum(n_i) / s, and VP N sum(n_i) has the right direction
    /// with no square root or division. Holds VP N.
    Similar(Mat4),
    /// Anything else: each face normal is transformed and normalized.
    General,
}

impl NormalProjector {
    fn new(pr: &Projector) -> Self {
        let n = pr.normal_matrix;
        let (x, y, z) = (n.x_axis, n.y_axis, n.z_axis);
        let l = x.length_squared();
        let tol = 1e-5 * l;
        let similar = l > 0.0
            && (y.length_squared() - l).abs() <= tol
            && (z.length_squared() - l).abs() <= tol
            && x.dot(y).abs() <= tol
            && x.dot(z).abs() <= tol
            && y.dot(z).abs() <= tol;
        if similar {
            NormalProjector::Similar(pr.light.view_proj * Mat4::from_mat3(n))
        } else {
            NormalProjector::General
        }
    }

    fn clip(&self, adj: &Adjacency, pr: &Projector, e: &SilhouetteEdge) -> Vec4 {
        match self {
            // The same sum, in the same order, as the General branch's before normalizing.
            NormalProjector::Similar(m) => *m * adj.edge_normals[e.edge as usize].extend(0.0),
            NormalProjector::General => {
                let faces = adj.edge_faces(e.edge as usize);
                let valid = faces.iter().filter(|ef| !adj.degenerate[ef.face as usize]);
                let n: glam::Vec3 = valid
                    .map(|ef| {
                        (pr.normal_matrix * adj.face_normals[ef.face as usize]).normalize_or_zero()
                    })
                    .sum();
                pr.light.view_proj * n.extend(0.0)
            }
        }
    }
}

/// One silhouette vertex's corner: record index `c`, welded vertex `v`, its clip
/// coordinates and its kept incident edges.
struct Corner<'a> {
    c: u32,
    v: u32,
    clip: Vec4,
    inc: &'a Incident,
    /// Its kept edges after the first two (`Scratch::extra`).
    extra: &'a [(u32, u32, Vec2)],
    /// `fast_atan2` of the cross and dot products of the first two edges' directions.
    arc: f32,
}

impl Corner<'_> {
    /// The vertex as the shared helpers take it, exactly as `build_smoothies_width`
    /// projects it (uv from the record, depth = clip w, the world point recomputed).
    fn vertex(&self, adj: &Adjacency, pr: &Projector, rec: &SmoothieRecords) -> SilVertex {
        let r = &rec.vertices[self.c as usize];
        SilVertex {
            v: self.v,
            p: pr.world(adj.positions[self.v as usize]),
            proj: Some(Projected {
                s: Vec2::from(r.uv),
                z: self.clip.w,
                inv: r.inv_depth,
                t: r.width,
            }),
        }
    }

    /// The corner's fans; whether it is special, or `None` when it needs no corner. Two
    /// edges: the shorter arc from d1 to d2, or the hairpin half turn, as `build_corner`
    /// decides; none when d1 == d2. An even number of four and more: the same for each of
    /// the pairs `pair_corner_edges` makes. One edge, three, or another odd number (the
    /// paper's special case): the full disc, one fan from d1 (see the module header).
    fn build(
        &self,
        adj: &Adjacency,
        pr: &Projector,
        sil: &[SilhouetteEdge],
        rec: &mut SmoothieRecords,
    ) -> Option<bool> {
        // A kept edge has both ends projected (`edge_dir`), so a vertex with one is too.
        let [first, second] = self.inc.edges;
        if self.inc.count == 2 {
            return self
                .two_edge(adj, pr, sil, rec, first, second, self.arc)
                .then_some(false);
        }
        if self.inc.count > 2 {
            let all: Vec<(u32, Vec2)> = [first, second]
                .into_iter()
                .chain(self.extra.iter().map(|&(_, i, d)| (i, d)))
                .collect();
            let outward: Vec<Vec2> = all.iter().map(|&(_, d)| d).collect();
            if let Some(pairs) = pair_corner_edges(&outward) {
                for [a, b] in pairs {
                    let (d1, d2) = (all[a].1, all[b].1);
                    let arc = fast_atan2(d1.perp_dot(d2), d1.dot(d2).clamp(-1.0, 1.0));
                    self.two_edge(adj, pr, sil, rec, all[a], all[b], arc);
                }
                return Some(true);
            }
        }
        rec.push_fan(self.c, first.1, TAU, segment_count(TAU));
        Some(true)
    }

    /// The two-edge corner of edges `(i1, d1)` and `(i2, d2)` (silhouette order), `arc`
    /// the `fast_atan2` of their directions' cross and dot products; false when it needs
    /// no fan.
    #[allow(clippy::too_many_arguments)]
    fn two_edge(
        &self,
        adj: &Adjacency,
        pr: &Projector,
        sil: &[SilhouetteEdge],
        rec: &mut SmoothieRecords,
        (i1, d1): (u32, Vec2),
        (i2, d2): (u32, Vec2),
        arc: f32,
    ) -> bool {
        let cos = d1.dot(d2).clamp(-1.0, 1.0);
        // The exact thresholds of `build_corner` (no corner below MIN_CORNER_ANGLE, the
        // hairpin above PI - MIN_CORNER_ANGLE): cos == +-1.
        if cos >= 1.0 {
            return false;
        }
        let sweep = if cos <= -1.0 {
            let edges = [&sil[i1 as usize], &sil[i2 as usize]];
            if hairpin_ccw(adj, pr, &self.vertex(adj, pr, rec), edges.into_iter(), d1) {
                PI
            } else {
                -PI
            }
        } else {
            arc
        };
        rec.push_fan(self.c, d1, sweep, segment_count(sweep));
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A vertex where an odd number of kept edges meet (one, three, ...) gets one fan over
    /// the full disc from its first kept edge's direction, in 13 segments; one where an
    /// even number of four and more meet, at most one fan of at most a half turn per pair
    /// of edges (`pair_corner_edges`), and no full disc; a two-edge corner at most one such
    /// fan. On a vertex where ten edges meet and on every built-in scene.
    #[test]
    fn special_vertices_get_paired_fans_or_one_full_disc() {
        use crate::frustum::fit_light;
        use crate::scene::{Light, LightView, Mesh, Scene, BUILTIN_SCENES};
        let check = |r: &SmoothieRecords, name: &str| {
            let mut kept = vec![0usize; r.vertices.len()];
            for e in &r.edges {
                kept[e.a as usize] += 1;
                kept[e.b as usize] += 1;
            }
            let mut fans_at = vec![0usize; r.vertices.len()];
            for f in &r.fans {
                fans_at[f.centre as usize] += 1;
            }
            for (c, (&k, &n)) in kept.iter().zip(&fans_at).enumerate() {
                match k {
                    0 => assert_eq!(n, 0, "{name}: vertex {c}"),
                    k if k % 2 == 1 => assert_eq!(n, 1, "{name}: vertex {c}, {k} edges"),
                    k => assert!(n <= k / 2, "{name}: vertex {c}, {k} edges, {n} fans"),
                }
            }
            let odd = kept.iter().filter(|&&k| k % 2 == 1).count();
            let special = kept.iter().filter(|&&k| k != 0 && k != 2).count();
            assert_eq!(special, r.special_vertices, "{name}");
            let mut segments = vec![0u32; r.fans.len()];
            for &w in &r.segments {
                let (fan, n) = ((w >> 8) as usize, (w >> 4) & 15);
                assert_eq!(n, segment_count(r.fans[fan].sweep), "{name}");
                segments[fan] += 1;
            }
            let mut full = 0;
            for (f, &n) in r.fans.iter().zip(&segments) {
                assert_eq!(n, segment_count(f.sweep), "{name}");
                if f.sweep == TAU {
                    full += 1;
                    assert_eq!(kept[f.centre as usize] % 2, 1, "{name}: full disc");
                    assert_eq!(n, 13, "{name}");
                    let first = r.edges.iter().find(|e| e.a == f.centre || e.b == f.centre);
                    assert_eq!(first.map(|e| e.dir), Some(f.from), "{name}: from d1");
                } else {
                    assert!(f.sweep.abs() <= PI, "{name}: sweep {}", f.sweep);
                }
            }
            assert_eq!(full, odd, "{name}");
            special
        };
        // Five separate triangles around one vertex: ten boundary edges (all silhouette
        // edges) meet there.
        let mut star = Mesh::default();
        star.positions.push(glam::Vec3::ZERO);
        star.normals.push(glam::Vec3::Z);
        for k in 0..5 {
            let a = k as f32 * TAU / 5.0;
            for da in [0.0, 0.4] {
                let (s, c) = (a + da).sin_cos();
                star.positions.push(glam::Vec3::new(c, s, 0.0));
                star.normals.push(glam::Vec3::Z);
            }
            star.indices.extend([0, 1 + 2 * k, 2 + 2 * k]);
        }
        let adj = Adjacency::build(&star).expect("adjacency");
        let light = LightView::new(
            &Light {
                position: glam::Vec3::new(0.3, 0.2, 5.0),
                target: glam::Vec3::ZERO,
                fov_deg: 60.0,
                radius: 0.2,
                kind: crate::scene::LightKind::Spot,
            },
            0.1,
            20.0,
        );
        let sil = crate::silhouette::extract(&adj, Mat4::IDENTITY, light.position);
        // Every edge is a boundary edge: 15, ten of them at the centre.
        assert_eq!(sil.len(), 15);
        let rec = build_records(&adj, &sil, Mat4::IDENTITY, &light, Width::Fixed(0.02));
        check(&rec, "star");
        let centre_uv = light.project(glam::Vec3::ZERO).0;
        let at_centre: Vec<_> = rec
            .fans
            .iter()
            .filter(|f| {
                (Vec2::from(rec.vertices[f.centre as usize].uv) - centre_uv).length() < 1e-6
            })
            .collect();
        // Pairs of nearest outward directions: the five notches between neighbouring
        // triangles, each a fan of a few degrees.
        assert_eq!(at_centre.len(), 5, "a fan per pair at the centre");
        assert!(
            at_centre.iter().all(|f| f.sweep.abs() < 0.25),
            "{at_centre:?}"
        );
        let mut specials = 0;
        for &name in BUILTIN_SCENES.iter().filter(|&&n| n != "dense-1m") {
            let scene = Scene::load(name).expect("built-in scene");
            let light = fit_light(&scene);
            for o in scene.objects.iter().filter(|o| o.role.casts()) {
                let adj = Adjacency::build(&o.mesh).expect("adjacency");
                let sil = crate::silhouette::extract(&adj, o.transform, light.position);
                let rec = build_records(&adj, &sil, o.transform, &light, Width::Fixed(0.02));
                specials += check(&rec, name);
            }
        }
        assert!(specials > 1000, "{specials} special vertices");
    }

    /// `uv_bounds` holds every vertex the draw makes, outer and inner, full width or
    /// shortened (`Extent`), on every built-in scene's casters at the widths the renderer
    /// uses (fixed and calibrated), and is not the whole map: the smoothie pass clears and
    /// draws only inside it. The shortened box lies inside the full one.
    #[test]
    fn uv_bounds_hold_every_expanded_vertex() {
        use crate::frustum::fit_light;
        use crate::scene::{Scene, BUILTIN_SCENES};
        let mut shrunk = 0;
        for &name in BUILTIN_SCENES.iter().filter(|&&n| n != "dense-1m") {
            let scene = Scene::load(name).expect("built-in scene");
            let light = fit_light(&scene);
            let calibrated = Width::Calibrated {
                radius: scene.light.radius,
                tan_half_fov: (light.fov_deg.to_radians() * 0.5).tan(),
            };
            let short = Extent {
                depth: light.far,
                pad: 1.0 / 1024.0,
                span: 0.0,
            };
            for width in [Width::Fixed(0.02), Width::Fixed(0.2), calibrated] {
                for o in scene.objects.iter().filter(|o| o.role.casts()) {
                    let adj = Adjacency::build(&o.mesh).expect("adjacency");
                    let sil = crate::silhouette::extract(&adj, o.transform, light.position);
                    let rec = build_records(&adj, &sil, o.transform, &light, width);
                    let Some((lo, hi)) = rec.uv_bounds(Extent::FULL) else {
                        assert_eq!(rec.draw_vertices(), 0, "{name}: vertices without bounds");
                        continue;
                    };
                    let (slo, shi) = rec.uv_bounds(short).expect("shortened bounds");
                    assert!(
                        slo.cmpge(lo).all() && shi.cmple(hi).all(),
                        "{name}: {slo}..{shi} beyond {lo}..{hi}"
                    );
                    shrunk += usize::from((shi - slo).cmplt(hi - lo).any());
                    let dirs: [Vec2; 16] = std::array::from_fn(|k| {
                        Vec2::from_angle(k as f32 * std::f32::consts::TAU / 16.0)
                    });
                    for extent in [Extent::FULL, short] {
                        let (lo, hi) = rec.uv_bounds(extent).expect("bounds");
                        assert!(lo.is_finite() && hi.is_finite(), "{name}: {lo} {hi}");
                        // The support in 16 directions holds them too (the final pass's
                        // regions), and in the axes' directions it is the box.
                        let support = rec.uv_support(&dirs, extent).expect("support");
                        let axes = [hi.x, hi.y, -lo.x, -lo.y];
                        for (k, a) in [0, 4, 8, 12].into_iter().zip(axes) {
                            assert!(
                                (support[k] - a).abs() < 1e-5,
                                "{name}: {support:?} {lo} {hi}"
                            );
                        }
                        for side in [Side::Outer, Side::Inner] {
                            let mut vertices = Vec::new();
                            rec.expand_side(side, extent, &mut vertices);
                            for v in vertices {
                                let uv = Vec2::from(v.uv);
                                assert!(
                                    uv.cmpge(lo).all() && uv.cmple(hi).all(),
                                    "{name} {width:?} {extent:?}: vertex {uv} outside {lo}..{hi}"
                                );
                                for (d, s) in dirs.iter().zip(support) {
                                    assert!(
                                        d.dot(uv) <= s + 1e-6,
                                        "{name} {width:?}: vertex {uv} beyond {s} towards {d}"
                                    );
                                }
                            }
                        }
                    }
                    let area = (hi - lo).max(Vec2::ZERO);
                    if width == Width::Fixed(0.02) {
                        assert!(area.x * area.y < 0.5, "{name}: box {lo}..{hi}");
                    }
                }
            }
        }
        assert!(shrunk > 20, "only {shrunk} boxes shrank");
    }

    /// A shortened edge quad reaches at least t (1 - b / depth) at every point along the
    /// edge, where t is interpolated linearly and b is 1 / (interpolated 1 / b), as the
    /// smoothie pass interpolates them: the fragments it leaves out are all discarded.
    /// With each end's own factor (1 - b_end / depth) instead of the nearer end's, the
    /// line between the ends cuts into the convex b and this fails: by 0.002 uv (two
    /// texels of a 1024^2 map, more than the pad) midway along ends at 4 and 8 of one t.
    #[test]
    fn shortened_edges_reach_what_the_shader_keeps() {
        let depth = 10.0f32;
        let extent = Extent {
            depth,
            pad: 0.0,
            span: 0.0,
        };
        let record = |b: f32, t: f32| VertexRecord {
            uv: [0.0; 2],
            inv_depth: 1.0 / b,
            width: t,
        };
        // A sun whose map spans depths 1 to 10 (span 9, so every b here lies in it): b
        // interpolated linearly, the factor (depth - b) / span.
        let sun = extent.for_sun(Some(9.0));
        assert_eq!(sun.span, 9.0);
        for (b0, b1, t0, t1) in [
            (4.0, 8.0, 0.03, 0.03),
            (4.0, 8.0, 0.05, 0.02),
            (8.0, 4.0, 0.02, 0.05),
            (5.0, 5.5, 0.03, 0.03),
            (2.0, 9.9, 0.1, 0.02),
            (6.0, 6.0, 0.04, 0.04),
        ] {
            let (a, b) = (record(b0, t0), record(b1, t1));
            let (e0, e1) = extent.of_edge(&a, &b);
            let (s0, s1) = sun.of_edge(&a, &b);
            for i in 0..=100 {
                let x = i as f32 / 100.0;
                let inv = a.inv_depth + (b.inv_depth - a.inv_depth) * x;
                let t = t0 + (t1 - t0) * x;
                let needed = t * (1.0 - 1.0 / (inv * depth));
                let drawn = e0 + (e1 - e0) * x;
                assert!(
                    drawn >= needed * (1.0 - 1e-6),
                    "ends {b0}, {b1} at {x}: quad reaches {drawn}, fragments kept to {needed}"
                );
                let needed = t * ((depth - (b0 + (b1 - b0) * x)) / 9.0).max(0.0);
                let drawn = s0 + (s1 - s0) * x;
                assert!(
                    drawn >= needed * (1.0 - 1e-6) && drawn <= t * (1.0 + 1e-6),
                    "sun, ends {b0}, {b1} at {x}: quad reaches {drawn}, fragments kept to {needed}"
                );
            }
        }
        // A sun's extent is no spotlight's: the deep end of the (4, 8) edge reaches
        // t (10 - 4) / 9 there, not t (1 - 4 / 10).
        let (a, b) = (record(4.0, 0.05), record(8.0, 0.05));
        let (s0, _) = sun.of_edge(&a, &b);
        assert!((s0 - 0.05 * 6.0 / 9.0).abs() < 1e-6, "{s0}");
        // The full width is each end's own t.
        let (a, b) = (record(4.0, 0.05), record(8.0, 0.02));
        assert_eq!(Extent::FULL.of_edge(&a, &b), (0.05, 0.02));
    }

    /// `Extent::at_most` never shortens below the bound it is given, lengthens by at most
    /// 1/64 octave, keeps one value for a bound that moves within a grid cell, and gives
    /// the full width for a bound that is no bound.
    #[test]
    fn extent_bounds_round_up_to_a_grid() {
        for d in [1e-3f32, 0.7, 1.0, 7.694, 13.39, 1e4, 3e30] {
            let e = Extent::at_most(d, 0.5);
            assert!(
                e.depth >= d && e.depth <= d * 1.0109 * (1.0 + 1e-6),
                "{d}: {e:?}"
            );
            assert_eq!(e.pad, 0.5);
        }
        // Mid-cell: 0.5 % either way stays in the cell.
        let mid = (10.5f32 / 64.0).exp2() * 8.0;
        let e = Extent::at_most(mid, 0.0);
        assert_eq!(Extent::at_most(mid * 0.995, 0.0), e);
        assert_eq!(Extent::at_most(mid * 1.005, 0.0), e);
        for d in [0.0, -1.0, f32::NAN, f32::INFINITY, f32::MAX] {
            assert_eq!(Extent::at_most(d, 0.5), Extent::FULL, "{d}");
        }
    }

    #[test]
    fn record_sizes() {
        assert_eq!(std::mem::size_of::<VertexRecord>(), 16);
        assert_eq!(std::mem::size_of::<EdgeRecord>(), 16);
        assert_eq!(std::mem::size_of::<FanRecord>(), 16);
    }

    #[test]
    fn fast_atan2_accuracy() {
        let mut worst = 0.0f32;
        let mut prev = -4.0f32;
        for i in 0..=200_000 {
            let a = -PI + TAU * i as f32 / 200_000.0;
            let (y, x) = (a.sin(), a.cos());
            let f = fast_atan2(y, x);
            worst = worst.max((f - y.atan2(x)).abs());
            // Monotonic along the circle (away from the wrap at +-PI).
            if i > 1 && i < 200_000 {
                assert!(f >= prev - 1e-7, "{a}: {f} < {prev}");
            }
            prev = f;
        }
        assert!(worst < 2e-6, "max error {worst}");
        for (y, x) in [
            (0.0, 1.0),
            (1.0, 0.0),
            (0.0, -1.0),
            (-1.0, 0.0),
            (3.0, -3.0),
        ] {
            assert!(
                (fast_atan2(y, x) - f32::atan2(y, x)).abs() < 2e-6,
                "{y} {x}"
            );
        }
        assert_eq!(fast_atan2(0.0, 0.0), 0.0);
    }

    #[test]
    fn segment_counts_match_the_reference_ceil() {
        for i in -4000..=4000 {
            let sweep = TAU * i as f32 / 4000.0;
            // smoothie.rs `fan`'s count.
            let padded = sweep + 2.0 * FAN_OVERLAP.copysign(sweep);
            let reference = ((padded.abs() / MAX_SEGMENT).ceil() as u32).max(1);
            assert_eq!(segment_count(sweep), reference, "{sweep}");
        }
        assert_eq!(segment_count(TAU), 13);
        assert_eq!(segment_count(PI), 7);
        // The clamp to [1, 15], and no overflow or panic on what a broken input could send.
        assert_eq!(segment_count(0.0), 1);
        assert_eq!(segment_count(f32::NAN), 1);
        assert_eq!(segment_count(f32::INFINITY), 15);
        assert_eq!(segment_count(f32::NEG_INFINITY), 15);
        assert_eq!(segment_count(1e30), 15);
        // Exactly on a step (q an integer): no extra segment.
        let on_step = 3.0 * MAX_SEGMENT - 2.0 * FAN_OVERLAP;
        let q = (on_step.abs() + 2.0 * FAN_OVERLAP) * (1.0 / MAX_SEGMENT);
        assert_eq!(segment_count(on_step), q.ceil() as u32);
    }
}
