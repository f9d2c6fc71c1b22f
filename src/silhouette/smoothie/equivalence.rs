//! The faster paths against the reference constructions, bit for bit where they promise it:
//! - extraction: [`extract`] (serial, parallel, with and without 16-bit face numbers)
//!   against [`extract_reference`];
//! - smoothies: the parallel split of `build_impl` against the serial
//!   [`build_smoothies_width`], the reference construction (smoothie.rs), bit for bit; the
//!   records (records.rs) expanded as the renderer draws them (`SmoothieRecords::expand`)
//!   against it:
//!   the same edge quads bit for bit, the same two-edge corner fans within `FAN_TOL`, the same
//!   coverage at special vertices (see `records_match`).
//!
//! The GPU compute path (glsl/silhouette/) is checked against the CPU path on the device:
//! the same silhouette edges (tests/gpu_silhouettes.rs
//! `gpu_finds_exactly_the_cpu_silhouette_edges`) and the same images within one 8-bit level
//! (`gpu_and_cpu_paths_render_the_same_image`).

use super::records::{build_records, Extent, SmoothieRecords};
use super::MIN_CORNER_ANGLE;
use super::{
    build_impl, build_smoothies_side, build_smoothies_width, SmoothieGeometry, SmoothieVertex,
    Width,
};
use crate::scene::{Light, LightView, Mesh, Scene};
use crate::silhouette::test_meshes::{bowtie, cube, sphere};
use crate::silhouette::Side;
use crate::silhouette::{extract, extract_impl, extract_reference, extract_serial, Adjacency};
use glam::{Mat4, Vec2, Vec3};

/// Fan vertices of the records against the reference's, in units of t: the reference's
/// spokes are `from_angle(atan2(d1) - pad + phi i)`, the records' `d1` rotated by `-pad + phi i`
/// with the sweep from `fast_atan2` (< 2e-6 rad) and a few f32 roundings of angles up
/// to 2 PI (< 1e-6 rad), at radius <= 1.04 t: about 3e-6 t, bounded here by 1e-5 t
/// (2e-6 uv at the largest t = 0.2: 0.004 texel of a 2048 map).
const FAN_TOL: f32 = 1e-5;
/// Both constructions round uv (|uv| < 2 for anything on the map's side, ulp 2.4e-7)
/// after a different sequence of operations: two ulps.
const UV_ROUNDING: f32 = 5e-7;

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

/// Every faster path against the reference for one object and one light; returns
/// (silhouette edges, smoothie vertices) so callers can check they tested something.
fn same(adj: &Adjacency, model: Mat4, lv: &LightView, width: Width) -> (usize, usize) {
    let sil = extract_reference(adj, model, lv.position);
    assert_eq!(extract(adj, model, lv.position), sil);
    assert_eq!(extract_serial(adj, model, lv.position), sil);
    // Tiny chunks force the rayon paths.
    assert_eq!(extract_impl(adj, model, lv.position, true, 5), sil);
    // Without the 16-bit face numbers (the path of meshes above 2^16 - 2 faces).
    let wide = Adjacency {
        edge_pairs16: Vec::new(),
        ..adj.clone()
    };
    assert!(adj.edge_pairs16.len() == adj.edges.len() || adj.edge_pairs16.is_empty());
    assert_eq!(extract_serial(&wide, model, lv.position), sil);
    assert_eq!(extract_impl(&wide, model, lv.position, true, 5), sil);
    let reference = build_smoothies_width(adj, &sil, model, lv, width);
    // Tiny chunks force the rayon split of quads and corners.
    let par = build_impl(adj, &sil, model, lv, width, 3, Side::Outer);
    assert_eq!(
        bits(&par),
        bits(&reference),
        "parallel, light at {}",
        lv.position
    );
    let records = build_records(adj, &sil, model, lv, width);
    let fallbacks = records_match(&records, &reference);
    assert!(
        fallbacks * 100 <= reference.corners.max(1) + 99,
        "{fallbacks} of {} corners compared by coverage, light at {}",
        reference.corners,
        lv.position
    );
    // The inner smoothies (smoothies-centred): the mirrored records against the inner
    // reference, the same way; its parallel split too.
    let inner = build_smoothies_side(adj, &sil, model, lv, width, Side::Inner);
    let par = build_impl(adj, &sil, model, lv, width, 3, Side::Inner);
    assert_eq!(
        bits(&par),
        bits(&inner),
        "inner parallel, light at {}",
        lv.position
    );
    assert_eq!(
        [inner.edges, inner.corners, inner.skipped_edges],
        [reference.edges, reference.corners, reference.skipped_edges]
    );
    let mirrored = records.mirrored();
    let mut inner_side = Vec::new();
    records.expand_side(Side::Inner, Extent::FULL, &mut inner_side);
    assert!(
        inner_side == mirrored.expand(),
        "expand_side(Inner) is mirrored()'s expansion"
    );
    let fallbacks = records_match(&mirrored, &inner);
    assert!(
        fallbacks * 100 <= inner.corners.max(1) + 99,
        "inner: {fallbacks} of {} corners compared by coverage, light at {}",
        inner.corners,
        lv.position
    );
    (sil.len(), reference.vertices.len())
}

/// Records (expanded as the shader expands them) against the reference's triangle list: the
/// same edges bit for bit (same counts, same quads: `expand` does `build_edge`'s arithmetic
/// on the same inputs); two-edge corners as fans around the same anchors in the same order,
/// each vertex within `FAN_TOL` (plus the reference sweep's acos error) of the reference's.
/// Special vertices (full discs: one fan here, one per gap between spokes there; pairs: a
/// fan per pair at one centre), and any fan whose segmentation differs (an arc within 2e-6
/// rad of a 30-degree step minus the padding), are compared by coverage: points of the disc
/// of radius t on a polar grid are inside the reference's triangles exactly when inside the
/// records' (away from the reference's sector sides by 1e-3 rad). Returns how many two-edge
/// corners needed the coverage comparison.
fn records_match(records: &SmoothieRecords, reference: &SmoothieGeometry) -> usize {
    assert_eq!(records.edges.len(), reference.edges);
    assert_eq!(records.skipped_edges, reference.skipped_edges);
    assert_eq!(records.corners, reference.corners);
    assert_eq!(records.special_vertices, reference.special_vertices);
    let expanded = records.expand();
    assert_eq!(expanded.len(), records.draw_vertices() as usize);
    let quads = 6 * reference.edges;
    let as_bits = |v: &[SmoothieVertex]| bytemuck::cast_slice::<_, u32>(v).to_vec();
    assert_eq!(
        as_bits(&expanded[..quads]),
        as_bits(&reference.vertices[..quads])
    );
    let (a, b) = (
        groups(&expanded[quads..]),
        groups(&reference.vertices[quads..]),
    );
    assert_eq!(a.len(), b.len(), "corner groups");
    // Per group, the acos error of the reference's sweep (`angle_to` = acos(d1 . d2) for a
    // two-edge corner): about 2.5e-7 / sin(sweep) rad, up to 6e-4 rad for the smallest
    // corners (`fast_atan2` of the cross and dot products has no such loss).
    // Special vertices (full discs: one fan of a full turn here, a fan per gap between
    // spokes there; pairs: a fan per pair at one centre) are compared by coverage only.
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
    // The records visit corners in silhouette-vertex order, the reference by welded
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
        // The reference fans' sector sides, to keep samples off them.
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
fn cube_sphere_bowtie_agree_with_the_reference() {
    let (e, v) = check_mesh(&cube(), &models());
    assert!(e > 100 && v > 1000, "{e} edges, {v} vertices");
    let (e, v) = check_mesh(&sphere(60, 120, 0.1), &models());
    assert!(e > 5000 && v > 50_000, "{e} edges, {v} vertices");
    let (e, v) = check_mesh(&bowtie(), &models());
    assert!(e > 50 && v > 1000, "{e} edges, {v} vertices");
}

#[test]
fn odd_meshes_agree_with_the_reference() {
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
fn builtin_scenes_agree_with_the_reference() {
    for name in ["dense", "primitives", "bunny", "fence"] {
        let scene = Scene::load(name).unwrap();
        let fitted = crate::frustum::fit_light(&scene);
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
