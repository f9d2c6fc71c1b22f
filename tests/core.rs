//! The core renderer on lavapipe with validation on: hard shadows and smoothies on the
//! paper's scenes, checked by pixel values in lit / umbra / penumbra regions, widths that
//! must grow, convergence to hard shadows, minimum blending, and per-pass timestamps.

mod common;

use common::{covered, pixel_at, small, Gpu};
use glam::{Vec3, Vec4};
use softshadow::output::FrameImages;
use softshadow::scene::Scene;
use softshadow::settings::Settings;

/// The `cylinder` scene's geometry, from its objects and light.
struct CylinderFrame {
    axis: Vec3,
    /// Horizontal direction the shadow runs (away from the light).
    along: Vec3,
    /// Horizontal, perpendicular to `along`.
    across: Vec3,
    radius: f32,
}

fn cylinder_frame(scene: &Scene) -> CylinderFrame {
    let cyl = scene
        .objects
        .iter()
        .find(|o| o.name == "cylinder")
        .expect("cylinder object");
    let b = cyl.world_bounds();
    let axis = Vec3::new((b.min.x + b.max.x) * 0.5, 0.0, (b.min.z + b.max.z) * 0.5);
    let l = scene.light.position;
    let along = Vec3::new(axis.x - l.x, 0.0, axis.z - l.z).normalize();
    CylinderFrame {
        axis,
        along,
        across: Vec3::Y.cross(along).normalize(),
        radius: (b.max.x - b.min.x) * 0.5,
    }
}

fn pos(img: &FrameImages, i: usize) -> Vec3 {
    Vec4::from(img.position[i]).truncate()
}

/// Visibility at the covered pixel nearest `p`, checking such a pixel really is near `p`.
fn vis_at(img: &FrameImages, p: Vec3) -> f32 {
    let i = pixel_at(img, p);
    assert!(
        (pos(img, i) - p).length() < 0.1,
        "no pixel near {p} (nearest {})",
        pos(img, i)
    );
    img.visibility[i]
}

/// Penumbra width (world units) on one side of the cylinder's shadow, in a strip across the
/// shadow at distance `s` behind the axis: lateral extent of ground pixels with 0.02 < v < 0.98.
fn penumbra_width(img: &FrameImages, f: &CylinderFrame, s: f32, side: f32) -> (f32, f32) {
    let mut lo = f32::MAX;
    let mut hi = f32::MIN;
    let mut spacing = Vec::new();
    for i in covered(img) {
        let p = pos(img, i);
        if p.y.abs() > 1e-3 || ((p - f.axis).dot(f.along) - s).abs() > 0.05 {
            continue;
        }
        let u = (p - f.axis).dot(f.across) * side;
        if u <= 0.0 {
            continue;
        }
        let v = img.visibility[i];
        if v > 0.02 && v < 0.98 {
            lo = lo.min(u);
            hi = hi.max(u);
        }
        if i + 1 < img.position.len() && img.position[i + 1][3] > 0.5 {
            spacing.push((pos(img, i + 1) - p).length());
        }
    }
    spacing.sort_by(f32::total_cmp);
    let pixel = spacing.get(spacing.len() / 2).copied().unwrap_or(f32::NAN);
    ((hi - lo).max(0.0), pixel)
}

#[test]
fn lit_is_one_and_umbra_is_zero_for_hard_and_smoothies() {
    let gpu = Gpu::new();
    let scene = Scene::load("cylinder").unwrap();
    let f = cylinder_frame(&scene);
    for technique in ["hard", "smoothies"] {
        let img = gpu.render("cylinder", technique, small(256, 1024));
        // Lit: in front of the cylinder (towards the light) and well to its side.
        for p in [
            f.axis + f.across * 2.0,
            f.axis + f.along * 1.0 + f.across * 1.6,
            f.axis + f.along * 2.0 + f.across * 2.0,
        ] {
            let v = vis_at(&img, p);
            assert!(v > 0.999, "{technique}: lit point {p} has visibility {v}");
        }
        // Umbra: on the shadow's centre line, close behind the cylinder and further out.
        for s in [1.0, 2.0] {
            let p = f.axis + f.along * (f.radius + s);
            let v = vis_at(&img, p);
            assert!(v < 0.001, "{technique}: umbra point {p} has visibility {v}");
        }
        for v in &img.visibility {
            assert!(
                v.is_finite() && (0.0..=1.0).contains(v),
                "{technique}: visibility {v}"
            );
        }
    }
}

#[test]
fn smoothie_penumbra_grows_away_from_the_contact() {
    let gpu = Gpu::new();
    let scene = Scene::load("cylinder").unwrap();
    let f = cylinder_frame(&scene);
    let img = gpu.render("cylinder", "smoothies", small(320, 1024));
    for side in [1.0, -1.0] {
        let (near, pixel) = penumbra_width(&img, &f, f.radius * 0.6, side);
        let (far, _) = penumbra_width(&img, &f, 3.2, side);
        assert!(
            far > 3.0 * near.max(pixel),
            "side {side}: penumbra far from the contact ({far}) must be much wider than near it ({near}, pixel {pixel})"
        );
        assert!(
            near <= 2.0 * pixel,
            "side {side}: near the contact the penumbra is {near} wide, more than two pixels ({pixel} each)"
        );
    }
    // The hard shadow has no such growth: its transition stays about one texel wide.
    let hard = gpu.render("cylinder", "hard", small(320, 1024));
    let (hard_far, pixel) = penumbra_width(&hard, &f, 3.2, 1.0);
    assert!(
        hard_far <= 3.0 * pixel,
        "hard shadow edge is {hard_far} wide"
    );
}

#[test]
fn smoothies_converge_to_hard_as_t_shrinks() {
    let gpu = Gpu::new();
    let hard = gpu.render("cylinder", "hard", small(192, 512));
    let cov = covered(&hard);
    let mut last = f32::MAX;
    for t in [0.04, 0.01, 0.002] {
        let s = Settings {
            smoothie_t: Some(t),
            ..small(192, 512)
        };
        let img = gpu.render("cylinder", "smoothies", s);
        let diff: f32 = cov
            .iter()
            .map(|&i| (img.visibility[i] - hard.visibility[i]).abs())
            .sum::<f32>()
            / cov.len() as f32;
        assert!(
            diff < last,
            "t = {t}: mean |smoothies - hard| {diff} did not shrink (was {last})"
        );
        last = diff;
    }
    assert!(
        last < 2e-3,
        "t = 0.002 still differs from hard by {last} on average"
    );
}

#[test]
fn overlapping_penumbrae_use_minimum_blending() {
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
    // Fixed t: the calibrated width depends on the casters' bounds, which change below.
    let settings = Settings {
        smoothie_t: Some(0.03),
        ..small(192, 512)
    };
    let render = |scene: Scene| gpu.render_frames(scene, "smoothies", settings.clone(), 1).0;
    let both = render(scene.clone());
    // The other blocker is moved under the ground: out of the light's and the camera's view.
    let only = |keep: usize| {
        let mut s = scene.clone();
        for &b in &blockers {
            if b != keep {
                s.objects[b].transform = glam::Mat4::from_translation(Vec3::new(0.0, -50.0, 0.0))
                    * s.objects[b].transform;
            }
        }
        render(s)
    };
    let a = only(blockers[0]);
    let b = only(blockers[1]);
    let same_point = |i: usize| {
        [&a, &b]
            .iter()
            .all(|o| o.position[i][3] > 0.5 && (pos(o, i) - pos(&both, i)).length() < 1e-4)
    };
    let mut overlap = 0;
    let mut differ = 0;
    let mut compared = 0;
    for i in covered(&both).into_iter().filter(|&i| same_point(i)) {
        compared += 1;
        // Per texel the blend is an exact min; the 2x2 bilinear filter of mins can dip below
        // the min of the two filtered images where the darker blocker switches, so the bound
        // is the darker image's darkest value over the pixel's 3x3 neighbourhood. Additive or
        // multiplicative compositing (0.25 where two half-shadows overlap) fails it.
        let w = both.width as usize;
        let darker = [
            i.saturating_sub(w + 1),
            i.saturating_sub(w),
            i.saturating_sub(w - 1),
            i - 1,
            i,
            i + 1,
            i + w - 1,
            i + w,
            i + w + 1,
        ]
        .into_iter()
        .filter(|&j| j < both.visibility.len())
        .map(|j| a.visibility[j].min(b.visibility[j]))
        .fold(f32::MAX, f32::min);
        assert!(
            both.visibility[i] >= darker - 0.01,
            "pixel {i}: {} is darker than both single-blocker images ({darker})",
            both.visibility[i]
        );
        // A filter of per-texel minima is at most the minimum of the filtered images: MAX
        // blending, or the last blocker drawn winning, shows the lighter of the two here.
        let (va, vb) = (a.visibility[i], b.visibility[i]);
        assert!(
            both.visibility[i] <= va.min(vb) + 0.01,
            "pixel {i}: {} is lighter than the darker single-blocker image ({va}, {vb})",
            both.visibility[i]
        );
        if va < 0.98 && vb < 0.98 && va > 0.02 {
            overlap += 1;
        }
        if (va - vb).abs() > 0.1 {
            differ += 1;
        }
    }
    assert!(compared > 1000, "only {compared} pixels comparable");
    assert!(
        overlap > 20,
        "the two penumbrae should overlap somewhere ({overlap} pixels)"
    );
    // Where the two single-blocker images differ, only the minimum passes both bounds.
    assert!(
        differ > 100,
        "only {differ} pixels where the blockers' shadows differ by more than 0.1"
    );
}

#[test]
fn smoothie_pass_writes_depth_and_alpha() {
    let gpu = Gpu::new();
    let scene = Scene::load("cylinder").unwrap();
    let mut r =
        softshadow::render::Renderer::new(&gpu.ctx, scene, "smoothies", small(128, 256)).unwrap();
    r.render().unwrap();
    // One RG32F target: channel 0 the smoothie depth, channel 1 the remapped alpha.
    let mut smoothie = r.read_technique_buffer("smoothie_buffer").unwrap().channels;
    let alpha = smoothie.remove(1);
    let depth = smoothie.remove(0);
    // Channel 1: the nearest surface of any role, the receiver the smoothie shadows.
    let shadow = r
        .read_technique_buffer("shadow_map")
        .unwrap()
        .channels
        .remove(1);
    let far = softshadow::gpu::passes::FAR_DEPTH;
    let near_count = depth.iter().filter(|&&d| d < far * 0.5).count();
    assert!(
        near_count > 100,
        "smoothie depth written at only {near_count} texels"
    );
    assert!(
        depth.iter().any(|&d| d >= far * 0.5),
        "smoothie depth covers everything"
    );
    let dark = alpha.iter().filter(|&&a| a < 0.5).count();
    assert!(dark > 50, "smoothie alpha below 0.5 at only {dark} texels");
    assert!(
        alpha.iter().any(|&a| a >= 1.0),
        "smoothie alpha is nowhere 1"
    );
    assert!(alpha
        .iter()
        .all(|a| a.is_finite() && (0.0..=1.0).contains(a)));
    // A smoothie lies at its blocker's depth: never behind the receiver it shadows.
    for (i, &d) in depth.iter().enumerate() {
        if d < far * 0.5 {
            assert!(
                d <= shadow[i] * 1.0001,
                "texel {i}: smoothie depth {d} behind receiver {}",
                shadow[i]
            );
        }
    }
}

#[test]
fn every_pass_of_every_technique_is_timed_in_order_within_the_frame() {
    let gpu = Gpu::new();
    for info in softshadow::technique::TECHNIQUES {
        if info.name == "reference" {
            continue; // CPU ray casting, no light passes; its GPU passes have their own tests.
        }
        let name = info.name;
        let scene = Scene::load("cylinder").unwrap();
        let mut r =
            softshadow::render::Renderer::new(&gpu.ctx, scene, name, small(96, 256)).unwrap();
        r.render().unwrap();
        // The light moves: this frame rebuilds every light pass.
        r.scene.light.position += Vec3::new(0.05, 0.0, 0.0);
        let moved = r.render().unwrap();
        // Nothing moves: this frame reuses the light passes, which names them.
        let still = r.render().unwrap();
        let light: Vec<&str> = still
            .passes
            .iter()
            .filter(|p| p.not_run.is_some())
            .map(|p| p.name.as_str())
            .collect();
        assert!(!light.is_empty(), "{name}: a static frame left out no pass");
        let mut end = 0.0;
        let mut sum = 0.0;
        for p in &moved.passes {
            assert!(
                p.name.starts_with(name),
                "pass {} is not named {name}/...",
                p.name
            );
            let (Some(ms), Some(start), None) = (p.gpu_ms, p.gpu_start_ms, &p.not_run) else {
                panic!(
                    "{name}: pass {} was not timed in a frame that moved the light: {p:?}",
                    p.name
                )
            };
            assert!(ms > 0.0, "{name}: pass {} took {ms} ms", p.name);
            // Each pass begins after the previous one ended (f64 rounding aside).
            assert!(
                start >= end - 1e-9,
                "{name}: pass {} starts at {start} ms, before the previous pass ended ({end} ms)",
                p.name
            );
            end = start + ms;
            sum += ms;
        }
        for l in &light {
            assert!(
                moved.pass_ms(l).is_some(),
                "{name}: light pass {l} not timed in the frame that rebuilt it"
            );
        }
        assert!(
            moved.passes.len() > light.len(),
            "{name}: no final pass besides the light passes {light:?}"
        );
        let frame = moved.gpu_frame_ms.expect("frame span");
        assert!(
            sum <= frame + 1e-9 && end <= frame + 1e-9,
            "{name}: passes sum to {sum} ms, end at {end} ms, in a frame of {frame} ms"
        );
        // The static frame times its final pass the same way.
        for p in still.passes.iter().filter(|p| p.not_run.is_none()) {
            assert!(
                p.gpu_ms.is_some_and(|ms| ms > 0.0),
                "{name}: pass {} of the static frame: {p:?}",
                p.name
            );
        }
    }
}

#[test]
fn zero_light_radius_gives_the_hard_result() {
    let gpu = Gpu::new();
    let s = Settings {
        light_radius: Some(0.0),
        ..small(128, 512)
    };
    let hard = gpu.render("boxes", "hard", s.clone());
    let smooth = gpu.render("boxes", "smoothies", s);
    // Away from the one-texel filtered edge (where the falloff curve reshapes the ramp).
    for i in covered(&hard)
        .into_iter()
        .filter(|&i| hard.visibility[i] == 0.0 || hard.visibility[i] == 1.0)
    {
        assert!(
            (hard.visibility[i] - smooth.visibility[i]).abs() < 1e-6,
            "pixel {i}: hard {} vs smoothies {}",
            hard.visibility[i],
            smooth.visibility[i]
        );
    }
}

/// The timed final pass writes the shaded colour only; `read_back` then runs the AOV pass
/// (same geometry, same shader source built with -DAOV) for visibility, position and
/// normal. Its colour must equal the timed pass's bit for bit, for every technique and both
/// SPIR-V builds of smoothies: the visibility it writes is the one the timed frame shaded.
#[test]
fn the_aov_pass_shades_bit_for_bit_as_the_timed_pass() {
    use softshadow::render::Renderer;
    use softshadow::settings::SpirvChoice;
    let gpu = Gpu::new();
    let mut runs: Vec<(&str, SpirvChoice)> = softshadow::technique::TECHNIQUES
        .iter()
        .map(|t| (t.name, SpirvChoice::Glslang))
        .collect();
    runs.push(("smoothies", SpirvChoice::Tuned));
    for (name, spirv) in runs {
        let scene = Scene::load("overlap").unwrap();
        let settings = Settings {
            spirv,
            ..small(96, 256)
        };
        let mut r = Renderer::new(&gpu.ctx, scene, name, settings).unwrap();
        let timings = r.render().unwrap();
        // The timed frame holds no AOV pass.
        assert!(
            timings.passes.iter().all(|p| !p.name.ends_with("/aov")),
            "{name}: an AOV pass in the timed frame"
        );
        let img = r.read_back().unwrap();
        let aov_color = r.read_color().unwrap();
        let differing = img
            .color
            .iter()
            .zip(&aov_color)
            .filter(|(a, b)| a != b)
            .count();
        assert_eq!(
            differing, 0,
            "{name} ({spirv}): {differing} pixels of the timed colour differ from the AOV pass's"
        );
        // Not a vacuous comparison: the frame has lit and shadowed surfaces.
        let cov = covered(&img);
        let shadowed = cov.iter().filter(|&&i| img.visibility[i] < 0.5).count();
        let lit = cov.iter().filter(|&&i| img.visibility[i] > 0.99).count();
        assert!(
            shadowed > 50 && lit > 50,
            "{name}: {shadowed} shadowed and {lit} lit pixels"
        );
    }
}
