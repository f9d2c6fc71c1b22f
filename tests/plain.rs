//! `Settings::plain` (`--plain`): every technique without the speed layer (no culling, no
//! reuse of light passes or caster caches, whole light maps with full-width smoothies, one
//! full-screen final pass) draws the image of the optimised path, on every built-in scene.

mod common;

use common::{small, Gpu};
use glam::Vec3;
use softshadow::output::FrameImages;
use softshadow::render::Renderer;
use softshadow::scene::{Scene, BUILTIN_SCENES};
use softshadow::settings::{Settings, SilhouettePath};
use softshadow::technique::TECHNIQUES;
use softshadow::vk::FrameTimings;

/// The techniques whose optimised final pass runs their shader only where a shadow can
/// fall (`FinalPass::split`).
const SPLIT: [&str; 9] = [
    "pcf",
    "pcss",
    "smoothies",
    "smoothies-centred",
    "penumbra-map",
    "penumbra-map-centred",
    "plateaus",
    "plateaus-centred",
    "ssm-bitmask",
];

/// Three frames: the first, one after the light moved (light passes rebuilt, the optimised
/// path's areas joined with the first frame's) and one with nothing moved (the optimised
/// path reuses its light passes, the plain one redraws them). The third frame's images and
/// timings, and the objects kept in the (light, camera) frusta.
fn frames(
    gpu: &Gpu,
    scene: &Scene,
    technique: &str,
    settings: Settings,
) -> (FrameImages, FrameTimings, (usize, usize)) {
    let mut r = Renderer::new(&gpu.ctx, scene.clone(), technique, settings)
        .unwrap_or_else(|e| panic!("creating {technique}: {e:#}"));
    r.render().unwrap();
    let size = (r.scene.bounds().max - r.scene.bounds().min).length();
    r.scene.light.position += Vec3::new(0.02, 0.0, -0.01) * size;
    r.render().unwrap();
    let timings = r.render().unwrap();
    (r.read_back().unwrap(), timings, r.objects_in_frusta())
}

/// The largest difference of two visibilities (NaN on one side only: infinite), and how
/// many values differ.
fn visibility_diff(a: &[f32], b: &[f32]) -> (f32, usize) {
    let diffs: Vec<f32> = a
        .iter()
        .zip(b)
        .filter(|(x, y)| !(x == y || x.is_nan() && y.is_nan()))
        .map(|(x, y)| (x - y).abs())
        .map(|d| if d.is_nan() { f32::INFINITY } else { d })
        .collect();
    (diffs.iter().copied().fold(0.0, f32::max), diffs.len())
}

/// `name` on `scene` with and without the speed layer: asserts the plain path ran without
/// it and draws the optimised image (and, with `split`, that the optimised final pass of a
/// `SPLIT` technique was split); returns whether the optimised path reused its light
/// passes on the still frame, and where the two differ at all.
fn plain_against_optimised(
    gpu: &Gpu,
    scene: &Scene,
    scene_name: &str,
    name: &str,
    split: bool,
) -> (bool, Option<String>) {
    let settings = Settings {
        silhouettes: SilhouettePath::Cpu,
        ..small(64, 256)
    };
    let (fast, fast_t, _) = frames(gpu, scene, name, settings.clone());
    let (plain, plain_t, kept) = frames(
        gpu,
        scene,
        name,
        Settings {
            plain: true,
            ..settings
        },
    );
    let case = format!("{name} on {scene_name}");
    // The plain path ran without the speed layer: every object kept, every pass
    // run on the still frame, the final pass whole.
    let n = scene.objects.len();
    assert_eq!(kept, (n, n), "{case}: plain culled");
    let not_run = |t: &FrameTimings| t.passes.iter().filter(|p| p.not_run.is_some()).count();
    assert_eq!(not_run(&plain_t), 0, "{case}: plain left out a pass");
    let final_pass = format!("{name}/final");
    let area = |t: &FrameTimings| t.lookup_area_of(&final_pass).unwrap_or(1.0);
    assert_eq!(area(&plain_t), 1.0, "{case}: plain split its final pass");
    if split && SPLIT.contains(&name) {
        assert!(
            area(&fast_t) < 1.0,
            "{case}: the optimised final pass was whole"
        );
    }
    let reused = not_run(&fast_t) > 0;
    assert_eq!(fast.visibility.len(), 64 * 64, "{case}");
    let (vis, n_vis) = visibility_diff(&fast.visibility, &plain.visibility);
    let levels = common::max_colour_diff(&fast, &plain);
    let n_colour = fast
        .color
        .iter()
        .zip(&plain.color)
        .filter(|(a, b)| a != b)
        .count();
    // Shortened smoothies (`records::Extent`: the paper form's outer ones, the
    // centred form's inner ones) and cut cones and sheets interpolate alpha, t and
    // 1/b, or Zv, over triangles other than the full ones, so a few visibilities move
    // by that rounding (as in tests/avoided_work.rs `light_areas_change_no_pixel`):
    // measured up to 4.9e-5 on up to 155 of 4096 pixels for the paper form, a fraction of
    // a key's step for the centred forms. Everything else is bit for bit.
    let vis_bound = match name {
        "smoothies" => 1e-4,
        // Cut cones and sheets interpolate over shorter triangles: a value in the 16-bit
        // penumbra map can round to its neighbouring step (2^-11 in [0.5, 1)).
        "penumbra-map" => 5e-4,
        // The centred forms' keys (technique::packed) round each share to its step:
        // such a move can cross one, 1/511 of an outer share or 2/1023 of an inner one,
        // which moves the visibility by at most 2/pi of it (the profile's steepest
        // slope, at the hard edge), and a footprint's bilinear weights sum to 1.
        "smoothies-centred" | "penumbra-map-centred" => 1.3e-3,
        _ => 0.0,
    };
    // A visibility moved by that rounding can still cross the boundary of a colour level.
    let level_bound = if vis_bound > 0.0 { 1 } else { 0 };
    assert!(
        vis <= vis_bound && levels <= level_bound,
        "{case}: plain differs in {n_vis} visibilities by up to {vis}, in {n_colour} pixels by up to {levels} levels"
    );
    // Not a blank frame on either side: the comparison saw shading.
    assert!(
        fast.position.iter().any(|p| p[3] > 0.5),
        "{case}: nothing covered"
    );
    let worst = (n_vis > 0 || n_colour > 0).then(|| {
        format!("{case}: {n_vis} visibilities by up to {vis}, {n_colour} pixels by up to {levels}")
    });
    (reused, worst)
}

#[test]
fn plain_draws_the_optimised_image() {
    let gpu = Gpu::new();
    let mut worst = Vec::new();
    let mut reused = 0;
    // Every built-in but dense-1m, whose million triangles, drawn 96 times here, would
    // dominate the test; dense holds the same kind of casters (bumpy spheres over a plane).
    for &scene_name in BUILTIN_SCENES.iter().filter(|&&s| s != "dense-1m") {
        let scene = Scene::load(scene_name).unwrap();
        for t in TECHNIQUES {
            // The split final passes follow a spotlight's central projection and run whole
            // under a sun (`regions::shadowed`): asserted split on spotlight scenes only.
            let split = !scene.light.is_sun();
            let (r, w) = plain_against_optimised(&gpu, &scene, scene_name, t.name, split);
            reused += usize::from(r);
            worst.extend(w);
        }
    }
    // And the optimised path did what plain does not: reused its light passes (the
    // reference: its ray cast) on every still frame (the split final passes are checked
    // above).
    let cases = (BUILTIN_SCENES.len() - 1) * TECHNIQUES.len();
    assert_eq!(reused, cases, "light passes reused");
    // Shown with --nocapture: where rounding made the two differ at all.
    for w in worst {
        println!("{w}");
    }
}
