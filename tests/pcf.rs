//! `pcf` and `pcss` on the `cylinder` scene: lit and umbra agree with `hard`, a wider box
//! widens the transition, pcss hardens at the contact, R = 0 gives `hard`, bad kernels are
//! refused with the parameter and its range.

mod common;

use common::{covered, small, Gpu};
use glam::{Vec3, Vec4};
use softshadow::output::FrameImages;
use softshadow::render::Renderer;
use softshadow::scene::Scene;
use softshadow::settings::{PcfKernel, Settings};

const SIZE: u32 = 192;
const SHADOW_RES: u32 = 512;

fn pos(img: &FrameImages, i: usize) -> Vec3 {
    Vec4::from(img.position[i]).truncate()
}

fn settings(kernel: PcfKernel) -> Settings {
    Settings {
        pcf_kernel: kernel,
        ..small(SIZE, SHADOW_RES)
    }
}

/// Covered pixels whose whole (2r+1)^2 neighbourhood in `img` is covered and has
/// visibility `v` (within 1e-6): far from every edge of that image's shadow.
fn interior(img: &FrameImages, v: f32, r: i64) -> Vec<usize> {
    let (w, h) = (img.width as i64, img.height as i64);
    covered(img)
        .into_iter()
        .filter(|&i| {
            let (x, y) = (i as i64 % w, i as i64 / w);
            (-r..=r).all(|dy| {
                (-r..=r).all(|dx| {
                    let (xx, yy) = (x + dx, y + dy);
                    if xx < 0 || yy < 0 || xx >= w || yy >= h {
                        return false;
                    }
                    let j = (yy * w + xx) as usize;
                    img.position[j][3] > 0.5 && (img.visibility[j] - v).abs() < 1e-6
                })
            })
        })
        .collect()
}

fn penumbra(v: f32) -> bool {
    v > 0.05 && v < 0.95
}

/// World area of the ground seen by pixel i (from the position AOV's screen derivatives).
fn pixel_area(img: &FrameImages, i: usize) -> f32 {
    let w = img.width as usize;
    let (x, y) = (i % w, i / w);
    let nx = if x + 1 < w { i + 1 } else { i - 1 };
    let ny = if y + 1 < img.height as usize {
        i + w
    } else {
        i - w
    };
    let p = pos(img, i);
    (pos(img, nx) - p).cross(pos(img, ny) - p).length()
}

#[test]
fn lit_and_umbra_agree_with_hard() {
    let gpu = Gpu::new();
    let hard = gpu.render("cylinder", "hard", settings(PcfKernel::Box(3)));
    // Lit by hard and over 1.5 world units from its shadow: the outer penumbra of the
    // scene's light (R ~ 0.6) reaches about 0.8 beyond the hard edge at the shadow's tip.
    let shadow: Vec<Vec3> = covered(&hard)
        .into_iter()
        .filter(|&i| hard.visibility[i] < 1.0)
        .map(|i| pos(&hard, i))
        .collect();
    let lit: Vec<usize> = interior(&hard, 1.0, 2)
        .into_iter()
        .filter(|&i| {
            let p = pos(&hard, i);
            shadow.iter().all(|q| (*q - p).length_squared() > 1.5 * 1.5)
        })
        .collect();
    // Ground umbra next to the cylinder's base: its contact shadow, where every technique is 0.
    let umbra: Vec<usize> = interior(&hard, 0.0, 3)
        .into_iter()
        .filter(|&i| {
            let p = pos(&hard, i);
            let r = (p.x * p.x + p.z * p.z).sqrt();
            p.y.abs() < 0.01 && r > 0.55 && r < 1.5
        })
        .collect();
    assert!(lit.len() > 1000, "only {} deep-lit pixels", lit.len());
    assert!(
        umbra.len() > 20,
        "only {} umbra pixels at the base",
        umbra.len()
    );
    for (technique, kernel) in [
        ("pcf", PcfKernel::Box(5)),
        ("pcf", PcfKernel::Poisson(16)),
        ("pcss", PcfKernel::Box(3)),
        ("pcss", PcfKernel::Poisson(32)),
    ] {
        let img = gpu.render("cylinder", technique, settings(kernel));
        let out: Vec<f32> = img
            .visibility
            .iter()
            .copied()
            .filter(|v| !(v.is_finite() && (0.0..=1.0).contains(v)))
            .collect();
        assert!(
            out.is_empty(),
            "{technique} {kernel:?}: {} values out of [0,1]: {:?}",
            out.len(),
            &out[..out.len().min(8)]
        );
        let bad_lit = lit.iter().filter(|&&i| img.visibility[i] < 0.99).count();
        let bad_umbra: Vec<f32> = umbra
            .iter()
            .map(|&i| img.visibility[i])
            .filter(|&v| v > 0.01)
            .collect();
        assert!(
            bad_lit == 0,
            "{technique} {kernel:?}: {bad_lit} of {} deep-lit pixels below 0.99",
            lit.len()
        );
        assert!(
            bad_umbra.is_empty(),
            "{technique} {kernel:?}: {} of {} base-umbra pixels above 0.01: {:?}",
            bad_umbra.len(),
            umbra.len(),
            &bad_umbra[..bad_umbra.len().min(8)]
        );
    }
}

#[test]
fn pcf_box5_widens_the_transition_and_box1_is_hard() {
    let gpu = Gpu::new();
    let hard = gpu.render("cylinder", "hard", settings(PcfKernel::Box(3)));
    let box1 = gpu.render("cylinder", "pcf", settings(PcfKernel::Box(1)));
    let box5 = gpu.render("cylinder", "pcf", settings(PcfKernel::Box(5)));
    let max_diff = covered(&hard)
        .into_iter()
        .map(|i| (hard.visibility[i] - box1.visibility[i]).abs())
        .fold(0.0f32, f32::max);
    assert!(
        max_diff < 1e-5,
        "pcf box1 differs from hard by up to {max_diff}"
    );
    let count = |img: &FrameImages| {
        covered(img)
            .into_iter()
            .filter(|&i| penumbra(img.visibility[i]))
            .count()
    };
    let (n1, n5) = (count(&box1), count(&box5));
    assert!(n1 > 0, "box1 has no transition pixels");
    assert!(
        n5 as f32 > 1.8 * n1 as f32,
        "box5 transition {n5} px is not wider than box1's {n1} px"
    );
}

/// Mean total penumbra width (world units, both sides) of the cylinder's ground shadow over
/// a band of distances [s0, s1] from the base along the shadow: penumbra area / band length.
fn penumbra_width(img: &FrameImages, light: Vec3, s0: f32, s1: f32) -> f32 {
    let axis = Vec3::new(-light.x, 0.0, -light.z).normalize();
    let area: f32 = covered(img)
        .into_iter()
        .filter(|&i| {
            let p = pos(img, i);
            let s = p.dot(axis);
            let lateral = (p - axis * s).length();
            p.y.abs() < 0.01 && s >= s0 && s < s1 && lateral < 1.5 && penumbra(img.visibility[i])
        })
        .map(|i| pixel_area(img, i))
        .sum();
    area / (s1 - s0)
}

#[test]
fn pcss_contact_hardening() {
    let gpu = Gpu::new();
    let scene = Scene::load("cylinder").unwrap();
    let light = scene.light.position;
    let (img, _) = gpu.render_frames(scene, "pcss", settings(PcfKernel::Box(3)), 1);
    // The shadow runs from the base (s = 0.5) to about s = 4 (light at height 5, top at 2).
    let near = penumbra_width(&img, light, 0.7, 1.5);
    let far = penumbra_width(&img, light, 2.8, 3.6);
    eprintln!("pcss penumbra width: near the base {near:.3}, far {far:.3}");
    assert!(far > 0.05, "no penumbra far from the base ({far})");
    assert!(
        near < 0.5 * far,
        "penumbra near the base {near} is not narrower than far {far}"
    );
    // pcf's kernel is fixed in texels: no such hardening (the check above can fail).
    let (pcf, _) = gpu.render_frames(
        Scene::load("cylinder").unwrap(),
        "pcf",
        settings(PcfKernel::Box(5)),
        1,
    );
    let (pn, pf) = (
        penumbra_width(&pcf, light, 0.7, 1.5),
        penumbra_width(&pcf, light, 2.8, 3.6),
    );
    eprintln!("pcf box5 penumbra width: near {pn:.3}, far {pf:.3}");
    assert!(
        pn > 0.5 * pf,
        "pcf box5 should not harden at the contact: {pn} vs {pf}"
    );
}

#[test]
fn pcss_with_point_light_is_hard() {
    let gpu = Gpu::new();
    let s = Settings {
        light_radius: Some(0.0),
        ..settings(PcfKernel::Poisson(32))
    };
    let hard = gpu.render("cylinder", "hard", s.clone());
    let pcss = gpu.render("cylinder", "pcss", s);
    let all = covered(&hard);
    let mut edge = 0;
    for &i in &all {
        let d = (hard.visibility[i] - pcss.visibility[i]).abs();
        let (h, p) = (hard.visibility[i], pcss.visibility[i]);
        if h > 0.0 && h < 1.0 {
            edge += usize::from(d > 1e-4);
        } else {
            assert!(d < 1e-4, "pixel {i}: hard {h}, pcss {p} away from any edge");
        }
    }
    assert!(
        edge * 1000 <= all.len(),
        "{edge} edge pixels of {} differ",
        all.len()
    );
}

#[test]
fn bad_kernel_names_the_parameter() {
    let gpu = Gpu::new();
    for (kernel, range) in [
        (PcfKernel::Box(0), "1..=15"),
        (PcfKernel::Box(4), "1..=15"),
        (PcfKernel::Poisson(0), "1..=64"),
        (PcfKernel::Poisson(65), "1..=64"),
    ] {
        for technique in ["pcf", "pcss"] {
            let scene = Scene::load("cylinder").unwrap();
            let err = match Renderer::new(&gpu.ctx, scene, technique, settings(kernel)) {
                Ok(_) => panic!("{technique} accepted {kernel:?}"),
                Err(e) => format!("{e:#}"),
            };
            assert!(
                err.contains("--pcf-kernel") && err.contains(range),
                "{technique} {kernel:?}: error does not name the parameter and its range: {err}"
            );
        }
    }
}

#[test]
fn cli_refuses_a_zero_kernel() {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_softshadow"))
        .args([
            "render",
            "--technique",
            "pcf",
            "--pcf-kernel",
            "box0",
            "--out",
            "/tmp/never.png",
        ])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "box0 was accepted");
    assert!(
        err.contains("--pcf-kernel") && err.contains("box0") && err.contains("1..=15"),
        "the error does not name the parameter and its range: {err}"
    );
}
