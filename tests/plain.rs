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

/// Three frames: the first, one after the light moved (light passes rebuilt, the optimised
/// path's areas joined with the first frame's) and one with nothing moved (the optimised
/// path reuses its light passes, the plain one redraws them). The third frame's images.
fn frames(gpu: &Gpu, scene: &Scene, technique: &str, settings: Settings) -> FrameImages {
    let mut r = Renderer::new(&gpu.ctx, scene.clone(), technique, settings)
        .unwrap_or_else(|e| panic!("creating {technique}: {e:#}"));
    r.render().unwrap();
    let size = (r.scene.bounds().max - r.scene.bounds().min).length();
    r.scene.light.position += Vec3::new(0.02, 0.0, -0.01) * size;
    r.render().unwrap();
    r.render().unwrap();
    r.read_back().unwrap()
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

#[test]
fn plain_draws_the_optimised_image() {
    let gpu = Gpu::new();
    let mut worst = Vec::new();
    for &scene_name in BUILTIN_SCENES {
        let scene = Scene::load(scene_name).unwrap();
        for t in TECHNIQUES {
            let name = t.name;
            let settings = Settings {
                silhouettes: SilhouettePath::Cpu,
                ..small(64, 256)
            };
            let fast = frames(&gpu, &scene, name, settings.clone());
            let plain = frames(
                &gpu,
                &scene,
                name,
                Settings {
                    plain: true,
                    ..settings
                },
            );
            let case = format!("{name} on {scene_name}");
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
            // centred form's inner ones) interpolate alpha, t and 1/b over triangles other
            // than the full-width ones: a few values move by that rounding (as in
            // tests/avoided_work.rs `light_areas_change_no_pixel`). Everything else is bit
            // for bit.
            let (vis_bound, level_bound) = if name.starts_with("smoothies") {
                (1e-3, 1)
            } else {
                (0.0, 0)
            };
            assert!(
                vis <= vis_bound && levels <= level_bound,
                "{case}: plain differs in {n_vis} visibilities by up to {vis}, in {n_colour} pixels by up to {levels} levels"
            );
            // Not a blank frame on either side: the comparison saw shading.
            assert!(
                fast.position.iter().any(|p| p[3] > 0.5),
                "{case}: nothing covered"
            );
            if n_vis > 0 || n_colour > 0 {
                worst.push(format!(
                    "{case}: {n_vis} visibilities by up to {vis}, {n_colour} pixels by up to {levels}"
                ));
            }
        }
    }
    // Shown with --nocapture: where rounding made the two differ at all.
    for w in worst {
        println!("{w}");
    }
}
