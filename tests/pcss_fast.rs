//! `pcss-fast` is `pcss` with a min/max hierarchy that settles lit and umbra points before
//! the blocker search: its image must be pcss's (issue 22 item 4: within 1/255 where the
//! search finds the same blockers; the hierarchy's answers are conservative, so everywhere).

mod common;

use common::{covered, small, Gpu};
use softshadow::scene::Scene;
use softshadow::settings::Settings;

/// Largest |pcss-fast - pcss| over covered pixels, and (lit, penumbra, umbra) counts of pcss
/// among them.
fn compare(gpu: &Gpu, scene: &str, settings: &Settings) -> (f32, [usize; 3]) {
    let a = gpu.render(scene, "pcss", settings.clone());
    let b = gpu.render(scene, "pcss-fast", settings.clone());
    let mut worst = 0.0f32;
    let mut counts = [0; 3];
    for i in covered(&a) {
        worst = worst.max((a.visibility[i] - b.visibility[i]).abs());
        let v = a.visibility[i];
        counts[if v >= 1.0 {
            0
        } else if v > 0.0 {
            1
        } else {
            2
        }] += 1;
    }
    (worst, counts)
}

#[test]
fn same_image_as_pcss_on_every_scene_and_radius() {
    let gpu = Gpu::new();
    for scene in [
        "cylinder",
        "bunny",
        "fence",
        "overlap",
        "primitives",
        "boxes",
    ] {
        let r = Scene::load(scene).expect("built-in scene").light.radius;
        // The scene's light, a point light, and one wide enough to clamp the search.
        for radius in [r, 0.0, 4.0 * r] {
            let settings = Settings {
                light_radius: Some(radius),
                ..small(160, 512)
            };
            let (worst, [lit, penumbra, umbra]) = compare(&gpu, scene, &settings);
            assert!(
                worst <= 1.0 / 255.0,
                "{scene} R {radius}: pcss-fast differs from pcss by {worst}"
            );
            // Not vacuous: the frame has lit and shadowed points, and a penumbra unless R = 0.
            assert!(
                lit > 100 && umbra + penumbra > 50,
                "{scene} R {radius}: {lit} lit, {penumbra} penumbra, {umbra} umbra"
            );
            if radius > 0.0 {
                assert!(
                    penumbra > 20,
                    "{scene} R {radius}: {penumbra} penumbra points"
                );
            }
        }
    }
}

/// A map whose size is not a power of two: odd levels keep their last texel (minmax.comp
/// clamps, hierarchy.glsl rounds sizes up), so the texels along the far edges are covered.
#[test]
fn same_image_as_pcss_with_odd_map_sizes() {
    let gpu = Gpu::new();
    for res in [300, 97] {
        let (worst, [lit, penumbra, umbra]) = compare(&gpu, "cylinder", &small(160, res));
        assert!(worst <= 1.0 / 255.0, "shadow res {res}: differs by {worst}");
        assert!(
            lit > 100 && penumbra > 20 && umbra > 20,
            "shadow res {res}: {lit} {penumbra} {umbra}"
        );
    }
}
