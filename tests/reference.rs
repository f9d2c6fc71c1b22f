//! The ray-cast reference (src/reference.rs) against two independent paths: the GPU's
//! average of hard shadows from points over the light disc (Heckbert & Herf), and, for a
//! point light, the hard shadow map itself; the `reference` technique's image; the cache;
//! bad input.
mod common;

use common::{small, Gpu};
use softshadow::eval::accumulate::heckbert_herf;
use softshadow::eval::metrics::errors;
use softshadow::frustum::fit_light;
use softshadow::output::FrameImages;
use softshadow::reference::{
    cache_key, cache_key_of_code, cache_path, encode_cache, read_cache, visibility_at,
    visibility_cached, CacheEntry, ReferenceParams,
};
use softshadow::scene::Scene;

/// Covered pixels well inside the spotlight frustum: outside it the shadow map says "lit"
/// while the geometric reference knows no frustum, and the Heckbert-Herf sub-lights shift
/// the frustum by up to R.
fn in_light_frustum(scene: &Scene, img: &FrameImages) -> Vec<bool> {
    let light = fit_light(scene);
    img.position
        .iter()
        .map(|p| {
            let (uv, depth) = light.project(glam::Vec3::new(p[0], p[1], p[2]));
            p[3] > 0.5 && depth > light.near && uv.min_element() > 0.05 && uv.max_element() < 0.95
        })
        .collect()
}

/// `in_light_frustum` less the pixels whose tangent plane cuts the light disc or nearly
/// (|n.l| below R/d + 0.1, i.e. within about 6 degrees of it): there the true visibility is
/// the part of the disc above the surface's own plane (the reference's answer), while a
/// shadow map's self-shadowing is decided by its normal offset and depth bias, which lean
/// to "lit" (the boxes' front face, whose plane holds the light centre, is 1 in every hard
/// map and about 1/2 in the reference). That is an error of shadow maps, not a disagreement
/// about the integral, so the cross-check leaves those pixels out.
fn facing_the_light(scene: &Scene, img: &FrameImages, radius: f32) -> Vec<bool> {
    let l = scene.light.position;
    in_light_frustum(scene, img)
        .into_iter()
        .zip(img.position.iter().zip(&img.normal))
        .map(|(inside, (p, n))| {
            let to = l - glam::Vec3::new(p[0], p[1], p[2]);
            let d = to.length();
            let cos = glam::Vec3::from(*n).normalize_or_zero().dot(to / d);
            // 0.2 past the disc's own grazing band: on a smooth-shaded curved caster the
            // terminator is where the interpolated normal and the true facet disagree, and the
            // shadow maps' 2-texel normal offset decides which side of it a pixel falls on: a
            // self-shadowing artefact of every shadow map, not a disagreement on the integral.
            inside && cos.abs() > radius / d + 0.2
        })
        .collect()
}

fn load(name: &str) -> Scene {
    Scene::load(name).unwrap_or_else(|e| panic!("{e:#}"))
}

/// Heckbert & Herf (K = 64 hard maps at 1024^2) and the ray-cast reference (256 rays per
/// pixel) estimate the same integral by unrelated means; they must agree on the pixels that
/// face the light (`facing_the_light`).
///
/// Tolerance: the H&H estimate is a 64-point quadrature of the disc, so a penumbra pixel is
/// off by about one sub-light's weight, 1/64 ~ 0.016; its disc is fixed perpendicular to the
/// spot axis while the reference's faces each point, narrowing penumbrae by 1 - cos(angle
/// off axis), a few per cent of their width; its 1024^2 maps are rasterised, so each
/// sub-shadow's edge is off by up to a texel. The reference's own noise is below 0.01 per
/// penumbra pixel (256 stratified samples). Averaged over the shadow region, most of which
/// is umbra where both are exactly 0, that is well under 1/64: `mae_shadow` < 0.02 (measured
/// 0.009 cylinder, 0.007 boxes on lavapipe). Per pixel, 99% of the region within six
/// sub-lights' weight: `p99` < 0.12 (measured 0.07, 0.04). RMS is printed, not bounded: a few
/// pixels straddling a box's edge, where the map's normal offset and the rays' epsilon
/// disagree by up to 1, dominate it. The same check against the reference for twice the
/// radius fails (measured mae 0.065 / 0.042, p99 0.26 / 0.28), so the bounds catch a wrong
/// light size.
fn cross_check(scene_name: &str) {
    cross_check_scene(&Gpu::new(), load(scene_name), scene_name);
}

fn cross_check_scene(gpu: &Gpu, scene: Scene, scene_name: &str) {
    let radius = scene.light.radius;
    let settings = small(96, 1024);
    let hh =
        heckbert_herf(&gpu.ctx, &scene, radius, &settings, 64).unwrap_or_else(|e| panic!("{e:#}"));
    let mask = facing_the_light(&scene, &hh, radius);
    let params = ReferenceParams::default();
    let v_ref = visibility_at(&scene, radius, &hh.position, &hh.normal, &params).unwrap();
    let e = errors(&hh.visibility, &v_ref, &mask, &mask);
    // SOFTSHADOW_DUMP=DIR writes both estimates and their false-colour difference as PNGs.
    if let Ok(dir) = std::env::var("SOFTSHADOW_DUMP") {
        let w = hh.width;
        let gray = |v: &[f32]| {
            image::GrayImage::from_raw(w, w, v.iter().map(|x| (x * 255.0) as u8).collect()).unwrap()
        };
        gray(&hh.visibility)
            .save(format!("{dir}/{scene_name}_hh.png"))
            .unwrap();
        gray(&v_ref)
            .save(format!("{dir}/{scene_name}_ref.png"))
            .unwrap();
        let ei = softshadow::eval::metrics::error_image(&hh.visibility, &v_ref, &mask, 0.2);
        image::RgbaImage::from_raw(w, w, ei.into_iter().flatten().collect())
            .unwrap()
            .save(format!("{dir}/{scene_name}_err.png"))
            .unwrap();
    }
    println!("{scene_name}: H&H vs reference {e:?}");
    assert!(
        e.shadow_pixels > 300,
        "too few shadow pixels to compare: {e:?}"
    );
    let penumbra = v_ref
        .iter()
        .zip(&mask)
        .filter(|(v, &m)| m && **v > 0.05 && **v < 0.95)
        .count();
    assert!(
        penumbra > 100,
        "the scene should show a penumbra at 96x96: {penumbra} pixels"
    );
    assert!(
        e.mae_shadow < 0.02,
        "{scene_name}: H&H and reference disagree: {e:?}"
    );
    assert!(
        e.p99 < 0.12,
        "{scene_name}: H&H and reference disagree: {e:?}"
    );

    let wrong = visibility_at(&scene, radius * 2.0, &hh.position, &hh.normal, &params).unwrap();
    let w = errors(&hh.visibility, &wrong, &mask, &mask);
    println!("{scene_name}: H&H vs reference at 2R {w:?}");
    assert!(
        w.mae_shadow > 0.02 || w.p99 > 0.12,
        "{scene_name}: the cross-check cannot tell R from 2R: {w:?}"
    );
}

#[test]
fn reference_agrees_with_heckbert_herf_on_cylinder() {
    cross_check("cylinder");
}

#[test]
fn reference_agrees_with_heckbert_herf_on_boxes() {
    cross_check("boxes");
}

/// R = 0: the reference's single ray per pixel equals the hard shadow map wherever the hard
/// result is 0 or 1 over a 5x5 neighbourhood (away from edges, where the map's texels alias).
#[test]
fn point_light_reference_equals_hard_shadow_away_from_edges() {
    let gpu = Gpu::new();
    for name in ["cylinder", "boxes"] {
        point_light_check(&gpu, load(name), name);
    }
}

/// The check of `point_light_reference_equals_hard_shadow_away_from_edges` on one scene.
fn point_light_check(gpu: &Gpu, scene: Scene, name: &str) {
    {
        let hard = gpu
            .render_frames(scene.clone(), "hard", small(128, 2048), 1)
            .0;
        let v_ref = visibility_at(
            &scene,
            0.0,
            &hard.position,
            &hard.normal,
            &ReferenceParams::default(),
        )
        .unwrap();
        let mask = in_light_frustum(&scene, &hard);
        let (w, h) = (hard.width as i64, hard.height as i64);
        let flat = |x: i64, y: i64| {
            let v0 = hard.visibility[(y * w + x) as usize];
            (v0 == 0.0 || v0 == 1.0)
                && (-2..=2).all(|dy| {
                    (-2..=2).all(|dx| {
                        let (xx, yy) = (x + dx, y + dy);
                        xx >= 0 && yy >= 0 && xx < w && yy < h && {
                            let i = (yy * w + xx) as usize;
                            mask[i] && hard.visibility[i] == v0
                        }
                    })
                })
        };
        let (mut lit, mut umbra, mut wrong) = (0, 0, 0);
        for y in 0..h {
            for x in 0..w {
                if !flat(x, y) {
                    continue;
                }
                let i = (y * w + x) as usize;
                let v = hard.visibility[i];
                if v == 1.0 {
                    lit += 1
                } else {
                    umbra += 1
                }
                if v_ref[i] != v {
                    wrong += 1;
                }
            }
        }
        println!(
            "{name}: R = 0, {lit} lit and {umbra} umbra pixels away from edges, {wrong} differ"
        );
        assert!(
            lit > 1000 && umbra > 200,
            "{name}: too few pixels away from edges: {lit} lit, {umbra} umbra"
        );
        assert!(
            (wrong as f64) < 0.002 * (lit + umbra) as f64,
            "{name}: reference at R = 0 differs from hard shadows on {wrong} of {} pixels",
            lit + umbra
        );
        // R = 0 gives exactly 0 or 1 everywhere.
        assert!(v_ref.iter().all(|&v| v == 0.0 || v == 1.0));
    }
}

/// The reference at the edges of the documented scene scale (bounding radius 1e-5 ... 2e7),
/// and with a receiver far larger than what casts: the cylinder scene scaled to radii 1e-5,
/// 1e-4, 1e5 and 2e7, and a unit box on a ground 1e5 wide (stress case `ground-1e5`). At each,
/// the point-light reference equals the hard shadow map's footprint away from edges; at the
/// two edges and on the huge ground, the area-light reference agrees with Heckbert & Herf
/// within the bounds of `cross_check`. The rays' self-hit guard once scaled with what the
/// light sees (every shadow on the 1e5 ground lost) and obvhs passes over BVH nodes closer than an
/// absolute 1e-4 along a ray (every shadow lost below a radius of about 1e-4).
#[test]
fn reference_holds_at_every_legal_scene_scale() {
    let gpu = Gpu::new();
    let base = load("cylinder");
    let r = base.bounds().radius();
    for target in [1.001e-5f32, 1e-4, 1e5, 1.999e7] {
        let mut scene = softshadow::eval::stress::scaled(&base, target / r);
        scene.name = format!("cylinder at radius {target:e}");
        assert!(
            (scene.bounds().radius() / target - 1.0).abs() < 1e-3,
            "{}",
            scene.name
        );
        let label = scene.name.clone();
        point_light_check(&gpu, scene.clone(), &label);
        if !(1e-4..=1e7).contains(&target) {
            cross_check_scene(&gpu, scene, &label);
        }
    }
    let mut ground = softshadow::eval::stress::case_scene("ground-1e5").unwrap();
    point_light_check(&gpu, ground.clone(), "ground-1e5");
    // A light 4x the case's, so the unit box's penumbra spans enough pixels at 96x96.
    ground.light.radius *= 4.0;
    cross_check_scene(&gpu, ground, "ground-1e5");
}

/// `--technique reference` shows exactly the reference computed at its own pixels, with lit,
/// umbra and penumbra pixels; a second frame of the same view reuses the ray casting.
#[test]
fn reference_technique_shows_the_reference() {
    let gpu = Gpu::new();
    let scene = load("cylinder");
    let (img, timings) = gpu.render_frames(scene.clone(), "reference", small(96, 512), 2);
    assert!(timings[0]
        .cpu
        .iter()
        .any(|(n, _)| n == "reference/ray_cast"));
    assert!(timings[1]
        .passes
        .iter()
        .any(|p| p.name == "reference/ray_cast" && p.not_run.is_some()));
    let v_ref = visibility_at(
        &scene,
        scene.light.radius,
        &img.position,
        &img.normal,
        &ReferenceParams::default(),
    )
    .unwrap();
    let covered: Vec<usize> = common::covered(&img);
    assert!(covered.len() > 96 * 96 / 2);
    for &i in &covered {
        assert_eq!(img.visibility[i], v_ref[i], "pixel {i}");
    }
    let count = |f: &dyn Fn(f32) -> bool| covered.iter().filter(|&&i| f(img.visibility[i])).count();
    assert!(count(&|v| v == 1.0) > 1000);
    assert!(count(&|v| v == 0.0) > 50);
    assert!(count(&|v| v > 0.05 && v < 0.95) > 100);
}

/// A second `visibility_cached` call reads the file the first one wrote.
#[test]
fn cached_reference_is_reused() {
    let scene = load("boxes");
    let params = ReferenceParams {
        samples: 256,
        seed: 99,
    };
    // Synthetic pixels: a small grid on the ground under the boxes.
    let positions: Vec<[f32; 4]> = (0..400)
        .map(|k| {
            [
                (k % 20) as f32 * 0.2 - 2.0,
                0.0,
                (k / 20) as f32 * 0.2 - 2.0,
                1.0,
            ]
        })
        .collect();
    let normals = vec![[0.0, 1.0, 0.0]; positions.len()];
    let path = cache_path(cache_key(&scene, 0.3, &positions, &normals, &params));
    let _ = std::fs::remove_file(&path);
    let a = visibility_cached(&scene, 0.3, &positions, &normals, &params).unwrap();
    assert!(path.is_file(), "{} not written", path.display());
    let b = visibility_at(&scene, 0.3, &positions, &normals, &params).unwrap();
    assert_eq!(a, b);
    assert!(
        a.iter().any(|&v| v < 0.5),
        "the grid should reach the boxes' shadow"
    );
    // A valid entry holding a marker: a reuse returns it.
    let mut marked = a.clone();
    marked[0] = 0.125;
    std::fs::write(&path, encode_cache(&marked)).unwrap();
    let c = visibility_cached(&scene, 0.3, &positions, &normals, &params).unwrap();
    assert_eq!(
        c[0], 0.125,
        "the second call recomputed instead of reading the cache"
    );
    assert_eq!(&c[1..], &a[1..]);
    // Values overwritten behind a kept header (the checksum no longer matches): recomputed,
    // and the entry rewritten valid.
    let mut bytes = std::fs::read(&path).unwrap();
    let n = bytes.len();
    for b in &mut bytes[n - 400..] {
        *b = 0x3f;
    }
    std::fs::write(&path, &bytes).unwrap();
    assert!(matches!(
        read_cache(&path, positions.len()),
        CacheEntry::Bad(_)
    ));
    let d = visibility_cached(&scene, 0.3, &positions, &normals, &params).unwrap();
    assert_eq!(d, b, "a corrupted entry was trusted");
    assert!(matches!(
        read_cache(&path, positions.len()),
        CacheEntry::Valid(v) if v == b
    ));
    // An entry of another format version (the previous header layout) is recomputed.
    let mut old = b"SSREF001".to_vec();
    old.extend_from_slice(&(positions.len() as u64).to_le_bytes());
    old.extend(marked.iter().flat_map(|x| x.to_le_bytes()));
    std::fs::write(&path, &old).unwrap();
    let e = visibility_cached(&scene, 0.3, &positions, &normals, &params).unwrap();
    assert_eq!(e, b);
    // Another sample count is another key.
    let other = ReferenceParams {
        samples: 324,
        seed: 99,
    };
    assert_ne!(
        cache_key(&scene, 0.3, &positions, &normals, &other),
        cache_key(&scene, 0.3, &positions, &normals, &params)
    );
    std::fs::remove_file(&path).unwrap();
}

/// Synthetic pixels for the cache tests: a grid on `boxes`' ground under the boxes.
fn ground_grid() -> (Vec<[f32; 4]>, Vec<[f32; 3]>) {
    let positions: Vec<[f32; 4]> = (0..400)
        .map(|k| {
            [
                (k % 20) as f32 * 0.2 - 2.0,
                0.0,
                (k / 20) as f32 * 0.2 - 2.0,
                1.0,
            ]
        })
        .collect();
    let normals = vec![[0.0, 1.0, 0.0]; positions.len()];
    (positions, normals)
}

/// Every input of the reference is in its cache key: a change to any one is another file.
#[test]
fn cache_key_changes_with_every_input() {
    let scene = load("boxes");
    let (positions, normals) = ground_grid();
    let params = ReferenceParams {
        samples: 256,
        seed: 7,
    };
    let key = |scene: &Scene, radius: f32, p: &[[f32; 4]], n: &[[f32; 3]], q: &ReferenceParams| {
        cache_key(scene, radius, p, n, q)
    };
    let base = key(&scene, 0.3, &positions, &normals, &params);
    assert_eq!(
        base,
        key(&scene.clone(), 0.3, &positions, &normals, &params)
    );
    let mut changed = Vec::new();
    changed.push(("radius", key(&scene, 0.31, &positions, &normals, &params)));
    let mut s = scene.clone();
    s.light.position.x += 0.01;
    changed.push(("light", key(&s, 0.3, &positions, &normals, &params)));
    let mut s = scene.clone();
    let caster = s.objects.iter().position(|o| o.role.casts()).unwrap();
    s.objects[caster].transform =
        glam::Mat4::from_translation(glam::Vec3::new(0.0, 0.0, 0.01)) * s.objects[caster].transform;
    changed.push(("moved object", key(&s, 0.3, &positions, &normals, &params)));
    let mut s = scene.clone();
    s.camera.position.y += 0.01;
    changed.push(("camera", key(&s, 0.3, &positions, &normals, &params)));
    let mut n = normals.clone();
    n[123] = [0.0, 0.0, 1.0];
    changed.push(("one normal", key(&scene, 0.3, &positions, &n, &params)));
    let mut p = positions.clone();
    p[200][2] += 1e-3;
    changed.push(("one position", key(&scene, 0.3, &p, &normals, &params)));
    let seed = ReferenceParams { seed: 8, ..params };
    changed.push(("seed", key(&scene, 0.3, &positions, &normals, &seed)));
    // The ray caster's code: the key is of this source, and one edit to it is another key.
    let mut source = include_bytes!("../src/reference.rs").to_vec();
    let of_code = |code: &[u8]| cache_key_of_code(code, &scene, 0.3, &positions, &normals, &params);
    assert_eq!(
        of_code(&source),
        base,
        "the key is not of the ray caster's source"
    );
    let at = source.len() / 2;
    source[at] ^= 1;
    changed.push(("ray caster code", of_code(&source)));
    for (what, k) in &changed {
        assert_ne!(*k, base, "{what}: same cache key");
    }
}

/// A cache file that is truncated, of another format, or holds values no visibility can
/// take is not read: the reference is ray cast again and the file rewritten.
#[test]
fn damaged_cache_files_are_recomputed() {
    let scene = load("boxes");
    let (positions, normals) = ground_grid();
    let params = ReferenceParams {
        samples: 256,
        seed: 41,
    };
    let path = cache_path(cache_key(&scene, 0.3, &positions, &normals, &params));
    let exact = visibility_at(&scene, 0.3, &positions, &normals, &params).unwrap();
    let _ = std::fs::remove_file(&path);
    visibility_cached(&scene, 0.3, &positions, &normals, &params).unwrap();
    let good = std::fs::read(&path).unwrap();
    assert_eq!(
        good,
        encode_cache(&exact),
        "the file is not the encoding of the values"
    );
    let n = good.len();
    let mut high = exact.clone();
    high[3] = 2.0;
    type Damage = Box<dyn Fn(&mut Vec<u8>)>;
    let damage: [(&str, Damage); 6] = [
        ("truncated", Box::new(|b| b.truncate(b.len() - 4))),
        ("empty", Box::new(|b| b.clear())),
        (
            "foreign magic",
            Box::new(|b| b[..8].copy_from_slice(b"PNG\r\n\x1a\n\0")),
        ),
        // A value changed within [0, 1]: only the checksum tells.
        (
            "corrupted value",
            Box::new(move |b| b[n - 4..].copy_from_slice(&0.3f32.to_le_bytes())),
        ),
        (
            "value 2.0, checksum right",
            Box::new(move |b| *b = encode_cache(&high)),
        ),
        (
            "one more value",
            Box::new(|b| b.extend_from_slice(&0.5f32.to_le_bytes())),
        ),
    ];
    for (what, f) in damage {
        let mut bytes = good.clone();
        f(&mut bytes);
        std::fs::write(&path, &bytes).unwrap();
        let v = visibility_cached(&scene, 0.3, &positions, &normals, &params).unwrap();
        assert_eq!(v, exact, "{what}: the damaged file was read");
        assert_eq!(std::fs::read(&path).unwrap(), good, "{what}: not rewritten");
    }
    std::fs::remove_file(&path).unwrap();
}

/// Pixels on an object that casts but does not receive get 1, as the final pass writes
/// there; the same point on a receiving object keeps its shadow.
#[test]
fn non_receivers_get_full_visibility() {
    let mut scene = load("boxes");
    // The upper box's +x face looks away from the light (at x = -2) and towards the camera.
    let p = [[1.1f32, 2.5, 0.3, 1.0], [1.1, 2.5, 0.3, 0.0]];
    let n = [[1.0f32, 0.0, 0.0]; 2];
    let params = ReferenceParams::default();
    let both = visibility_at(&scene, 0.2, &p, &n, &params).unwrap();
    assert_eq!(
        both,
        vec![0.0, 1.0],
        "a back face in its own shadow; background 1"
    );
    let k = scene.objects.iter().position(|o| o.name == "box1").unwrap();
    scene.objects[k].role = softshadow::scene::Role::Caster;
    let caster = visibility_at(&scene, 0.2, &p, &n, &params).unwrap();
    assert_eq!(caster, vec![1.0, 1.0]);
}

/// A sample count of 0 is one clear line, from the library and from the CLI (exit != 0).
#[test]
fn zero_samples_is_a_one_line_error() {
    let scene = load("cylinder");
    let e = visibility_at(
        &scene,
        0.1,
        &[[0.0, 0.0, 0.0, 1.0]],
        &[[0.0, 1.0, 0.0]],
        &ReferenceParams {
            samples: 0,
            seed: 1,
        },
    )
    .unwrap_err();
    let e = format!("{e:#}");
    println!("{e}");
    assert!(e.contains("sample count 0") && !e.contains('\n'), "{e}");

    let out = std::process::Command::new(env!("CARGO_BIN_EXE_softshadow"))
        .args([
            "render",
            "--technique",
            "reference",
            "--reference-samples",
            "0",
            "--out",
        ])
        .arg(std::env::temp_dir().join("ss-ref-zero.png"))
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    println!("{stderr}");
    assert!(!out.status.success());
    assert_eq!(stderr.trim_end().lines().count(), 1, "{stderr}");
    assert!(stderr.contains("--reference-samples 0"), "{stderr}");
}
