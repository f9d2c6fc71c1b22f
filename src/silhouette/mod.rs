//! CPU silhouettes: an edge -> triangle adjacency built once per mesh, and per light a
//! brute-force pass over the faces and then the edges (split over rayon only for meshes
//! above `PAR_CHUNK` faces or edges; smaller ones are faster on the calling thread).
//!
//! # Adjacency ([`Adjacency::build`])
//! Positions are welded by exact value (`-0.0` and `0.0` are the same point) because meshes
//! may be split for flat shading; without welding every edge of a flat-shaded mesh would look
//! like an open boundary. Triangles are re-indexed into the welded vertices, and every
//! undirected welded edge gets the list of faces that use it, each with a `forward` flag
//! saying whether the face's winding runs `v[0] -> v[1]` (`v[0] < v[1]`) or the reverse.
//! Faces whose welded corners repeat, or whose area is zero relative to their size, are
//! flagged degenerate: they get a zero normal, take part in no facing test, and an edge that
//! only degenerate faces use is never a silhouette. Edges are numbered in (lower, higher)
//! welded-vertex order, so the numbering is deterministic; each edge's faces are in face order.
//!
//! # Extraction ([`extract`])
//! The light is moved into object space once; face `f` faces the light iff
//! `dot(n_f, L - p_f) > 0` (`p_f` = its first welded corner), evaluated over per-face
//! arrays of n and p prepared by the adjacency build. With only non-degenerate faces
//! counted, an edge is a silhouette when
//! - it has 2 faces (manifold) and exactly one of them faces the light;
//! - it has 1 face (boundary): always, the rim of an open mesh outlines its shadow;
//! - it has 3 or more faces (non-manifold): its faces disagree in facing.
//!
//! The build also records, per edge, whether it is a plain manifold edge (exactly two faces,
//! both non-degenerate) and if so its two faces with their winding flags, so the per-light
//! pass decides those edges from two facing bytes; only the others walk their face lists.
//! That pass is branch-free over the edges (a flag byte per edge, packed 64 to a mask) and
//! branches only per silhouette edge: about one edge in ten is one, scattered along the
//! edge order, so a branch per edge mispredicted at nearly every silhouette edge (see
//! `classify_range`). A mesh of at most 2^16 - 2 faces (every caster of the built-in
//! scenes but `dense-1m`'s) also keeps those two face numbers as u16, which index a
//! 2^16-entry facing table with no mask or bounds check and halve the bytes read per edge;
//! the table is kept per thread and never cleared (only the entries of real faces and the
//! two of the general edges are read, and each light writes all of them).
//!
//! # The silhouette bounds the projection
//! Seen from the light (every vertex in front of its eye plane), a mesh's projection lies
//! in the convex hull of its silhouette vertices: so a light pass that knows where those
//! project knows every texel the caster covers (smoothies' and penumbra maps' areas and
//! final-pass regions use this in place of the caster's box). The projection lies in the
//! hull of the projected vertices, and a corner of that hull is a silhouette vertex: were
//! every face around a vertex turned the same way (a face exactly edge-on reads as facing
//! away and projects to a segment, which either ends at the vertex or passes through it,
//! and then the vertex is no corner), the faces would project with one orientation, wind
//! round the vertex and cover a neighbourhood of it; and a boundary edge, or one whose
//! other faces are degenerate, is a silhouette edge itself. Property-tested on closed,
//! open, bumpy and scanned meshes, edge-on lights included
//! (`silhouette_vertices_bound_the_projection`).
//!
//! # Orientation convention of [`SilhouetteEdge`]
//! `front_face` is a light-facing face of the edge (the lowest-numbered one), or, for a
//! boundary edge whose only face looks away from the light, that face. `a -> b` runs along
//! `front_face`'s winding when it faces the light and against it otherwise. Seen from the
//! light, in light-screen uv (x right, y up, see `LightView`), `front_face` therefore lies to
//! the LEFT of `a -> b` and the outside of the silhouette is to the RIGHT. Model matrices with
//! a negative determinant (mirrors) are accounted for by swapping `a` and `b`.

use crate::scene::Mesh;
use anyhow::{bail, Context as _, Result};
use glam::{Mat4, Vec3};
use rayon::prelude::*;
use std::collections::HashMap;
use std::hash::{BuildHasherDefault, Hasher};
use std::sync::Arc;

pub mod gpu;
pub mod penumbra;
pub mod smoothie;

pub use smoothie::{build_smoothies, SmoothieGeometry, SmoothieVertex};

/// Which side of the silhouette a penumbra construction (smoothies, cones and sheets)
/// opens to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Side {
    /// Outward, away from the hard shadow: the papers' constructions.
    Outer,
    /// Inward, into the hard shadow: the centred forms (smoothies-centred,
    /// penumbra-map-centred).
    Inner,
}

impl Side {
    /// +1 outward, -1 inward: the factor on an outward direction.
    pub fn sign(self) -> f32 {
        match self {
            Side::Outer => 1.0,
            Side::Inner => -1.0,
        }
    }
}

/// Multiplicative (Fx-style) hasher: the keys are small integers built from our own data, so
/// HashDoS resistance is irrelevant, and SipHash would dominate the build time of big meshes.
#[derive(Default, Clone, Copy)]
struct FxHasher(u64);

impl Hasher for FxHasher {
    fn write(&mut self, bytes: &[u8]) {
        // Whole 8-byte words at a time: `[u32; 3]` keys arrive here as 12 raw bytes.
        let mut words = bytes.chunks_exact(8);
        for w in &mut words {
            let mut b = [0u8; 8];
            b.copy_from_slice(w);
            self.write_u64(u64::from_le_bytes(b));
        }
        let tail = words.remainder();
        if !tail.is_empty() {
            let mut b = [0u8; 8];
            b[..tail.len()].copy_from_slice(tail);
            self.write_u64(u64::from_le_bytes(b));
        }
    }
    fn write_u32(&mut self, v: u32) {
        self.write_u64(u64::from(v));
    }
    fn write_u64(&mut self, v: u64) {
        self.0 = (self.0.rotate_left(5) ^ v).wrapping_mul(0x51_7c_c1_b7_27_22_0a_95);
    }
    fn finish(&self) -> u64 {
        // Fold the high bits down: hashbrown takes its bucket from the low bits and its tag
        // from the top 7 bits, and the multiply leaves the low bits weakly mixed.
        self.0 ^ (self.0 >> 29)
    }
}

type FxMap<K, V> = HashMap<K, V, BuildHasherDefault<FxHasher>>;

/// One face as seen from one undirected edge.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct EdgeFace {
    /// Face (triangle) index, as in `Mesh::indices[3 * face..]`.
    pub face: u32,
    /// True when the face's winding traverses the edge `v[0] -> v[1]`.
    pub forward: bool,
}

/// An undirected welded edge, `v[0] < v[1]`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Edge {
    pub v: [u32; 2],
}

/// What an edge is, counting only its non-degenerate faces.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum EdgeKind {
    /// Exactly two faces.
    Manifold,
    /// One face: the rim of an open surface.
    Boundary,
    /// Three or more faces.
    NonManifold,
}

/// Edge -> face adjacency of one mesh, in object space. Built once per mesh.
#[derive(Clone, Debug, Default)]
pub struct Adjacency {
    /// Welded object-space positions.
    pub positions: Vec<Vec3>,
    /// Per face (same order as the mesh's triangles): welded corner indices.
    pub triangles: Vec<[u32; 3]>,
    /// Per face: unit object-space normal by the right-hand rule over the winding; zero when
    /// degenerate.
    pub face_normals: Vec<Vec3>,
    /// Per face: zero area or repeated welded corner. Ignored by facing tests.
    pub degenerate: Vec<bool>,
    /// Unique undirected edges, sorted by (`v[0]`, `v[1]`).
    pub edges: Vec<Edge>,
    /// CSR offsets into `edge_face_list`, `edges.len() + 1` entries.
    edge_face_start: Vec<u32>,
    edge_face_list: Vec<EdgeFace>,
    /// Per face, structure of arrays: the unit normal (x, y, z) and the first welded corner
    /// (x, y, z), so the per-light facing test streams through six arrays (and vectorises)
    /// instead of gathering from `positions`.
    face_planes: [Vec<f32>; 6],
    /// Per edge: for the common edge with exactly two faces, both non-degenerate, those faces
    /// (in face order) with `FORWARD_BIT` set when the face runs `v[0] -> v[1]`; `[F, F + 1]`
    /// (F = the face count) for every other edge (boundary, non-manifold, degenerate faces),
    /// which takes the general path: the per-light facing table has two extra entries there,
    /// back and front, so such an edge always reads as a candidate.
    edge_pairs: Vec<[u32; 2]>,
    /// `edge_pairs` as 16-bit face numbers without the winding flag, when every number fits
    /// (face count + 2 <= 2^16, every caster of the built-in scenes but `dense-1m`'s);
    /// empty otherwise. The per-light flag loop reads these: half the bytes per edge, and
    /// no mask to keep its lookups in bounds (a u16 indexes a 2^16-entry table).
    edge_pairs16: Vec<[u16; 2]>,
    /// Per edge: the sum of its non-degenerate faces' unit normals, in face order (what
    /// Volokh's direction test and a special vertex's normal project), so the per-light
    /// smoothie build reads 12 bytes per silhouette edge instead of walking the face list
    /// and gathering each face's normal.
    pub edge_normals: Vec<Vec3>,
}

/// Facing-table entries for `Adjacency::edge_pairs16`: every u16 face number is in bounds.
const SMALL_FACES: usize = 1 << 16;

/// Winding flag in `Adjacency::edge_pairs`; face numbers stay below 2^31 because corner numbers
/// `3 * face + k` fit in 32 bits.
const FORWARD_BIT: u32 = 1 << 31;

/// A face is degenerate when |e0 x e1| <= this * max|e|^2, i.e. its smallest angle is below
/// ~1e-6 rad: such faces' normals are noise, and a facing test on them would be random.
const DEGENERATE_SIN: f32 = 1e-6;

impl Adjacency {
    /// Welds positions, re-indexes faces, computes face normals and the edge -> faces lists.
    /// Fails on an index count that is not a multiple of 3, an out-of-range index, a
    /// non-finite position, or more than `u32::MAX` elements.
    pub fn build(mesh: &Mesh) -> Result<Adjacency> {
        if !mesh.indices.len().is_multiple_of(3) {
            bail!("index count {} is not a multiple of 3", mesh.indices.len());
        }
        // Corner numbers (3 * face + k) must fit in 32 bits.
        if mesh.positions.len() >= u32::MAX as usize || mesh.indices.len() >= u32::MAX as usize {
            bail!("mesh too large for u32 indices");
        }
        if let Some(i) = mesh.positions.iter().position(|p| !p.is_finite()) {
            bail!("position {i} is not finite: {:?}", mesh.positions[i]);
        }

        // Weld by exact bit pattern; `+ 0.0` turns -0.0 into +0.0 so both weld together.
        let mut weld: FxMap<[u32; 3], u32> = FxMap::default();
        weld.reserve(mesh.positions.len());
        let mut positions = Vec::new();
        let mut remap = Vec::with_capacity(mesh.positions.len());
        for p in &mesh.positions {
            let q = *p + Vec3::ZERO;
            let key = [q.x.to_bits(), q.y.to_bits(), q.z.to_bits()];
            let id = *weld.entry(key).or_insert_with(|| {
                positions.push(q);
                (positions.len() - 1) as u32
            });
            remap.push(id);
        }
        drop(weld);

        let n_pos = mesh.positions.len();
        let mut triangles = Vec::with_capacity(mesh.indices.len() / 3);
        for (f, tri) in mesh.indices.chunks_exact(3).enumerate() {
            let mut w = [0u32; 3];
            for k in 0..3 {
                let i = tri[k] as usize;
                if i >= n_pos {
                    bail!("face {f}: index {i} out of range ({n_pos} positions)");
                }
                w[k] = remap[i];
            }
            triangles.push(w);
        }

        let (face_normals, degenerate): (Vec<Vec3>, Vec<bool>) = triangles
            .par_iter()
            .map(|t| face_normal(&positions, t))
            .unzip();

        // Edges by a counting sort on the smaller welded vertex: bucket `lo` holds
        // `hi << 32 | corner` for every corner whose edge is (lo, hi). Sorting the (small)
        // buckets groups each edge's corners in face order. This streams through memory
        // instead of paying a random hash probe per corner, which made a HashMap version
        // about 3x slower at 1M faces; edges come out ordered by (lo, hi), deterministically.
        let nv = positions.len();
        let corner_edge = |t: &[u32; 3], k: usize| {
            let (p, q) = (t[k], t[(k + 1) % 3]);
            // A corner whose ends welded together is no edge.
            (p != q).then_some((p.min(q), p.max(q)))
        };
        let mut start = vec![0u32; nv + 1];
        for t in &triangles {
            for k in 0..3 {
                if let Some((lo, _)) = corner_edge(t, k) {
                    start[lo as usize + 1] += 1;
                }
            }
        }
        for v in 0..nv {
            start[v + 1] += start[v];
        }
        let mut entries = vec![0u64; start[nv] as usize];
        {
            let mut fill: Vec<u32> = start[..nv].to_vec();
            for (f, t) in triangles.iter().enumerate() {
                for k in 0..3 {
                    if let Some((lo, hi)) = corner_edge(t, k) {
                        let slot = &mut fill[lo as usize];
                        entries[*slot as usize] = (u64::from(hi) << 32) | (3 * f + k) as u64;
                        *slot += 1;
                    }
                }
            }
        }
        sort_buckets(&mut entries, &start);

        let mut edges: Vec<Edge> = Vec::with_capacity(entries.len() / 2 + 1);
        let mut edge_face_start: Vec<u32> = Vec::with_capacity(entries.len() / 2 + 2);
        let mut edge_face_list: Vec<EdgeFace> = Vec::with_capacity(entries.len());
        for lo in 0..nv {
            let bucket = &entries[start[lo] as usize..start[lo + 1] as usize];
            let mut prev_hi = None;
            for &entry in bucket {
                let hi = (entry >> 32) as u32;
                if prev_hi != Some(hi) {
                    edges.push(Edge { v: [lo as u32, hi] });
                    edge_face_start.push(edge_face_list.len() as u32);
                    prev_hi = Some(hi);
                }
                let c = (entry & 0xffff_ffff) as usize;
                let (f, k) = (c / 3, c % 3);
                let t = triangles[f];
                edge_face_list.push(EdgeFace {
                    face: f as u32,
                    forward: t[k] < t[(k + 1) % 3],
                });
            }
        }
        edge_face_start.push(edge_face_list.len() as u32);

        let face_planes = std::array::from_fn(|k| {
            triangles
                .iter()
                .zip(&face_normals)
                .map(|(t, n)| match k {
                    0..3 => n[k],
                    _ => positions[t[0] as usize][k - 3],
                })
                .collect()
        });
        // Cannot fail: the corner count 3 F fits in u32 (checked above), so F + 1 < 2^31 too.
        let general = u32::try_from(triangles.len()).context("face count")?;
        let edge_pairs: Vec<[u32; 2]> = edge_face_start
            .windows(2)
            .map(|w| match &edge_face_list[w[0] as usize..w[1] as usize] {
                [x, y] if !degenerate[x.face as usize] && !degenerate[y.face as usize] => {
                    let pack = |ef: &EdgeFace| ef.face | if ef.forward { FORWARD_BIT } else { 0 };
                    [pack(x), pack(y)]
                }
                _ => [general, general + 1],
            })
            .collect();
        let edge_pairs16 = if triangles.len() + 2 <= SMALL_FACES {
            edge_pairs
                .iter()
                // In range: every number is below F + 2 <= 2^16 once the flag is stripped.
                .map(|pair| pair.map(|f| (f & !FORWARD_BIT) as u16))
                .collect()
        } else {
            Vec::new()
        };
        let edge_normals = edge_face_start
            .windows(2)
            .map(|w| {
                edge_face_list[w[0] as usize..w[1] as usize]
                    .iter()
                    .filter(|ef| !degenerate[ef.face as usize])
                    .map(|ef| face_normals[ef.face as usize])
                    .sum()
            })
            .collect();

        Ok(Adjacency {
            positions,
            triangles,
            face_normals,
            degenerate,
            edges,
            edge_face_start,
            edge_face_list,
            face_planes,
            edge_pairs,
            edge_pairs16,
            edge_normals,
        })
    }

    /// All faces (degenerate ones included) using edge `e`, in face order.
    pub fn edge_faces(&self, e: usize) -> &[EdgeFace] {
        let s = self.edge_face_start[e] as usize;
        let t = self.edge_face_start[e + 1] as usize;
        &self.edge_face_list[s..t]
    }

    /// Kind of edge `e` counting only non-degenerate faces; `None` when it has none.
    pub fn edge_kind(&self, e: usize) -> Option<EdgeKind> {
        let n = self
            .edge_faces(e)
            .iter()
            .filter(|ef| !self.degenerate[ef.face as usize])
            .count();
        kind_of(n)
    }

    pub fn num_faces(&self) -> usize {
        self.triangles.len()
    }
}

/// Sorts each bucket `entries[start[v]..start[v + 1]]`, in parallel over vertex ranges.
fn sort_buckets(entries: &mut [u64], start: &[u32]) {
    let nv = start.len() - 1;
    let step = nv.div_ceil(64).max(1024);
    let mut jobs = Vec::new();
    let mut rest = entries;
    let mut v0 = 0;
    while v0 < nv {
        let v1 = (v0 + step).min(nv);
        let (head, tail) = rest.split_at_mut((start[v1] - start[v0]) as usize);
        jobs.push((v0, v1, head));
        rest = tail;
        v0 = v1;
    }
    jobs.into_par_iter().for_each(|(v0, v1, chunk)| {
        let base = start[v0];
        for v in v0..v1 {
            chunk[(start[v] - base) as usize..(start[v + 1] - base) as usize].sort_unstable();
        }
    });
}

fn kind_of(valid_faces: usize) -> Option<EdgeKind> {
    match valid_faces {
        0 => None,
        1 => Some(EdgeKind::Boundary),
        2 => Some(EdgeKind::Manifold),
        _ => Some(EdgeKind::NonManifold),
    }
}

fn face_normal(positions: &[Vec3], t: &[u32; 3]) -> (Vec3, bool) {
    if t[0] == t[1] || t[1] == t[2] || t[2] == t[0] {
        return (Vec3::ZERO, true);
    }
    let [a, b, c] = t.map(|i| positions[i as usize]);
    let (e0, e1, e2) = (b - a, c - a, c - b);
    let cr = e0.cross(e1);
    let lmax2 = e0
        .length_squared()
        .max(e1.length_squared())
        .max(e2.length_squared());
    let len = cr.length();
    // NaN/Inf (from overflowing coordinates) count as degenerate: never a NaN normal.
    if !len.is_finite() || !lmax2.is_finite() || len <= DEGENERATE_SIN * lmax2 {
        return (Vec3::ZERO, true);
    }
    (cr / len, false)
}

/// A silhouette edge, oriented so that, seen from the light, `front_face` lies to the left of
/// `a -> b` in light-screen uv (x right, y up) and the outside is to the right.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SilhouetteEdge {
    /// Index into `Adjacency::edges`.
    pub edge: u32,
    /// Welded vertex indices (into `Adjacency::positions`).
    pub a: u32,
    pub b: u32,
    pub kind: EdgeKind,
    /// The light-facing face (lowest index), or a boundary edge's only face if it faces away.
    pub front_face: u32,
}

/// Per face: 0 faces away, 1 faces the light. A degenerate face reads as BACK (its normal
/// is zero); only general edges have one, and `classify` skips it by `Adjacency::degenerate`.
const BACK: u8 = 0;
const FRONT: u8 = 1;

/// Facing of faces `first..first + out.len()`. Branch-free so that it vectorises; the test
/// is exactly `dot(n_f, L - p_f) > 0`.
fn facings_into(adj: &Adjacency, first: usize, out: &mut [u8], light_obj: Vec3) {
    let r = first..first + out.len();
    let [nx, ny, nz, px, py, pz] = adj.face_planes.each_ref().map(|a| &a[r.clone()]);
    let l = light_obj;
    for (i, o) in out.iter_mut().enumerate() {
        // Vec3::dot's order of operations: (x * x' + y * y') + z * z'.
        let d = nx[i] * (l.x - px[i]) + ny[i] * (l.y - py[i]) + nz[i] * (l.z - pz[i]);
        *o = u8::from(d > 0.0);
    }
}

/// Any edge, by its face list (the general rule of the module header).
fn classify(adj: &Adjacency, e: usize, facings: &[u8], mirror: bool) -> Option<SilhouetteEdge> {
    let faces = adj.edge_faces(e);
    let mut valid = 0usize;
    let mut n_front = 0usize;
    let mut first_front: Option<EdgeFace> = None;
    let mut first_valid: Option<EdgeFace> = None;
    for ef in faces.iter().filter(|ef| !adj.degenerate[ef.face as usize]) {
        valid += 1;
        first_valid.get_or_insert(*ef);
        if facings[ef.face as usize] == FRONT {
            n_front += 1;
            first_front.get_or_insert(*ef);
        }
    }
    let kind = kind_of(valid)?;
    let is_sil = match kind {
        EdgeKind::Boundary => true,
        EdgeKind::Manifold | EdgeKind::NonManifold => n_front > 0 && n_front < valid,
    };
    if !is_sil {
        return None;
    }
    // Along the front face's winding; a back-facing boundary face is traversed backwards so
    // that it, too, lies to the left as seen from the light.
    let (ef, along) = match first_front {
        Some(ef) => (ef, ef.forward),
        None => {
            let ef = first_valid?;
            (ef, !ef.forward)
        }
    };
    Some(oriented(adj, e, ef.face, along, kind, mirror))
}

fn oriented(
    adj: &Adjacency,
    e: usize,
    front_face: u32,
    along: bool,
    kind: EdgeKind,
    mirror: bool,
) -> SilhouetteEdge {
    let [lo, hi] = adj.edges[e].v;
    // `along != mirror`: a mirror swaps a and b.
    let (a, b) = if along != mirror { (lo, hi) } else { (hi, lo) };
    SilhouetteEdge {
        edge: e as u32,
        a,
        b,
        kind,
        front_face,
    }
}

/// Edges per block of [`classify_range`]: their flag bytes (1 KiB on the stack) stay in L1
/// between the two passes.
const CLASSIFY_BLOCK: usize = 1024;

/// Silhouette edges among edges `first..first + n`, appended to `out` in edge order.
/// `facings` has the two extra entries of `Adjacency::edge_pairs`' general edges.
///
/// Two passes per block of edges. The first writes a flag byte per edge, "its two facing
/// bytes differ", with no branch; the second packs 64 flags into a mask and visits only
/// the set bits. A branch per edge on the same test mispredicts at nearly every silhouette
/// edge (about one in ten, scattered), which cost more than the test itself; a candidate
/// list written at a running count (a store whose address waits on the previous edge's
/// loads) and a mask built bit by bit were both slower than the branch (BENCHMARKS.md).
fn classify_range(
    adj: &Adjacency,
    first: usize,
    n: usize,
    facings: &[u8],
    mirror: bool,
    out: &mut Vec<SilhouetteEdge>,
) {
    let general = adj.num_faces() as u32;
    // `facings` has a power-of-two length above every face number, which FORWARD_BIT
    // (bit 31) exceeds: masking by len - 1 strips the bit, and the compiler sees that the
    // index is in bounds (two compares and branches less per edge in the hot loop).
    let mask = facings.len().max(1) - 1;
    debug_assert!(facings.len().is_power_of_two() && mask < FORWARD_BIT as usize);
    // Re-sliced to exactly mask + 1 entries: what lets the compiler see it.
    let facings = &facings[..=mask];
    let face = |f: u32| f as usize & mask;
    // The 16-bit numbers, with the 2^16-entry table they index (`extract_impl` sizes the
    // table so whenever the mesh has them).
    let small = match <&[u8; SMALL_FACES]>::try_from(facings) {
        Ok(table) if !adj.edge_pairs16.is_empty() => Some((&adj.edge_pairs16, table)),
        _ => None,
    };
    let mut flags = [0u8; CLASSIFY_BLOCK];
    for (b, block) in adj.edge_pairs[first..first + n]
        .chunks(CLASSIFY_BLOCK)
        .enumerate()
    {
        let base = first + b * CLASSIFY_BLOCK;
        if let Some((pairs, table)) = small {
            // 16-bit face numbers into a table of 2^16 entries: no mask, half the bytes.
            for (f, &[p, q]) in flags.iter_mut().zip(&pairs[base..base + block.len()]) {
                *f = u8::from(table[usize::from(p)] != table[usize::from(q)]);
            }
        } else {
            for (f, &pair) in flags.iter_mut().zip(block) {
                // Both face numbers in one 8-byte load (four loads per edge were the limit).
                let pq: u64 = bytemuck::cast(pair);
                let (p, q) = (pq as u32, (pq >> 32) as u32);
                *f = u8::from(facings[face(p)] != facings[face(q)]);
            }
        }
        // The last group's flags past the block's end are stale: cleared.
        let used = &mut flags[..block.len().next_multiple_of(64)];
        used[block.len()..].fill(0);
        for (g, group) in used.as_chunks::<64>().0.iter().enumerate() {
            let mut mask = 0u64;
            for (j, w) in group.as_chunks::<8>().0.iter().enumerate() {
                // Eight 0/1 bytes to eight bits: the product sums byte k's bit into bit
                // 56 + k, with no carries (each bit lands in its own place).
                let bits = u64::from_le_bytes(*w).wrapping_mul(0x0102_0408_1020_4080) >> 56;
                mask |= bits << (8 * j);
            }
            while mask != 0 {
                let e = base + 64 * g + mask.trailing_zeros() as usize;
                mask &= mask - 1;
                let [p, q] = adj.edge_pairs[e];
                if p == general {
                    out.extend(classify(adj, e, facings, mirror));
                    continue;
                }
                // Two valid faces, exactly one facing the light: it is the front face (the
                // general rule for a manifold edge, without the face-list walk).
                // Which of the two is a coin toss: a select, not a branch (the branch
                // mispredicted about 4k times per light on `dense`, BENCHMARKS.md).
                let front = std::hint::select_unpredictable(facings[face(p)] == FRONT, p, q);
                out.push(oriented(
                    adj,
                    e,
                    front & !FORWARD_BIT,
                    front & FORWARD_BIT != 0,
                    EdgeKind::Manifold,
                    mirror,
                ));
            }
        }
    }
}

/// A sun's stand-in light point for the facing test, in map widths plus depths towards it.
const SUN_DISTANCE: f32 = 1e6;

/// Most kept edges a vertex may have for its corner to be built in pairs
/// (`pair_corner_edges`): the GPU paths' slots per vertex (MAX_INCIDENT in
/// glsl/silhouette/silhouette.glsl); a vertex with more keeps the full disc or cone on
/// both paths.
pub(crate) const MAX_PAIRED_EDGES: usize = 16;

/// Where an even number k >= 4 of silhouette edges meet (two silhouette curves through one
/// vertex of a closed mesh, e.g. a saddle of a bumpy blob), their outward directions
/// `outward` (silhouette order: smoothie edges' d, penumbra sheets' tangent normals)
/// paired into k/2 two-edge corners: sorted by angle, each direction paired with a
/// neighbour, the two ways of doing so compared by their summed arcs, the smaller one kept
/// (the first unless the second is smaller by 1e-4 rad, so that the GPU paths choose
/// alike). Each curve's own two edges turn by the small arc between their directions;
/// their convex gap is what its smoothie fan or cone arc must fill, as at any two-edge
/// corner. The pairs are positions in `outward`, each ascending. `None` for an odd count
/// (a chain's end, or three curves' ends) or more than MAX_PAIRED_EDGES: those keep the
/// full disc (smoothies) or the whole cone (penumbra maps).
pub(crate) fn pair_corner_edges(outward: &[glam::Vec2]) -> Option<Vec<[usize; 2]>> {
    let k = outward.len();
    if k < 4 || !k.is_multiple_of(2) || k > MAX_PAIRED_EDGES {
        return None;
    }
    let mut order: Vec<usize> = (0..k).collect();
    order.sort_by(|&a, &b| {
        outward[a]
            .to_angle()
            .total_cmp(&outward[b].to_angle())
            .then(a.cmp(&b))
    });
    let arc = |a: usize, b: usize| {
        let (u, v) = (outward[a], outward[b]);
        u.perp_dot(v).atan2(u.dot(v)).abs()
    };
    let pairing = |shift: usize| -> (f32, Vec<[usize; 2]>) {
        let pairs: Vec<[usize; 2]> = (0..k / 2)
            .map(|j| {
                let (a, b) = (order[(2 * j + shift) % k], order[(2 * j + shift + 1) % k]);
                [a.min(b), a.max(b)]
            })
            .collect();
        (pairs.iter().map(|&[a, b]| arc(a, b)).sum(), pairs)
    };
    let (first, second) = (pairing(0), pairing(1));
    Some(if second.0 < first.0 - 1e-4 {
        second.1
    } else {
        first.1
    })
}

/// The point silhouettes are taken from (`extract`'s `light_pos_world`): a spotlight's
/// centre; a sun's, a point `SUN_DISTANCE` times its map's width and depth towards it from
/// the map's eye. The facing test only needs the sun's direction: rays to that point stray
/// from it by about a millionth of a radian over the map, and f32 still holds the point
/// with the scene's.
pub fn light_point(light: &crate::scene::LightView) -> Vec3 {
    match light.sun {
        None => light.position,
        Some(s) => {
            // The view looks along -(the direction towards the sun): its z row.
            let towards = light.view.row(2).truncate().normalize_or(Vec3::Y);
            light.position + towards * (SUN_DISTANCE * (2.0 * s.half_width + light.far))
        }
    }
}

pub(crate) fn light_in_object(model: Mat4, light_pos_world: Vec3) -> (Vec3, bool) {
    // A singular model has no object-space light; such an object is flat and casts no
    // meaningful silhouette, so any finite light position will do.
    let inv = model.inverse();
    let l = inv.transform_point3(light_pos_world);
    let l = if l.is_finite() { l } else { Vec3::ZERO };
    (l, model.determinant() < 0.0)
}

/// Work items (faces, edges) per rayon task: below about this much work per task, the
/// hand-off to the pool costs more than it saves, so smaller meshes run on the calling thread.
const PAR_CHUNK: usize = 32 * 1024;

fn extract_impl(
    adj: &Adjacency,
    model: Mat4,
    light_pos_world: Vec3,
    parallel: bool,
    chunk: usize,
) -> Vec<SilhouetteEdge> {
    let nf = adj.num_faces();
    // Two extra entries, back and front, for `edge_pairs`' general edges; a power of two
    // in all, so that `classify_range`'s lookups need no bounds check (see there), and
    // 2^16 for `edge_pairs16`.
    let len = if adj.edge_pairs16.is_empty() {
        (nf + 2).next_power_of_two()
    } else {
        SMALL_FACES
    };
    with_facings(len, |facings| {
        extract_into(adj, model, light_pos_world, parallel, chunk, facings)
    })
}

thread_local! {
    /// The per-light facing table, kept per thread: a fresh 2^16-entry table per caster
    /// (calloc and its memset) costs more than the 16-bit face numbers save (BENCHMARKS.md).
    static FACINGS: std::cell::RefCell<Vec<u8>> = const { std::cell::RefCell::new(Vec::new()) };
}

/// Runs `f` on a facing table of `len` entries: this thread's, or a new one while that is
/// in use (a rayon worker that waits inside one extraction may start another). Entries
/// keep what an earlier caster wrote: only the first F + 2 are ever read, and
/// `extract_into` writes all of those.
fn with_facings<R>(len: usize, f: impl FnOnce(&mut [u8]) -> R) -> R {
    FACINGS.with(|cell| match cell.try_borrow_mut() {
        Ok(mut table) => {
            if table.len() < len {
                table.resize(len, BACK);
            }
            f(&mut table[..len])
        }
        Err(_) => f(&mut vec![BACK; len]),
    })
}

fn extract_into(
    adj: &Adjacency,
    model: Mat4,
    light_pos_world: Vec3,
    parallel: bool,
    chunk: usize,
    facings: &mut [u8],
) -> Vec<SilhouetteEdge> {
    let (l, mirror) = light_in_object(model, light_pos_world);
    let (nf, ne) = (adj.num_faces(), adj.edges.len());
    facings[nf] = BACK;
    facings[nf + 1] = FRONT;
    if parallel && nf > chunk {
        facings[..nf]
            .par_chunks_mut(chunk)
            .enumerate()
            .for_each(|(c, out)| facings_into(adj, c * chunk, out, l));
    } else {
        facings_into(adj, 0, &mut facings[..nf], l);
    }
    // About one edge in ten is a silhouette edge on a typical closed mesh.
    let mut out = Vec::with_capacity(ne / 8 + 16);
    if parallel && ne > chunk {
        let parts: Vec<Vec<SilhouetteEdge>> = (0..ne.div_ceil(chunk))
            .into_par_iter()
            .map(|c| {
                let first = c * chunk;
                let mut part = Vec::with_capacity(chunk / 8);
                classify_range(
                    adj,
                    first,
                    chunk.min(ne - first),
                    facings,
                    mirror,
                    &mut part,
                );
                part
            })
            .collect();
        for p in parts {
            out.extend_from_slice(&p);
        }
    } else {
        classify_range(adj, 0, ne, facings, mirror, &mut out);
    }
    out
}

/// Silhouette edges of `adj` under `model` (object -> world) for a point light at
/// `light_pos_world`, sorted by edge index. Meshes above `PAR_CHUNK` faces or edges are
/// split over rayon, smaller ones run on the calling thread; the result is the same.
pub fn extract(adj: &Adjacency, model: Mat4, light_pos_world: Vec3) -> Vec<SilhouetteEdge> {
    extract_impl(adj, model, light_pos_world, true, PAR_CHUNK)
}

/// Same result as [`extract`] on the calling thread only (for benchmarks).
pub fn extract_serial(adj: &Adjacency, model: Mat4, light_pos_world: Vec3) -> Vec<SilhouetteEdge> {
    extract_impl(adj, model, light_pos_world, false, PAR_CHUNK)
}

/// The reference extraction, the rule of the module header edge by edge with nothing
/// else: the facing test per face, then every edge by its face list. [`extract`] and the
/// GPU path (glsl/silhouette/silhouette.glsl) are optimisations of it that must return
/// exactly this list (`smoothie::equivalence` compares `extract` with it, and
/// tests/gpu_silhouettes.rs the GPU path with `extract`). A port can start here.
pub fn extract_reference(
    adj: &Adjacency,
    model: Mat4,
    light_pos_world: Vec3,
) -> Vec<SilhouetteEdge> {
    let (l, mirror) = light_in_object(model, light_pos_world);
    let facings: Vec<u8> = (0..adj.num_faces())
        .map(|f| {
            let p = adj.positions[adj.triangles[f][0] as usize];
            u8::from(adj.face_normals[f].dot(l - p) > 0.0)
        })
        .collect();
    (0..adj.edges.len())
        .filter_map(|e| classify(adj, e, &facings, mirror))
        .collect()
}

/// Edge adjacency of every object that casts and passes `keep` (index, object), built once
/// per technique; `None` for the others, so the result zips with `scene.objects`. Objects
/// that instance one mesh (the same `Arc<Mesh>`) share one adjacency: it depends on the
/// mesh alone. On `dense` (36 rocks, 6 meshes) the per-light extraction and records then
/// stream ~0.6 MB of adjacency instead of ~3.5 MB, which stays in a 2 MB L2: 7-13 % less CPU
/// time per light (BENCHMARKS.md), and 6 builds instead of 36.
pub fn caster_adjacency(
    scene: &crate::scene::Scene,
    keep: impl Fn(usize) -> bool,
) -> Result<Vec<Option<Arc<Adjacency>>>> {
    let mut built: HashMap<*const Mesh, Arc<Adjacency>> = HashMap::new();
    scene
        .objects
        .iter()
        .enumerate()
        .map(|(i, o)| {
            if !(o.role.casts() && keep(i)) {
                return Ok(None);
            }
            // `scene` holds every key's mesh while the map lives: no address is reused.
            let key = Arc::as_ptr(&o.mesh);
            if let Some(adj) = built.get(&key) {
                return Ok(Some(Arc::clone(adj)));
            }
            let adj = Arc::new(
                Adjacency::build(&o.mesh)
                    .with_context(|| format!("edge adjacency of '{}'", o.name))?,
            );
            built.insert(key, Arc::clone(&adj));
            Ok(Some(adj))
        })
        .collect()
}

/// Test meshes shared by this module's and `smoothie`'s tests.
#[cfg(test)]
pub(crate) mod test_meshes {
    use crate::scene::Mesh;
    use glam::Vec3;

    /// Unit cube [-0.5, 0.5]^3, flat shaded: 24 split positions, outward CCW winding.
    pub fn cube() -> Mesh {
        let mut m = Mesh::default();
        let axes = [Vec3::X, Vec3::Y, Vec3::Z];
        for (i, &n) in axes.iter().enumerate() {
            for s in [1.0f32, -1.0] {
                let n = n * s;
                let u = axes[(i + 1) % 3] * s;
                let v = n.cross(u);
                let base = m.positions.len() as u32;
                for (a, b) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
                    m.positions.push((n + u * a + v * b) * 0.5);
                    m.normals.push(n);
                }
                m.indices
                    .extend_from_slice(&[base, base + 1, base + 2, base, base + 2, base + 3]);
            }
        }
        m
    }

    /// A bumpy UV sphere (radius 1 +- `bump`) with `rings` latitude bands and `segs`
    /// longitude segments, shared (welded) vertices, single pole vertices, outward winding.
    pub fn sphere(rings: u32, segs: u32, bump: f32) -> Mesh {
        let mut m = Mesh::default();
        let r = |th: f32, ph: f32| 1.0 + bump * (5.0 * th).sin() * (7.0 * ph).sin();
        m.positions.push(Vec3::Y * r(0.0, 0.0));
        for i in 1..rings {
            let th = std::f32::consts::PI * i as f32 / rings as f32;
            for j in 0..segs {
                let ph = std::f32::consts::TAU * j as f32 / segs as f32;
                let d = Vec3::new(th.sin() * ph.cos(), th.cos(), -th.sin() * ph.sin());
                m.positions.push(d * r(th, ph));
            }
        }
        m.positions.push(-Vec3::Y);
        m.normals = m.positions.iter().map(|p| p.normalize()).collect();
        let ring = |i: u32, j: u32| 1 + (i - 1) * segs + j % segs;
        let last = m.positions.len() as u32 - 1;
        for j in 0..segs {
            m.indices
                .extend_from_slice(&[0, ring(1, j), ring(1, j + 1)]);
            m.indices
                .extend_from_slice(&[last, ring(rings - 1, j + 1), ring(rings - 1, j)]);
        }
        for i in 1..rings - 1 {
            for j in 0..segs {
                let (a, b, c, d) = (
                    ring(i, j),
                    ring(i, j + 1),
                    ring(i + 1, j),
                    ring(i + 1, j + 1),
                );
                m.indices.extend_from_slice(&[a, c, d, a, d, b]);
            }
        }
        m
    }

    /// Two tetrahedra touching only at the origin, mirrored about x = 0. Lit from straight
    /// above, each shows only its horizontal top face, so the origin has 4 silhouette edges.
    pub fn bowtie() -> Mesh {
        let mut m = Mesh::default();
        for s in [1.0f32, -1.0] {
            let p = [
                Vec3::ZERO,
                Vec3::new(2.0 * s, -1.0, 0.0),
                Vec3::new(2.0 * s, 1.0, 0.0),
                Vec3::new(1.5 * s, 0.0, -1.0),
            ];
            let base = m.positions.len() as u32;
            let centre = (p[0] + p[1] + p[2] + p[3]) / 4.0;
            for q in p {
                m.positions.push(q);
                m.normals.push(Vec3::Z);
            }
            for t in [[0u32, 1, 2], [0, 1, 3], [0, 2, 3], [1, 2, 3]] {
                let [a, b, c] = t.map(|i| p[i as usize]);
                let n = (b - a).cross(c - a);
                let t = if n.dot(a - centre) > 0.0 {
                    t
                } else {
                    [t[0], t[2], t[1]]
                };
                m.indices.extend(t.map(|i| base + i));
            }
        }
        m
    }
}

#[cfg(test)]
mod tests {
    use super::test_meshes::{bowtie, cube};
    use super::*;
    use std::collections::{BTreeSet, HashMap};

    /// "The silhouette bounds the projection": every vertex projects inside the support
    /// (in 16 directions) of the silhouette vertices, for meshes closed, open (the bow
    /// tie), bumpy and scanned (the bunny), under several models, from lights all round
    /// them and lights exactly in the planes of the cube's faces (faces edge-on, read as
    /// facing away), wherever every vertex is in front of the light's eye plane.
    #[test]
    fn silhouette_vertices_bound_the_projection() {
        use crate::scene::{Light, LightView};
        use glam::{Quat, Vec2};
        use test_meshes::sphere;
        let bunny = crate::scene::Scene::load("bunny").expect("bunny");
        let meshes = [
            ("cube", cube()),
            ("sphere", sphere(12, 24, 0.0)),
            ("bumpy sphere", sphere(16, 32, 0.3)),
            ("bow tie", bowtie()),
            ("bunny", {
                // At the scene's scale (2 units tall), centred on the origin.
                let o = &bunny.objects[0];
                let centre = o.world_bounds().center();
                let mut m = crate::scene::Mesh::default();
                m.append(&o.mesh, Mat4::from_translation(-centre) * o.transform);
                m
            }),
        ];
        let models = [
            Mat4::IDENTITY,
            Mat4::from_scale_rotation_translation(
                Vec3::new(1.5, 0.5, 1.0),
                Quat::from_rotation_y(0.7) * Quat::from_rotation_x(0.3),
                Vec3::new(0.2, -0.1, 0.3),
            ),
            // A mirror.
            Mat4::from_scale(Vec3::new(-1.0, 1.0, 1.0)),
        ];
        let dirs: [Vec2; 16] =
            std::array::from_fn(|k| Vec2::from_angle(k as f32 * std::f32::consts::TAU / 16.0));
        // Lights all round (a spiral over the sphere of radius 4), then in the cube's face
        // planes x = 0.5 and y = -0.5 (identity model).
        let mut lights: Vec<Vec3> = (0..40)
            .map(|k| {
                let z = 1.0 - 2.0 * (k as f32 + 0.5) / 40.0;
                let a = k as f32 * 2.4;
                let r = (1.0 - z * z).sqrt();
                Vec3::new(r * a.cos(), z, r * a.sin()) * 4.0
            })
            .collect();
        lights.extend([
            Vec3::new(0.5, 3.0, 1.0),
            Vec3::new(0.5, 2.0, -2.5),
            Vec3::new(2.0, -0.5, 3.0),
            Vec3::new(-3.0, -0.5, 0.25),
        ]);
        let (mut checked, mut edge_on) = (0, 0);
        for (name, mesh) in &meshes {
            let adj = Adjacency::build(mesh).expect("adjacency");
            for (m, model) in models.iter().enumerate() {
                for (l, &position) in lights.iter().enumerate() {
                    let light = LightView::new(
                        &Light {
                            position,
                            target: model.transform_point3(Vec3::ZERO),
                            fov_deg: 90.0,
                            radius: 0.2,
                            kind: crate::scene::LightKind::Spot,
                        },
                        0.05,
                        50.0,
                    );
                    let sil = extract(&adj, *model, light.position);
                    // The renderer's precondition: the caster's box in front of the light's
                    // eye plane (`regions::caster_corner_uvs`), so every vertex is.
                    let depth = |p: Vec3| light.linear_depth(model.transform_point3(p));
                    if sil.is_empty() || adj.positions.iter().any(|&p| depth(p) <= 0.0) {
                        continue;
                    }
                    let uv = |v: u32| {
                        light
                            .project(model.transform_point3(adj.positions[v as usize]))
                            .0
                    };
                    let uvs: Vec<Vec2> = sil.iter().flat_map(|e| [uv(e.a), uv(e.b)]).collect();
                    let support =
                        dirs.map(|d| uvs.iter().fold(f32::MIN, |s, uv| s.max(d.dot(*uv))));
                    for &p in &adj.positions {
                        let (uv, _) = light.project(model.transform_point3(p));
                        for (d, s) in dirs.iter().zip(support) {
                            assert!(
                                d.dot(uv) <= s + 1e-5,
                                "{name}, model {m}, light {position}: vertex {p} at {uv} \
                                 beyond the silhouette's {s} towards {d}"
                            );
                        }
                    }
                    checked += 1;
                    edge_on += usize::from(*name == "cube" && m == 0 && l >= 40);
                }
            }
        }
        assert!(checked > 500, "{checked} cases");
        assert_eq!(edge_on, 4, "every edge-on light checked");
    }

    #[test]
    fn cube_welds_and_is_closed() {
        let adj = Adjacency::build(&cube()).unwrap();
        assert_eq!(adj.positions.len(), 8);
        assert_eq!(adj.triangles.len(), 12);
        // 12 cube edges + 6 face diagonals.
        assert_eq!(adj.edges.len(), 18);
        for e in 0..adj.edges.len() {
            assert_eq!(adj.edge_kind(e), Some(EdgeKind::Manifold));
            let f = adj.edge_faces(e);
            // Consistent winding: the two faces traverse the edge in opposite directions.
            assert_ne!(f[0].forward, f[1].forward);
        }
        assert!(adj.degenerate.iter().all(|d| !d));
    }

    #[test]
    fn cube_corner_light_gives_hexagon() {
        let adj = Adjacency::build(&cube()).unwrap();
        let light = Vec3::new(3.0, 2.5, 2.2);
        let sil = extract(&adj, Mat4::IDENTITY, light);
        assert_eq!(sil.len(), 6);
        // Expected: cube edges between a +axis face (visible) and a -axis face of another axis.
        let mut expected = BTreeSet::new();
        for e in &adj.edges {
            let (p, q) = (
                adj.positions[e.v[0] as usize],
                adj.positions[e.v[1] as usize],
            );
            let m = (p + q) * 0.5;
            // Cube edges have exactly two coordinates at +-0.5 at their midpoint.
            let ax: Vec<usize> = (0..3).filter(|&i| m[i].abs() == 0.5).collect();
            if ax.len() == 2 && (m[ax[0]] > 0.0) != (m[ax[1]] > 0.0) {
                expected.insert(e.v);
            }
        }
        assert_eq!(expected.len(), 6);
        let got: BTreeSet<[u32; 2]> = sil.iter().map(|s| adj.edges[s.edge as usize].v).collect();
        assert_eq!(got, expected);
        // Loop: every silhouette vertex has degree 2; edges sorted by index.
        let mut deg: HashMap<u32, usize> = HashMap::new();
        for s in &sil {
            *deg.entry(s.a).or_default() += 1;
            *deg.entry(s.b).or_default() += 1;
            assert_eq!(s.kind, EdgeKind::Manifold);
        }
        assert!(deg.values().all(|&d| d == 2));
        assert!(sil.windows(2).all(|w| w[0].edge < w[1].edge));
        // Consistent orientation: each vertex is the `a` of one edge and the `b` of another.
        let a_set: BTreeSet<u32> = sil.iter().map(|s| s.a).collect();
        let b_set: BTreeSet<u32> = sil.iter().map(|s| s.b).collect();
        assert_eq!(a_set, b_set);
        // front_face faces the light and traverses a -> b.
        for s in &sil {
            let f = s.front_face as usize;
            let p = adj.positions[adj.triangles[f][0] as usize];
            assert!(adj.face_normals[f].dot(light - p) > 0.0);
            let t = adj.triangles[f];
            assert!((0..3).any(|k| t[k] == s.a && t[(k + 1) % 3] == s.b));
        }
    }

    #[test]
    fn transformed_cube_matches_object_space_light() {
        let adj = Adjacency::build(&cube()).unwrap();
        let model = Mat4::from_scale_rotation_translation(
            Vec3::new(2.0, 0.5, 1.5),
            glam::Quat::from_rotation_y(0.7),
            Vec3::new(5.0, -1.0, 2.0),
        );
        let light_obj = Vec3::new(3.0, 2.5, 2.2);
        let a = extract(&adj, model, model.transform_point3(light_obj));
        let b = extract(&adj, Mat4::IDENTITY, light_obj);
        assert_eq!(a, b);
        // A mirror keeps the edge set but swaps a and b, keeping the screen-space convention.
        let mirror = Mat4::from_scale(Vec3::new(-1.0, 1.0, 1.0));
        let c = extract(&adj, mirror, mirror.transform_point3(light_obj));
        assert_eq!(c.len(), b.len());
        for (x, y) in c.iter().zip(&b) {
            assert_eq!((x.edge, x.a, x.b), (y.edge, y.b, y.a));
        }
    }

    #[test]
    fn open_quad_boundary_edges_are_silhouettes() {
        let mesh = Mesh {
            positions: vec![
                Vec3::new(0.0, 0.0, 0.0),
                Vec3::new(1.0, 0.0, 0.0),
                Vec3::new(1.0, 1.0, 0.0),
                Vec3::new(0.0, 1.0, 0.0),
            ],
            normals: vec![Vec3::Z; 4],
            indices: vec![0, 1, 2, 0, 2, 3],
        };
        let adj = Adjacency::build(&mesh).unwrap();
        assert_eq!(adj.edges.len(), 5);
        for light in [Vec3::new(0.3, 0.4, 5.0), Vec3::new(0.3, 0.4, -5.0)] {
            let sil = extract(&adj, Mat4::IDENTITY, light);
            assert_eq!(sil.len(), 4, "light {light}");
            assert!(sil.iter().all(|s| s.kind == EdgeKind::Boundary));
            // Orientation: around the rim consistently.
            let a: BTreeSet<u32> = sil.iter().map(|s| s.a).collect();
            let b: BTreeSet<u32> = sil.iter().map(|s| s.b).collect();
            assert_eq!(a, b);
            // From above (+z, CCW face facing the light) a->b follows the winding; from below
            // it runs against it, so the face is on the left as seen from the light each time.
            let s0 = sil
                .iter()
                .find(|s| adj.edges[s.edge as usize].v == [0, 1])
                .unwrap();
            if light.z > 0.0 {
                assert_eq!((s0.a, s0.b), (0, 1));
            } else {
                assert_eq!((s0.a, s0.b), (1, 0));
            }
        }
    }

    #[test]
    fn non_manifold_fin() {
        // Three triangles sharing the edge (0,0,0)-(0,0,1): fins towards +x, +y and -x.
        let mesh = Mesh {
            positions: vec![
                Vec3::new(0.0, 0.0, 0.0),
                Vec3::new(0.0, 0.0, 1.0),
                Vec3::new(1.0, 0.0, 0.5),
                Vec3::new(0.0, 1.0, 0.5),
                Vec3::new(-1.0, 0.0, 0.5),
            ],
            normals: vec![Vec3::Z; 5],
            indices: vec![0, 1, 2, 0, 1, 3, 0, 1, 4],
        };
        let adj = Adjacency::build(&mesh).unwrap();
        let shared = adj.edges.iter().position(|e| e.v == [0, 1]).unwrap();
        assert_eq!(adj.edge_kind(shared), Some(EdgeKind::NonManifold));
        assert_eq!(adj.edge_faces(shared).len(), 3);
        // The +x fin's normal is +y, the -x fin's -y, the +y fin's +-x: a light on the +y side
        // splits them.
        let light = Vec3::new(0.5, 3.0, 0.5);
        let facing: Vec<bool> = (0..3)
            .map(|f| {
                adj.face_normals[f].dot(light - adj.positions[adj.triangles[f][0] as usize]) > 0.0
            })
            .collect();
        let sil = extract(&adj, Mat4::IDENTITY, light);
        let on = sil.iter().find(|s| s.edge as usize == shared);
        let disagree = facing.iter().any(|&x| x) && facing.iter().any(|&x| !x);
        assert!(
            disagree,
            "test set-up: the fins must disagree, got {facing:?}"
        );
        let s = on.expect("non-manifold edge with disagreeing faces is a silhouette");
        assert_eq!(s.kind, EdgeKind::NonManifold);
        assert!(facing[s.front_face as usize]);
        // All outer fin edges are boundary silhouettes.
        assert_eq!(
            sil.iter().filter(|s| s.kind == EdgeKind::Boundary).count(),
            6
        );
        // Three fins whose normals all agree (+y): never a silhouette, whatever the light.
        let mesh2 = Mesh {
            indices: vec![0, 1, 2, 1, 0, 4, 0, 1, 2],
            ..mesh.clone()
        };
        let adj2 = Adjacency::build(&mesh2).unwrap();
        let shared2 = adj2.edges.iter().position(|e| e.v == [0, 1]).unwrap();
        assert_eq!(adj2.edge_kind(shared2), Some(EdgeKind::NonManifold));
        let n0 = adj2.face_normals[0];
        let n1 = adj2.face_normals[1];
        assert!(n0.dot(n1) > 0.99);
        for light in [Vec3::new(0.2, -4.0, 0.5), Vec3::new(0.2, 4.0, 0.5)] {
            let sil2 = extract(&adj2, Mat4::IDENTITY, light);
            assert!(sil2.iter().all(|s| s.edge as usize != shared2));
        }
    }

    #[test]
    fn bowtie_vertex_has_four_silhouette_edges() {
        let adj = Adjacency::build(&bowtie()).unwrap();
        // The two tetrahedra share only the origin.
        assert_eq!(adj.positions.len(), 7);
        assert_eq!(adj.edges.len(), 12);
        let origin = adj.positions.iter().position(|p| *p == Vec3::ZERO).unwrap() as u32;
        let sil = extract(&adj, Mat4::IDENTITY, Vec3::new(0.0, 0.0, 10.0));
        assert_eq!(sil.len(), 6);
        let deg = sil
            .iter()
            .filter(|s| s.a == origin || s.b == origin)
            .count();
        assert_eq!(deg, 4);
        let outs = sil.iter().filter(|s| s.a == origin).count();
        assert_eq!(outs, 2);
    }

    #[test]
    fn degenerate_and_duplicate_vertices() {
        let mut mesh = cube();
        let n = mesh.positions.len() as u32;
        // A duplicate of an existing corner (also with -0.0 style variants of 0), a sliver
        // with three collinear points and a triangle with a repeated corner.
        mesh.positions.push(Vec3::new(0.5, 0.5, 0.5));
        mesh.positions.push(Vec3::new(0.0, 0.0, -0.0));
        mesh.positions.push(Vec3::new(0.0, 0.0, 0.0));
        mesh.positions.push(Vec3::new(1.0, 0.0, 0.0));
        mesh.positions.push(Vec3::new(2.0, 0.0, 0.0));
        mesh.normals.resize(mesh.positions.len(), Vec3::Z);
        mesh.indices.extend_from_slice(&[n + 1, n + 3, n + 4]); // collinear sliver
        mesh.indices.extend_from_slice(&[n, n, 0]); // repeated corner
        mesh.indices.extend_from_slice(&[n + 1, n + 2, n + 3]); // -0.0 welds with 0.0
        let adj = Adjacency::build(&mesh).unwrap();
        assert_eq!(adj.positions.len(), 8 + 3);
        let nf = adj.num_faces();
        assert!(adj.degenerate[nf - 3] && adj.degenerate[nf - 2] && adj.degenerate[nf - 1]);
        assert!(adj.face_normals.iter().all(|n| n.is_finite()));
        assert_eq!(adj.degenerate.iter().filter(|d| **d).count(), 3);
        let light = Vec3::new(3.0, 2.5, 2.2);
        let sil = extract(&adj, Mat4::IDENTITY, light);
        // Degenerate faces change nothing: the same hexagon as the clean cube.
        assert_eq!(sil.len(), 6);
        // The edge between the cube corner and itself was dropped; edges only used by
        // degenerate faces exist but have no kind.
        assert!(adj.edges.iter().all(|e| e.v[0] != e.v[1]));
        assert!((0..adj.edges.len()).any(|e| adj.edge_kind(e).is_none()));
        assert!(Adjacency::build(&Mesh {
            indices: vec![0, 1],
            ..Mesh::default()
        })
        .is_err());
        assert!(Adjacency::build(&Mesh {
            positions: vec![Vec3::ZERO; 3],
            indices: vec![0, 1, 3],
            ..Mesh::default()
        })
        .is_err());
    }

    #[test]
    fn parallel_equals_serial() {
        // A bumpy, finely tessellated sphere: many silhouette edges, many rayon splits.
        let mesh = super::test_meshes::sphere(120, 240, 0.15);
        let adj = Adjacency::build(&mesh).unwrap();
        for light in [Vec3::new(3.0, 2.0, 1.0), Vec3::new(-0.2, 0.1, 0.3)] {
            let model = Mat4::from_rotation_x(0.3);
            let a = extract(&adj, model, light);
            let b = extract_serial(&adj, model, light);
            assert!(!a.is_empty());
            assert_eq!(a, b);
            assert_eq!(a, extract(&adj, model, light));
        }
    }

    /// Objects that instance one mesh share one adjacency, objects with distinct meshes do
    /// not, and the shared one is what a build of each object's own mesh gives.
    #[test]
    fn caster_adjacency_is_shared_per_mesh() {
        let scene = crate::scene::Scene::load("primitives").expect("built-in scene");
        let skip = scene
            .objects
            .iter()
            .position(|o| o.role.casts())
            .expect("a caster");
        let adj = caster_adjacency(&scene, |i| i != skip).unwrap();
        assert_eq!(adj.len(), scene.objects.len());
        assert!(adj[skip].is_none(), "object left out by `keep`");
        let mut shared = 0;
        for (i, (o, a)) in scene.objects.iter().zip(&adj).enumerate() {
            assert_eq!(a.is_some(), o.role.casts() && i != skip, "{}", o.name);
            let Some(a) = a else { continue };
            let own = Adjacency::build(&o.mesh).unwrap();
            assert_eq!((&a.positions, &a.edges), (&own.positions, &own.edges));
            for (p, b) in scene.objects.iter().zip(&adj).skip(i + 1) {
                let Some(b) = b else { continue };
                let same_mesh = Arc::ptr_eq(&o.mesh, &p.mesh);
                assert_eq!(Arc::ptr_eq(a, b), same_mesh, "{} / {}", o.name, p.name);
                shared += usize::from(same_mesh);
            }
        }
        assert!(
            shared >= 3,
            "primitives instances its cylinder and box: {shared} pairs"
        );
    }
}
