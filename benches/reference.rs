//! Wall time of the ray-cast reference (docs/DESIGN.md's ground truth), uncached, at a scene's
//! camera pixels: `cargo bench --bench reference [-- SCENE SIZE SAMPLES]` (default
//! `bunny 512 256`, the benchmark issue's speed goal: under 60 s on 2 cores). The pixels'
//! positions and normals come from one `hard` frame on the default device.

use softshadow::reference::{visibility_at, ReferenceParams, DEFAULT_SEED};
use softshadow::render::Renderer;
use softshadow::scene::Scene;
use softshadow::settings::Settings;
use softshadow::vk::{Context, ContextOptions};
use std::time::Instant;

fn main() -> anyhow::Result<()> {
    // cargo passes `--bench` (and any filter flags) to harness-less benches.
    let args: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| !a.starts_with("--"))
        .collect();
    let scene_name = args.first().map_or("bunny", |s| s.as_str());
    let size: u32 = args.get(1).map_or(Ok(512), |s| s.parse())?;
    let samples: u32 = args.get(2).map_or(Ok(256), |s| s.parse())?;
    let scene = Scene::load(scene_name)?;
    let ctx = Context::new(&ContextOptions::from_env())?;
    let settings = Settings {
        width: size,
        height: size,
        ..Settings::default()
    };
    let mut r = Renderer::new(&ctx, scene.clone(), "hard", settings)?;
    r.render()?;
    let img = r.read_back()?;
    let covered = img.position.iter().filter(|p| p[3] > 0.5).count();
    let params = ReferenceParams {
        samples,
        seed: DEFAULT_SEED,
    };
    let t = Instant::now();
    let v = visibility_at(
        &scene,
        scene.light.radius,
        &img.position,
        &img.normal,
        &params,
    )?;
    let s = t.elapsed().as_secs_f64();
    let penumbra = v.iter().filter(|&&x| x > 0.0 && x < 1.0).count();
    let rays = covered as f64 * samples as f64;
    println!(
        "reference {scene_name} {size}x{size}, {samples} rays/pixel, R = {}: {s:.2} s on {} threads ({covered} covered pixels, {penumbra} in penumbra, {:.1} Mrays/s)",
        scene.light.radius,
        rayon::current_num_threads(),
        rays / s * 1e-6
    );
    Ok(())
}
