//! The GPU silhouette path (`silhouette::gpu`: compute passes + indirect draws) against the
//! CPU path (`silhouette::extract` + `build_smoothies`): the same silhouette edges, as sets,
//! and the same images; and partial rebuilds when one caster moves.

mod common;

use common::{
    bowl, cube, max_colour_diff, max_visibility_diff, small, softshadow, with_caster, Gpu,
};
use glam::{Mat4, Vec3};
use softshadow::frustum::fit_light;
use softshadow::render::Renderer;
use softshadow::scene::{Mesh, Scene};
use softshadow::settings::{Settings, SilhouettePath};
use softshadow::silhouette::{extract, Adjacency, EdgeKind};
use softshadow::vk::FrameTimings;
use std::collections::BTreeSet;

fn settings(path: SilhouettePath) -> Settings {
    Settings {
        silhouettes: path,
        ..small(128, 512)
    }
}

fn quad(m: &mut Mesh, corners: [Vec3; 4]) {
    let base = m.positions.len() as u32;
    m.positions.extend(corners);
    m.indices
        .extend_from_slice(&[base, base + 1, base + 2, base, base + 2, base + 3]);
}

/// Three pages sharing one spine: the spine is a non-manifold edge (three faces).
fn book() -> Mesh {
    let mut m = Mesh::default();
    let (z0, z1) = (Vec3::new(0.0, 0.0, -0.6), Vec3::new(0.0, 0.0, 0.6));
    for k in 0..3 {
        let a = 0.4 + k as f32 * std::f32::consts::TAU / 3.0;
        let out = Vec3::new(a.cos(), a.sin(), 0.0) * 0.9;
        quad(&mut m, [z0, z1, z1 + out, z0 + out]);
    }
    m.compute_normals();
    m
}

/// The cube, open mesh and non-manifold edge, then every built-in scene but
/// `dense-1m` (a million triangles: minutes on lavapipe for no extra case).
fn scenes() -> Vec<Scene> {
    let mut scenes = vec![
        with_caster(cube(), "cube"),
        with_caster(bowl(), "open bowl"),
        with_caster(book(), "non-manifold book"),
    ];
    for name in softshadow::scene::BUILTIN_SCENES {
        if *name == "dense-1m" {
            continue;
        }
        scenes.push(Scene::load(name).unwrap());
    }
    scenes
}

#[test]
fn gpu_finds_exactly_the_cpu_silhouette_edges() {
    let gpu = Gpu::new();
    for scene in scenes() {
        let name = scene.name.clone();
        let light = fit_light(&scene);
        let mut r = Renderer::new(
            &gpu.ctx,
            scene.clone(),
            "smoothies",
            settings(SilhouettePath::Gpu),
        )
        .unwrap();
        r.render().unwrap();
        let found = r
            .read_gpu_silhouettes()
            .unwrap()
            .expect("smoothies on the GPU path expose their silhouettes");
        assert!(!found.is_empty(), "{name}: no caster on the GPU path");
        let mut kinds = BTreeSet::new();
        for (object, gpu_edges) in found {
            let o = &scene.objects[object];
            let adj = Adjacency::build(&o.mesh).unwrap();
            // A sun's silhouettes come from its stand-in point, as the renderer's.
            let cpu_sil = extract(
                &adj,
                o.transform,
                softshadow::silhouette::light_point(&light),
            );
            kinds.extend(cpu_sil.iter().map(|e| format!("{:?}", e.kind)));
            let cpu: BTreeSet<(u32, u32, u32)> =
                cpu_sil.iter().map(|e| (e.edge, e.a, e.b)).collect();
            let gpu: BTreeSet<(u32, u32, u32)> = gpu_edges.into_iter().collect();
            assert!(!cpu.is_empty(), "{name}/{}: no silhouette at all", o.name);
            assert_eq!(
                cpu.symmetric_difference(&gpu).count(),
                0,
                "{name}/{}: {} CPU edges, {} GPU edges, first differences {:?}",
                o.name,
                cpu.len(),
                gpu.len(),
                cpu.symmetric_difference(&gpu).take(5).collect::<Vec<_>>()
            );
        }
        // The special meshes exercise their special edges.
        let want = match name.as_str() {
            "open bowl" => Some(EdgeKind::Boundary),
            "non-manifold book" => Some(EdgeKind::NonManifold),
            _ => None,
        };
        if let Some(k) = want {
            assert!(
                kinds.contains(&format!("{k:?}")),
                "{name}: no {k:?} silhouette edge among {kinds:?}"
            );
        }
    }
}

/// Both smoothie forms: the centred form's inner smoothies on the GPU path are its outer
/// ones reflected by the vertex stage (glsl/smoothies_centred/mirrored.vert), where the CPU
/// path builds mirrored records.
#[test]
fn gpu_and_cpu_paths_render_the_same_image() {
    let gpu = Gpu::new();
    // The sun built-ins among them: orthographic depth, one width, the facing test's
    // stand-in point.
    for scene in scenes() {
        let name = scene.name.clone();
        let hard = gpu
            .render_frames(scene.clone(), "hard", settings(SilhouettePath::Cpu), 1)
            .0;
        for technique in ["smoothies", "smoothies-centred"] {
            let render = |path| {
                gpu.render_frames(scene.clone(), technique, settings(path), 1)
                    .0
            };
            let (cpu, on_gpu) = (render(SilhouettePath::Cpu), render(SilhouettePath::Gpu));
            let max_diff = max_visibility_diff(&cpu, &on_gpu);
            // Within one 8-bit level: the vertices may differ in the last bits (GPU sin/cos).
            // The centred form's inner smoothies show an edge whose outward side the two
            // paths decide apart, which the outer image can hide (the book's spine, before
            // both let the third-vertex test decide where the normals cancel).
            assert!(
                max_diff <= 1.0 / 255.0,
                "{name}, {technique}: GPU and CPU smoothies differ by {max_diff}"
            );
            let max_colour = max_colour_diff(&cpu, &on_gpu);
            assert!(
                max_colour <= 1,
                "{name}, {technique}: colours differ by {max_colour} levels"
            );
            // Both drew smoothies: an outer penumbra, darker than hard shadows just outside
            // the hard edge (smoothies: 225 to 542 of the 16384 pixels on the spotlight
            // scenes, 184 on sun-courtyard and 98 on sun-bunny, whose high sun casts a short
            // shadow; measured).
            let count = |v: &[f32], differs: fn(f32, f32) -> bool| {
                v.iter()
                    .zip(&hard.visibility)
                    .filter(|&(&s, &h)| differs(s, h))
                    .count()
            };
            let darker = |v: &[f32]| count(v, |s, h| s < h - 0.05);
            assert!(
                darker(&on_gpu.visibility) > 60 && darker(&cpu.visibility) > 60,
                "{name}, {technique}: no outer penumbra (GPU {}, CPU {} pixels darker than hard)",
                darker(&on_gpu.visibility),
                darker(&cpu.visibility)
            );
            // The centred form's inner penumbra too: lighter than hard shadows inside the
            // hard edge, which the reflected smoothies alone draw on the GPU path (133 to 384
            // pixels on the spotlight scenes, 92 on sun-courtyard, 37 on sun-bunny; measured).
            if technique == "smoothies-centred" {
                let lighter = |v: &[f32]| count(v, |s, h| s > h + 0.05);
                assert!(
                    lighter(&on_gpu.visibility) > 25,
                    "{name}: no inner penumbra on the GPU path ({} pixels lighter than hard)",
                    lighter(&on_gpu.visibility)
                );
            }
        }
    }
}

#[test]
fn a_moved_caster_rebuilds_only_its_own_smoothies() {
    let gpu = Gpu::new();
    for path in [SilhouettePath::Gpu, SilhouettePath::Cpu] {
        let scene = Scene::load("boxes").unwrap();
        let casters = scene.objects.iter().filter(|o| o.role.casts()).count();
        assert!(casters >= 2);
        // The lower box: moving it changes neither near (the upper box's top) nor far (the
        // ground), so the light's frame stays and only this caster is dirty.
        let lower = scene.objects.iter().position(|o| o.role.casts()).unwrap();
        let mut r = Renderer::new(&gpu.ctx, scene, "smoothies", settings(path)).unwrap();
        r.render().unwrap();
        if path == SilhouettePath::Gpu {
            assert_eq!(r.gpu_silhouettes_rebuilt(), Some(casters));
        }
        let near = fit_light(&r.scene).near;
        r.scene.objects[lower].transform =
            Mat4::from_translation(Vec3::new(0.3, 0.0, -0.2)) * r.scene.objects[lower].transform;
        assert_eq!(fit_light(&r.scene).near, near);
        let moved = r.render().unwrap();
        let ran: Vec<&str> = moved
            .passes
            .iter()
            .filter(|p| p.not_run.is_none())
            .map(|p| p.name.as_str())
            .collect();
        assert!(
            ran.contains(&"smoothies/smoothie") && ran.contains(&"smoothies/shadow_map"),
            "{path:?}: {ran:?}"
        );
        if path == SilhouettePath::Gpu {
            assert!(ran.contains(&"smoothies/silhouettes"), "{ran:?}");
            assert_eq!(
                r.gpu_silhouettes_rebuilt(),
                Some(1),
                "only the moved caster"
            );
        }
        let partial = r.read_back().unwrap();
        // The same scene rendered from scratch: a partial rebuild must not change a pixel
        // (min blending makes the draw order irrelevant).
        let fresh = gpu
            .render_frames(r.scene.clone(), "smoothies", settings(path), 1)
            .0;
        assert_eq!(partial.visibility, fresh.visibility, "{path:?}");

        // A receiver moving in its own plane changes no silhouette and not the deepest
        // surface under the casters: the GPU passes are left out. Moving down, it deepens
        // the extent the GPU path's smoothies are cut to (`speed::smoothies::gpu_extent`):
        // every caster is built again. Either way the image is a fresh render's.
        let ground = r
            .scene
            .objects
            .iter()
            .position(|o| !o.role.casts())
            .unwrap();
        for (step, rebuilt) in [
            (Vec3::new(0.05, 0.0, 0.0), None),
            (Vec3::new(0.0, -0.05, 0.0), Some(casters)),
        ] {
            r.scene.objects[ground].transform =
                Mat4::from_translation(step) * r.scene.objects[ground].transform;
            let receiver_moved = r.render().unwrap();
            if path == SilhouettePath::Gpu {
                let sil = receiver_moved
                    .passes
                    .iter()
                    .find(|p| p.name == "smoothies/silhouettes")
                    .unwrap();
                match rebuilt {
                    None => assert_eq!(
                        sil.not_run.as_deref(),
                        Some("light and casters unchanged"),
                        "{path:?}, {step}"
                    ),
                    Some(n) => assert_eq!(r.gpu_silhouettes_rebuilt(), Some(n), "{step}"),
                }
            }
            let partial = r.read_back().unwrap();
            let fresh = gpu
                .render_frames(r.scene.clone(), "smoothies", settings(path), 1)
                .0;
            assert_eq!(
                partial.visibility, fresh.visibility,
                "{path:?}: receiver move {step}"
            );
        }
    }
}

#[test]
fn penumbra_map_keeps_unmoved_casters_and_matches_a_fresh_render() {
    // penumbra-map caches each caster's cones and sheets like the smoothies' CPU path: after
    // one caster moves only it is rebuilt, and the cached others plus the rebuilt one must be
    // what a fresh renderer builds: the same penumbra buffer (the geometry's raster), texel
    // for texel, and the same image.
    let gpu = Gpu::new();
    let scene = Scene::load("boxes").unwrap();
    let casters = scene.objects.iter().filter(|o| o.role.casts()).count();
    assert_eq!(casters, 2, "boxes: two boxes on a receive-only ground");
    let lower = scene.objects.iter().position(|o| o.role.casts()).unwrap();
    let rebuilt = |t: &FrameTimings| {
        t.rebuilt_by("penumbra-map/silhouettes")
            .map(|r| (r.rebuilt, r.casters))
    };
    let mut r = Renderer::new(&gpu.ctx, scene, "penumbra-map", small(128, 512)).unwrap();
    let first = r.render().unwrap();
    assert_eq!(
        rebuilt(&first),
        Some((2, 2)),
        "first frame builds every caster"
    );
    let before = r.read_back().unwrap();
    let near = fit_light(&r.scene).near;
    r.scene.objects[lower].transform =
        Mat4::from_translation(Vec3::new(0.3, 0.0, -0.2)) * r.scene.objects[lower].transform;
    assert_eq!(fit_light(&r.scene).near, near, "the light's frame stays");
    let moved = r.render().unwrap();
    assert_eq!(rebuilt(&moved), Some((1, 2)), "only the moved caster");
    let partial = r.read_back().unwrap();
    assert_ne!(before.visibility, partial.visibility, "the box did move");
    let penumbra = r.read_technique_buffer("penumbra_map").unwrap().channels;
    let mut f = Renderer::new(&gpu.ctx, r.scene.clone(), "penumbra-map", small(128, 512)).unwrap();
    f.render().unwrap();
    let fresh = f.read_back().unwrap();
    assert_eq!(
        penumbra,
        f.read_technique_buffer("penumbra_map").unwrap().channels,
        "penumbra buffer of cached + rebuilt geometry vs a fresh build"
    );
    assert_eq!(partial.visibility, fresh.visibility);
}

#[test]
fn plateaus_rebuild_only_the_moved_caster_and_match_a_fresh_render() {
    // plateaus caches each caster's cones and sheets keyed on the plane frame and R: moving
    // one caster rebuilds 1 of 2, even when it moves the light's fitted near plane (the
    // texture's square does not depend on it); the concatenation of cached and rebuilt
    // geometry must give what a fresh renderer builds, bit for bit.
    let gpu = Gpu::new();
    let s = Settings {
        light_radius: Some(0.25),
        ..small(128, 512)
    };
    let scene = Scene::load("boxes").unwrap();
    let casters = scene.objects.iter().filter(|o| o.role.casts()).count();
    assert_eq!(casters, 2, "boxes: two boxes on a receive-only ground");
    let lower = scene.objects.iter().position(|o| o.name == "box2").unwrap();
    let upper = scene.objects.iter().position(|o| o.name == "box1").unwrap();
    let ground = scene
        .objects
        .iter()
        .position(|o| o.name == "ground")
        .unwrap();
    let rebuilt = |t: &FrameTimings| {
        t.rebuilt_by("plateaus/silhouettes")
            .map(|r| (r.rebuilt, r.casters))
    };
    let fresh = |scene: &Scene| gpu.render_frames(scene.clone(), "plateaus", s.clone(), 1).0;
    let mut r = Renderer::new(&gpu.ctx, scene, "plateaus", s.clone()).unwrap();
    let first = r.render().unwrap();
    assert_eq!(
        rebuilt(&first),
        Some((2, 2)),
        "first frame builds every caster"
    );
    let before = r.read_back().unwrap();

    // The lower box slides: the light's frame stays.
    let near = fit_light(&r.scene).near;
    r.scene.objects[lower].transform =
        Mat4::from_translation(Vec3::new(0.3, 0.0, -0.2)) * r.scene.objects[lower].transform;
    assert_eq!(fit_light(&r.scene).near, near);
    let moved = r.render().unwrap();
    assert_eq!(rebuilt(&moved), Some((1, 2)), "only the moved caster");
    assert!(
        moved
            .passes
            .iter()
            .any(|p| p.name == "plateaus/plateaus" && p.gpu_ms.is_some()),
        "{:?}",
        moved.passes
    );
    let partial = r.read_back().unwrap();
    assert_ne!(before.visibility, partial.visibility, "the box did move");
    assert_eq!(partial.visibility, fresh(&r.scene).visibility, "lower box");

    // The upper box rises towards the light: near moves, the plane frame does not.
    r.scene.objects[upper].transform =
        Mat4::from_translation(Vec3::new(0.0, 0.6, 0.1)) * r.scene.objects[upper].transform;
    assert_ne!(fit_light(&r.scene).near, near, "the near plane did move");
    let moved = r.render().unwrap();
    assert_eq!(rebuilt(&moved), Some((1, 2)), "only the risen caster");
    let partial = r.read_back().unwrap();
    assert_eq!(partial.visibility, fresh(&r.scene).visibility, "upper box");

    // Nothing moved: no light pass runs, nothing is rebuilt, the image stays.
    let still = r.render().unwrap();
    assert_eq!(rebuilt(&still), None);
    assert!(still
        .passes
        .iter()
        .filter(|p| p.name.starts_with("plateaus/") && p.name != "plateaus/final")
        .all(|p| p.not_run.as_deref() == Some("light and casters unchanged")));
    assert_eq!(r.read_back().unwrap().visibility, partial.visibility);

    // The plane moves: its frame is every caster's key, so all are rebuilt.
    r.scene.objects[ground].transform =
        Mat4::from_translation(Vec3::new(0.0, -0.05, 0.0)) * r.scene.objects[ground].transform;
    let moved = r.render().unwrap();
    assert_eq!(rebuilt(&moved), Some((2, 2)), "the plane moved");
    let partial = r.read_back().unwrap();
    assert_eq!(partial.visibility, fresh(&r.scene).visibility, "ground");

    // Without pass caching (`--timings`, the bench baseline) every frame rebuilds all.
    let (_, t) = gpu.render_frames(
        r.scene.clone(),
        "plateaus",
        Settings {
            cache_light_passes: false,
            ..s.clone()
        },
        2,
    );
    assert_eq!(rebuilt(&t[1]), Some((2, 2)));
    assert!(
        t[1].report().contains("(rebuilt 2 of 2 casters)"),
        "{}",
        t[1].report()
    );
}

#[test]
fn cli_selects_the_path_and_rejects_an_unknown_one() {
    let dir = std::env::temp_dir().join(format!("softshadow-sil-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let out = dir.join("gpu.png");
    let o = softshadow(&[
        "render",
        "--scene",
        "boxes",
        "--technique",
        "smoothies",
        "--width",
        "64",
        "--height",
        "64",
        "--shadow-res",
        "128",
        "--silhouettes",
        "gpu",
        "--timings",
        "--out",
        out.to_str().unwrap(),
    ]);
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    // The GPU path is a timed pass, not CPU work.
    assert!(stdout.contains("pass smoothies/silhouettes"), "{stdout}");
    assert!(!stdout.contains("cpu  smoothies/silhouettes"), "{stdout}");
    assert!(out.exists());

    let bogus = dir.join("bogus.png");
    let o = softshadow(&[
        "render",
        "--silhouettes",
        "bogus",
        "--out",
        bogus.to_str().unwrap(),
    ]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success());
    assert!(!stderr.contains("panicked"), "{stderr}");
    let errors: Vec<&str> = stderr.lines().filter(|l| l.starts_with("error")).collect();
    assert_eq!(errors.len(), 1, "{stderr}");
    assert!(errors[0].contains("allowed auto, cpu, gpu"), "{stderr}");
    assert!(!bogus.exists());
    let _ = std::fs::remove_dir_all(&dir);
}

/// The GPU path's light areas (`speed::smoothies::gpu_reaches`): each caster's projected
/// box grown by the reach of its smoothies bounds where the light passes clear and draw and
/// where the final shader runs, as the CPU path's smoothies do; and its smoothies are cut
/// to the frame's extent (`speed::smoothies::gpu_extent`). The same image as `--plain`
/// (whole passes, full-width smoothies) on every scene and both smoothie forms, up to the
/// rounding of t and 1/b interpolated over the cut triangles (tests/plain.rs's bounds);
/// fewer shadow-map and smoothie-pass fragments on every one. At 128^2, 512^2 maps,
/// `--plain` against the areas, smoothies-centred, measured: shadow map `cylinder` 299,360
/// and 156,480 (171,472 with the boxes grown by the full-width reach), `overlap` 363,872
/// and 99,024, `bunny` 327,808 and 256,640, `dense` 1,110,912 and 972,080; smoothie pass
/// `cylinder` 86,800 and 50,496, `bunny` 360,128 and 213,680, `dense` 2,725,248 and
/// 977,376, `sun-courtyard` 76,272 and 66,640 (every other scene 0.43-0.65x, either form).
#[test]
fn gpu_path_light_areas_keep_the_image() {
    let gpu = Gpu::new();
    let fragments = |t: &[FrameTimings], technique: &str, pass: &str| {
        let pass = format!("{technique}/{pass}");
        t[0].passes
            .iter()
            .find(|p| p.name == pass)
            .and_then(|p| p.stats)
            .expect("statistics on lavapipe")
            .fragment_invocations
    };
    for scene in scenes() {
        let name = scene.name.clone();
        for technique in ["smoothies", "smoothies-centred"] {
            let run = |plain| {
                let s = Settings {
                    plain,
                    ..settings(SilhouettePath::Gpu)
                };
                gpu.render_frames(scene.clone(), technique, s, 1)
            };
            let ((areas, t_areas), (whole, t_whole)) = (run(false), run(true));
            let diff = max_visibility_diff(&areas, &whole);
            // The centred form: a share moved to its neighbouring key step
            // (tests/plain.rs).
            let bound = if technique == "smoothies" {
                1e-4
            } else {
                1.3e-3
            };
            assert!(
                diff <= bound,
                "{name}, {technique}: the areas change the image by {diff}"
            );
            for pass in ["shadow_map", "smoothie"] {
                let a = fragments(&t_areas, technique, pass);
                let w = fragments(&t_whole, technique, pass);
                assert!(
                    a < w,
                    "{name}, {technique}: {a} {pass} fragments, {w} without areas"
                );
                // The boxes grown by the cut reach: 0.52x (0.57x by the full-width one).
                if name == "cylinder" && pass == "shadow_map" {
                    assert!(20 * a < 11 * w, "{name}, {technique}: {a} of {w} fragments");
                }
            }
            // The cut smoothies: at most 0.7x the full-width ones' fragments (0.45x on
            // `dense`, whose blob stands far above the ground; `sun-courtyard`'s walls
            // reach the ground's far edge, 0.81-0.87x).
            let cut = match name.as_str() {
                "dense" => 0.45,
                "sun-courtyard" => 0.95,
                _ => 0.7,
            };
            let a = fragments(&t_areas, technique, "smoothie");
            let w = fragments(&t_whole, technique, "smoothie");
            assert!(
                (a as f64) <= cut * w as f64,
                "{name}, {technique}: {a} of {w} smoothie fragments"
            );
        }
    }
}
