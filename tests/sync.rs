//! Race-free on a real GPU: every technique, every variant that records different commands
//! (both silhouette paths, both SPIR-V choices, both accumulation formats) and the bench's
//! motion scenarios, with the validation layer's synchronization validation on (as in every
//! test): not one message. Tiny images and maps, three frames each, so that lavapipe runs the
//! whole matrix in seconds.
//!
//! `SOFTSHADOW_BEST_PRACTICES=1 cargo test --test sync` runs the same matrix with the
//! layer's best-practices checks too; the findings left on purpose (docs/TESTING.md, "Validation")
//! are the only messages it lets through.

use softshadow::eval::bench::Motion;
use softshadow::render::Renderer;
use softshadow::scene::Scene;
use softshadow::settings::{AccumFormat, Settings, SilhouettePath, SpirvChoice};
use softshadow::technique::TECHNIQUES;
use softshadow::vk::{Context, ContextOptions};

/// Best-practices findings left on purpose, each explained in docs/TESTING.md, "Validation".
const KNOWN_BEST_PRACTICES: &[&str] = &[
    "UNASSIGNED-BestPractices-vkCreateInstance-specialuse-extension-debugging",
    "UNASSIGNED-BestPractices-pipeline-stage-flags",
    "UNASSIGNED-BestPractices-ImageBarrierAccessLayout",
];

fn best_practices() -> bool {
    std::env::var("SOFTSHADOW_BEST_PRACTICES").is_ok_and(|v| !v.is_empty() && v != "0")
}

/// lavapipe (or SOFTSHADOW_DEVICE) with validation on, as tests/common's `Gpu`, but every
/// case here checks its own messages (so that best-practices findings known to stay can
/// be let through).
fn context() -> Context {
    let device = std::env::var("SOFTSHADOW_DEVICE").unwrap_or_else(|_| "llvmpipe".into());
    Context::new(&ContextOptions {
        device: Some(device),
        validation: true,
    })
    .unwrap_or_else(|e| {
        panic!("the tests need a Vulkan device (lavapipe at least); they fail without one: {e:#}")
    })
}

/// The messages of `ctx` after `seen`, less the known best-practices findings when those
/// checks are on.
fn new_messages(ctx: &Context, seen: &mut usize) -> Vec<String> {
    let all = ctx.validation_messages();
    let fresh = all[*seen..].to_vec();
    *seen = all.len();
    let bp = best_practices();
    fresh
        .into_iter()
        .filter(|m| !(bp && KNOWN_BEST_PRACTICES.iter().any(|k| m.contains(k))))
        .collect()
}

fn tiny() -> Settings {
    Settings {
        width: 32,
        height: 32,
        shadow_res: 64,
        occluder_res: 32,
        ..Settings::default()
    }
}

/// Renders `frames` frames of `motion` on `cylinder` (as `bench` does: frame f is the
/// motion at f), then one at rest when something moved, reads back the image, the AOVs,
/// every technique buffer and the GPU-built geometry, and fails on any new validation
/// message. Returns the visibility of the last frame.
fn run(
    ctx: &Context,
    seen: &mut usize,
    technique: &str,
    settings: Settings,
    motion: Motion,
    label: &str,
) -> Vec<f32> {
    let base = Scene::load("cylinder").unwrap();
    let mut r = Renderer::new(ctx, base.clone(), technique, settings)
        .unwrap_or_else(|e| panic!("{label}: {e:#}"));
    for f in 0..3 {
        r.scene = motion.apply(&base, f);
        r.render()
            .unwrap_or_else(|e| panic!("{label}, frame {f}: {e:#}"));
    }
    if motion != Motion::Static {
        r.scene = base.clone();
        r.render()
            .unwrap_or_else(|e| panic!("{label}, at rest: {e:#}"));
    }
    let images = r.read_back().unwrap_or_else(|e| panic!("{label}: {e:#}"));
    for name in r.technique_buffer_names() {
        r.read_technique_buffer(name)
            .unwrap_or_else(|e| panic!("{label}, buffer {name}: {e:#}"));
    }
    r.read_gpu_geometry()
        .unwrap_or_else(|e| panic!("{label}, GPU geometry: {e:#}"));
    drop(r);
    let msgs = new_messages(ctx, seen);
    assert!(
        msgs.is_empty(),
        "{label}: {} validation message(s):\n{}",
        msgs.len(),
        msgs.join("\n")
    );
    images.visibility
}

/// The cylinder's shadow is there: some pixel in umbra, some fully lit. A pass that did
/// not run (or ran before what it reads was written) would not leave both.
fn assert_shadowed(v: &[f32], label: &str) {
    let min = v.iter().copied().fold(f32::INFINITY, f32::min);
    let max = v.iter().copied().fold(f32::NEG_INFINITY, f32::max);
    assert!(
        min < 0.3 && max > 0.9,
        "{label}: visibility in [{min}, {max}]"
    );
}

#[test]
fn every_technique_and_variant_is_race_free() {
    let ctx = context();
    let mut seen = 0;
    assert_eq!(new_messages(&ctx, &mut seen), Vec::<String>::new());
    for t in TECHNIQUES {
        let mut variants = vec![(t.name.to_string(), tiny())];
        if matches!(t.name, "smoothies" | "penumbra-map") {
            variants = [SilhouettePath::Cpu, SilhouettePath::Gpu]
                .into_iter()
                .map(|path| {
                    let s = Settings {
                        silhouettes: path,
                        ..tiny()
                    };
                    (format!("{} sil={}", t.name, path.name()), s)
                })
                .collect();
        }
        if softshadow::shaders::has_tuned(t.name) {
            let s = Settings {
                spirv: SpirvChoice::Tuned,
                ..tiny()
            };
            variants.push((format!("{} spirv=tuned", t.name), s));
        }
        if matches!(t.name, "ssm" | "ssm2") {
            let s = Settings {
                accum_format: AccumFormat::R16F,
                ..tiny()
            };
            variants.push((format!("{} accum=r16f", t.name), s));
        }
        for (label, settings) in variants {
            let v = run(&ctx, &mut seen, t.name, settings, Motion::Static, &label);
            assert_shadowed(&v, &label);
        }
    }
}

#[test]
fn bench_motions_are_race_free() {
    let ctx = context();
    let mut seen = 0;
    assert_eq!(new_messages(&ctx, &mut seen), Vec::<String>::new());
    let motions = [
        Motion::Static,
        Motion::Camera,
        Motion::Light,
        Motion::Object,
    ];
    for t in TECHNIQUES.iter().filter(|t| t.name != "reference") {
        let paths: &[SilhouettePath] = match t.name {
            "smoothies" | "penumbra-map" => &[SilhouettePath::Cpu, SilhouettePath::Gpu],
            _ => &[SilhouettePath::Cpu],
        };
        for &path in paths {
            for motion in motions {
                for reuse in [false, true] {
                    let settings = Settings {
                        silhouettes: path,
                        cache_light_passes: reuse,
                        ..tiny()
                    };
                    let label = format!(
                        "{} sil={} motion={} reuse={reuse}",
                        t.name,
                        path.name(),
                        motion.name()
                    );
                    let v = run(&ctx, &mut seen, t.name, settings, motion, &label);
                    assert_shadowed(&v, &label);
                }
            }
        }
    }
}
