//! The spotlight's shadow map fitted to what the camera sees (`frustum::fit_light`): a unit
//! box 5,000 units from a 40 degree spotlight throws its umbra under every technique, with
//! no warning, and a caster under two texels of the map is named in one warning line while
//! the render goes on.

mod common;
use common::{covered, small, softshadow, Gpu};
use glam::{Mat4, Vec3, Vec4};
use softshadow::eval::stress;
use softshadow::frustum::{caster_texel_warning, fit_light};
use softshadow::scene::{Aabb, Scene};

/// The `far-spot` stress case: its light, the box and the ground the camera sees.
fn far_spot() -> Scene {
    stress::case_scene("far-spot").unwrap()
}

/// Where the segment from `p` to `l` meets box `b` (slab test).
fn segment_hits(p: Vec3, l: Vec3, b: &Aabb) -> bool {
    let d = l - p;
    let (mut t0, mut t1) = (0.0f32, 1.0f32);
    for k in 0..3 {
        if d[k].abs() < 1e-12 {
            if p[k] < b.min[k] || p[k] > b.max[k] {
                return false;
            }
            continue;
        }
        let (a, c) = ((b.min[k] - p[k]) / d[k], (b.max[k] - p[k]) / d[k]);
        t0 = t0.max(a.min(c));
        t1 = t1.min(a.max(c));
    }
    t0 <= t1
}

/// Without the fit the box covers a third of a texel and no technique shows it (the issue's
/// bug): mutation that fails this test — `fit_light` returning the whole cone
/// (`tan_half * SPOT_FIT_MIN_GAIN <= tan_cone` replaced by `false`).
#[test]
fn a_box_far_from_a_spotlight_throws_its_umbra_under_every_technique() {
    let scene = far_spot();
    let light = fit_light(&scene);
    assert_eq!(caster_texel_warning(&scene, &light, 1024), None);
    let boxed = scene.objects.iter().find(|o| o.name == "box").unwrap();
    let b = boxed.world_bounds();
    // Beyond the penumbra: the segment towards the light's centre meets the box shrunk by
    // 0.1 (umbra) or misses it grown by 0.1 (lit); the penumbra is R x 1.5 / 5000 = 0.03
    // wide at most here.
    let shrunk = Aabb::new(b.min + Vec3::splat(0.1), b.max - Vec3::splat(0.1));
    let grown = Aabb::new(b.min - Vec3::splat(0.1), b.max + Vec3::splat(0.1));
    let l = scene.light.position;
    let gpu = Gpu::new();
    for technique in stress::technique_names() {
        let (img, _) = gpu.render_frames(scene.clone(), technique, small(160, 1024), 1);
        let (mut umbra, mut lit) = (Vec::new(), Vec::new());
        for i in covered(&img) {
            let p = Vec4::from(img.position[i]).truncate();
            // The ground only, inside the cone.
            if p.y.abs() > 1e-3 || img.spot[i] <= 0.5 {
                continue;
            }
            if segment_hits(p, l, &shrunk) {
                umbra.push(img.visibility[i]);
            } else if !segment_hits(p, l, &grown) {
                lit.push(img.visibility[i]);
            }
        }
        assert!(
            umbra.len() > 100 && lit.len() > 1000,
            "{technique}: {} umbra, {} lit pixels",
            umbra.len(),
            lit.len()
        );
        let mean = |v: &[f32]| v.iter().sum::<f32>() / v.len() as f32;
        let dark = umbra.iter().filter(|&&v| v < 0.1).count() as f32 / umbra.len() as f32;
        assert!(
            dark > 0.95 && mean(&umbra) < 0.05,
            "{technique}: umbra mean {} ({} of it < 0.1)",
            mean(&umbra),
            dark
        );
        assert!(mean(&lit) > 0.97, "{technique}: lit mean {}", mean(&lit));
    }
}

/// The fitted map keeps the spot's falloff on the cone: ground pixels the camera sees well
/// inside the cone get spot 1 under a fitted map, also those near the fitted map's edge (a
/// falloff read from the fitted frustum would darken them). Mutation that fails this test —
/// final.glsl's `frame.spot_from_light_clip * v_light_clip` back to `v_light_clip`.
#[test]
fn the_spot_falloff_follows_the_cone_not_the_fitted_map() {
    let gpu = Gpu::new();
    {
        let name = "wide-cone-small-caster";
        let scene = stress::case_scene(name).unwrap();
        let light = fit_light(&scene);
        let tan_fit = (light.fov_deg.to_radians() * 0.5).tan();
        let tan_cone = (scene.light.fov_deg.to_radians() * 0.5).tan();
        assert!(
            tan_fit * 5.0 < tan_cone,
            "{name}: fit {tan_fit} of cone {tan_cone}"
        );
        // As wide as the fit's view (SUN_FIT_ASPECT): the image reaches the map's edges.
        let settings = softshadow::settings::Settings {
            height: 96,
            ..small(192, 256)
        };
        let (img, _) = gpu.render_frames(scene.clone(), "hard", settings, 1);
        // The pixels inside 0.8 of the cone's half-width (the falloff starts at 0.85),
        // measured in the cone's own frame on the CPU.
        let cone = softshadow::scene::LightView::new(&scene.light, 1.0, 2.0);
        let ground: Vec<usize> = covered(&img)
            .into_iter()
            .filter(|&i| {
                let (uv, d) = cone.project(Vec4::from(img.position[i]).truncate());
                d > 0.0 && (uv * 2.0 - glam::Vec2::ONE).abs().max_element() < 0.8
            })
            .collect();
        assert!(ground.len() > 1000, "{name}: {}", ground.len());
        // How far out in the fitted map what is seen reaches (|ndc|, 1 at its edge).
        let edge = ground
            .iter()
            .map(|&i| {
                let (uv, _) = light.project(Vec4::from(img.position[i]).truncate());
                (uv * 2.0 - glam::Vec2::ONE).abs().max_element()
            })
            .fold(0.0f32, f32::max);
        assert!(
            edge > 0.9,
            "{name}: what is seen reaches only {edge} of the map"
        );
        // Inside the falloff's start: spot 1 there.
        let least = ground.iter().map(|&i| img.spot[i]).fold(1.0f32, f32::min);
        assert!(least == 1.0, "{name}: spot down to {least}");
    }
}

/// The same far light over a box of a thousandth of a unit: under a texel even with the
/// fit. Mutation that fails this test — `caster_texel_warning`'s `texels < MIN_CASTER_TEXELS`
/// replaced by `texels < 0.0`.
#[test]
fn a_sub_texel_caster_is_named_in_one_warning() {
    let mut scene = far_spot();
    let light = fit_light(&scene);
    assert_eq!(caster_texel_warning(&scene, &light, 1024), None);
    let o = scene.objects.iter_mut().find(|o| o.name == "box").unwrap();
    let c = o.world_bounds().center();
    o.transform = Mat4::from_translation(c)
        * Mat4::from_scale(Vec3::splat(1e-3))
        * Mat4::from_translation(-c)
        * o.transform;
    let light = fit_light(&scene);
    let w = caster_texel_warning(&scene, &light, 1024).expect("no warning for a speck");
    assert!(w.starts_with("warning: caster 'box' ("), "{w}");
    assert!(w.contains("1024x1024") && w.contains("--shadow-res"), "{w}");
}

/// Through the CLI: the speck's render prints the warning once and still writes its image
/// (exit 0); the unit box's prints none. Mutation that fails this test — main.rs's
/// `eprintln!("{w}")` of `caster_texel_warning` removed.
#[test]
fn the_cli_warns_about_a_sub_texel_caster_and_keeps_rendering() {
    let dir = std::env::temp_dir().join(format!("softshadow-spotfit-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for (size, warned) in [(1.0f32, false), (0.001, true)] {
        let toml = format!(
            "name = \"far\"\n\
             [[object]]\nname = \"ground\"\nprimitive = \"plane\"\nsize = [12, 12]\nrole = \"receiver\"\n\
             [[object]]\nname = \"speck\"\nprimitive = \"box\"\nsize = [{size}, {size}, {size}]\ntranslate = [0, {size}, 0]\nrole = \"both\"\n\
             [light]\nposition = [-1500, 4700, 1000]\ntarget = [0, 0, 0]\nfov_deg = 40\nradius = 100\n\
             [camera]\nposition = [2, 4, 5]\ntarget = [0, 0, 0]\nfov_deg = 45\n"
        );
        let scene = dir.join(format!("far-{size}.toml"));
        std::fs::write(&scene, toml).unwrap();
        let out = dir.join(format!("far-{size}.png"));
        let run = softshadow(&[
            "render",
            "--scene",
            scene.to_str().unwrap(),
            "--technique",
            "hard",
            "--width",
            "64",
            "--height",
            "64",
            "--out",
            out.to_str().unwrap(),
        ]);
        let stderr = String::from_utf8_lossy(&run.stderr);
        assert!(run.status.success(), "{size}: {stderr}");
        assert!(out.exists(), "{size}: no image");
        let lines: Vec<&str> = stderr
            .lines()
            .filter(|l| l.contains("spans fewer than"))
            .collect();
        match warned {
            true => assert!(
                lines.len() == 1 && lines[0].contains("'speck'"),
                "{size}: {stderr}"
            ),
            false => assert!(lines.is_empty(), "{size}: {stderr}"),
        }
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// Every pixel the camera sees lit inside the cone lies inside the fitted map, on the fit
/// cases and on every built-in scene (the fitted ones are printed). Mutation that fails this
/// test — `spot_window` dropping the camera's frustum planes' receivers for the casters'
/// bounds alone (`.filter(|o| o.role.receives())` replaced by `.filter(|o| o.role.casts())`).
#[test]
fn every_lit_pixel_the_camera_sees_lies_inside_the_fitted_map() {
    let gpu = Gpu::new();
    let mut scenes: Vec<Scene> = ["far-spot", "tiny-caster", "wide-cone-small-caster"]
        .iter()
        .map(|n| stress::case_scene(n).unwrap())
        .collect();
    scenes.extend(
        softshadow::scene::builtin::BUILTIN_SCENES
            .iter()
            .map(|n| Scene::load(n).unwrap()),
    );
    for scene in scenes {
        let light = fit_light(&scene);
        let (fit, cone) = (light.fov_deg, scene.light.fov_deg);
        if fit != cone {
            println!("{}: fitted, fov {fit:.4} of the cone's {cone}", scene.name);
        }
        let (img, _) = gpu.render_frames(scene.clone(), "hard", small(96, 256), 1);
        let mut checked = 0;
        for i in covered(&img) {
            if img.spot[i] <= 0.0 {
                continue;
            }
            let p = Vec4::from(img.position[i]).truncate();
            let (uv, d) = light.project(p);
            assert!(
                d > 0.0
                    && uv.cmpge(glam::Vec2::splat(-1e-3)).all()
                    && uv.cmple(glam::Vec2::splat(1.001)).all(),
                "{}: lit pixel at {p} outside the map (uv {uv})",
                scene.name
            );
            checked += 1;
        }
        assert!(checked > 500, "{}: {checked}", scene.name);
    }
}
