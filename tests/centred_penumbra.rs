//! The centred forms of smoothies (issue 22 item 1), penumbra maps and plateaus (item 2)
//! against their paper forms, `hard` and the ray-cast reference, on lavapipe with validation:
//! - mae_lit (tests/acceptance.rs's measurement) below the paper form's and `hard`'s on
//!   `cylinder`, `bunny` and `primitives`, by measured margins;
//! - an inner penumbra: the umbra shrinks as the light grows, as the reference's does;
//! - thin blockers: no pixel at 0 where the reference lets more than 0.2 through;
//! - two overlapping blockers: never lighter than the darker single-blocker image;
//!   (these three also for the other accurate form, `ssm-bitmask`)
//! - a wide light on `bunny` (3x its radius, the ears narrower than their penumbrae):
//!   mae_lit at or below `pcss`'s and at most 0.4x `hard`'s false edges;
//! - R = 0: exactly `hard`;
//! - smoothies-centred's outer smoothies, overlapping on `dense`: no more specks darker
//!   than the reference than `pcss` draws through the same lookup;
//! - penumbrae about a texel wide (`dense`'s ground): kept to their width by
//!   interpolating shares, not visibilities, a measured error bound on the ground;
//! - a point right behind a caster, nearer than the receiver its inner value was made for
//!   (`fence`'s rails behind its posts): its own narrower penumbra, a measured error bound.

mod common;

use common::{covered, false_edges_of, max_visibility_diff, small, with_radius, Gpu};
use glam::{Mat4, Vec3, Vec4};
use softshadow::eval::metrics::{errors_at, faces_light, Errors};
use softshadow::output::FrameImages;
use softshadow::reference::{visibility_cached, ReferenceParams};
use softshadow::scene::Scene;
use softshadow::settings::Settings;

/// Each centred form with its paper form.
const FORMS: &[(&str, &str)] = &[
    ("smoothies-centred", "smoothies"),
    ("penumbra-map-centred", "penumbra-map"),
    ("plateaus-centred", "plateaus"),
];

/// The other accurate form (issue 22 item 3), held to the same umbra, thin-blocker and
/// overlap rules as the centred forms; its paper form's failings differ (ssm's umbra does
/// shrink, it leaks under thin blockers instead: tests/ssm_bitmask.rs).
const BITMASK: &[&str] = &["ssm-bitmask"];

/// How far below its paper form's and `hard`'s mae_lit each centred form is at least, on
/// each of `cylinder`, `bunny`, `primitives` (160x160, default settings). Measured (paper -
/// centred, hard - centred), smallest over the three scenes: smoothies-centred 0.075 and
/// 0.054, penumbra-map-centred 0.079 and 0.056 (both on primitives), plateaus-centred 0.079
/// (cylinder) and 0.065 (primitives).
const MARGINS: &[(&str, f64, f64)] = &[
    ("smoothies-centred", 0.05, 0.04),
    ("penumbra-map-centred", 0.05, 0.04),
    ("plateaus-centred", 0.05, 0.04),
];

fn margins(centred: &str) -> (f64, f64) {
    MARGINS
        .iter()
        .find(|m| m.0 == centred)
        .map(|m| (m.1, m.2))
        .unwrap_or_else(|| panic!("no margins for {centred}"))
}

fn reference(scene: &Scene, radius: f32, img: &FrameImages) -> Vec<f32> {
    visibility_cached(
        scene,
        radius,
        &img.position,
        &img.normal,
        &ReferenceParams::default(),
    )
    .unwrap_or_else(|e| panic!("reference of {}: {e:#}", scene.name))
}

/// tests/acceptance.rs's measurement: 160x160, every other setting at its default, the
/// scene's light radius.
fn mae_lit(gpu: &Gpu, scene: &Scene, technique: &str) -> Errors {
    let settings = Settings {
        width: 160,
        height: 160,
        ..Settings::default()
    };
    let img = gpu.render_frames(scene.clone(), technique, settings, 1).0;
    let v_ref = reference(scene, scene.light.radius, &img);
    lit_errors(scene, &img, &v_ref)
}

/// mae_lit and the rest of `img`'s errors against `v_ref`.
fn lit_errors(scene: &Scene, img: &FrameImages, v_ref: &[f32]) -> Errors {
    errors_at(
        &img.visibility,
        v_ref,
        &img.position,
        &img.normal,
        &img.spot,
        scene.light.position,
    )
}

/// `name` under a light 3x its own radius, rendered `width` square on 1024^2 maps: the
/// scene, that radius and the settings.
fn at_three_times_its_radius(name: &str, width: u32) -> (Scene, f32, Settings) {
    let scene = Scene::load(name).unwrap();
    let r = scene.light.radius * 3.0;
    let s = with_radius(small(width, 1024), r);
    (scene, r, s)
}

#[test]
fn mae_lit_below_paper_form_and_hard() {
    let gpu = Gpu::new();
    let mut table = String::from("| scene | hard | technique | paper | centred |\n");
    let mut bad = Vec::new();
    for name in ["cylinder", "bunny", "primitives"] {
        let scene = Scene::load(name).unwrap_or_else(|e| panic!("{e:#}"));
        let hard = mae_lit(&gpu, &scene, "hard");
        for &(centred, paper) in FORMS {
            let c = mae_lit(&gpu, &scene, centred);
            let p = mae_lit(&gpu, &scene, paper);
            let (margin_paper, margin_hard) = margins(centred);
            assert!(c.lit_pixels > 200, "{name}/{centred}: {c:?}");
            table.push_str(&format!(
                "| {name} | {:.4} | {centred} | {:.4} | {:.4} |\n",
                hard.mae_lit, p.mae_lit, c.mae_lit
            ));
            if c.mae_lit > p.mae_lit - margin_paper {
                bad.push(format!(
                    "{name}/{centred}: mae_lit {:.4} not {margin_paper} below {paper}'s {:.4}",
                    c.mae_lit, p.mae_lit
                ));
            }
            if c.mae_lit > hard.mae_lit - margin_hard {
                bad.push(format!(
                    "{name}/{centred}: mae_lit {:.4} not {margin_hard} below hard's {:.4}",
                    c.mae_lit, hard.mae_lit
                ));
            }
        }
    }
    println!("{table}");
    assert!(bad.is_empty(), "{}\n{table}", bad.join("\n"));
}

/// Pixels of `img` on surfaces facing the light (mae_lit's region) where `v` is below 0.02.
fn umbra(scene: &Scene, img: &FrameImages, v: &[f32]) -> usize {
    let faces = faces_light(&img.position, &img.normal, scene.light.position);
    covered(img)
        .into_iter()
        .filter(|&i| faces[i] && v[i] < 0.02)
        .count()
}

#[test]
fn umbra_shrinks_as_the_light_grows() {
    let gpu = Gpu::new();
    let scene = Scene::load("cylinder").unwrap();
    let (small_r, big_r) = (0.15, 0.6);
    for &(centred, paper) in FORMS {
        let mut counts = Vec::new();
        for r in [small_r, big_r] {
            let s = with_radius(small(160, 512), r);
            let c = gpu.render_frames(scene.clone(), centred, s.clone(), 1).0;
            let p = gpu.render_frames(scene.clone(), paper, s, 1).0;
            let v_ref = reference(&scene, r, &c);
            counts.push((
                umbra(&scene, &c, &c.visibility),
                umbra(&scene, &p, &p.visibility),
                umbra(&scene, &c, &v_ref),
            ));
        }
        let [(c0, p0, r0), (c1, p1, r1)] = [counts[0], counts[1]];
        println!("{centred}: umbra pixels R {small_r} -> {big_r}: centred {c0} -> {c1}, {paper} {p0} -> {p1}, reference {r0} -> {r1}");
        assert!(r1 < r0 * 3 / 4, "the reference's umbra {r0} -> {r1}");
        assert!(p1 >= p0, "{paper}'s umbra does not shrink: {p0} -> {p1}");
        // The centred umbra shrinks as the reference's does, by a comparable share
        // (smoothies-centred and penumbra-map-centred: to 0.65 of it, plateaus-centred to
        // 0.70, the reference to 0.65).
        let (shrink, ref_shrink) = (c1 as f64 / c0 as f64, r1 as f64 / r0 as f64);
        assert!(
            shrink < 0.8 && (shrink - ref_shrink).abs() < 0.1,
            "{centred}: umbra {c0} -> {c1} ({shrink:.2}), reference {ref_shrink:.2}"
        );
        // And is close to the reference's, unlike the paper form's.
        for (c, p, r) in counts {
            assert!(
                c.abs_diff(r) * 2 < p.abs_diff(r).max(1),
                "{centred}: umbra {c} pixels, reference {r}, {paper} {p}"
            );
        }
    }
    for &t in BITMASK {
        let mut counts = Vec::new();
        for r in [small_r, big_r] {
            let img = gpu
                .render_frames(scene.clone(), t, with_radius(small(160, 512), r), 1)
                .0;
            let v_ref = reference(&scene, r, &img);
            counts.push((
                umbra(&scene, &img, &img.visibility),
                umbra(&scene, &img, &v_ref),
            ));
        }
        let [(c0, r0), (c1, r1)] = [counts[0], counts[1]];
        let (shrink, ref_shrink) = (c1 as f64 / c0 as f64, r1 as f64 / r0 as f64);
        println!("{t}: umbra pixels R {small_r} -> {big_r}: {c0} -> {c1} ({shrink:.2}), reference {r0} -> {r1} ({ref_shrink:.2})");
        assert!(
            shrink < 0.8 && (shrink - ref_shrink).abs() < 0.1,
            "{t}: umbra {c0} -> {c1} ({shrink:.2}), reference {ref_shrink:.2}"
        );
    }
}

/// The centred forms' mean error over the slats' penumbrae, as a share of the paper form's
/// at most (measured: smoothies-centred 0.055 against 0.345, penumbra-map-centred 0.055
/// against 0.369, plateaus-centred 0.071 against 0.306: 0.16, 0.15, 0.23).
const THIN_ERROR_SHARE: f64 = 0.3;

/// Forms whose soft shadows are made for one planar receiver only (both plateaus forms give
/// every other receiver the hard shadow map, by design: Haines 2001 Sec. 2): their
/// thin-blocker rule is judged on `fence`'s ground (y = 0). Off it, a post over a rail is a
/// full umbra (2 pixels at 192^2).
const PLANE_ONLY: &[&str] = &["plateaus-centred"];

#[test]
fn thin_blocker_is_never_a_full_umbra_where_light_gets_through() {
    let gpu = Gpu::new();
    // A larger light than the scene's: every post and rail is narrower than its penumbra on
    // the ground.
    let (scene, r, s) = at_three_times_its_radius("fence", 192);
    for &(centred, paper) in FORMS {
        let c = gpu.render_frames(scene.clone(), centred, s.clone(), 1).0;
        let p = gpu.render_frames(scene.clone(), paper, s.clone(), 1).0;
        let v_ref = reference(&scene, r, &c);
        let judged_here = |img: &FrameImages, i: usize| {
            !PLANE_ONLY.contains(&centred) || img.position[i][1].abs() < 1e-3
        };
        let bright = |img: &FrameImages| {
            covered(img)
                .into_iter()
                .filter(|&i| judged_here(img, i) && v_ref[i] > 0.2 && img.visibility[i] <= 0.0)
                .count()
        };
        let judged = covered(&c)
            .into_iter()
            .filter(|&i| judged_here(&c, i) && v_ref[i] > 0.2)
            .count();
        assert!(judged > 1000, "{centred}: only {judged} pixels judged");
        // The slats' penumbrae: how far from the reference there.
        let penumbra: Vec<usize> = covered(&c)
            .into_iter()
            .filter(|&i| v_ref[i] > 0.02 && v_ref[i] < 0.98)
            .collect();
        let mae = |img: &FrameImages| {
            penumbra
                .iter()
                .map(|&i| f64::from((img.visibility[i] - v_ref[i]).abs()))
                .sum::<f64>()
                / penumbra.len() as f64
        };
        println!(
            "{centred}: {} of {judged} pixels with reference > 0.2 at 0 ({paper}: {}); mean error over {} penumbra pixels {:.4} ({paper}: {:.4})",
            bright(&c),
            bright(&p),
            penumbra.len(),
            mae(&c),
            mae(&p)
        );
        assert!(
            bright(&p) > 50,
            "{paper} should show the full umbra of thin slats"
        );
        assert_eq!(bright(&c), 0, "{centred}: a thin blocker's full umbra");
        assert!(
            mae(&c) < THIN_ERROR_SHARE * mae(&p),
            "{centred}: the slats' penumbrae are off by {:.4} on average, {paper} {:.4}",
            mae(&c),
            mae(&p)
        );
    }
    for &t in BITMASK {
        let img = gpu.render_frames(scene.clone(), t, s.clone(), 1).0;
        let v_ref = reference(&scene, r, &img);
        let bright = covered(&img)
            .into_iter()
            .filter(|&i| v_ref[i] > 0.2 && img.visibility[i] <= 0.0)
            .count();
        println!("{t}: {bright} pixels with reference > 0.2 at 0");
        assert_eq!(bright, 0, "{t}: a thin blocker's full umbra");
    }
}

/// The forms whose outer side adds a thin blocker's far segment (`outer_far_share`,
/// glsl/common/inner_march.glsl), held to `pcss` under a wide light.
const FAR_SHARE: &[&str] = &["smoothies-centred", "penumbra-map-centred"];

/// At most this share of `hard`'s false edges on `bunny` at 3x its radius. Measured at
/// 384x384: smoothies-centred 162 and penumbra-map-centred 206 pairs against `hard`'s 561
/// (0.29x and 0.37x); 0.46x for both when the outer side's far segment came in, 0.61x and
/// 0.54x before it, while the outer side kept the half-plane's 0.5 at the hard edge. The
/// goal, 0.15x, is not met (BENCHMARKS.md, "Fast and accurate").
const WIDE_FALSE_EDGE_SHARE: f64 = 0.4;

/// `bunny` at 3x its light radius, 384x384 (the rest default): its ears are narrower than
/// their penumbrae, and where the two sides of the centred penumbra disagreed at the hard
/// edge each ear kept its hard outline inside a lighter penumbra. Each form's mae_lit is at
/// most `pcss`'s (measured 0.036 and 0.038 against 0.047; 0.053 for both before the
/// outer side's far segment) and its false edges at most `WIDE_FALSE_EDGE_SHARE` of `hard`'s.
#[test]
fn wide_light_thin_ears_lose_their_outline_and_match_pcss() {
    let gpu = Gpu::new();
    let (scene, r, s) = at_three_times_its_radius("bunny", 384);
    let measure = |technique: &str| {
        let img = gpu.render_frames(scene.clone(), technique, s.clone(), 1).0;
        let v_ref = reference(&scene, r, &img);
        let e = lit_errors(&scene, &img, &v_ref);
        let fe = false_edges_of(&img, &v_ref, &scene, 384);
        println!(
            "{technique}: mae_lit {:.4}, p99_lit {:.3}, {} false-edge pairs over {} penumbra pixels",
            e.mae_lit, e.p99_lit, fe.pairs, fe.penumbra_pixels
        );
        (e, fe)
    };
    let (_, hard) = measure("hard");
    let (pcss, _) = measure("pcss");
    assert!(hard.penumbra_pixels > 5000, "{hard:?}");
    let mut bad = Vec::new();
    for &t in FAR_SHARE {
        let (e, fe) = measure(t);
        if e.mae_lit > pcss.mae_lit {
            bad.push(format!(
                "{t}: mae_lit {:.4} above pcss's {:.4}",
                e.mae_lit, pcss.mae_lit
            ));
        }
        let share = fe.pairs as f64 / hard.pairs as f64;
        if share > WIDE_FALSE_EDGE_SHARE {
            bad.push(format!(
                "{t}: {} false-edge pairs, {share:.2}x hard's {}",
                fe.pairs, hard.pairs
            ));
        }
    }
    assert!(bad.is_empty(), "{}", bad.join("\n"));
}

fn pos(img: &FrameImages, i: usize) -> Vec3 {
    Vec4::from(img.position[i]).truncate()
}

#[test]
fn overlapping_blockers_are_never_lighter_than_either_alone() {
    let gpu = Gpu::new();
    let scene = Scene::load("overlap").unwrap();
    let blockers: Vec<usize> = scene
        .objects
        .iter()
        .enumerate()
        .filter(|(_, o)| o.role.casts() && o.name != "ground")
        .map(|(i, _)| i)
        .collect();
    assert_eq!(blockers.len(), 2, "overlap has two blockers");
    let names = FORMS
        .iter()
        .map(|&(centred, _)| centred)
        .chain(BITMASK.iter().copied());
    for centred in names {
        let render = |scene: Scene| gpu.render_frames(scene, centred, small(192, 512), 1).0;
        let both = render(scene.clone());
        // The other blocker moved under the ground: out of the light's and the camera's view
        // (tests/core.rs).
        let only = |keep: usize| {
            let mut s = scene.clone();
            for &b in &blockers {
                if b != keep {
                    s.objects[b].transform =
                        Mat4::from_translation(Vec3::new(0.0, -50.0, 0.0)) * s.objects[b].transform;
                }
            }
            render(s)
        };
        let a = only(blockers[0]);
        let b = only(blockers[1]);
        let mut compared = 0;
        let mut overlap = 0;
        for i in covered(&both) {
            let same = [&a, &b]
                .iter()
                .all(|o| o.position[i][3] > 0.5 && (pos(o, i) - pos(&both, i)).length() < 1e-4);
            if !same {
                continue;
            }
            compared += 1;
            let (va, vb) = (a.visibility[i], b.visibility[i]);
            assert!(
                both.visibility[i] <= va.min(vb) + 1e-3,
                "{centred} pixel {i}: {} is lighter than the darker single-blocker image ({va}, {vb})",
                both.visibility[i]
            );
            if va < 0.98 && vb < 0.98 {
                overlap += 1;
            }
        }
        println!("{centred}: {compared} pixels compared, {overlap} in both shadows");
        assert!(compared > 1000, "only {compared} pixels comparable");
        assert!(
            overlap > 20,
            "the two penumbrae should overlap ({overlap} pixels)"
        );
    }
}

/// `dense` at 320x240, every other setting at its default: the blobs' rims and shadows.
/// The mean |v - v_ref| over the light-facing pixels inside the cone where the reference is
/// in shadow or penumbra and `keep` holds, and how many there are.
fn shadow_error_where(
    scene: &Scene,
    img: &FrameImages,
    v_ref: &[f32],
    keep: impl Fn(usize) -> bool,
) -> (f64, usize) {
    let facing = faces_light(&img.position, &img.normal, scene.light.position);
    let pixels: Vec<usize> = (0..img.visibility.len())
        .filter(|&i| {
            facing[i]
                && img.spot[i] > 0.0
                && v_ref[i] < softshadow::eval::metrics::SHADOW_THRESHOLD
                && keep(i)
        })
        .collect();
    let sum: f64 = pixels
        .iter()
        .map(|&i| f64::from((img.visibility[i] - v_ref[i]).abs()))
        .sum();
    (sum / pixels.len().max(1) as f64, pixels.len())
}

fn dense_320x240() -> (Scene, Settings) {
    let settings = Settings {
        width: 320,
        height: 240,
        ..Settings::default()
    };
    (Scene::load("dense").unwrap(), settings)
}

/// smoothies-centred's outer smoothies write only what darkens (glsl/smoothies_centred/
/// outer.frag). On `dense` the blobs stand closer together than their smoothies are wide, so
/// each blob's outer smoothies reach over its neighbours' edges, under other blobs'
/// smoothies. A fully lit outer fragment (s >= 1) that still wrote its depth b there made
/// the final pass count the points of a neighbour's edge, in front of the darker smoothie,
/// as behind the nearest one, and give them that darker smoothie's visibility: dark specks
/// on the blobs' rims. Against the ray-cast reference at 320x240 over the light-facing
/// pixels (`mae_lit`'s): with those fragments written, 53 pixels were more than 0.2 darker
/// (the worst 0.44); with them discarded none is (the worst 0.137).
/// A lit outer-smoothie fragment's depth, MIN-blended into a texel another caster's smoothie
/// darkens, darkened the receivers between the two depths (smoothies_centred.rs, pass 2).
/// The bumpy spheres of `dense` lit at grazing angles also show the shared lookup's
/// self-shadowing (`light_sample`'s receiver offset sees no bump's concavity), which `pcss`
/// draws too, so the specks are counted against `pcss`'s on the same pixels. Measured on
/// light-facing pixels more than 0.2 darker than the reference: 17 for either; with the lit
/// fragments written, 18 for smoothies-centred (53 under the earlier normal offset).
#[test]
fn outer_smoothies_write_only_what_darkens() {
    let gpu = Gpu::new();
    let (scene, settings) = dense_320x240();
    let render = |t: &str| gpu.render_frames(scene.clone(), t, settings.clone(), 1).0;
    let img = render("smoothies-centred");
    let pcss = render("pcss");
    let v_ref = reference(&scene, scene.light.radius, &img);
    let facing = faces_light(&img.position, &img.normal, scene.light.position);
    let judged: Vec<usize> = (0..img.visibility.len())
        .filter(|&i| facing[i] && img.spot[i] > 0.0)
        .collect();
    assert!(judged.len() > 40_000, "{} pixels judged", judged.len());
    let darker = |v: &[f32]| -> Vec<(usize, f32)> {
        judged
            .iter()
            .map(|&i| (i, v_ref[i] - v[i]))
            .filter(|&(_, d)| d > 0.2)
            .collect()
    };
    let (specks, shared) = (darker(&img.visibility), darker(&pcss.visibility));
    println!(
        "{} pixels judged; more than 0.2 darker than the reference: smoothies-centred {}, pcss {}",
        judged.len(),
        specks.len(),
        shared.len()
    );
    assert!(
        !shared.is_empty(),
        "pcss drew no speck: the comparison is empty"
    );
    assert!(
        specks.len() <= shared.len(),
        "{} pixels more than 0.2 darker than the reference, pcss {} (pixel, amount): {:?}",
        specks.len(),
        shared.len(),
        &specks[..specks.len().min(10)]
    );
}

/// The largest mean error on `dense`'s ground each form may draw (light-facing ground
/// pixels in shadow or penumbra, 320x240, `narrow_penumbrae_keep_their_width`).
const NARROW_GROUND_ERROR: &[(&str, f64)] = &[
    ("smoothies-centred", 0.0080),
    ("penumbra-map-centred", 0.0065),
    ("plateaus-centred", 0.0108),
];

/// The centred forms' light passes store each texel's share s, the profile's argument
/// (glsl/common/penumbra.glsl), and their final passes interpolate shares, then take the
/// profile. Across a straight edge s is linear, so a penumbra keeps its width; interpolated
/// as visibilities, the S-shaped profile, flat at both ends, spread each penumbra by a tent
/// one texel wide. `dense`'s blobs stand close to the ground, and their penumbrae there are
/// about a texel wide. Mean |v - reference| over the ground's light-facing pixels in shadow
/// or penumbra at 320x240, visibilities (drawn narrower by the tent's variance) against
/// shares: smoothies-centred 0.00852 and 0.00751, penumbra-map-centred 0.00703 and 0.00606,
/// plateaus-centred 0.01162 and 0.00993 (pcss 0.0083). The bound lies halfway.
#[test]
fn narrow_penumbrae_keep_their_width() {
    dense_ground_errors_below(NARROW_GROUND_ERROR, false);
}

/// Asserts each form's mean error over `dense`'s ground (the plane at y = 0 facing up,
/// where the blobs' shadows fall; with `umbra_only`, only where the reference is umbra)
/// below its bound, at 320x240.
fn dense_ground_errors_below(bounds: &[(&str, f64)], umbra_only: bool) {
    let gpu = Gpu::new();
    let (scene, settings) = dense_320x240();
    let mut bad = Vec::new();
    let mut v_ref: Option<Vec<f32>> = None;
    for &(t, bound) in bounds {
        let img = gpu.render_frames(scene.clone(), t, settings.clone(), 1).0;
        let v_ref = v_ref.get_or_insert_with(|| reference(&scene, scene.light.radius, &img));
        let (error, ground) = shadow_error_where(&scene, &img, v_ref, |i| {
            img.normal[i][1] > 0.999
                && img.position[i][1].abs() < 1e-3
                && (!umbra_only || v_ref[i] < 1e-3)
        });
        assert!(ground > 3000, "{t}: {ground} ground pixels");
        println!("{t}: mean error {error:.5} over {ground} ground pixels");
        if error > bound {
            bad.push(format!("{t}: {error:.5} above {bound}"));
        }
    }
    assert!(bad.is_empty(), "{}", bad.join("\n"));
}

/// The ground's umbra on `dense` stays dark beside penumbrae about a texel wide. A bumpy
/// blob's outline has folds just inside it, the lip between narrower than a texel or two;
/// the light passing a fold meets the lip, not the ground. The centred inner sides read the
/// hidden receiver 1.5 texels out, past the lip, and drew the fold's penumbra for the
/// ground, lighting its umbra a texel or two in; read at the first texel that is not the
/// edge's own (glsl/common/inner_receiver.glsl), the lip is the fold's receiver and the
/// fold draws nothing. Mean |v - reference| over the ground's light-facing pixels in the
/// reference's umbra at 320x240, before and after: smoothies-centred 0.00550 and 0.00349,
/// penumbra-map-centred 0.00379 and 0.00246 (pcss 0.00124). The bound lies halfway.
#[test]
fn a_fold_behind_its_lip_lights_no_ground_umbra() {
    dense_ground_errors_below(
        &[
            ("smoothies-centred", 0.0045),
            ("penumbra-map-centred", 0.0031),
        ],
        true,
    );
}

#[test]
fn zero_radius_equals_hard() {
    let gpu = Gpu::new();
    for scene in ["cylinder", "fence"] {
        let s = with_radius(small(128, 256), 0.0);
        let hard = gpu.render(scene, "hard", s.clone());
        for &(centred, _) in FORMS {
            let img = gpu.render(scene, centred, s.clone());
            let max = max_visibility_diff(&img, &hard);
            assert!(max <= 1e-6, "{scene}/{centred}: max |v - hard| = {max}");
        }
    }
}

/// The inner values are made for the receiver just outside the silhouette edge; a point
/// nearer than it sees a narrower penumbra (glsl/common/nearer_receiver.glsl). On `fence`
/// at twice its radius the posts' inner penumbrae, made for the ground, fall on the rails
/// right behind them, where the reference is mostly umbra. Mean error over the fence's own
/// light-facing pixels in shadow or penumbra at 480x360 (166 pixels): with the ground's
/// penumbra 0.1146 and 0.1110 for smoothies-centred and penumbra-map-centred, narrowed to
/// their own depth 0.0360 and 0.0339, now below pcss's 0.0459. The bounds lie halfway, and
/// both must stay below pcss's.
#[test]
fn a_point_right_behind_a_caster_takes_its_own_narrower_penumbra() {
    let gpu = Gpu::new();
    let scene = Scene::load("fence").unwrap();
    let radius = 2.0 * scene.light.radius;
    let settings = Settings {
        width: 480,
        height: 360,
        light_radius: Some(radius),
        ..Settings::default()
    };
    let mut v_ref: Option<Vec<f32>> = None;
    let mut errors = Vec::new();
    for t in ["pcss", "smoothies-centred", "penumbra-map-centred"] {
        let img = gpu.render_frames(scene.clone(), t, settings.clone(), 1).0;
        let v_ref = v_ref.get_or_insert_with(|| reference(&scene, radius, &img));
        // Off the ground (y = 0): the posts and rails.
        let (error, fence) = shadow_error_where(&scene, &img, v_ref, |i| {
            img.position[i][3] > 0.5 && img.position[i][1] > 0.01
        });
        assert!(fence > 100, "{t}: {fence} fence pixels");
        println!("{t}: mean error {error:.4} over {fence} fence pixels");
        errors.push(error);
    }
    let pcss = errors[0];
    for (t, error, bound) in [
        ("smoothies-centred", errors[1], 0.075),
        ("penumbra-map-centred", errors[2], 0.072),
    ] {
        assert!(error < bound, "{t}: {error:.4} above {bound}");
        assert!(error < pcss, "{t}: {error:.4} above pcss's {pcss:.4}");
    }
}
