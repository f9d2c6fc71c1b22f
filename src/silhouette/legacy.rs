//! The silhouette extraction and smoothie construction as they were before the single-core
//! rewrite (commit a9f2962), kept verbatim for the tests that require the new code to give
//! bit-identical output. Test-only.
#![allow(dead_code)]

use super::smoothie::{
    SmoothieGeometry, SmoothieVertex, Width, FAN_OVERLAP, MAX_SEGMENT, MIN_CORNER_ANGLE, PROBE,
};
use super::{kind_of, light_in_object, Adjacency, EdgeFace, EdgeKind, SilhouetteEdge};
use crate::scene::LightView;
use glam::{Mat3, Mat4, Vec2, Vec3};
use rayon::prelude::*;

/// Per face: 0 faces away, 1 faces the light, 2 degenerate.
const BACK: u8 = 0;
const FRONT: u8 = 1;
const DEGEN: u8 = 2;

fn facing(adj: &Adjacency, f: usize, light_obj: Vec3) -> u8 {
    if adj.degenerate[f] {
        return DEGEN;
    }
    let p = adj.positions[adj.triangles[f][0] as usize];
    if adj.face_normals[f].dot(light_obj - p) > 0.0 {
        FRONT
    } else {
        BACK
    }
}

fn classify(adj: &Adjacency, e: usize, facings: &[u8], mirror: bool) -> Option<SilhouetteEdge> {
    let faces = adj.edge_faces(e);
    let mut valid = 0usize;
    let mut n_front = 0usize;
    let mut first_front: Option<EdgeFace> = None;
    let mut first_valid: Option<EdgeFace> = None;
    for ef in faces {
        match facings[ef.face as usize] {
            FRONT => {
                valid += 1;
                n_front += 1;
                first_front.get_or_insert(*ef);
                first_valid.get_or_insert(*ef);
            }
            BACK => {
                valid += 1;
                first_valid.get_or_insert(*ef);
            }
            _ => {}
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
    let [lo, hi] = adj.edges[e].v;
    let (mut a, mut b) = if along { (lo, hi) } else { (hi, lo) };
    if mirror {
        std::mem::swap(&mut a, &mut b);
    }
    Some(SilhouetteEdge {
        edge: e as u32,
        a,
        b,
        kind,
        front_face: ef.face,
    })
}

/// The old `extract_serial` (the old `extract` gave the same result in parallel).
pub fn extract_serial_old(
    adj: &Adjacency,
    model: Mat4,
    light_pos_world: Vec3,
) -> Vec<SilhouetteEdge> {
    let (l, mirror) = light_in_object(model, light_pos_world);
    let facings: Vec<u8> = (0..adj.num_faces()).map(|f| facing(adj, f, l)).collect();
    (0..adj.edges.len())
        .filter_map(|e| classify(adj, e, &facings, mirror))
        .collect()
}

/// Projects object-space geometry of one object for one light.
struct Projector<'a> {
    model: Mat4,
    normal_matrix: Mat3,
    light: &'a LightView,
}

impl Projector<'_> {
    fn world(&self, p_obj: Vec3) -> Vec3 {
        self.model.transform_point3(p_obj)
    }

    /// uv and linear depth, or None when the point is at or behind the near plane or the
    /// result is not finite (so callers never see NaN/Inf).
    fn project(&self, p_world: Vec3) -> Option<(Vec2, f32)> {
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

/// Kept silhouette edge: screen data needed by the quads and the corners.
struct EdgeOut {
    a: u32,
    b: u32,
    d: Vec2,
    verts: [SmoothieVertex; 6],
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

fn build_edge(
    adj: &Adjacency,
    pr: &Projector,
    e: &SilhouetteEdge,
    width: Width,
) -> Option<EdgeOut> {
    let pa = pr.world(adj.positions[e.a as usize]);
    let pb = pr.world(adj.positions[e.b as usize]);
    let (s0, z0) = pr.project(pa)?;
    let (s1, z1) = pr.project(pb)?;
    let along = s1 - s0;
    let len = along.length();
    // Also catches NaN.
    if len.is_nan() || len <= 1e-9 {
        return None;
    }
    // Left perpendicular of a -> b; flipped below when the blocker is on the right.
    let mut d = along.perp() / len;
    let mut decided = false;
    if e.kind != EdgeKind::Boundary {
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
    }
    let (i0, i1) = (1.0 / z0, 1.0 / z1);
    let (t0, t1) = (width.at(z0), width.at(z1));
    let (o0, o1) = (s0 + t0 * d, s1 + t1 * d);
    let v = |uv: Vec2, inv: f32, t: f32| vertex(uv, inv, 0.0, s0, d, t);
    Some(EdgeOut {
        a: e.a,
        b: e.b,
        d,
        verts: [
            v(s0, i0, t0),
            v(s1, i1, t1),
            v(o1, i1, t1),
            v(s0, i0, t0),
            v(o1, i1, t1),
            v(o0, i0, t0),
        ],
    })
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
    for i in 0..k {
        out.push(cv(s));
        out.push(cv(at(i)));
        out.push(cv(at(i + 1)));
    }
    k
}

struct CornerOut {
    verts: Vec<SmoothieVertex>,
    special: bool,
}

/// Projected vertex normal: sum of the faces adjacent to the vertex's silhouette edges.
fn vertex_normal_screen(
    adj: &Adjacency,
    pr: &Projector,
    edges: &[&SilhouetteEdge],
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

fn build_corner(
    adj: &Adjacency,
    pr: &Projector,
    vtx: u32,
    inc: &[(&SilhouetteEdge, Vec2)],
    width: Width,
) -> Option<CornerOut> {
    let p = pr.world(adj.positions[vtx as usize]);
    let (s, z) = pr.project(p)?;
    let inv = 1.0 / z;
    let t = width.at(z);
    let edges: Vec<&SilhouetteEdge> = inc.iter().map(|(e, _)| *e).collect();
    let mut verts = Vec::new();
    if let [(_, d1), (_, d2)] = inc {
        let cos = d1.dot(*d2).clamp(-1.0, 1.0);
        let angle = cos.acos();
        if angle < MIN_CORNER_ANGLE {
            return None;
        }
        let a1 = d1.to_angle();
        let mut sweep = d1.angle_to(*d2);
        if angle > std::f32::consts::PI - MIN_CORNER_ANGLE {
            // Hairpin: both edges leave the vertex in almost the same screen direction, so
            // the outside is the opposite way. The projected vertex normal (Volokh) only
            // decides when that is ambiguous: for faces facing the light it points radially
            // from the light's axis, not necessarily away from the blocker.
            let mut away = Vec2::ZERO;
            for (e, _) in inc {
                let other = if e.a == vtx { e.b } else { e.a };
                if let Some((so, _)) = pr.project(pr.world(adj.positions[other as usize])) {
                    away -= (so - s).normalize_or_zero();
                }
            }
            if away.length() < 1e-3 {
                away = vertex_normal_screen(adj, pr, &edges, p, s, z);
            }
            let ccw = away.dot(d1.perp()) >= 0.0;
            sweep = if ccw {
                std::f32::consts::PI
            } else {
                -std::f32::consts::PI
            };
        }
        fan(&mut verts, s, inv, t, a1, sweep);
        return Some(CornerOut {
            verts,
            special: false,
        });
    }
    // Special case: spokes at every d_i and at the projected vertex normal; full disc.
    let mut angles: Vec<f32> = inc.iter().map(|(_, d)| d.to_angle()).collect();
    let n = vertex_normal_screen(adj, pr, &edges, p, s, z);
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
            fan(&mut verts, s, inv, t, a, gap);
        }
    }
    Some(CornerOut {
        verts,
        special: true,
    })
}

/// Smoothie edges and corners of one object (`model`: object -> world) for `light`, from
/// its silhouette `sil` (as returned by `extract`); `t` is the smoothie width in uv units.
/// Parallel over edges and over corners; the output order is deterministic.
pub fn build_smoothies_old(
    adj: &Adjacency,
    sil: &[SilhouetteEdge],
    model: Mat4,
    light: &LightView,
    t: f32,
) -> SmoothieGeometry {
    build_smoothies_width_old(adj, sil, model, light, Width::Fixed(t))
}

/// `build_smoothies` with a width per silhouette vertex (`Width::Calibrated`) or fixed.
pub fn build_smoothies_width_old(
    adj: &Adjacency,
    sil: &[SilhouetteEdge],
    model: Mat4,
    light: &LightView,
    width: Width,
) -> SmoothieGeometry {
    let normal_matrix = Mat3::from_mat4(model).inverse().transpose();
    let normal_matrix = if normal_matrix.is_finite() {
        normal_matrix
    } else {
        // Singular model: normals cannot be transformed; the third-vertex test takes over.
        Mat3::ZERO
    };
    let pr = Projector {
        model,
        normal_matrix,
        light,
    };
    let built: Vec<Option<EdgeOut>> = sil
        .par_iter()
        .with_min_len(256)
        .map(|e| build_edge(adj, &pr, e, width))
        .collect();

    let mut geo = SmoothieGeometry::default();
    // (vertex, index into `sil`, outward d) for the corner pass, grouped by sorting.
    let mut incid: Vec<(u32, usize, Vec2)> = Vec::new();
    for (i, b) in built.iter().enumerate() {
        match b {
            Some(eo) => {
                geo.vertices.extend_from_slice(&eo.verts);
                geo.edges += 1;
                incid.push((eo.a, i, eo.d));
                incid.push((eo.b, i, eo.d));
            }
            None => geo.skipped_edges += 1,
        }
    }
    incid.sort_by_key(|&(v, i, _)| (v, i));
    let groups: Vec<&[(u32, usize, Vec2)]> = incid.chunk_by(|x, y| x.0 == y.0).collect();
    let corners: Vec<Option<CornerOut>> = groups
        .par_iter()
        .with_min_len(64)
        .map(|g| {
            let inc: Vec<(&SilhouetteEdge, Vec2)> =
                g.iter().map(|&(_, i, d)| (&sil[i], d)).collect();
            build_corner(adj, &pr, g[0].0, &inc, width)
        })
        .collect();
    for c in corners.into_iter().flatten() {
        geo.corners += 1;
        geo.special_vertices += usize::from(c.special);
        geo.corner_triangles += c.verts.len() / 3;
        geo.vertices.extend_from_slice(&c.verts);
    }
    geo
}

/// The rewritten extraction and smoothie construction against the code above, bit for bit.
mod equivalence {
    use super::super::smoothie::records::{build_records, SmoothieRecords};
    use super::super::test_meshes::{bowtie, cube, sphere};
    use super::super::{extract, extract_impl, extract_serial};
    use super::*;

    /// Fan vertices of the records against the old ones, in units of t: the old spokes are
    /// `from_angle(atan2(d1) - pad + phi i)`, the new ones `d1` rotated by `-pad + phi i`
    /// with the sweep from `fast_atan2` (< 2e-6 rad) and a few f32 roundings of angles up
    /// to 2 PI (< 1e-6 rad), at radius <= 1.04 t: about 3e-6 t, bounded here by 1e-5 t
    /// (2e-6 uv at the largest t = 0.2: 0.004 texel of a 2048 map).
    const FAN_TOL: f32 = 1e-5;
    /// Both constructions round uv (|uv| < 2 for anything on the map's side, ulp 2.4e-7)
    /// after a different sequence of operations: two ulps.
    const UV_ROUNDING: f32 = 5e-7;
    use crate::scene::{Light, Mesh, Scene};

    fn light_at(position: Vec3, target: Vec3) -> LightView {
        LightView::new(
            &Light {
                position,
                target,
                fov_deg: 60.0,
                radius: 0.2,
            },
            0.1,
            50.0,
        )
    }

    fn calibrated(lv: &LightView) -> Width {
        Width::Calibrated {
            radius: 0.2,
            tan_half_fov: (lv.fov_deg.to_radians() * 0.5).tan(),
        }
    }

    fn bits(g: &SmoothieGeometry) -> (&[u32], [usize; 5]) {
        (
            bytemuck::cast_slice(&g.vertices),
            [
                g.edges,
                g.corners,
                g.special_vertices,
                g.corner_triangles,
                g.skipped_edges,
            ],
        )
    }

    /// New against old for one object and one light, serial and forced-parallel paths;
    /// returns (silhouette edges, smoothie vertices) so callers can check they tested something.
    fn same(adj: &Adjacency, model: Mat4, lv: &LightView, width: Width) -> (usize, usize) {
        let old_sil = extract_serial_old(adj, model, lv.position);
        let sil = extract(adj, model, lv.position);
        assert_eq!(sil, old_sil);
        assert_eq!(extract_serial(adj, model, lv.position), old_sil);
        // Tiny chunks force the rayon paths.
        assert_eq!(extract_impl(adj, model, lv.position, true, 5), old_sil);
        // Without the 16-bit face numbers (the path of meshes above 2^16 - 2 faces).
        let wide = Adjacency {
            edge_pairs16: Vec::new(),
            ..adj.clone()
        };
        assert!(adj.edge_pairs16.len() == adj.edges.len() || adj.edge_pairs16.is_empty());
        assert_eq!(extract_serial(&wide, model, lv.position), old_sil);
        assert_eq!(extract_impl(&wide, model, lv.position, true, 5), old_sil);
        let old = build_smoothies_width_old(adj, &sil, model, lv, width);
        let new = super::super::smoothie::build_smoothies_width(adj, &sil, model, lv, width);
        assert_eq!(bits(&new), bits(&old), "light at {}", lv.position);
        let par = super::super::smoothie::build_impl(adj, &sil, model, lv, width, 3);
        assert_eq!(bits(&par), bits(&old), "parallel, light at {}", lv.position);
        let records = build_records(adj, &sil, model, lv, width);
        let fallbacks = records_match(&records, &old);
        assert!(
            fallbacks * 100 <= old.corners.max(1) + 99,
            "{fallbacks} of {} corners compared by coverage, light at {}",
            old.corners,
            lv.position
        );
        (sil.len(), old.vertices.len())
    }

    /// Records (expanded as the shader expands them) against the old triangle list: the
    /// same edges bit for bit (same counts, same quads: `expand` does `build_edge`'s
    /// arithmetic on the same inputs); two-edge corners as fans around the same anchors in
    /// the same order, each vertex within `FAN_TOL` (plus the old sweep's acos error) of the
    /// old one. Special vertices (full discs: one fan here, several there), and any fan whose
    /// segmentation differs (an arc within 2e-6 rad of a 30-degree step minus the padding),
    /// are compared by coverage: points of the disc of radius t on a polar grid are inside
    /// the old triangles exactly when inside the new ones (away from the old sector sides by
    /// 1e-3 rad). Returns how many two-edge corners needed the coverage comparison.
    fn records_match(records: &SmoothieRecords, old: &SmoothieGeometry) -> usize {
        assert_eq!(records.edges.len(), old.edges);
        assert_eq!(records.skipped_edges, old.skipped_edges);
        assert_eq!(records.corners, old.corners);
        assert_eq!(records.special_vertices, old.special_vertices);
        let new = records.expand();
        assert_eq!(new.len(), records.draw_vertices() as usize);
        let quads = 6 * old.edges;
        let as_bits = |v: &[SmoothieVertex]| bytemuck::cast_slice::<_, u32>(v).to_vec();
        assert_eq!(as_bits(&new[..quads]), as_bits(&old.vertices[..quads]));
        let (a, b) = (groups(&new[quads..]), groups(&old.vertices[quads..]));
        assert_eq!(a.len(), b.len(), "corner groups");
        // Per group, the acos error of the old sweep (`angle_to` = acos(d1 . d2) for a
        // two-edge corner): about 2.5e-7 / sin(sweep) rad, up to 6e-4 rad for the smallest
        // corners (`fast_atan2` of the cross and dot products has no such loss).
        // Special vertices (full discs: one fan of a full turn here, a fan per gap between
        // spokes there) are compared by coverage only.
        let mut acos_err: Vec<(f32, bool)> = Vec::new();
        let mut last: Option<[f32; 2]> = None;
        for f in &records.fans {
            let uv = records.vertices[f.centre as usize].uv;
            let e = if f.sweep.abs() < std::f32::consts::PI {
                2.5e-7 / f.sweep.sin().abs().max(4e-4)
            } else {
                0.0
            };
            let special = f.sweep.abs() > std::f32::consts::PI;
            if last == Some(uv) {
                let l = acos_err.len() - 1;
                acos_err[l].0 = acos_err[l].0.max(e);
                acos_err[l].1 = true;
            } else {
                acos_err.push((e, special));
            }
            last = Some(uv);
        }
        assert_eq!(acos_err.len(), a.len());
        // The records visit corners in silhouette-vertex order, the old code by welded
        // vertex index: pair the groups by anchor (the smoothie pass blends with MIN, so the
        // order is invisible). Anchors are distinct vertices' uv; a sort by their bits puts
        // both lists in one order.
        let key = |g: &Vec<SmoothieVertex>| g[0].anchor.map(f32::to_bits);
        let mut a: Vec<_> = a.into_iter().zip(acos_err).collect();
        a.sort_by_key(|(g, _)| key(g));
        let mut b = b;
        b.sort_by_key(key);
        let mut fallbacks = 0;
        for ((ga, (eps, special)), gb) in a.iter().zip(&b) {
            let (eps, special) = (*eps, *special);
            let (c, t) = (Vec2::from(ga[0].anchor), ga[0].width);
            assert_eq!(ga[0].anchor, gb[0].anchor);
            assert_eq!(ga[0].inv_depth, gb[0].inv_depth);
            assert_eq!(ga[0].width, gb[0].width);
            let close = !special
                && ga.len() == gb.len()
                && ga.iter().zip(gb.iter()).all(|(x, y)| {
                    x.kind == 1.0
                        && x.dir == [0.0, 0.0]
                        && (Vec2::from(x.uv) - Vec2::from(y.uv)).length()
                            <= (FAN_TOL + 1.04 * eps) * t + UV_ROUNDING
                });
            if close {
                continue;
            }
            fallbacks += usize::from(!special);
            let inside = |tris: &[SmoothieVertex], p: Vec2| {
                tris.chunks_exact(3).any(|q| {
                    let [p0, p1, p2] = [0, 1, 2].map(|i| Vec2::from(q[i].uv));
                    let (d0, d1, d2) = (
                        (p1 - p0).perp_dot(p - p0),
                        (p2 - p1).perp_dot(p - p1),
                        (p0 - p2).perp_dot(p - p2),
                    );
                    let e = -1e-9;
                    (d0 >= e && d1 >= e && d2 >= e) || (d0 <= -e && d1 <= -e && d2 <= -e)
                })
            };
            // The old fans' sector sides, to keep samples off them.
            let sides: Vec<f32> = gb
                .chunks_exact(3)
                .flat_map(|q| [q[1], q[2]])
                .map(|v| (Vec2::from(v.uv) - c).to_angle())
                .collect();
            for i in 0..360 {
                let ang = (i as f32 + 0.37) * std::f32::consts::TAU / 360.0 - std::f32::consts::PI;
                let off = sides.iter().all(|&s| {
                    let d = (ang - s).rem_euclid(std::f32::consts::TAU);
                    d.min(std::f32::consts::TAU - d) > 1e-3
                });
                if !off {
                    continue;
                }
                for r in [0.05, 0.3, 0.6, 0.9, 0.99] {
                    let p = c + r * t * Vec2::from_angle(ang);
                    assert_eq!(
                        inside(ga, p),
                        inside(gb, p),
                        "corner at {c}, angle {ang}, r {r}"
                    );
                }
            }
        }
        fallbacks
    }

    /// Corner triangles grouped by anchor (consecutive runs), as vertex lists.
    fn groups(v: &[SmoothieVertex]) -> Vec<Vec<SmoothieVertex>> {
        let mut out: Vec<Vec<SmoothieVertex>> = Vec::new();
        for q in v.chunks_exact(3) {
            match out.last_mut() {
                Some(g) if g[0].anchor == q[0].anchor => g.extend_from_slice(q),
                _ => out.push(q.to_vec()),
            }
        }
        out
    }

    /// Lights around and close to an object at `centre` of size about `size`: above, below,
    /// grazing, and some within the object's reach (edges behind the near plane).
    fn lights(centre: Vec3, size: f32) -> Vec<LightView> {
        let mut out = Vec::new();
        for (i, dir) in [
            Vec3::new(3.0, 8.0, 2.0),
            Vec3::new(-2.0, 5.0, -4.0),
            Vec3::new(0.01, 10.0, 0.02),
            Vec3::new(6.0, 0.3, 1.0),
            Vec3::new(-1.0, -7.0, 2.0),
            Vec3::new(0.6, 0.9, 0.3),
        ]
        .into_iter()
        .enumerate()
        {
            let target = centre + Vec3::new(0.1, -0.2, 0.05) * size * (i as f32);
            out.push(light_at(centre + dir * size, target));
        }
        out
    }

    fn check_mesh(mesh: &Mesh, models: &[Mat4]) -> (usize, usize) {
        let adj = Adjacency::build(mesh).unwrap();
        let mut total = (0, 0);
        for &model in models {
            let c = model.transform_point3(Vec3::ZERO);
            let size = model.transform_vector3(Vec3::ONE).length().max(1.0);
            for lv in lights(c, size) {
                for width in [Width::Fixed(0.05), calibrated(&lv)] {
                    let (e, v) = same(&adj, model, &lv, width);
                    total.0 += e;
                    total.1 += v;
                }
            }
        }
        total
    }

    fn models() -> Vec<Mat4> {
        vec![
            Mat4::IDENTITY,
            Mat4::from_scale_rotation_translation(
                Vec3::new(2.0, 0.5, 1.5),
                glam::Quat::from_rotation_y(0.7),
                Vec3::new(5.0, -1.0, 2.0),
            ),
            // A mirror.
            Mat4::from_scale(Vec3::new(-1.0, 1.0, 1.0)) * Mat4::from_rotation_x(0.3),
            // Singular: flattened onto a plane.
            Mat4::from_scale(Vec3::new(1.0, 0.0, 1.0)),
        ]
    }

    #[test]
    fn cube_sphere_bowtie_match_the_old_code() {
        let (e, v) = check_mesh(&cube(), &models());
        assert!(e > 100 && v > 1000, "{e} edges, {v} vertices");
        let (e, v) = check_mesh(&sphere(60, 120, 0.1), &models());
        assert!(e > 5000 && v > 50_000, "{e} edges, {v} vertices");
        let (e, v) = check_mesh(&bowtie(), &models());
        assert!(e > 50 && v > 1000, "{e} edges, {v} vertices");
    }

    #[test]
    fn odd_meshes_match_the_old_code() {
        // Open quad (boundary edges), a non-manifold fin, a hairpin blade, a cube with
        // degenerate and duplicate faces, a bar reaching behind the light.
        let quad = Mesh {
            positions: vec![
                Vec3::new(-1.0, 0.0, -1.0),
                Vec3::new(1.0, 0.0, -1.0),
                Vec3::new(1.0, 0.0, 1.0),
                Vec3::new(-1.0, 0.0, 1.0),
            ],
            normals: vec![Vec3::Y; 4],
            indices: vec![0, 2, 1, 0, 3, 2],
        };
        let fin = Mesh {
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
        let blade = Mesh {
            positions: vec![
                Vec3::new(0.0, 0.0, 0.0),
                Vec3::new(-2.0, 0.0, -0.002),
                Vec3::new(-2.0, 0.0, 0.002),
            ],
            normals: vec![Vec3::Y; 3],
            indices: vec![0, 1, 2],
        };
        let mut degen = cube();
        let n = degen.positions.len() as u32;
        degen.positions.extend([
            Vec3::new(0.5, 0.5, 0.5),
            Vec3::new(0.0, 0.0, -0.0),
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(2.0, 0.0, 0.0),
        ]);
        degen.normals.resize(degen.positions.len(), Vec3::Z);
        degen
            .indices
            .extend_from_slice(&[n + 1, n + 3, n + 4, n, n, 0, n + 1, n + 2, n + 3]);
        let mut bar = cube();
        for p in &mut bar.positions {
            p.z *= 20.0;
        }
        let mut total = 0;
        for mesh in [&quad, &fin, &blade, &degen, &bar] {
            total += check_mesh(mesh, &models()).1;
        }
        assert!(total > 5000);
        // The hairpin corner and the skipped edges of the bar from the original tests.
        let adj = Adjacency::build(&blade).unwrap();
        let lv = light_at(Vec3::new(1.5, 4.0, 0.3), Vec3::new(1.5, 0.0, 0.0));
        same(&adj, Mat4::IDENTITY, &lv, Width::Fixed(0.05));
        let adj = Adjacency::build(&bar).unwrap();
        let lv = light_at(Vec3::new(0.0, 2.0, 0.0), Vec3::new(0.0, 0.0, -5.0));
        same(&adj, Mat4::IDENTITY, &lv, Width::Fixed(0.05));
    }

    /// Every caster of the built-in scenes under the scene's own (fitted) light and a few
    /// others, fixed and calibrated widths.
    #[test]
    fn builtin_scenes_match_the_old_code() {
        for name in ["dense", "primitives", "bunny", "fence"] {
            let scene = Scene::load(name).unwrap();
            let fitted = crate::render::fit_light(&scene);
            let mut views = vec![fitted];
            let b = scene.bounds();
            views.extend(lights(
                (b.min + b.max) * 0.5,
                (b.max - b.min).length() * 0.5,
            ));
            let (mut e, mut v) = (0, 0);
            for o in scene.objects.iter().filter(|o| o.role.casts()) {
                let adj = Adjacency::build(&o.mesh).unwrap();
                for lv in &views {
                    for width in [Width::Fixed(0.0165), calibrated(lv)] {
                        let (ne, nv) = same(&adj, o.transform, lv, width);
                        e += ne;
                        v += nv;
                    }
                }
            }
            assert!(e > 100 && v > 1000, "{name}: {e} edges, {v} vertices");
        }
    }

    /// `build_corner` compares the cosine with +-1 instead of acos with the angle limits:
    /// the same decision for every float near +-1 (the rest of [-1, 1] has acos in
    /// [1.04, 2.1], far from both limits).
    #[test]
    fn acos_thresholds_are_exact() {
        let pi = std::f32::consts::PI;
        let mut x = 0.5f32;
        while x <= 1.0 {
            for c in [x, -x] {
                assert_eq!(c.acos() < MIN_CORNER_ANGLE, c >= 1.0, "{c}");
                assert_eq!(c.acos() > pi - MIN_CORNER_ANGLE, c <= -1.0, "{c}");
            }
            x = f32::from_bits(x.to_bits() + 1);
        }
        assert!(0.5f32.acos() > 1.04 && (-0.5f32).acos() < 2.1);
    }
}
