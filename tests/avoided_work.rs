//! Leaving out what a frame does not need: light-space passes reused while the light and the
//! objects stay put, frustum culling that changes no pixel, lights that see no caster,
//! light passes drawn only where they are read, and final-pass lookups only where a shadow
//! can fall.

mod common;

use common::{covered, max_colour_diff, small, Gpu};
use glam::{Mat4, Vec3};
use softshadow::render::Renderer;
use softshadow::scene::{Role, Scene};
use softshadow::settings::{Settings, SilhouettePath};
use softshadow::technique::TECHNIQUES;
use softshadow::vk::FrameTimings;

fn ran(t: &FrameTimings) -> Vec<&str> {
    t.passes
        .iter()
        .filter(|p| p.gpu_ms.is_some())
        .map(|p| p.name.as_str())
        .collect()
}

fn not_run(t: &FrameTimings) -> Vec<&str> {
    t.passes
        .iter()
        .filter(|p| p.not_run.is_some())
        .map(|p| p.name.as_str())
        .collect()
}

fn subjects() -> impl Iterator<Item = &'static str> {
    // The reference has no light-space pass; its ray cast keys on the camera (tests/reference.rs).
    TECHNIQUES
        .iter()
        .map(|t| t.name)
        .filter(|&n| n != "reference")
}

#[test]
fn static_second_frame_runs_only_the_final_pass_and_matches_the_first() {
    let gpu = Gpu::new();
    for name in subjects() {
        let scene = Scene::load("boxes").unwrap();
        let mut r = Renderer::new(&gpu.ctx, scene, name, small(96, 256)).unwrap();
        let first = r.render().unwrap();
        let a = r.read_back().unwrap();
        let second = r.render().unwrap();
        let b = r.read_back().unwrap();
        assert!(
            ran(&first).len() >= 2,
            "{name}: first frame ran {:?}",
            ran(&first)
        );
        assert_eq!(
            ran(&second),
            vec![format!("{name}/final").as_str()],
            "{name}: second frame"
        );
        assert_eq!(
            not_run(&second).len(),
            ran(&first).len() - 1,
            "{name}: every light pass left out"
        );
        for p in &second.passes {
            if let Some(reason) = &p.not_run {
                assert_eq!(reason, "light and casters unchanged");
            }
        }
        assert_eq!(a.visibility, b.visibility, "{name}: static frames differ");
        assert_eq!(a.color, b.color, "{name}: static frames differ");
    }
}

#[test]
fn camera_moves_reuse_light_passes_light_moves_rebuild_them() {
    let gpu = Gpu::new();
    for name in ["hard", "smoothies", "penumbra-map", "ssm"] {
        let scene = Scene::load("cylinder").unwrap();
        let mut r = Renderer::new(&gpu.ctx, scene, name, small(96, 256)).unwrap();
        r.render().unwrap();
        let before = r.read_back().unwrap();
        r.scene.camera.position += Vec3::new(0.7, 0.3, -0.4);
        let moved_camera = r.render().unwrap();
        let after = r.read_back().unwrap();
        assert_eq!(
            ran(&moved_camera),
            vec![format!("{name}/final").as_str()],
            "{name}: camera move"
        );
        assert_ne!(
            before.position, after.position,
            "{name}: the camera did move"
        );
        r.scene.light.position += Vec3::new(0.0, 0.2, 0.1);
        let moved_light = r.render().unwrap();
        assert!(
            not_run(&moved_light).is_empty(),
            "{name}: light move left out {:?}",
            not_run(&moved_light)
        );
        assert!(
            ran(&moved_light).len() >= 2,
            "{name}: light move ran {:?}",
            ran(&moved_light)
        );
        // A caster that moves rebuilds too.
        r.render().unwrap();
        r.scene.objects[1].transform =
            Mat4::from_translation(Vec3::X * 0.1) * r.scene.objects[1].transform;
        let moved_caster = r.render().unwrap();
        assert!(
            not_run(&moved_caster).is_empty(),
            "{name}: caster move left out {:?}",
            not_run(&moved_caster)
        );
    }
}

/// The smoothie pass, the penumbra pass and the shadow map clear only the texels their draws can
/// reach this frame or could last frame (CPU path; `speed::smoothies::Areas::light_areas`,
/// `speed::penumbra_map::Areas::light_areas`). While the caster slides off its old smoothies (cones
/// and sheets), frame after frame, every light-space buffer (shadow map included) and the image
/// equal those of a new renderer's first frame of the same scene, which clears the whole buffers;
/// and some texels that held a smoothie (a penumbra) one frame hold none the next, so stale ones
/// would show.
#[test]
fn light_passes_clear_what_their_last_frame_drew() {
    let gpu = Gpu::new();
    let settings = Settings {
        silhouettes: SilhouettePath::Cpu,
        ..small(96, 256)
    };
    for name in [
        "smoothies",
        "smoothies-centred",
        "penumbra-map",
        "penumbra-map-centred",
    ] {
        let mut r = Renderer::new(
            &gpu.ctx,
            Scene::load("cylinder").unwrap(),
            name,
            settings.clone(),
        )
        .unwrap();
        r.render().unwrap();
        // The smoothie depth: the "depth" channel of `smoothie_buffer` (paper) or
        // `smoothie_outer`, clear 1e30; the centred penumbra map's "surface_depth", clear
        // 1e30; the paper penumbra map's outer intensity (its one channel), clear 1.
        let depth = r
            .technique_buffer_names()
            .into_iter()
            .find(|b| b.starts_with("smoothie") || *b == "penumbra_map")
            .expect("a smoothie buffer or a penumbra map");
        let clear = if name == "penumbra-map" { 1.0 } else { 1e29 };
        let drawn = |r: &mut Renderer| {
            let mut b = r.read_technique_buffer(depth).unwrap();
            let c = b
                .channel_names
                .iter()
                .position(|&c| c.ends_with("depth"))
                .unwrap_or(0);
            b.channels.swap_remove(c)
        };
        let mut last = drawn(&mut r);
        let mut uncovered = 0;
        for step in 1..=3 {
            r.scene.objects[1].transform =
                Mat4::from_translation(Vec3::X * 0.5) * r.scene.objects[1].transform;
            r.render().unwrap();
            let mut fresh =
                Renderer::new(&gpu.ctx, r.scene.clone(), name, settings.clone()).unwrap();
            fresh.render().unwrap();
            for buffer in r.technique_buffer_names() {
                let kept = r.read_technique_buffer(buffer).unwrap();
                let new = fresh.read_technique_buffer(buffer).unwrap();
                assert!(
                    kept.channels == new.channels,
                    "{name}/{buffer}, step {step}: differs from a fresh renderer's"
                );
            }
            assert_eq!(
                r.read_back().unwrap().color,
                fresh.read_back().unwrap().color,
                "{name}, step {step}: image"
            );
            let now = drawn(&mut r);
            uncovered += last
                .iter()
                .zip(&now)
                .filter(|(a, b)| **a < clear && **b >= clear)
                .count();
            last = now;
        }
        assert!(
            uncovered > 100,
            "{name}: only {uncovered} texels lost their smoothie or penumbra"
        );
    }
}

/// The light targets that hold packed keys (technique::packed): their depths are compared
/// as logarithms.
const KEYED: &[&str] = &[
    "smoothie_outer",
    "smoothie_inner",
    "penumbra_map",
    "penumbra_inner",
];

/// The light passes that clear and draw only the texels a frame reads (`light_areas` of
/// smoothies and penumbra maps: the casters' boxes, the smoothies' or cones' texels, the
/// receivers only where their depth is read, for smoothies-centred also just outside the
/// edges, where the inner fragments look for the hidden receiver, and its inner smoothies
/// only as wide as a penumbra can be) give the frame that clearing and drawing everything
/// gives: the same image and visibility, the same smoothie and penumbra buffers, the same
/// casters' depth (the shortened smoothies' values up to interpolation rounding). Two
/// frames, every pass rebuilt: the second is the confined one (a first frame clears the
/// whole buffers). With thin smoothies (a fixed small t) the inner fragments' receiver
/// samples reach past the smoothies' own box.
#[test]
fn light_areas_change_no_pixel() {
    let gpu = Gpu::new();
    let cases = [
        ("cylinder", None, None),
        ("cylinder", Some(1.5), None),
        ("cylinder", None, Some(0.01)),
        ("boxes", None, None),
        ("boxes", None, Some(0.01)),
        ("bunny", None, None),
        ("overlap", None, None),
        ("fence", None, None),
    ];
    for name in [
        "smoothies",
        "smoothies-centred",
        "penumbra-map",
        "penumbra-map-centred",
    ] {
        for (scene_name, light_radius, smoothie_t) in cases {
            if smoothie_t.is_some() && !name.starts_with("smoothies") {
                continue;
            }
            let case = format!("{name} on {scene_name}, R {light_radius:?}, t {smoothie_t:?}");
            let render = |light_areas: bool| {
                let s = Settings {
                    light_areas,
                    light_radius,
                    smoothie_t,
                    silhouettes: SilhouettePath::Cpu,
                    cache_light_passes: false,
                    ..small(96, 256)
                };
                let mut r =
                    Renderer::new(&gpu.ctx, Scene::load(scene_name).unwrap(), name, s).unwrap();
                r.render().unwrap();
                r.render().unwrap();
                let buffers: Vec<(&str, Vec<Vec<f32>>)> = r
                    .technique_buffer_names()
                    .into_iter()
                    .map(|b| {
                        let buffer = r.read_technique_buffer(b).unwrap();
                        let mut channels = buffer.channels;
                        // The receivers' depth (g) is drawn only where it is read.
                        if b == "shadow_map" {
                            channels.truncate(1);
                        }
                        // A packed key's depth has a relative step (technique::packed):
                        // compared as its logarithm, so that one step is one tolerance.
                        if KEYED.contains(&b) {
                            for (c, name) in channels.iter_mut().zip(buffer.channel_names) {
                                if name.ends_with("depth") {
                                    c.iter_mut().for_each(|d| *d = d.ln());
                                }
                            }
                        }
                        (b, channels)
                    })
                    .collect();
                (r.read_back().unwrap(), buffers)
            };
            let (on, on_buffers) = render(true);
            let (off, off_buffers) = render(false);
            assert!(!on_buffers.is_empty(), "{case}: no light buffer");
            // Shortened smoothies (both forms' outer ones, the centred form's inner ones:
            // `records::Extent`) interpolate t and 1/b over other triangles: their
            // values may move by that rounding (alpha and b by up to 6e-5 on up to 0.9 %
            // of the paper form's values, measured; the centred form's b by up to 5.6e-5
            // on 248 of 65536 values (cylinder), a few 16-bit ulps of its penumbra on
            // fewer); no texel is written in one and not the other, and everything else
            // is bit for bit. Cut cones (both penumbra-map forms) interpolate Z_F over
            // shorter triangles: Eq. 1's intensity moves by up to 0.021 on 5 of 65536
            // values (cylinder, R 1.5, measured) where Z_P - Zv is small, the centred
            // form's inner values by up to 1.2e-3 on 6 of 131072 (bunny). The centred
            // forms' packed keys round each part to its step, and such a move can cross
            // one: measured up to 2.1e-4 in the smoothie depth's logarithm (cylinder, R
            // 1.5) on 1 of 131072 values.
            let rounding = name.starts_with("smoothies") || name.starts_with("penumbra-map");
            for ((b, a), (_, w)) in on_buffers.iter().zip(&off_buffers) {
                let tolerance = match *b {
                    "smoothie_inner" if rounding => 4e-3,
                    "smoothie_buffer" if rounding => 1e-4,
                    // A rounding can move a key by one step of either part: 1/1022 of the
                    // visibility, ln(far / near) / 32767 of the depth's logarithm.
                    "smoothie_outer" if rounding => 1e-3,
                    "penumbra_map" | "penumbra_inner" if rounding => 0.05,
                    _ => 0.0,
                };
                // NaN on one side only counts as an infinite difference.
                let diffs: Vec<f32> = a
                    .iter()
                    .zip(w)
                    .flat_map(|(a, w)| a.iter().zip(w))
                    .filter(|(x, y)| !(x == y || x.is_nan() && y.is_nan()))
                    .map(|(x, y)| (x - y).abs())
                    .map(|d| if d.is_nan() { f32::INFINITY } else { d })
                    .collect();
                let worst = diffs.iter().copied().fold(0.0, f32::max);
                let values: usize = a.iter().map(Vec::len).sum();
                assert!(
                    worst <= tolerance && diffs.len() * if rounding { 50 } else { 1000 } <= values,
                    "{case}: {b} differs in {} of {values} values, by up to {worst}",
                    diffs.len()
                );
            }
            let off_by = |x: &[f32], y: &[f32]| {
                x.iter()
                    .zip(y)
                    .filter(|(a, b)| !(a == b || a.is_nan() && b.is_nan()))
                    .map(|(a, b)| (a - b).abs())
                    .map(|d| if d.is_nan() { f32::INFINITY } else { d })
                    .fold(0.0, f32::max)
            };
            let vis = off_by(&on.visibility, &off.visibility);
            // Eq. 1's rounding reaches the image where its denominator is small: 0.009 on
            // penumbra-map's cylinder at R 1.5, measured.
            let vis_bound = match name {
                _ if name.starts_with("penumbra-map") => 0.01,
                _ if rounding => 1e-3,
                _ => 0.0,
            };
            assert!(
                vis <= vis_bound,
                "{case}: the visibility differs by up to {vis}"
            );
            let levels = max_colour_diff(&on, &off);
            assert!(
                levels <= u8::from(rounding),
                "{case}: the image differs by up to {levels} levels"
            );
        }
    }
}

#[test]
fn light_without_casters_records_no_shadow_pass() {
    let gpu = Gpu::new();
    let mut scene = Scene::load("boxes").unwrap();
    // Every caster far behind the light: outside its frustum, still in the scene.
    for o in scene.objects.iter_mut().filter(|o| o.name != "ground") {
        o.transform = Mat4::from_translation(Vec3::new(0.0, 60.0, 0.0)) * o.transform;
    }
    for name in subjects() {
        let mut r = Renderer::new(&gpu.ctx, scene.clone(), name, small(64, 128)).unwrap();
        r.render().unwrap();
        let second = r.render().unwrap();
        assert_eq!(
            ran(&second),
            vec![format!("{name}/final").as_str()],
            "{name}"
        );
        assert!(
            second.passes.iter().all(|p| p
                .not_run
                .as_deref()
                .is_none_or(|s| s == "no caster in the light frustum")),
            "{name}: {:?}",
            second.passes
        );
        let img = r.read_back().unwrap();
        let dark: Vec<(usize, f32)> = img
            .visibility
            .iter()
            .copied()
            .enumerate()
            .filter(|&(_, v)| v < 1.0 - 1e-6)
            .take(5)
            .collect();
        assert!(
            dark.is_empty(),
            "{name}: a shadow without casters: {dark:?} {:?}",
            dark.first().map(|d| img.position[d.0])
        );
    }
}

#[test]
fn culling_changes_no_pixel() {
    let gpu = Gpu::new();
    let scenes = [
        "cylinder",
        "boxes",
        "overlap",
        "fence",
        "bunny",
        "primitives",
        "dense",
    ];
    for scene_name in scenes {
        let mut scene = Scene::load(scene_name).unwrap();
        // A far copy of the first caster: outside both frusta, so culling has work to do.
        let mut far = scene
            .objects
            .iter()
            .find(|o| o.role.casts())
            .unwrap()
            .clone();
        far.transform = Mat4::from_translation(Vec3::new(500.0, 0.0, 0.0)) * far.transform;
        scene.objects.push(far);
        let techniques: Vec<&str> = if scene_name == "boxes" {
            subjects().collect()
        } else {
            vec!["hard", "smoothies"]
        };
        for name in techniques {
            let render = |culling: bool| {
                let s = Settings {
                    culling,
                    ..small(64, 256)
                };
                let mut r = Renderer::new(&gpu.ctx, scene.clone(), name, s).unwrap();
                r.render().unwrap();
                (r.read_back().unwrap(), r.objects_in_frusta())
            };
            let (on, kept_on) = render(true);
            let (off, kept_off) = render(false);
            // Culling had work to do and did it: the far copy is in neither frustum, and
            // without culling every object is kept.
            let n = scene.objects.len();
            assert_eq!(kept_off, (n, n), "{scene_name}/{name}: culling off");
            assert!(
                kept_on.0 < n && kept_on.1 < n && kept_on.0 >= 1 && kept_on.1 >= 1,
                "{scene_name}/{name}: culling kept {kept_on:?} of {n}"
            );
            assert!(
                on.visibility == off.visibility,
                "{scene_name}/{name}: culling changed the visibility"
            );
        }
    }
}

/// The split techniques' timed final pass runs their shader only on the pixels where a
/// shadow can fall (the receivers' boxes cut to the light's frustum over the texels their
/// lookups can reach in what the light passes drew) and a shader without lookups
/// elsewhere. Its colour must equal the AOV pass's, which runs the shader on every pixel,
/// bit for bit: for both smoothies forms, the three pcss searches, both penumbra-map
/// forms, pcf, both plateaus forms and ssm-bitmask, on every built-in scene but the
/// million-triangle one, from the scene's camera, from one orbited round the scene and from
/// one low over the ground (which reaches behind it: the near plane cuts the boxes), at
/// light radius 0 (not ssm-bitmask, which is `hard` there), and with a caster that
/// receives nothing (never split).
/// And the split must happen: on most of these frames well under all of the area drawn
/// runs the shader.
#[test]
fn split_final_pass_shades_as_the_whole_one() {
    let gpu = Gpu::new();
    let (mut frames, mut split) = (0, 0);
    for name in [
        "smoothies",
        "smoothies-centred",
        "pcss",
        "penumbra-map",
        "penumbra-map-centred",
        // pcf with its widest kernels, whose reach the regions must hold.
        "pcf box15",
        "pcf poisson64",
        "plateaus",
        "plateaus-centred",
        "ssm-bitmask",
    ] {
        let label = name;
        let (name, kernel) = match name.split_once(' ') {
            Some((name, kernel)) => (name, kernel.parse().unwrap()),
            None => (name, Settings::default().pcf_kernel),
        };
        let cases = [
            ("cylinder", None),
            ("cylinder", Some(0.0)),
            // A light large enough that penumbrae reach as far as lookups can.
            ("cylinder", Some(1.5)),
            ("boxes", Some(1.5)),
            // The cylinder casting only: drawn unshadowed wherever it is.
            ("caster-only cylinder", None),
            ("boxes", None),
            ("bunny", None),
            ("primitives", None),
            ("fence", None),
            ("overlap", None),
            ("dense", None),
        ];
        for (scene_name, radius) in cases {
            // At R = 0 ssm-bitmask is made as `hard`, whose final pass is whole.
            if name == "ssm-bitmask" && radius == Some(0.0) {
                continue;
            }
            let mut scene = Scene::load(scene_name.trim_start_matches("caster-only ")).unwrap();
            if scene_name.starts_with("caster-only") {
                for o in scene.objects.iter_mut().filter(|o| o.role.casts()) {
                    o.role = Role::Caster;
                }
            }
            let settings = Settings {
                light_radius: radius,
                pcf_kernel: kernel,
                ..small(128, 512)
            };
            let mut r = Renderer::new(&gpu.ctx, scene, name, settings).unwrap();
            let own = r.scene.camera;
            let b = r.scene.bounds();
            let (centre, size) = ((b.min + b.max) * 0.5, (b.max - b.min).length());
            let orbit = Mat4::from_rotation_y(2.0).transform_point3(own.position - centre) + centre;
            let low = Vec3::new(centre.x, b.min.y + 0.03 * size, centre.z)
                + (own.position - centre).with_y(0.0).normalize() * 0.2 * size;
            for (view, position) in [("own", own.position), ("orbit", orbit), ("low", low)] {
                r.scene.camera.position = position;
                r.scene.camera.target = if view == "low" {
                    centre.with_y(b.min.y)
                } else {
                    own.target
                };
                let timings = r.render().unwrap();
                let img = r.read_back().unwrap();
                let whole = r.read_color().unwrap();
                let differing = img.color.iter().zip(&whole).filter(|(a, b)| a != b).count();
                // Sharper than the colours, which the screen boxes' slack hides.
                let outside = shaded_outside_regions(&r, &img);
                assert_eq!(
                    outside, 0,
                    "{label} on {scene_name} (R {radius:?}, {view} camera): {outside} shadowed points outside its regions"
                );
                assert_eq!(
                    differing, 0,
                    "{label} on {scene_name} (R {radius:?}, {view} camera): {differing} pixels differ"
                );
                let area = timings
                    .lookup_area_of(&format!("{name}/final"))
                    .unwrap_or(1.0);
                frames += 1;
                if area < 0.8 {
                    split += 1;
                }
            }
        }
    }
    assert!(split * 3 >= frames * 2, "{split} of {frames} frames split");
}

/// How many points the technique's shader shades below 1 lie outside its regions
/// (`Renderer::shadowed`), in the AOVs `img` of its last frame: none may. Below 1 by more
/// than the rounding of a bilinear sum of four lit texels' weights (smoothies at R 0).
fn shaded_outside_regions(r: &Renderer, img: &softshadow::output::FrameImages) -> usize {
    let shadowed = r.shadowed().expect("a split final pass");
    covered(img)
        .into_iter()
        .filter(|&i| img.visibility[i] < 1.0 - 1e-6)
        .filter(|&i| !shadowed.contains(Vec3::from_slice(&img.position[i][..3])))
        .count()
}

/// The regions are rebuilt from per-caster outlines kept between frames (smoothies'
/// records, penumbra maps' cones and sheets, `regions::AroundCasters` for the pcss family,
/// pcf and ssm-bitmask, plateaus' discs and outlines): when the bunny slides and turns, and
/// then the light moves, every point shaded below 1 still lies inside a region and the
/// timed colour equals the AOV pass's, frame after frame.
#[test]
fn regions_follow_a_moving_caster_and_light() {
    let gpu = Gpu::new();
    let settings = Settings {
        silhouettes: SilhouettePath::Cpu,
        ..small(128, 512)
    };
    for name in [
        "smoothies",
        "penumbra-map",
        "pcss",
        "pcf",
        "plateaus",
        "plateaus-centred",
        "ssm-bitmask",
    ] {
        let mut r = Renderer::new(
            &gpu.ctx,
            Scene::load("bunny").unwrap(),
            name,
            settings.clone(),
        )
        .unwrap();
        let bunny = r
            .scene
            .objects
            .iter()
            .position(|o| o.name == "bunny")
            .unwrap();
        let mut split = 0;
        for step in 0..5 {
            if step > 0 && step < 4 {
                let centre = r.scene.objects[bunny].world_bounds().center();
                r.scene.objects[bunny].transform = Mat4::from_translation(centre + Vec3::X * 0.4)
                    * Mat4::from_rotation_y(0.6)
                    * Mat4::from_translation(-centre)
                    * r.scene.objects[bunny].transform;
            } else if step == 4 {
                r.scene.light.position += Vec3::new(0.8, 0.3, -0.5);
            }
            let timings = r.render().unwrap();
            let img = r.read_back().unwrap();
            let whole = r.read_color().unwrap();
            let outside = shaded_outside_regions(&r, &img);
            assert_eq!(
                outside, 0,
                "{name}, step {step}: shadowed points outside the regions"
            );
            assert!(
                img.color == whole,
                "{name}, step {step}: the split pass's colour differs"
            );
            let area = timings
                .lookup_area_of(&format!("{name}/final"))
                .unwrap_or(1.0);
            split += usize::from(area < 0.9);
        }
        assert_eq!(split, 5, "{name}: a frame not split");
    }
}
