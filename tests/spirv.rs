//! Hand-tuned SPIR-V (`--spirv tuned`, glsl/smoothies/*.spvasm) against glslang's: the same
//! image within one 8-bit level, the same smoothie buffers, smaller modules; and the
//! command line's fallback note and bad-value error.

mod common;

use common::{covered, max_visibility_diff, small, softshadow, Gpu};
use softshadow::eval::{bench, spirv};
use softshadow::render::Renderer;
use softshadow::scene::Scene;
use softshadow::settings::{Settings, SpirvChoice};

const ONE_LEVEL: f32 = 1.0 / 255.0;

/// Renders `scene` with smoothies both ways and compares colour, visibility and the
/// smoothie buffers. Returns the visibilities (glslang's) for the caller's own checks and
/// the number of visibility pixels whose bits differ between the two.
fn compare(gpu: &Gpu, scene: &str, settings: Settings) -> (Vec<f32>, usize) {
    let mut out = Vec::new();
    let mut buffers = Vec::new();
    for spirv in [SpirvChoice::Glslang, SpirvChoice::Tuned] {
        let s = Settings {
            spirv,
            ..settings.clone()
        };
        let mut r = Renderer::new(&gpu.ctx, Scene::load(scene).unwrap(), "smoothies", s)
            .unwrap_or_else(|e| panic!("smoothies --spirv {spirv}: {e:#}"));
        r.render().unwrap();
        out.push(r.read_back().unwrap());
        let mut smoothie = r.read_technique_buffer("smoothie_buffer").unwrap().channels;
        assert_eq!(smoothie.len(), 2, "smoothie buffer: depth and alpha");
        let alpha = smoothie.remove(1);
        buffers.push([smoothie.remove(0), alpha]);
    }
    let (g, t) = (&out[0], &out[1]);
    let mut worst_color = 0;
    for (a, b) in g.color.iter().zip(&t.color) {
        for c in 0..4 {
            worst_color = worst_color.max((a[c] as i32 - b[c] as i32).abs());
        }
    }
    assert!(
        worst_color <= 1,
        "{scene} {settings:?}: colour differs by {worst_color} levels"
    );
    let worst_vis = max_visibility_diff(g, t);
    assert!(
        worst_vis <= ONE_LEVEL,
        "{scene} {settings:?}: visibility differs by {worst_vis}"
    );
    assert!(t
        .visibility
        .iter()
        .all(|v| v.is_finite() && (0.0..=1.0).contains(v)));
    // The position and normal AOVs come from the same inputs, untouched by the tuning.
    assert_eq!(g.position, t.position, "{scene}: position AOV");
    assert_eq!(g.normal, t.normal, "{scene}: normal AOV");
    // The spot factor (the normal AOV's alpha) is the metrics' cone mask: the tuned module
    // makes its own light-clip product, so it rounds (measured 4.9e-4 on cylinder at the
    // cone's smoothstep), but never loses the cone.
    let worst_spot = g
        .spot
        .iter()
        .zip(&t.spot)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0f32, f32::max);
    assert!(
        worst_spot <= 1e-3,
        "{scene}: spot factor differs by {worst_spot}"
    );
    assert!(
        t.spot.iter().filter(|&&v| v > 0.99).count() > 50,
        "{scene}: no pixel in the cone"
    );

    // The smoothie MRT shader: which texels are written, and b, are unchanged (op for op);
    // the remapped alpha may move by rounding only (R16F, one division fewer).
    let [gd, ga] = &buffers[0];
    let [td, ta] = &buffers[1];
    assert_eq!(gd, td, "{scene}: smoothie depth");
    let worst_alpha = ga
        .iter()
        .zip(ta)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0f32, f32::max);
    assert!(
        worst_alpha <= 2e-3,
        "{scene}: smoothie alpha differs by {worst_alpha}"
    );
    let rounded = g
        .visibility
        .iter()
        .zip(&t.visibility)
        .filter(|(a, b)| a != b)
        .count();
    println!("{scene}: {rounded} visibility pixels differ by rounding");
    (g.visibility.clone(), rounded)
}

#[test]
fn tuned_matches_glslang_on_cylinder_primitives_and_a_sun() {
    let gpu = Gpu::new();
    // The courtyard under a sun: the tuned modules' light-kind selects (orthographic depth,
    // the sun's direction and normal offset, Eq. 1s, b interpolated itself).
    for scene in ["cylinder", "primitives", "assets/scenes/sun-courtyard.toml"] {
        let img = gpu.render(scene, "hard", small(192, 256));
        let cov = covered(&img);
        let (vis, rounded) = compare(&gpu, scene, small(192, 256));
        // The tuned final shader rounds differently in some penumbra pixels (bits, well
        // under one level): that shows the tuned module ran; were the choice ignored, no
        // bit would differ.
        assert!(rounded > 0, "{scene}: no texel shows the tuned module ran");
        // The comparison is worth something only if the soft path ran: penumbra pixels
        // (the falloff and the alpha gather), umbra and lit pixels.
        let n = |f: &dyn Fn(f32) -> bool| cov.iter().filter(|&&i| f(vis[i])).count();
        assert!(n(&|v| v > 0.05 && v < 0.95) > 50, "{scene}: no penumbra");
        assert!(n(&|v| v == 0.0) > 50, "{scene}: no umbra");
        assert!(n(&|v| v == 1.0) > 50, "{scene}: nothing lit");
    }
}

#[test]
fn tuned_matches_glslang_with_fixed_t_and_a_point_light() {
    let gpu = Gpu::new();
    // The paper's fixed width (wide smoothies: more alpha lookups).
    let (_, rounded) = compare(
        &gpu,
        "primitives",
        Settings {
            smoothie_t: Some(0.05),
            ..small(160, 256)
        },
    );
    assert!(rounded > 0, "no texel shows the tuned module ran");
    // R = 0: t = 0, the `hard` branch of both modules.
    let (vis, _) = compare(
        &gpu,
        "cylinder",
        Settings {
            light_radius: Some(0.0),
            ..small(160, 256)
        },
    );
    let hard = gpu.render(
        "cylinder",
        "hard",
        Settings {
            light_radius: Some(0.0),
            ..small(160, 256)
        },
    );
    let worst = vis
        .iter()
        .zip(&hard.visibility)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0f32, f32::max);
    assert!(worst <= 1e-6, "R = 0 differs from hard by {worst}");
}

#[test]
fn tuned_modules_are_smaller_than_spirv_opt() {
    let table = spirv::cost_table(softshadow::shaders::ALL).expect("every shader counts");
    for path in ["smoothies/final.frag", "smoothies/smoothie.frag"] {
        let row = table
            .iter()
            .find(|c| c.shader == path)
            .unwrap_or_else(|| panic!("{path} in the table"));
        let tuned = row
            .tuned
            .unwrap_or_else(|| panic!("{path}: no tuned counts"));
        let shipped = row.shipped;
        assert!(row.optimised, "{path}: spirv-opt did not run at build time");
        assert!(
            tuned.total < shipped.total && tuned.body < shipped.body && tuned.ops < shipped.ops,
            "{path}: tuned {tuned:?} is not smaller than spirv-opt's {shipped:?}"
        );
        // The tuned module has its own row too, flagged as hand-tuned.
        assert!(table
            .iter()
            .any(|c| c.hand_tuned && c.shader == format!("{path}.spvasm") && c.shipped == tuned));
    }
    assert!(softshadow::shaders::has_tuned("smoothies"));
    assert!(!softshadow::shaders::has_tuned("hard"));
}

#[test]
fn bench_rows_time_both_spirv_variants() {
    let names = |v: &[&str]| v.iter().map(|s| s.to_string()).collect::<Vec<_>>();
    let both = [SpirvChoice::Glslang, SpirvChoice::Tuned];
    let (rows, _) = bench::variants(&names(&["pcf", "smoothies"]), &[0.02], &both).unwrap();
    let labels: Vec<(&str, SpirvChoice)> =
        rows.iter().map(|r| (r.label.as_str(), r.spirv)).collect();
    assert_eq!(
        labels,
        [
            ("hard", SpirvChoice::Glslang),
            ("pcf", SpirvChoice::Glslang),
            ("smoothies", SpirvChoice::Glslang),
            ("smoothies spirv=tuned", SpirvChoice::Tuned),
            ("smoothies t=0.02", SpirvChoice::Glslang),
            ("smoothies t=0.02 spirv=tuned", SpirvChoice::Tuned),
        ]
    );
    // Tuned only: techniques without tuned modules keep their glslang row.
    let (rows, _) =
        bench::variants(&names(&["pcf", "smoothies"]), &[], &[SpirvChoice::Tuned]).unwrap();
    let labels: Vec<&str> = rows.iter().map(|r| r.label.as_str()).collect();
    assert_eq!(labels, ["hard", "pcf", "smoothies spirv=tuned"]);
    assert_eq!("tuned".parse::<SpirvChoice>().unwrap(), SpirvChoice::Tuned);
    assert!("bogus".parse::<SpirvChoice>().is_err());
}

#[test]
fn cli_falls_back_once_and_rejects_bogus() {
    let dir = std::env::temp_dir().join(format!("softshadow-spirv-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let out = dir.join("hard.png");
    let size = ["--width", "64", "--height", "64", "--shadow-res", "64"];
    let mut args = vec!["render", "--scene", "cylinder", "--technique", "hard"];
    args.extend(size);
    args.extend(["--spirv", "tuned", "--out", out.to_str().unwrap()]);
    let o = softshadow(&args);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{stderr}");
    let note = "note: no hand-tuned SPIR-V for 'hard': falling back to glslang's";
    assert_eq!(
        stderr.lines().filter(|l| l.contains("hand-tuned")).count(),
        1,
        "{stderr}"
    );
    assert!(stderr.lines().any(|l| l == note), "{stderr}");
    assert!(out.exists());

    // smoothies has tuned modules: no note.
    let out2 = dir.join("smoothies.png");
    let mut args = vec!["render", "--scene", "cylinder", "--technique", "smoothies"];
    args.extend(size);
    args.extend(["--spirv", "tuned", "--out", out2.to_str().unwrap()]);
    let o = softshadow(&args);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{stderr}");
    assert!(!stderr.contains("hand-tuned"), "{stderr}");

    let out3 = dir.join("bogus.png");
    let o = softshadow(&[
        "render",
        "--spirv",
        "bogus",
        "--out",
        out3.to_str().unwrap(),
    ]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success());
    assert!(!stderr.contains("panicked"), "{stderr}");
    let errors: Vec<&str> = stderr.lines().filter(|l| l.starts_with("error")).collect();
    assert_eq!(errors.len(), 1, "{stderr}");
    assert!(
        errors[0].contains("bogus") && errors[0].contains("glslang, tuned"),
        "{stderr}"
    );
    assert!(!out3.exists());
    let _ = std::fs::remove_dir_all(&dir);
}
