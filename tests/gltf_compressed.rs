//! Compressed glTF in: Draco (`KHR_draco_mesh_compression`), meshopt
//! (`EXT_meshopt_compression`, with its octahedral and exponential filters) and
//! `KHR_mesh_quantization`'s integer attributes.
//!
//! The `bunny-*.glb` files in tests/data are the built-in `bunny` scene exported with
//! `softshadow export --scene bunny --gltf bunny.glb` and compressed four ways (see
//! tests/data/README.md): their world geometry must equal the built-in's within one
//! quantization step, and they must render the same shadows. `pmndrs-bunny.glb` is a real
//! CC0 model as its package ships it (Draco), rendered with a ground plane against the
//! ray-cast reference, as is assets/scenes/suzanne.gltf.

mod common;

use common::{small, softshadow, Gpu};
use glam::Vec3;
use softshadow::scene::{Role, Scene};
use std::path::{Path, PathBuf};

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(name)
}

fn load(p: &Path) -> Scene {
    Scene::load(p.to_str().unwrap()).unwrap_or_else(|e| panic!("{e:#}"))
}

/// The compressed copies of the built-in bunny, with the position bits each was quantized to
/// (gltf-transform's and gltfpack's defaults).
const VARIANTS: [(&str, u32); 4] = [
    ("bunny-draco.glb", 14),
    ("bunny-meshopt.glb", 14),
    ("bunny-quantized.glb", 14),
    ("bunny-gltfpack.glb", 14),
];

/// Every distinct world-space vertex of the scene with the (unit) normal it carries.
fn world_vertices(s: &Scene) -> Vec<(Vec3, Vec3)> {
    let mut out = Vec::new();
    for o in &s.objects {
        let normal_matrix = glam::Mat3::from_mat4(o.transform).inverse().transpose();
        for (p, n) in o.mesh.positions.iter().zip(&o.mesh.normals) {
            out.push((
                o.transform.transform_point3(*p),
                (normal_matrix * *n).normalize(),
            ));
        }
    }
    out
}

/// For each of `a`, the nearest of `b`: the largest such distance, and the smallest cosine
/// between the normals of a vertex and its nearest.
fn one_sided(a: &[(Vec3, Vec3)], b: &[(Vec3, Vec3)]) -> (f32, f32) {
    let (mut worst, mut min_cos) = (0.0f32, 1.0f32);
    for (p, n) in a {
        let (d2, m) = b
            .iter()
            .map(|(q, m)| (p.distance_squared(*q), *m))
            .min_by(|x, y| x.0.total_cmp(&y.0))
            .unwrap();
        worst = worst.max(d2.sqrt());
        min_cos = min_cos.min(n.dot(m));
    }
    (worst, min_cos)
}

/// For each triangle of `a`, the triangle of `b` with the nearest centroid: the largest
/// distance between a corner and the nearest corner of that triangle, and how many of the
/// pair's face normals point apart (a flipped winding).
fn triangles_match(a: &[[Vec3; 3]], b: &[[Vec3; 3]]) -> (f32, usize) {
    let centroid = |t: &[Vec3; 3]| (t[0] + t[1] + t[2]) / 3.0;
    let normal = |t: &[Vec3; 3]| (t[1] - t[0]).cross(t[2] - t[0]);
    let cb: Vec<Vec3> = b.iter().map(centroid).collect();
    let (mut worst, mut flipped) = (0.0f32, 0usize);
    for t in a {
        let c = centroid(t);
        let k = (0..b.len())
            .min_by(|&i, &j| {
                c.distance_squared(cb[i])
                    .total_cmp(&c.distance_squared(cb[j]))
            })
            .unwrap();
        let u = &b[k];
        for p in t {
            let d = u.iter().map(|q| p.distance(*q)).fold(f32::MAX, f32::min);
            worst = worst.max(d);
        }
        if normal(t).dot(normal(u)) < 0.0 {
            flipped += 1;
        }
    }
    (worst, flipped)
}

#[test]
fn compressed_copies_hold_the_uncompressed_geometry_within_one_quantization_step() {
    let reference = Scene::load("bunny").unwrap();
    let ref_tris = reference.world_triangles(false);
    let ref_verts = world_vertices(&reference);
    for (name, bits) in VARIANTS {
        let s = load(&data(name));
        let tris = s.world_triangles(false);
        assert_eq!(tris.len(), ref_tris.len(), "{name}: triangle count");
        // The quantizers map each mesh's bounding box onto 2^bits - 1 steps; the largest
        // box (the ground) sets the coarsest step. A vertex moves by at most half a step
        // per axis, so under one step in length.
        let step = s
            .objects
            .iter()
            .map(|o| o.world_bounds().extent().max_element())
            .fold(0.0, f32::max)
            / ((1u32 << bits) - 1) as f32;
        let verts = world_vertices(&s);
        let (there, there_cos) = one_sided(&verts, &ref_verts);
        let (back, back_cos) = one_sided(&ref_verts, &verts);
        let (corner, flipped) = triangles_match(&tris, &ref_tris);
        eprintln!(
            "{name}: step {step:.2e}; vertex distance {there:.2e} / {back:.2e}, triangle corners {corner:.2e}, normals' min cos {there_cos:.5} / {back_cos:.5}"
        );
        assert!(
            there <= step && back <= step,
            "{name}: vertices {there} / {back} apart, step {step}"
        );
        assert!(
            corner <= step,
            "{name}: triangle corners {corner} apart, step {step}"
        );
        assert_eq!(flipped, 0, "{name}: triangles wound the other way");
        // Normals quantized to 8 bits (octahedral or per component) turn by under 1.5
        // degrees. Measured min cos: 0.99999 (Draco), 0.99984 (meshopt, gltfpack), 1.0
        // (quantized); positions 3.5e-4 (Draco), 4.4e-4 (meshopt, quantized) and 3.0e-4
        // (gltfpack) from the uncompressed ones, under the 5.0e-4 step.
        assert!(
            there_cos > 0.9996 && back_cos > 0.9996,
            "{name}: normals turned (min cos {there_cos} / {back_cos})"
        );
    }
}

#[test]
fn compressed_copies_render_the_shadows_of_the_uncompressed_scene() {
    let gpu = Gpu::new();
    let bunny = Scene::load("bunny").unwrap();
    let plain = gpu
        .render_frames(bunny.clone(), "pcss", small(96, 512), 1)
        .0;
    for (name, _) in VARIANTS {
        // The geometry alone: gltfpack drops extras (the light's radius, the roles), so
        // the light and camera are the built-in's and the flat ground only receives.
        let mut s = load(&data(name));
        s.light = bunny.light;
        s.camera = bunny.camera;
        for o in &mut s.objects {
            if o.world_bounds().extent().y == 0.0 {
                o.role = Role::Receiver;
            }
        }
        let img = gpu.render_frames(s, "pcss", small(96, 512), 1).0;
        let off = img
            .visibility
            .iter()
            .zip(&plain.visibility)
            .filter(|(a, b)| (*a - *b).abs() > 0.1)
            .count();
        let shadowed = plain.visibility.iter().filter(|v| **v < 0.5).count();
        eprintln!(
            "{name}: {off} of {} pixels off by > 0.1 ({shadowed} shadowed)",
            img.visibility.len()
        );
        assert!(shadowed > 200, "the bunny scene should cast a shadow");
        // Measured: 0 (Draco), 1 (meshopt), 1 (quantized), 1 (gltfpack) pixels: a silhouette
        // edge moved by under a quantization step.
        assert!(
            off <= 8,
            "{name}: {off} pixels differ from the uncompressed render"
        );
    }
}

/// The real CC0 models (the package's bunny, Suzanne and logo): its own Draco file loads as it is; with a ground plane
/// added (a scene file that keeps the model's Draco stream untouched) it renders shadows
/// within the errors measured against the reference.
#[test]
fn real_draco_models_render_shadows_close_to_the_reference() {
    // As shipped: one Draco primitive of 5648 triangles; its accessor bounds (written by
    // the compressor from the float data) hold the decoded points within a 14-bit step.
    let s = load(&data("pmndrs-bunny.glb"));
    assert_eq!(s.objects.len(), 1);
    assert_eq!(s.objects[0].mesh.indices.len(), 16944);
    let b = s.objects[0].world_bounds();
    let (lo, hi) = (
        Vec3::new(-0.913_770_8, -0.891_041_6, -0.696_372_4),
        Vec3::new(0.917_214_3, 0.939_882_9, 0.698_864_3),
    );
    let step = (hi - lo).max_element() / 16383.0;
    assert!(
        (b.min - lo).abs().max_element() <= step && (b.max - hi).abs().max_element() <= step,
        "bounds {b:?}"
    );

    let gpu = Gpu::new();
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    for (path, margin) in [
        // Measured mae_lit of smoothies: pmndrs-bunny 0.069 (1715 shadow pixels),
        // suzanne 0.022 (2299), pmndrs-logo 0.0134 (2304); the margins sit a sixth above.
        (data("pmndrs-bunny-scene.gltf"), 0.08),
        (root.join("assets/scenes/suzanne.gltf"), 0.026),
        (data("pmndrs-logo-scene.gltf"), 0.016),
    ] {
        let scene = load(&path);
        let e = common::errors_160(&gpu, &scene, "smoothies");
        eprintln!("{}: {e:?}", scene.name);
        assert!(
            e.shadow_pixels > 500,
            "{}: no shadow to speak of ({e:?})",
            scene.name
        );
        assert!(
            e.mae_lit < margin,
            "{}: mae_lit {} ({e:?})",
            scene.name,
            e.mae_lit
        );
    }

    // The command line renders it too.
    let dir = std::env::temp_dir().join(format!("softshadow-draco-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let png = dir.join("bunny.png");
    let o = softshadow(&[
        "render",
        "--scene",
        data("pmndrs-bunny.glb").to_str().unwrap(),
        "--width",
        "64",
        "--height",
        "64",
        "--out",
        png.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(png.is_file());
    std::fs::remove_dir_all(&dir).ok();
}

/// Broken compressed data gives one error line naming the file and the extension.
#[test]
fn broken_compressed_streams_are_refused_with_one_line() {
    let dir = std::env::temp_dir().join(format!("softshadow-badzip-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for (name, what) in [
        ("bunny-draco.glb", "Draco"),
        ("bunny-meshopt.glb", "EXT_meshopt_compression"),
    ] {
        let mut bytes = std::fs::read(data(name)).unwrap();
        // Zero the middle of the binary chunk: the streams no longer decode.
        let json_len = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
        let bin = 20 + json_len + 8;
        let len = bytes.len() - bin;
        bytes[bin + len / 4..bin + len * 3 / 4].fill(0xa5);
        let p = dir.join(name);
        std::fs::write(&p, &bytes).unwrap();
        let e = format!("{:#}", Scene::load(p.to_str().unwrap()).unwrap_err());
        assert!(
            e.contains(name) && e.contains(what) && !e.contains('\n'),
            "{e}"
        );
    }
    std::fs::remove_dir_all(&dir).ok();
}
