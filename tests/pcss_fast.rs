//! `pcss-fast` and `pcss-walk` are `pcss` with a caster-depth hierarchy of the shadow map
//! (issue 22 item 4), whose early exits settle lit and umbra points with pcss's own values.
//! - `pcss-fast` runs pcss's search and filter for the points left: its image is pcss's
//!   (within 1/255; the early exits are conservative bounds), on every scene and radius.
//! - `pcss-walk` walks the hierarchy for the blocker average instead of pcss's 16 taps. The
//!   walk's average is not the taps' average, so its image is not pcss's everywhere; what
//!   must still hold, on lavapipe with validation:
//!   - where pcss gives exactly 0 or 1, pcss-walk almost always gives the same, and over
//!     all covered pixels only a small, measured fraction differs by more than 1/255;
//!   - R = 0: pcss's image exactly (the walk is skipped under half a texel of search);
//!   - mae_lit against the ray-cast reference within a measured margin of pcss's;
//!   - the penumbra still widens with the light.

mod common;

use common::{covered, small, Gpu};
use softshadow::output::FrameImages;
use softshadow::scene::Scene;
use softshadow::settings::Settings;

/// pcss-fast or pcss-walk against pcss over the covered pixels of one frame.
#[derive(Debug)]
struct Comparison {
    covered: usize,
    /// pcss's lit (v = 1) and umbra (v = 0) pixels.
    lit: usize,
    umbra: usize,
    /// Pixels where pcss gives exactly 0 or 1, and of those where the other gives the same.
    settled: usize,
    settled_same: usize,
    /// Pixels differing by more than 1/255.
    off: usize,
    /// Pixels differing by more than 0.5: a blocker the walk missed or invented.
    far_off: usize,
    worst: f32,
    /// pcss's penumbra pixels (0 < v < 1).
    penumbra: usize,
}

impl Comparison {
    fn settled_same_fraction(&self) -> f64 {
        self.settled_same as f64 / self.settled.max(1) as f64
    }
    fn off_fraction(&self) -> f64 {
        self.off as f64 / self.covered.max(1) as f64
    }
}

/// Renders `technique` and compares it with `pcss`, the same frame already rendered.
fn compare(
    gpu: &Gpu,
    scene: &str,
    settings: &Settings,
    pcss: &FrameImages,
    technique: &str,
) -> Comparison {
    let b = gpu.render(scene, technique, settings.clone());
    let mut c = Comparison {
        covered: 0,
        lit: 0,
        umbra: 0,
        settled: 0,
        settled_same: 0,
        off: 0,
        far_off: 0,
        worst: 0.0,
        penumbra: 0,
    };
    for i in covered(pcss) {
        let (va, vb) = (pcss.visibility[i], b.visibility[i]);
        let d = (va - vb).abs();
        c.covered += 1;
        c.worst = c.worst.max(d);
        c.off += usize::from(d > 1.0 / 255.0);
        c.far_off += usize::from(d > 0.5);
        c.lit += usize::from(va == 1.0);
        c.umbra += usize::from(va == 0.0);
        if va == 0.0 || va == 1.0 {
            c.settled += 1;
            c.settled_same += usize::from(va == vb);
        } else {
            c.penumbra += 1;
        }
    }
    c
}

/// pcss-fast gives pcss's image (its early exits are conservative bounds on pcss's test).
fn check_fast(c: &Comparison, what: &str) {
    assert!(
        c.worst <= 1.0 / 255.0,
        "{what}: pcss-fast differs from pcss by {}",
        c.worst
    );
}

/// Bounds, per light radius, on the least fraction of pcss's 0/1 pixels where pcss-walk gives
/// the same value, on the most fraction of covered pixels off by more than 1/255, and on the
/// pixels off by more than 0.5, over the six scenes of
/// `match_pcss_on_every_scene_and_radius` (160², map 512²). Measured (least same, most
/// off, most far off): the scene's radius 0.9914 (overlap), 0.0437 (cylinder), 0 (largest
/// difference 0.477, bunny); four times it 0.9570 (overlap), 0.1334 (primitives), one pixel
/// each on bunny, fence and boxes (largest 0.964, fence). The walk averages over the whole
/// search square where pcss averages 16 taps, so nearly every penumbra pixel moves a little,
/// and the wider the light the more pixels are penumbra. Comparing a cell with the plane's
/// nearest depth only (not its farthest) to call it open left 5 to 28 pixels per frame lit
/// that pcss shadows (largest difference 1.0): `far_off` catches that.
const SCENE_R: Bounds = Bounds {
    same: 0.985,
    off: 0.06,
    far_off: 0,
};
const WIDE_R: Bounds = Bounds {
    same: 0.95,
    off: 0.15,
    far_off: usize::MAX,
};

struct Bounds {
    same: f64,
    off: f64,
    far_off: usize,
}

fn check(c: &Comparison, bounds: &Bounds, what: &str) {
    assert!(
        c.settled_same_fraction() >= bounds.same,
        "{what}: only {:.4} of pcss's 0/1 pixels the same ({c:?})",
        c.settled_same_fraction()
    );
    assert!(
        c.off_fraction() <= bounds.off,
        "{what}: {:.4} of the pixels off by more than 1/255 ({c:?})",
        c.off_fraction()
    );
    assert!(
        c.far_off <= bounds.far_off,
        "{what}: {} pixels off by more than 0.5 ({c:?})",
        c.far_off
    );
}

#[test]
fn match_pcss_on_every_scene_and_radius() {
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
            let what = format!("{scene} R {radius}");
            let pcss = gpu.render(scene, "pcss", settings.clone());
            let fast = compare(&gpu, scene, &settings, &pcss, "pcss-fast");
            check_fast(&fast, &what);
            // Not vacuous: the frame has lit and shadowed points, and a penumbra unless R = 0.
            assert!(
                fast.lit > 100 && fast.umbra + fast.penumbra > 50,
                "{what}: {fast:?}"
            );

            let c = compare(&gpu, scene, &settings, &pcss, "pcss-walk");
            println!(
                "{what}: pcss-walk settled same {:.4}, off {:.4}, worst {:.3} ({c:?})",
                c.settled_same_fraction(),
                c.off_fraction(),
                c.worst
            );
            if radius == 0.0 {
                // The walk is skipped under half a texel of search: pcss's code, bit for bit.
                assert!(c.worst == 0.0, "{what}: differs from pcss by {}", c.worst);
            } else if radius == r {
                check(&c, &SCENE_R, &what);
            } else {
                check(&c, &WIDE_R, &what);
            }
            assert!(c.settled > 100 && c.settled < c.covered, "{what}: {c:?}");
            if radius > 0.0 {
                assert!(c.penumbra > 20, "{what}: {c:?}");
            }
        }
    }
}

/// A map whose size is not a power of two: cells along the far edges cover fewer texels
/// (their count decides "every texel a caster"), and the clamp-to-edge gathers of
/// minmax.comp must not count a texel twice. The scene radius's bounds hold (measured: same
/// 0.9938 and 0.9952, off 0.0486 and 0.0510, largest difference 0.080 and 0.038 at 300² and
/// 97²).
#[test]
fn match_pcss_with_odd_map_sizes() {
    let gpu = Gpu::new();
    for res in [300, 97] {
        let settings = small(160, res);
        let what = format!("shadow res {res}");
        let pcss = gpu.render("cylinder", "pcss", settings.clone());
        let fast = compare(&gpu, "cylinder", &settings, &pcss, "pcss-fast");
        check_fast(&fast, &what);
        assert!(
            fast.lit > 100 && fast.penumbra > 20 && fast.umbra > 20,
            "{what}: {fast:?}"
        );
        let c = compare(&gpu, "cylinder", &settings, &pcss, "pcss-walk");
        println!(
            "{what}: pcss-walk settled same {:.4}, off {:.4}, worst {:.3} ({c:?})",
            c.settled_same_fraction(),
            c.off_fraction(),
            c.worst
        );
        check(&c, &SCENE_R, &what);
        assert!(c.penumbra > 20 && c.settled > 100, "{what}: {c:?}");
    }
}

/// How far above pcss's mae_lit pcss-walk's may be, on each of `cylinder`, `bunny`,
/// `primitives`. Measured (pcss-walk - pcss): 0.0004, 0.0025, 0.0024.
const MAE_MARGIN: f64 = 0.003;

#[test]
fn mae_lit_near_pcss() {
    let gpu = Gpu::new();
    for name in ["cylinder", "bunny", "primitives"] {
        let scene = Scene::load(name).expect("built-in scene");
        let p = common::errors_160(&gpu, &scene, "pcss").mae_lit;
        let f = common::errors_160(&gpu, &scene, "pcss-walk").mae_lit;
        println!(
            "{name}: mae_lit pcss {p:.4}, pcss-walk {f:.4}, difference {:.4}",
            f - p
        );
        assert!(f <= p + MAE_MARGIN, "{name}: pcss-walk {f:.4}, pcss {p:.4}");
    }
}

/// The penumbra estimate survives the walk: a larger light gives more penumbra pixels
/// (measured on `cylinder` at R/2, R, 2R: 756, 1410, 2727, 1.87x and 1.93x).
#[test]
fn penumbra_grows_with_the_light() {
    let gpu = Gpu::new();
    let r = Scene::load("cylinder")
        .expect("built-in scene")
        .light
        .radius;
    let mut last = 0usize;
    for radius in [0.5 * r, r, 2.0 * r] {
        let settings = Settings {
            light_radius: Some(radius),
            ..small(160, 512)
        };
        let img = gpu.render("cylinder", "pcss-walk", settings);
        let penumbra = covered(&img)
            .into_iter()
            .filter(|&i| img.visibility[i] > 0.0 && img.visibility[i] < 1.0)
            .count();
        println!("R {radius}: {penumbra} penumbra pixels");
        assert!(
            penumbra as f64 > 1.5 * last as f64,
            "R {radius}: {penumbra} penumbra pixels, not 1.5x the {last} of a smaller light"
        );
        last = penumbra;
    }
}
