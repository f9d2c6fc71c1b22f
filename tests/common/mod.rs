//! Shared test harness: a lavapipe context with the Khronos validation layers on, and
//! one-call rendering. Every test that renders goes through `Gpu`, whose `Drop` fails the
//! test on any validation message.
#![allow(dead_code)]

use softshadow::output::FrameImages;
use softshadow::render::Renderer;
use softshadow::scene::Scene;
use softshadow::settings::Settings;
use softshadow::vk::{Context, ContextOptions, FrameTimings};

pub struct Gpu {
    pub ctx: Context,
}

impl Gpu {
    /// lavapipe (or SOFTSHADOW_DEVICE), validation on. A missing device fails the test.
    pub fn new() -> Self {
        let device = std::env::var("SOFTSHADOW_DEVICE")
            .ok()
            .or(Some("llvmpipe".into()));
        let ctx = Context::new(&ContextOptions {
            device,
            validation: true,
        })
        .unwrap_or_else(|e| {
            panic!(
                "the tests need a Vulkan device (lavapipe at least); they fail without one: {e:#}"
            )
        });
        Self { ctx }
    }

    /// Renders `frames` frames of `scene` with `technique`; returns the last frame's images
    /// and every frame's timings.
    pub fn render_frames(
        &self,
        scene: Scene,
        technique: &str,
        settings: Settings,
        frames: usize,
    ) -> (FrameImages, Vec<FrameTimings>) {
        let mut r = Renderer::new(&self.ctx, scene, technique, settings)
            .unwrap_or_else(|e| panic!("creating {technique}: {e:#}"));
        let timings = (0..frames)
            .map(|_| {
                r.render()
                    .unwrap_or_else(|e| panic!("rendering {technique}: {e:#}"))
            })
            .collect();
        let images = r
            .read_back()
            .unwrap_or_else(|e| panic!("reading back: {e:#}"));
        (images, timings)
    }

    pub fn render(&self, scene: &str, technique: &str, settings: Settings) -> FrameImages {
        let scene = Scene::load(scene).unwrap_or_else(|e| panic!("{e:#}"));
        self.render_frames(scene, technique, settings, 1).0
    }

    pub fn assert_clean(&self) {
        let msgs = self.ctx.validation_messages();
        assert!(msgs.is_empty(), "validation messages:\n{}", msgs.join("\n"));
    }
}

impl Drop for Gpu {
    fn drop(&mut self) {
        if !std::thread::panicking() {
            self.assert_clean();
        }
    }
}

/// Small, fast settings for tests.
pub fn small(width: u32, shadow_res: u32) -> Settings {
    Settings {
        width,
        height: width,
        shadow_res,
        ..Settings::default()
    }
}

/// `s` under a light of radius `r` (a spotlight's; the scene's own when not set).
pub fn with_radius(mut s: Settings, r: f32) -> Settings {
    s.light_radius = Some(r);
    s
}

/// The largest difference of two images' visibilities.
pub fn max_visibility_diff(a: &FrameImages, b: &FrameImages) -> f32 {
    a.visibility
        .iter()
        .zip(&b.visibility)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0f32, f32::max)
}

/// The largest difference of two images' colours, in 8-bit levels over every channel.
pub fn max_colour_diff(a: &FrameImages, b: &FrameImages) -> u8 {
    a.color
        .iter()
        .zip(&b.color)
        .flat_map(|(p, q)| p.iter().zip(q).map(|(x, y)| x.abs_diff(*y)))
        .max()
        .unwrap_or(0)
}

/// Pixels that hit a receiving surface (position alpha 1).
pub fn covered(img: &FrameImages) -> Vec<usize> {
    (0..img.visibility.len())
        .filter(|&i| img.position[i][3] > 0.5)
        .collect()
}

/// Pixel index nearest to a world point among covered pixels.
pub fn pixel_at(img: &FrameImages, p: glam::Vec3) -> usize {
    covered(img)
        .into_iter()
        .min_by(|&a, &b| {
            let da = (glam::Vec4::from(img.position[a]).truncate() - p).length();
            let db = (glam::Vec4::from(img.position[b]).truncate() - p).length();
            da.total_cmp(&db)
        })
        .expect("no covered pixel")
}

/// Runs the `softshadow` binary with validation on and no device override.
pub fn softshadow(args: &[&str]) -> std::process::Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_softshadow"))
        .args(args)
        .arg("--validation")
        .env_remove("SOFTSHADOW_DEVICE")
        .output()
        .expect("running softshadow")
}

// Casters for the CPU-vs-GPU geometry tests (tests/gpu_silhouettes.rs, tests/gpu_penumbra.rs).

/// `cylinder`'s ground, light and camera with another caster in the cylinder's place.
pub fn with_caster(mesh: softshadow::scene::Mesh, name: &str) -> Scene {
    let mut scene = Scene::load("cylinder").unwrap();
    let caster = scene
        .objects
        .iter_mut()
        .find(|o| o.name == "cylinder")
        .unwrap();
    caster.mesh = std::sync::Arc::new(mesh);
    caster.transform = glam::Mat4::from_translation(glam::Vec3::new(0.0, 1.2, 0.0));
    scene.name = name.into();
    scene
}

/// A unit cube, flat shaded (split vertices, welded by the adjacency).
pub fn cube() -> softshadow::scene::Mesh {
    softshadow::scene::primitives::cuboid(glam::Vec3::ONE)
}

/// An open bowl: the lower half of a sphere, rim and all (boundary edges).
pub fn bowl() -> softshadow::scene::Mesh {
    let sphere = softshadow::scene::primitives::sphere(0.8, 24, 12);
    let mut m = softshadow::scene::Mesh {
        positions: sphere.positions.clone(),
        ..softshadow::scene::Mesh::default()
    };
    for t in sphere.indices.chunks_exact(3) {
        let c = t
            .iter()
            .map(|&i| sphere.positions[i as usize])
            .sum::<glam::Vec3>()
            / 3.0;
        if c.y < 0.0 {
            m.indices.extend_from_slice(t);
        }
    }
    m.compute_normals();
    m
}

/// Covered pixels of `img` at least `r` pixels from a shadow edge: their (2r+1)^2
/// neighbourhood lies on one side of visibility 0.5 (edges alias differently in each
/// technique's map, so comparisons with `hard` leave them out).
pub fn off_edges(img: &FrameImages, r: i64) -> Vec<usize> {
    let (w, h) = (img.width as i64, img.height as i64);
    let lit = |i: i64| img.visibility[i as usize] > 0.5;
    covered(img)
        .into_iter()
        .filter(|&i| {
            let (x, y) = (i as i64 % w, i as i64 / w);
            (-r..=r).all(|dy| {
                (-r..=r).all(|dx| {
                    let (nx, ny) = (x + dx, y + dy);
                    nx < 0 || ny < 0 || nx >= w || ny >= h || lit(ny * w + nx) == lit(i as i64)
                })
            })
        })
        .collect()
}

/// mae_lit and the other errors of `technique` against the ray-cast reference as issue 21's
/// acceptance measured them (tests/acceptance.rs): 160x160, every other setting at its
/// default, the scene's light radius.
pub fn errors_160(gpu: &Gpu, scene: &Scene, technique: &str) -> softshadow::eval::metrics::Errors {
    let settings = Settings {
        width: 160,
        height: 160,
        ..Settings::default()
    };
    errors_with(gpu, scene, technique, settings)
}

/// mae_lit and the other errors of `technique` at `settings` against the ray-cast
/// reference, at the scene's light radius.
pub fn errors_with(
    gpu: &Gpu,
    scene: &Scene,
    technique: &str,
    settings: Settings,
) -> softshadow::eval::metrics::Errors {
    let img = gpu.render_frames(scene.clone(), technique, settings, 1).0;
    let v_ref = softshadow::reference::visibility_cached(
        scene,
        scene.light.radius,
        &img.position,
        &img.normal,
        &softshadow::reference::ReferenceParams::default(),
    )
    .unwrap_or_else(|e| panic!("reference of {}: {e:#}", scene.name));
    softshadow::eval::metrics::errors_at(
        &img.visibility,
        &v_ref,
        &img.position,
        &img.normal,
        &img.spot,
        scene.light.position,
    )
}

/// `metrics::false_edges` of `img` (one image row `width` wide) against `v_ref` over the
/// pixels `mae_lit` judges: covered, inside the cone, facing `scene`'s light.
pub fn false_edges_of(
    img: &FrameImages,
    v_ref: &[f32],
    scene: &Scene,
    width: usize,
) -> softshadow::eval::metrics::FalseEdges {
    use softshadow::eval::metrics::{faces, false_edges, judged};
    let facing = faces(&img.position, &img.normal, &scene.light);
    let covered = judged(&img.position, &img.spot);
    false_edges(
        &img.visibility,
        v_ref,
        width,
        &img.position,
        &img.normal,
        &covered,
        &facing,
    )
}
