//! Soft shadow maps with exact occlusion (issue 22 item 3), `ssm-bitmask`, against the
//! paper's additive forms, `hard`, `pcss` and the ray-cast reference, on lavapipe with
//! validation:
//! - mae_lit below ssm's (and hard's) on `cylinder`, `bunny`, `primitives` and `fence`, by
//!   measured margins;
//! - fewer light leaks where the reference is in full umbra (the fence's slats);
//! - at `--occluder-res 512`, mae_lit below the default's and within measured bounds on
//!   every one of those scenes;
//! - penumbrae no darker than the reference than measured (a union, not a sum);
//! - the edge offsets the final pass interpolates invert the disc segment, and keep mae_lit
//!   and false edges below the interpolated shares' by measured bounds;
//! - R = 0 is `hard` exactly.

mod common;

use common::{covered, Gpu};
use softshadow::eval::metrics::{errors_at, faces_light, Errors};
use softshadow::output::FrameImages;
use softshadow::reference::{visibility_cached, ReferenceParams};
use softshadow::scene::Scene;
use softshadow::settings::Settings;

const SCENES: &[&str] = &["cylinder", "bunny", "primitives", "fence"];
const TECHNIQUES: &[&str] = &["hard", "pcss", "ssm", "ssm-bitmask"];

/// How far below ssm's mae_lit the bitmask form is at least, per scene of `SCENES`.
/// Measured (paper - bitmask): 0.034, 0.047, 0.039, 0.150.
const MARGINS: &[(&str, [f64; 4])] = &[("ssm-bitmask", [0.025, 0.035, 0.03, 0.1])];

fn reference(scene: &Scene, img: &FrameImages) -> Vec<f32> {
    visibility_cached(
        scene,
        scene.light.radius,
        &img.position,
        &img.normal,
        &ReferenceParams::default(),
    )
    .unwrap_or_else(|e| panic!("reference of {}: {e:#}", scene.name))
}

/// tests/acceptance.rs's measurement: 160x160, every other setting at its default.
fn render(gpu: &Gpu, scene: &Scene, technique: &str) -> FrameImages {
    let settings = Settings {
        width: 160,
        height: 160,
        ..Settings::default()
    };
    gpu.render_frames(scene.clone(), technique, settings, 1).0
}

fn errors(scene: &Scene, img: &FrameImages, v_ref: &[f32]) -> Errors {
    errors_at(
        &img.visibility,
        v_ref,
        &img.position,
        &img.normal,
        &img.spot,
        scene.light.position,
    )
}

/// Surface pixels facing the light (mae_lit's region).
fn lit_pixels(scene: &Scene, img: &FrameImages) -> Vec<usize> {
    let faces = faces_light(&img.position, &img.normal, scene.light.position);
    covered(img).into_iter().filter(|&i| faces[i]).collect()
}

#[test]
fn mae_lit_below_the_additive_forms() {
    let gpu = Gpu::new();
    let mut table = format!("| scene | {} |\n", TECHNIQUES.join(" | "));
    let mut bad = Vec::new();
    for (s, name) in SCENES.iter().enumerate() {
        let scene = Scene::load(name).unwrap_or_else(|e| panic!("{e:#}"));
        let mut mae = Vec::new();
        let mut v_ref = None;
        for t in TECHNIQUES {
            let img = render(&gpu, &scene, t);
            let r = v_ref.get_or_insert_with(|| reference(&scene, &img));
            let e = errors(&scene, &img, r);
            assert!(e.lit_pixels > 200, "{name}/{t}: {e:?}");
            mae.push(e.mae_lit);
        }
        let of = |t: &str| mae[TECHNIQUES.iter().position(|x| *x == t).unwrap()];
        table.push_str(&format!(
            "| {name} | {} |\n",
            mae.iter()
                .map(|m| format!("{m:.4}"))
                .collect::<Vec<_>>()
                .join(" | ")
        ));
        for &(t, margins) in MARGINS {
            let paper = t.strip_suffix("-bitmask").unwrap();
            if of(t) > of(paper) - margins[s] {
                bad.push(format!(
                    "{name}/{t}: mae_lit {:.4} not {} below {paper}'s {:.4}",
                    of(t),
                    margins[s],
                    of(paper)
                ));
            }
            // On `cylinder` the exact occlusion beats pcss (measured 0.0087 and 0.0073
            // against 0.0139); elsewhere the occluder map's 256^2 texels limit it
            // (docs/TECHNIQUES.md).
            if *name == "cylinder" && of(t) > of("pcss") {
                bad.push(format!(
                    "{name}/{t}: mae_lit {:.4} above pcss's {:.4}",
                    of(t),
                    of("pcss")
                ));
            }
            if of(t) >= of("hard") {
                bad.push(format!(
                    "{name}/{t}: mae_lit {:.4} not below hard's {:.4}",
                    of(t),
                    of("hard")
                ));
            }
        }
    }
    println!("mae_lit\n{table}");
    assert!(bad.is_empty(), "{}\n{table}", bad.join("\n"));
}

/// Light-facing pixels where the reference is in full umbra and `img` lets more than 0.1
/// through, and how many such umbra pixels there are.
fn leaks(scene: &Scene, img: &FrameImages, v_ref: &[f32]) -> (usize, usize) {
    let umbra: Vec<usize> = lit_pixels(scene, img)
        .into_iter()
        .filter(|&i| v_ref[i] <= 0.001)
        .collect();
    let leaking = umbra.iter().filter(|&&i| img.visibility[i] > 0.1).count();
    (leaking, umbra.len())
}

/// The fence's rails are two occluder texels tall at the default 256^2: most pixels that
/// leak light are on the umbra's edge, where the map's texels and the reference disagree
/// (measured at 256^2: ssm 176 of 398 umbra pixels, ssm-bitmask 85; at 512^2: ssm 72,
/// ssm-bitmask 22). ssm's offset lookup and the gaps between its micro-patches add the
/// rest; the bitmask form leaks at most 55 % as often.
#[test]
fn light_leaks_under_fence_slats_are_halved() {
    let gpu = Gpu::new();
    let scene = Scene::load("fence").unwrap();
    for occluder_res in [256, 512] {
        let settings = Settings {
            width: 160,
            height: 160,
            occluder_res,
            ..Settings::default()
        };
        let render = |t: &str| gpu.render_frames(scene.clone(), t, settings.clone(), 1).0;
        let ssm = render("ssm");
        let v_ref = reference(&scene, &ssm);
        let (ssm_leaks, umbra) = leaks(&scene, &ssm, &v_ref);
        assert!(umbra > 100, "fence: {umbra} umbra pixels");
        {
            let t = "ssm-bitmask";
            let (n, _) = leaks(&scene, &render(t), &v_ref);
            println!("fence at {occluder_res}^2: {n} of {umbra} umbra pixels lit above 0.1 by {t} (ssm: {ssm_leaks})");
            assert!(
                n * 100 <= ssm_leaks * 55,
                "{t} at {occluder_res}^2: {n} leaks, ssm {ssm_leaks}"
            );
            if occluder_res == 512 {
                assert!(
                    n * 100 <= umbra * 8,
                    "{t} at 512^2: {n} of {umbra} umbra pixels leak"
                );
            }
        }
    }
}

/// How much darker than the reference `img` is on average over the reference's penumbra on
/// light-facing pixels: mean of max(v_ref - v, 0).
fn darkening(scene: &Scene, img: &FrameImages, v_ref: &[f32]) -> f64 {
    let penumbra: Vec<usize> = lit_pixels(scene, img)
        .into_iter()
        .filter(|&i| v_ref[i] > 0.02 && v_ref[i] < 0.98)
        .collect();
    penumbra
        .iter()
        .map(|&i| f64::from((v_ref[i] - img.visibility[i]).max(0.0)))
        .sum::<f64>()
        / penumbra.len().max(1) as f64
}

/// Mean darkening over the penumbra at most, per scene (measured x 1.2). Measured
/// (ssm-bitmask; ssm): cylinder 0.0090; 0.0102; overlap 0.0310; 0.0258; bunny 0.0278;
/// 0.0146. The union never counts the light twice, yet the bitmask form is a little darker
/// than the additive one here: ssm's normal offset shifts its penumbrae outward (too bright
/// overall, mae_lit 2-3x higher), and the micro-quads reach down to the receiver at
/// contacts.
const DARKENING: &[(&str, f64)] = &[("cylinder", 0.011), ("overlap", 0.037), ("bunny", 0.033)];

#[test]
fn penumbrae_are_not_much_darker_than_the_reference() {
    let gpu = Gpu::new();
    for &(name, bound) in DARKENING {
        let scene = Scene::load(name).unwrap();
        let ssm = render(&gpu, &scene, "ssm");
        let v_ref = reference(&scene, &ssm);
        {
            let (t, paper) = ("ssm-bitmask", "ssm");
            let d_paper = darkening(&scene, &render(&gpu, &scene, paper), &v_ref);
            let d = darkening(&scene, &render(&gpu, &scene, t), &v_ref);
            println!(
                "{name}: mean darkening over the penumbra {d:.4} with {t} ({paper}: {d_paper:.4})"
            );
            assert!(
                d <= bound,
                "{name}/{t}: darkening {d:.4} above {bound} ({paper} {d_paper:.4})"
            );
        }
    }
}

/// R = 0 is `hard` exactly (issue 22: "R = 0 still gives exactly hard for every accurate
/// form"): a point light leaves the masks no penumbra to sample, and the form renders
/// `hard`'s passes under its own name. Every covered pixel, not only those mae_lit judges.
#[test]
fn zero_radius_equals_hard() {
    let gpu = Gpu::new();
    {
        let t = "ssm-bitmask";
        for name in ["cylinder", "boxes", "fence"] {
            let set = Settings {
                light_radius: Some(0.0),
                occluder_res: 256,
                ..common::small(128, 256)
            };
            let hard = gpu.render(name, "hard", set.clone());
            let scene = Scene::load(name).unwrap();
            let (soft, timings) = gpu.render_frames(scene, t, set, 1);
            let px = covered(&hard);
            let shadowed = px.iter().filter(|&&i| hard.visibility[i] < 0.5).count();
            let max = px
                .iter()
                .map(|&i| (hard.visibility[i] - soft.visibility[i]).abs())
                .fold(0.0f32, f32::max);
            println!(
                "{t} {name}: {} covered pixels, {shadowed} in shadow, max |v - hard| {max}",
                px.len()
            );
            assert!(shadowed > 200, "{t} {name}: {shadowed} shadowed pixels");
            assert!(max <= 1e-6, "{t} {name}: max |v - hard| = {max} at R = 0");
            // The timings name this technique's passes, not hard's.
            let prefix = format!("{t}/");
            for p in &timings[0].passes {
                assert!(p.name.starts_with(&prefix), "{t} {name}: pass {}", p.name);
            }
        }
    }
}

/// At 512^2 occluder texels (`--occluder-res 512`) the bitmask form's error shrinks from
/// its default's, to bounds measured per scene of `SCENES`. Measured mae_lit at 512^2 (at
/// the default 256^2): cylinder 0.0055 (0.0086), bunny 0.0274 (0.0363), primitives 0.0215
/// (0.0452), fence 0.0321 (0.0777). pcss, through the shared lookup's receiver offset
/// (common/shadow.glsl), which this form does not use (it reads its masks at the point
/// itself), is below it on bunny, primitives and fence (0.0264, 0.0142, 0.0182): the bound
/// is this form's own measured error, not pcss's.
const AT_512: [f64; 4] = [0.007, 0.030, 0.024, 0.036];

#[test]
fn at_512_occluder_texels_mae_lit_shrinks_to_its_measured_bounds() {
    let gpu = Gpu::new();
    let mut bad = Vec::new();
    for (name, bound) in SCENES.iter().zip(AT_512) {
        let scene = Scene::load(name).unwrap();
        let t = "ssm-bitmask";
        let default = render(&gpu, &scene, t);
        let v_ref = reference(&scene, &default);
        let at_default = errors(&scene, &default, &v_ref).mae_lit;
        let settings = Settings {
            width: 160,
            height: 160,
            occluder_res: 512,
            ..Settings::default()
        };
        let img = gpu.render_frames(scene.clone(), t, settings, 1).0;
        let got = errors(&scene, &img, &v_ref).mae_lit;
        println!("{name}: {t} at 512^2 mae_lit {got:.4}, at the default {at_default:.4}");
        if got > bound || got > at_default - 0.002 {
            bad.push(format!(
                "{name}/{t}: {got:.4} at 512^2, above {bound} or not 0.002 below the default's {at_default:.4}"
            ));
        }
    }
    assert!(bad.is_empty(), "{}", bad.join("\n"));
}

/// The light samples fill the disc evenly, and the edge table is what its header says:
/// every sample left of a line far right of the disc, none far left, monotone between,
/// about half through the centre, in every direction.
#[test]
fn samples_and_edge_table() {
    use softshadow::technique::ssm_bitmask::{edge_table, light_samples, SAMPLES};
    let s = light_samples();
    assert_eq!(s.len(), SAMPLES);
    assert!(s.iter().all(|p| p.length() < 1.0));
    for q in 0..4 {
        let n = s
            .iter()
            .filter(|p| (p.x >= 0.0) == (q & 1 == 0) && (p.y >= 0.0) == (q & 2 == 0))
            .count();
        assert!((26..=38).contains(&n), "quadrant {q}: {n} samples");
    }
    let table = edge_table();
    let columns = 256;
    assert_eq!(table.len(), 512 * columns);
    let count = |m: &[u32; 4]| m.iter().map(|w| w.count_ones()).sum::<u32>();
    for row in [0, 100, 255, 511] {
        let line = &table[row * columns..(row + 1) * columns];
        assert_eq!(count(&line[0]), SAMPLES as u32, "row {row}");
        assert_eq!(count(&line[columns - 1]), 0, "row {row}");
        assert!(line.windows(2).all(|w| count(&w[1]) <= count(&w[0])));
        let mid = count(&line[columns / 2]);
        assert!(
            (50..=78).contains(&mid),
            "row {row}: {mid} left of the centre"
        );
    }
}

/// The edge offsets invert the disc segment's share (ssm_bitmask_table.rs, "Edge offsets"):
/// the edge clears the disc at no hidden sample and covers it at all of them, crosses its
/// centre at half, falls with the count, and its segment hides c / 128 of the disc.
#[test]
fn edge_offsets_invert_the_disc_segment() {
    use softshadow::technique::ssm_bitmask::{edge_offsets, SAMPLES};
    let d = edge_offsets();
    assert_eq!(d.len(), SAMPLES + 1);
    assert_eq!((d[0], d[SAMPLES]), (1.0, -1.0));
    assert!(d[SAMPLES / 2].abs() < 1e-6, "{}", d[SAMPLES / 2]);
    assert!(d.windows(2).all(|w| w[1] < w[0]));
    for (c, &x) in d.iter().enumerate() {
        let x = f64::from(x);
        let share = (x.acos() - x * (1.0 - x * x).sqrt()) / std::f64::consts::PI;
        let want = c as f64 / SAMPLES as f64;
        assert!(
            (share - want).abs() < 1e-6,
            "count {c}: {share} against {want}"
        );
    }
}

/// What interpolating the edge offsets instead of the hidden shares buys (final.glsl): at
/// 160x160, mae_lit and false edges (per 1,000 penumbra pixels) of `ssm-bitmask`, each bound
/// between the two measured forms. Measured with shares / with offsets: `primitives`
/// 0.0455 / 0.0412 and 350 / 286; `fence` 0.0778 / 0.0713 and 253 / 195; `bunny` 0.0365 /
/// 0.0339 and 94.4 / 88.0.
const OFFSET_BOUNDS: &[(&str, f64, f64)] = &[
    ("primitives", 0.0430, 315.0),
    ("fence", 0.0745, 225.0),
    ("bunny", 0.0352, 91.5),
];

#[test]
fn edge_offsets_keep_penumbrae_to_their_width() {
    let gpu = Gpu::new();
    let mut bad = Vec::new();
    for &(name, mae_bound, edges_bound) in OFFSET_BOUNDS {
        let scene = Scene::load(name).unwrap();
        let img = render(&gpu, &scene, "ssm-bitmask");
        let v_ref = reference(&scene, &img);
        let mae = errors(&scene, &img, &v_ref).mae_lit;
        let fe = common::false_edges_of(&img, &v_ref, &scene, 160);
        let edges = fe.per_1000;
        println!("{name}: mae_lit {mae:.4}, false edges {edges:.1} per 1,000 penumbra pixels");
        if mae > mae_bound || edges > edges_bound {
            bad.push(format!(
                "{name}: mae_lit {mae:.4} (bound {mae_bound}), false edges {edges:.1} (bound {edges_bound})"
            ));
        }
    }
    assert!(bad.is_empty(), "{}", bad.join("\n"));
}

/// A unit box on a ground plane under a light of radius 1 about 9 units away, aimed past
/// the box's shadow edge with a cone of `fov_deg`; the camera looks along the light from
/// beside it with a slightly narrower cone, so every pixel lies inside the light's cone.
fn narrow_cone(fov_deg: f32) -> Scene {
    let text = format!(
        "{}[camera]\nposition = [-1, 9, -1]\ntarget = [0.6, 0, -0.55]\nup = [0, 1, 0]\nfov_deg = {}\n",
        narrow_cone_light(fov_deg),
        fov_deg * 0.8
    );
    softshadow::scene::file::parse_toml(&text, "narrow.toml", "narrow", std::path::Path::new("."))
        .unwrap_or_else(|e| panic!("{e:#}"))
}

/// `narrow_cone`'s objects and light, without its camera (a scene file's text).
fn narrow_cone_light(fov_deg: f32) -> String {
    format!(
        "[[object]]\nprimitive = \"box\"\n[[object]]\nprimitive = \"plane\"\nrole = \"receiver\"\n\
         [light]\nposition = [-3, 8, 2]\ntarget = [0.6, 0, -0.55]\nradius = 1\nfov_deg = {fov_deg}\n"
    )
}

/// The fragments one micro-patch per occupied occluder texel draws, worked out on the CPU
/// from the occluder and receiver maps read back: texel (i, j) at depth z_O draws its
/// square grown by h = reach (1/z_O - 1/z_max) texels on each side, clipped to the N x N
/// map (whole fragments inside it: a lower bound on what the rasteriser shades). Also the
/// number of occupied texels.
fn one_patch_per_texel_work(r: &mut softshadow::render::Renderer, reach: f64) -> (f64, usize) {
    let occ = r.read_technique_buffer("occluder_map").unwrap();
    let n = occ.width as usize;
    let mut zmax = 0.0f32;
    for name in ["receiver_map", "receiver_map_pure"] {
        let b = r.read_technique_buffer(name).unwrap();
        for &z in &b.channels[0] {
            if z < 0.5e30 {
                zmax = zmax.max(z);
            }
        }
    }
    let (mut work, mut texels) = (0.0f64, 0usize);
    for (k, &z) in occ.channels[0].iter().enumerate() {
        if !(z < 0.5e30 && z < zmax) {
            continue;
        }
        texels += 1;
        let h = reach * (1.0 / z as f64 - 1.0 / zmax as f64);
        let (i, j) = ((k % n) as f64, (k / n) as f64);
        let side = |a: f64| ((a + 1.0 + h).min(n as f64) - (a - h).max(0.0)).floor();
        work += side(i) * side(j);
    }
    (work, texels)
}

/// The micro-patch work of a narrow cone is bounded (counted, not timed). At 1 degree the
/// micro-patches' penumbrae span much of the map: one patch per texel, as before the bound,
/// shades (worked out here from the maps read back) 1.7e9 fragments for ssm over 65530
/// texels, 26 N^4 / 64. The pass now shades at most N^4 / 64 (the budget,
/// glsl/ssm/patch_step.comp) times the sparse blocks' slack (measured 0.46x for ssm, 0.58x
/// for ssm-bitmask; allowed 2x), at least 10x fewer, in blocks of more than one texel.
/// Built-in `cylinder` at an occluder map of 512 (the most micro-patch work of the
/// built-ins) stays one patch per texel, its estimate under a quarter of the budget.
#[test]
fn narrow_cone_micro_patch_work_is_bounded() {
    let gpu = Gpu::new();
    let settings = common::small(48, Settings::default().shadow_res);
    let n = settings.occluder_res as f64;
    for technique in ["ssm", "ssm-bitmask"] {
        let scene = narrow_cone(1.0);
        let light = softshadow::frustum::fit_light(&scene);
        let t = (light.fov_deg.to_radians() as f64 * 0.5).tan();
        let radius = scene.light.radius as f64;
        // The vertex shaders' growth per unit of (1/z_O - 1/z_max): ssm's square of side R
        // sqrt(pi), L N / (4 tan); the bitmask's disc, at least R N / (2 tan) (its extents
        // are R / cos(alpha) with a margin, never less than R).
        let reach = match technique {
            "ssm" => radius * std::f64::consts::PI.sqrt() * n / (4.0 * t),
            _ => radius * n / (2.0 * t),
        };
        let mut r = softshadow::render::Renderer::new(&gpu.ctx, scene, technique, settings.clone())
            .unwrap();
        let timings = r.render().unwrap();
        let frags = timings
            .passes
            .iter()
            .find(|p| p.name == format!("{technique}/soft_shadow"))
            .and_then(|p| p.stats)
            .expect("the micro-patch pass has statistics on lavapipe")
            .fragment_invocations as f64;
        let (old, texels) = one_patch_per_texel_work(&mut r, reach);
        let step = r.micro_patch_step().unwrap();
        eprintln!("{technique} at 1 degree: {frags} fragments, one patch per texel {old:.3e} over {texels} texels, {step:?}");
        assert!(texels as f64 > n * n / 4.0, "{technique}: {texels} texels");
        assert!(step.step > 1, "{technique}: {step:?}");
        assert!(frags <= 2.0 * n.powi(4) / 64.0, "{technique}: {frags}");
        assert!(frags * 10.0 <= old, "{technique}: {frags} against {old}");
    }
    for technique in ["ssm", "ssm-bitmask"] {
        let settings = Settings {
            width: 48,
            height: 48,
            occluder_res: 512,
            ..Settings::default()
        };
        let scene = Scene::load("cylinder").unwrap();
        let mut r =
            softshadow::render::Renderer::new(&gpu.ctx, scene, technique, settings).unwrap();
        r.render().unwrap();
        let step = r.micro_patch_step().unwrap();
        assert_eq!(step.step, 1, "{technique} on cylinder at 512: {step:?}");
        assert!(step.work < 0.25 * step.budget, "{technique}: {step:?}");
    }
    gpu.assert_clean();
}

/// 1, 2 and 10 degree cones render (micro-patches in blocks at 1 and 2), and the shadow is
/// where the reference has it: at 2 and 10 degrees mae_lit against the reference stays
/// below half hard's (measured, 2 degrees: ssm 0.029, ssm-bitmask 0.026, one patch per
/// texel 0.029 and 0.025, hard 0.125; 10 degrees, one patch per texel: 0.010, 0.004, hard
/// 0.138), and the reference's umbra is dark. At 1 degree the light's cone sees only part
/// of the box (what lies outside it is unknown to every shadow map; ssm with one patch per
/// texel measures the same 0.199): most of the umbra dark (measured 1346 and 1407 of 2146).
#[test]
fn narrow_cone_shadow_is_sane() {
    let gpu = Gpu::new();
    let settings = common::small(48, Settings::default().shadow_res);
    for fov in [1.0f32, 2.0, 10.0] {
        let scene = narrow_cone(fov);
        let hard = gpu
            .render_frames(scene.clone(), "hard", settings.clone(), 1)
            .0;
        let v_ref = reference(&scene, &hard);
        let eh = errors(&scene, &hard, &v_ref);
        for technique in ["ssm", "ssm-bitmask"] {
            let img = gpu
                .render_frames(scene.clone(), technique, settings.clone(), 1)
                .0;
            let e = errors(&scene, &img, &v_ref);
            let umbra: Vec<usize> = (0..v_ref.len())
                .filter(|&i| img.position[i][3] > 0.5 && v_ref[i] < 0.02)
                .collect();
            let dark = umbra.iter().filter(|&&i| img.visibility[i] < 0.25).count();
            eprintln!(
                "{technique} at {fov} deg: {e:?} (hard {:.3}), umbra {} of which dark {dark}",
                eh.mae_lit,
                umbra.len()
            );
            assert!(e.lit_pixels > 400, "{technique} {fov} deg: {e:?}");
            assert!(e.mae_lit < 0.25, "{technique} {fov} deg: {e:?}");
            assert!(
                umbra.len() > 100,
                "{technique} {fov} deg: umbra {}",
                umbra.len()
            );
            assert!(
                dark * 2 >= umbra.len(),
                "{technique} {fov} deg: {dark} of {} dark",
                umbra.len()
            );
            if fov == 2.0 {
                assert!(e.mae_lit < 0.04, "{technique} {fov} deg: {e:?}");
            }
            if fov > 1.0 {
                assert!(
                    e.mae_lit < 0.5 * eh.mae_lit,
                    "{technique} {fov} deg: {e:?} against hard {eh:?}"
                );
            }
        }
    }
    gpu.assert_clean();
}

/// `render` names the bound on one `warning:` line when it changed the result (1 degree:
/// blocks of 8 x 8 texels, as measured in `narrow_cone_micro_patch_work_is_bounded`) and
/// prints nothing on stderr when it did not (10 degrees: one patch per texel).
#[test]
fn the_bound_is_named_on_one_warning_line() {
    let dir = std::env::temp_dir().join(format!("softshadow-narrow-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for (fov, warned) in [(1.0f32, true), (10.0, false)] {
        let scene = dir.join(format!("cone{fov}.toml"));
        std::fs::write(&scene, narrow_cone_light(fov)).unwrap();
        let out = dir.join("o.png");
        let o = common::softshadow(&[
            "render",
            "--scene",
            scene.to_str().unwrap(),
            "--technique",
            "ssm-bitmask",
            "--width",
            "32",
            "--height",
            "32",
            "--out",
            out.to_str().unwrap(),
        ]);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(o.status.success(), "{fov} deg: {err}");
        let lines: Vec<&str> = err.lines().collect();
        if warned {
            assert_eq!(lines.len(), 1, "{fov} deg: {err}");
            assert!(
                lines[0].starts_with("warning: ssm-bitmask: ")
                    && lines[0].contains("bound of")
                    && lines[0].contains("occluder-res^4 / 64")
                    && lines[0].contains("blocks of 8 x 8"),
                "{fov} deg: {err}"
            );
        } else {
            assert!(lines.is_empty(), "{fov} deg: {err}");
        }
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// `ssm-bitmask/soft_shadow`'s vertex and fragment invocations on `scene` (default 256^2
/// occluder map), with the speed layer or without it (`--plain`).
fn micro_quad_work(gpu: &Gpu, scene: &str, plain: bool) -> (u64, u64) {
    let settings = Settings {
        width: 64,
        height: 64,
        plain,
        ..Settings::default()
    };
    let scene = Scene::load(scene).unwrap();
    let mut r =
        softshadow::render::Renderer::new(&gpu.ctx, scene, "ssm-bitmask", settings).unwrap();
    let timings = r.render().unwrap();
    let stats = timings
        .passes
        .iter()
        .find(|p| p.name == "ssm-bitmask/soft_shadow")
        .and_then(|p| p.stats)
        .expect("ssm-bitmask/soft_shadow has statistics on lavapipe");
    (stats.vertex_invocations, stats.fragment_invocations)
}

/// The speed layer's micro-quad list (speed::ssm::QuadList: each quad derived once and
/// listed only when it reaches a receiver) and receiver tiles (each quad drawn only as far
/// as the deepest receiver under its extent, not the frame's). Under `--plain` the pass
/// runs 5 vertices for each of the 256^2 texels (a point, a strip) and shades 438,560
/// fragments on `cylinder` and 241,424 on `bunny`; the listed quads run 3,960 and 4,045
/// vertices and shade 254,592 and 144,192 (1.72x and 1.67x fewer). The images are equal
/// (tests/plain.rs).
#[test]
fn listed_micro_quads_stop_at_the_deepest_receiver_under_them() {
    let gpu = Gpu::new();
    for (scene, max_frags) in [("cylinder", 345_000), ("bunny", 210_000)] {
        let (plain_vertices, plain_frags) = micro_quad_work(&gpu, scene, true);
        let (vertices, frags) = micro_quad_work(&gpu, scene, false);
        println!("{scene}: plain {plain_vertices} vertices, {plain_frags} fragments; listed {vertices}, {frags}");
        // Each instance: one point, then a strip of four vertices (one of them outside
        // clip space).
        assert_eq!(plain_vertices, 5 * 256 * 256, "{scene}: one quad per texel");
        assert!(
            vertices < 10_000,
            "{scene}: listed quads' vertices {vertices}"
        );
        assert!(
            frags < max_frags,
            "{scene}: listed quads' fragments {frags}"
        );
        assert!(
            plain_frags > frags * 3 / 2,
            "{scene}: plain fragments {plain_frags}, listed {frags}"
        );
    }
}

/// The micro-quads drawn as point sprites (glsl/ssm_bitmask/quad_vertex.glsl): one square
/// primitive where a triangle strip's two triangles each shade the pixel blocks along their
/// shared diagonal. Here against the same device with `largePoints` off, where every quad
/// is a strip: the same visibility bit for bit, and fewer fragments (lavapipe shades 4x4
/// blocks). As strips the pass shades 322,032 fragments on `cylinder`, 193,056 on `bunny`
/// and 103,120 on `fence`; as points 254,592, 144,192 and 70,336.
#[test]
fn micro_quads_drawn_as_points_shade_fewer_fragments_than_as_strips() {
    let mut gpu = Gpu::new();
    assert!(gpu.ctx.large_points, "lavapipe offers largePoints");
    for (scene_name, strips_before, bound) in [
        ("cylinder", 322_032, 280_000),
        ("bunny", 193_040, 165_000),
        ("fence", 103_120, 80_000),
    ] {
        let mut run = |large_points: bool| {
            gpu.ctx.large_points = large_points;
            let settings = Settings {
                width: 96,
                height: 96,
                ..Settings::default()
            };
            let scene = Scene::load(scene_name).unwrap();
            let mut r = softshadow::render::Renderer::new(&gpu.ctx, scene, "ssm-bitmask", settings)
                .unwrap();
            let timings = r.render().unwrap();
            let frags = timings
                .passes
                .iter()
                .find(|p| p.name == "ssm-bitmask/soft_shadow")
                .and_then(|p| p.stats)
                .expect("statistics on lavapipe")
                .fragment_invocations;
            (r.read_back().unwrap().visibility, frags)
        };
        let (strip_vis, strip_frags) = run(false);
        let (point_vis, point_frags) = run(true);
        println!("{scene_name}: {strip_frags} fragments as strips, {point_frags} as points");
        assert!(
            strip_frags > bound,
            "{scene_name}: {strip_frags} fragments as strips (before points: {strips_before})"
        );
        assert!(
            point_frags < bound,
            "{scene_name}: {point_frags} fragments as points (strips: {strip_frags})"
        );
        let differ = strip_vis
            .iter()
            .zip(&point_vis)
            .filter(|(a, b)| a.to_bits() != b.to_bits())
            .count();
        assert_eq!(
            differ, 0,
            "{scene_name}: visibilities differ in {differ} pixels"
        );
    }
}

/// The occluder blocks (module header of src/technique/ssm_bitmask.rs): the texels of a
/// flat patch draw one quad per block, whose penumbra extent is shaded once where each
/// micro-quad's was shaded again. One micro-quad per drawn texel shaded 1,590,080 fragments
/// (listed) on `cylinder`, 1,358,240 on `overlap` and 745,616 on `bunny`; with blocks of
/// interior texels only, 404,128, 189,632 and 334,832; with the silhouettes' texels too and
/// corners within 0.3 % of 1/depth of the block quad, 334,208, 107,920 and 254,128; within
/// one self-occlusion guard, 322,032, 107,920 and 193,040 (`fence` 130,816 -> 103,120);
/// drawn as points, 254,592, 82,768 and 144,192 (`fence` 70,336).
/// mae_lit stays within 3e-4 of one micro-quad per texel's on the built-in scenes
/// (BENCHMARKS.md); the errors' own margins are the tests above.
#[test]
fn occluder_blocks_shade_fewer_micro_quad_fragments() {
    let gpu = Gpu::new();
    for (scene, before, bound) in [
        ("cylinder", 1_590_080, 330_000),
        ("overlap", 1_358_240, 120_000),
        ("bunny", 745_616, 215_000),
        ("fence", 175_632, 115_000),
    ] {
        let (_, frags) = micro_quad_work(&gpu, scene, false);
        println!("{scene}: {frags} fragments, {before} with one quad per texel");
        assert!(
            frags < bound,
            "{scene}: {frags} micro-quad fragments (one quad per texel: {before})"
        );
    }
}

/// The speed layer runs the per-tile passes that only work where a micro-quad is drawn
/// (`ssm-bitmask/occluder_blocks`, `ssm-bitmask/micro_quads`) on the tiles that hold a
/// drawn texel (`PatchStep::drawn`, an indirect dispatch): 256 invocations a tile, the
/// tiles counted here from the occluder map itself (a caster texel; none lies behind every
/// receiver on these scenes). Before, both ran on all 256 tiles, 65,536 invocations each;
/// `cylinder` has 28 such tiles, `overlap` 31. `--plain` runs the blocks pass on every
/// tile.
#[test]
fn per_tile_passes_run_on_the_tiles_with_a_drawn_texel() {
    let gpu = Gpu::new();
    for scene_name in ["cylinder", "overlap"] {
        for plain in [false, true] {
            let settings = Settings {
                width: 64,
                height: 64,
                plain,
                ..Settings::default()
            };
            let scene = Scene::load(scene_name).unwrap();
            let mut r = softshadow::render::Renderer::new(&gpu.ctx, scene, "ssm-bitmask", settings)
                .unwrap();
            let timings = r.render().unwrap();
            let invocations = |pass: &str| {
                timings
                    .passes
                    .iter()
                    .find(|p| p.name == pass)
                    .and_then(|p| p.stats)
                    .unwrap_or_else(|| panic!("{scene_name}: {pass} has statistics on lavapipe"))
                    .compute_invocations
            };
            let map = r.read_technique_buffer("occluder_map").unwrap();
            let n = map.width as usize;
            assert_eq!(n, 256, "{scene_name}: the default occluder map");
            let caster = &map.channels[0];
            let tiles = (0..n / 16)
                .flat_map(|ty| (0..n / 16).map(move |tx| (tx, ty)))
                .filter(|&(tx, ty)| {
                    (0..16).any(|y| (0..16).any(|x| caster[(ty * 16 + y) * n + tx * 16 + x] < 1e29))
                })
                .count() as u64;
            let blocks = invocations("ssm-bitmask/occluder_blocks");
            if plain {
                assert_eq!(blocks, 65_536, "{scene_name}: plain runs every tile");
                continue;
            }
            println!("{scene_name}: {tiles} tiles hold a caster texel");
            assert!(tiles > 0 && tiles < 64, "{scene_name}: {tiles} tiles");
            assert_eq!(blocks, 256 * tiles, "{scene_name}: occluder_blocks");
            let list = invocations("ssm-bitmask/micro_quads");
            assert_eq!(list, 256 * tiles, "{scene_name}: micro_quads");
        }
    }
}

/// The largest occluder map the CLI allows, 2048^2: one listed quad per texel (48 bytes) is
/// 192 MiB, above lavapipe's maxStorageBufferRange (128 MiB), where binding the list was a
/// validation error. Such a device draws the micro-quads as `--plain` does; the technique
/// is made without a validation message (the harness fails the test on any).
#[test]
fn the_largest_occluder_map_binds_within_the_devices_storage_range() {
    let gpu = Gpu::new();
    let limit = u64::from(gpu.ctx.limits.max_storage_buffer_range);
    for res in [1024, 2048] {
        let settings = Settings {
            width: 32,
            height: 32,
            occluder_res: res,
            ..Settings::default()
        };
        let scene = Scene::load("bunny").unwrap();
        softshadow::render::Renderer::new(&gpu.ctx, scene, "ssm-bitmask", settings)
            .unwrap_or_else(|e| panic!("occluder-res {res}: {e:#}"));
        let bytes = 48 * u64::from(res) * u64::from(res);
        println!(
            "occluder-res {res}: list of {} MiB, fits: {}",
            bytes >> 20,
            bytes <= limit
        );
    }
    assert!(
        48 * 2048 * 2048 > limit,
        "lavapipe's range holds the 2048^2 list: the case is not tested"
    );
}

/// The quad list lists blocks as the plain draw draws them when the micro-patch step is
/// above 1 (a 1 and a 2 degree cone: blocks of several texels), and under a sun: the
/// visibilities of the listed and the plain draws are equal.
#[test]
fn listed_blocks_and_sun_quads_equal_the_plain_draw() {
    let gpu = Gpu::new();
    let settings = common::small(48, Settings::default().shadow_res);
    let cases = [
        (narrow_cone(1.0), true),
        (narrow_cone(2.0), true),
        (Scene::load("sun-bunny").unwrap(), false),
    ];
    for (scene, blocks) in cases {
        let render = |plain: bool| {
            let mut r = softshadow::render::Renderer::new(
                &gpu.ctx,
                scene.clone(),
                "ssm-bitmask",
                Settings {
                    plain,
                    ..settings.clone()
                },
            )
            .unwrap();
            r.render().unwrap();
            let step = r.micro_patch_step().unwrap().step;
            (r.read_back().unwrap(), step)
        };
        let (listed, step) = render(false);
        let (plain, plain_step) = render(true);
        assert_eq!(step, plain_step, "{}", scene.name);
        assert_eq!(step > 1, blocks, "{}: step {step}", scene.name);
        let shadowed = plain.visibility.iter().filter(|v| **v < 0.99).count();
        assert!(shadowed > 50, "{}: {shadowed} shadowed pixels", scene.name);
        let differ = (listed.visibility.iter().zip(&plain.visibility))
            .filter(|(a, b)| a != b)
            .count();
        assert_eq!(differ, 0, "{}: {differ} visibilities differ", scene.name);
    }
    gpu.assert_clean();
}

/// The speed layer's split final pass (speed/regions.rs): the final shader runs only within
/// a micro-quad's reach of a caster, where a mask can hold a hidden sample; elsewhere every
/// mask is clear and the visibility exactly 1 (tests/avoided_work.rs holds the colour to
/// the whole pass's). The final pass's texel reads, warp-summed, at 128^2 (256^2 occluder
/// map): whole (--plain, and every frame before the split) 90,880 on `cylinder`, 89,600 on
/// `bunny` and 124,672 on `overlap`; split 54,016, 51,456 and 75,776.
#[test]
fn the_split_final_pass_reads_only_within_reach_of_a_caster() {
    let gpu = Gpu::new();
    for (scene, whole_before, bound) in [
        ("cylinder", 90_880, 70_000),
        ("bunny", 89_600, 70_000),
        ("overlap", 124_672, 100_000),
    ] {
        let reads = |plain: bool| {
            let settings = Settings {
                width: 128,
                height: 128,
                plain,
                ..Settings::default()
            };
            let mut r = softshadow::render::Renderer::new(
                &gpu.ctx,
                Scene::load(scene).unwrap(),
                "ssm-bitmask",
                settings,
            )
            .unwrap();
            r.render().unwrap();
            r.count_lookups().unwrap().warp_sum(0)
        };
        let (whole, split) = (reads(true), reads(false));
        println!("{scene}: final pass warp texels {whole} whole, {split} split");
        assert!(
            whole > bound,
            "{scene}: {whole} whole (before the split: {whole_before})"
        );
        assert!(split < bound, "{scene}: {split} split (whole: {whole})");
    }
}
