//! The command line as a user meets it: a render that writes its outputs, and bad input
//! that gets one clear line, a non-zero exit, no panic, no validation message and no file.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn softshadow(args: &[&str], envs: &[(&str, &str)]) -> Output {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_softshadow"));
    cmd.args(args)
        .arg("--validation")
        .env_remove("SOFTSHADOW_DEVICE");
    for (k, v) in envs {
        cmd.env(k, v);
    }
    cmd.output().expect("running softshadow")
}

fn tmp(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("softshadow-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

/// Runs a command that must fail: one `error:` line naming `expect`, exit 1, no panic,
/// no validation message, and `out` not written.
fn assert_fails(args: &[&str], envs: &[(&str, &str)], expect: &str, out: &Path) {
    let o = softshadow(args, envs);
    let stderr = String::from_utf8_lossy(&o.stderr);
    // 1: a runtime error (bad input the arguments' syntax allows); 2 is a usage error.
    assert_eq!(o.status.code(), Some(1), "{args:?}: exit status\n{stderr}");
    assert!(!stderr.contains("panicked"), "{args:?} panicked:\n{stderr}");
    assert!(
        !stderr.contains("validation"),
        "{args:?} hit validation:\n{stderr}"
    );
    let errors: Vec<&str> = stderr.lines().filter(|l| l.starts_with("error")).collect();
    assert_eq!(
        errors.len(),
        1,
        "{args:?}: expected one error line:\n{stderr}"
    );
    assert!(
        errors[0].to_lowercase().contains(&expect.to_lowercase()),
        "{args:?}: '{}' does not mention '{expect}'",
        errors[0]
    );
    assert!(!out.exists(), "{args:?} left {} behind", out.display());
}

#[test]
fn render_writes_png_aovs_and_timings() {
    let out = tmp("ok.png");
    let aov = tmp("aov");
    let buffers = tmp("buffers");
    let o = softshadow(
        &[
            "render",
            "--scene",
            "boxes",
            "--width",
            "96",
            "--height",
            "64",
            "--shadow-res",
            "256",
            "--out",
            out.to_str().unwrap(),
            "--aov",
            aov.to_str().unwrap(),
            "--buffers",
            buffers.to_str().unwrap(),
            "--timings",
        ],
        &[("SOFTSHADOW_DEVICE", "llvmpipe")],
    );
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(
        stdout.starts_with("device: "),
        "device line first: {stdout}"
    );
    for pass in [
        "smoothies/shadow_map",
        "smoothies/smoothie",
        "smoothies/final",
    ] {
        let line = stdout
            .lines()
            .find(|l| l.starts_with(&format!("pass {pass} ")))
            .unwrap_or_else(|| panic!("no timing line for {pass}:\n{stdout}"));
        let ms: f64 = line.split_whitespace().nth(2).unwrap().parse().unwrap();
        assert!(ms > 0.0, "{line}");
        // Fragment invocations beside the time: per pixel on screen, per texel in the light.
        let unit = if pass.ends_with("/final") {
            "/px)"
        } else {
            "/tx)"
        };
        assert!(line.contains("  frags ") && line.contains(unit), "{line}");
    }
    assert!(
        stdout
            .lines()
            .any(|l| l.starts_with("work smoothies/count texels ")),
        "{stdout}"
    );
    assert!(
        stdout.lines().any(|l| l.starts_with("frame gpu")),
        "{stdout}"
    );
    let png = image::open(&out).unwrap();
    assert_eq!((png.width(), png.height()), (96, 64));
    let vis = exr::prelude::read_first_flat_layer_from_file(aov.join("visibility.exr")).unwrap();
    let layer = &vis.layer_data;
    assert_eq!((layer.size.width(), layer.size.height()), (96, 64));
    assert_eq!(layer.channel_data.list.len(), 1, "one channel");
    let v: Vec<f32> = layer.channel_data.list[0]
        .sample_data
        .values_as_f32()
        .collect();
    assert!(v.iter().all(|p| (0.0..=1.0).contains(p)));
    assert!(v.iter().any(|&p| p < 0.5), "some shadow");
    let pos = image::open(aov.join("position.exr"))
        .unwrap()
        .into_rgba32f();
    assert!(pos.pixels().any(|p| p[3] == 1.0) && pos.pixels().any(|p| p[3] == 0.0));
    image::open(aov.join("normal.exr")).unwrap();
    // --buffers: smoothies' light-space buffers at the shadow resolution, the shadow map's two
    // channels (nearest caster, nearest surface) ordered, the smoothie alpha in [0, 1].
    let channels = |name: &str| -> Vec<(String, Vec<f32>)> {
        let path = buffers.join(format!("{name}.exr"));
        let img = exr::prelude::read_first_flat_layer_from_file(&path)
            .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        let layer = &img.layer_data;
        assert_eq!(
            (layer.size.width(), layer.size.height()),
            (256, 256),
            "{name}"
        );
        layer
            .channel_data
            .list
            .iter()
            .map(|c| (c.name.to_string(), c.sample_data.values_as_f32().collect()))
            .collect()
    };
    let shadow = channels("shadow_map");
    let channel = |list: &[(String, Vec<f32>)], name: &str| -> Vec<f32> {
        list.iter()
            .find(|(n, _)| n == name)
            .unwrap_or_else(|| panic!("no channel {name}"))
            .1
            .clone()
    };
    let (surface, caster) = (
        channel(&shadow, "surface_depth"),
        channel(&shadow, "caster_depth"),
    );
    assert!(surface.iter().zip(&caster).all(|(s, c)| s <= c));
    assert!(
        surface.iter().zip(&caster).any(|(s, c)| s < c),
        "receivers nearer than casters"
    );
    let smoothie = channels("smoothie_buffer");
    let alpha = channel(&smoothie, "alpha");
    assert!(alpha.iter().all(|a| (0.0..=1.0).contains(a)));
    assert!(alpha.iter().any(|&a| a < 0.5), "no smoothie drawn");
    let depth = channel(&smoothie, "depth");
    assert!(depth.iter().any(|&d| d < 1e29), "no smoothie depth written");
}

/// Exit status by value: 0 for help, 2 for a usage error (the arguments' syntax), 1 for a
/// runtime error (covered case by case in `bad_input_gets_one_clear_line`).
#[test]
fn exit_status_tells_usage_from_runtime_errors() {
    let out = tmp("usage.png");
    let o = out.to_str().unwrap();
    for args in [
        vec!["render", "--no-such-flag", "--out", o],
        vec!["render", "--width", "wide", "--out", o],
        vec!["no-such-command"],
        vec!["bench", "--frames", "-3", "--out", o],
    ] {
        let r = softshadow(&args, &[]);
        let stderr = String::from_utf8_lossy(&r.stderr);
        assert_eq!(r.status.code(), Some(2), "{args:?}\n{stderr}");
        assert!(stderr.starts_with("error:"), "{args:?}: {stderr}");
        assert!(!out.exists());
    }
    // A value outside a fixed list is a usage error too, said on one line with the list.
    let r = softshadow(&["render", "--technique", "nosuch", "--out", o], &[]);
    let stderr = String::from_utf8_lossy(&r.stderr);
    assert_eq!(r.status.code(), Some(2), "{stderr}");
    let first = stderr.lines().next().unwrap_or_default();
    assert!(
        first.starts_with("error: invalid value 'nosuch' for '--technique'")
            && first.contains("hard, pcf"),
        "{stderr}"
    );
    assert!(!out.exists());
    let r = softshadow(&["render", "--scene", "nosuchscene", "--out", o], &[]);
    assert_eq!(r.status.code(), Some(1));
    let r = softshadow(&["--help"], &[]);
    assert_eq!(r.status.code(), Some(0));
    assert!(String::from_utf8_lossy(&r.stdout).contains("render"));
}

#[test]
fn bad_input_gets_one_clear_line() {
    let out = tmp("never.png");
    let o = out.to_str().unwrap();
    let bad_obj = tmp("bad.obj");
    std::fs::write(&bad_obj, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n").unwrap();
    let nan_obj = tmp("nan.obj");
    std::fs::write(&nan_obj, "v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    let bad_toml = tmp("bad.toml");
    std::fs::write(
        &bad_toml,
        "[light]\nposition = [0, 5, 0]\nradius = 0.1\nbrightness = 3\n",
    )
    .unwrap();
    let lavapipe = [("SOFTSHADOW_DEVICE", "llvmpipe")];
    // (arguments, environment, what the one error line must name)
    type Case<'a> = (Vec<&'a str>, &'a [(&'a str, &'a str)], &'a str);
    let cases: Vec<Case> = vec![
        (
            vec!["render", "--scene", "/no/such/file.obj", "--out", o],
            &lavapipe,
            "file.obj",
        ),
        (
            vec!["render", "--scene", bad_obj.to_str().unwrap(), "--out", o],
            &lavapipe,
            "bad.obj",
        ),
        (
            vec!["render", "--scene", nan_obj.to_str().unwrap(), "--out", o],
            &lavapipe,
            "non-finite",
        ),
        (
            vec!["render", "--scene", "nosuchscene", "--out", o],
            &lavapipe,
            "unknown scene",
        ),
        (
            vec!["render", "--scene", bad_toml.to_str().unwrap(), "--out", o],
            &lavapipe,
            "brightness",
        ),
        (
            vec!["render", "--width", "0", "--out", o],
            &lavapipe,
            "--width 0",
        ),
        (
            vec!["render", "--height", "100000", "--out", o],
            &lavapipe,
            "--height 100000",
        ),
        (
            vec!["render", "--shadow-res", "0", "--out", o],
            &lavapipe,
            "--shadow-res",
        ),
        (
            vec!["render", "--light-radius", "-1", "--out", o],
            &lavapipe,
            "--light-radius",
        ),
        (
            vec!["render", "--light-radius", "NaN", "--out", o],
            &lavapipe,
            "--light-radius",
        ),
        (
            vec!["render", "--out", "/no/such/dir/x.png"],
            &lavapipe,
            "does not exist",
        ),
        (
            vec!["render", "--device", "NoSuchGpu", "--out", o],
            &[],
            "NoSuchGpu",
        ),
        // No driver at all: the loader finds no ICD.
        (
            vec!["render", "--out", o],
            &[
                ("VK_ICD_FILENAMES", "/nonexistent.json"),
                ("VK_DRIVER_FILES", "/nonexistent.json"),
            ],
            "mesa-vulkan-drivers",
        ),
    ];
    for (args, envs, expect) in cases {
        assert_fails(&args, envs, expect, &out);
    }
}

#[test]
fn export_writes_obj_and_json() {
    let obj = tmp("scene.obj");
    let o = softshadow(
        &[
            "export",
            "--scene",
            "overlap",
            "--obj",
            obj.to_str().unwrap(),
        ],
        &[],
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = std::fs::read_to_string(&obj).unwrap();
    let faces = text.lines().filter(|l| l.starts_with("f ")).count();
    let scene = softshadow::scene::Scene::load("overlap").unwrap();
    assert_eq!(faces, scene.triangle_count());
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(obj.with_extension("json")).unwrap())
            .unwrap();
    assert_eq!(json["camera"]["width"].as_u64(), Some(1024));
    // The light and camera are the scene's.
    let v3 = |v: &serde_json::Value| {
        let a: Vec<f32> = v
            .as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap() as f32)
            .collect();
        glam::Vec3::from_slice(&a)
    };
    let (l, c) = (&json["lights"][0], &json["camera"]);
    for (got, want) in [
        (v3(&l["position"]), scene.light.position),
        (v3(&l["target"]), scene.light.target),
        (v3(&c["position"]), scene.camera.position),
        (v3(&c["target"]), scene.camera.target),
        (v3(&c["up"]), scene.camera.up),
    ] {
        assert!((got - want).length() < 1e-4, "{got} vs {want}\n{json}");
    }
    for (got, want) in [
        (&l["radius"], scene.light.radius),
        (&l["fov_deg"], scene.light.fov_deg),
        (&c["fov_deg"], scene.camera.fov_deg),
    ] {
        assert!(
            (got.as_f64().unwrap() as f32 - want).abs() < 1e-5,
            "{got} vs {want}"
        );
    }
}

/// A reader that stops early (`softshadow describe | head -3`) ends the output, not with an
/// internal error: Rust's `println!` panics when standard output's pipe has closed. The
/// pipe's read end is closed before the command writes (it opens a device first).
#[test]
fn a_closed_output_pipe_is_not_an_internal_error() {
    use std::process::Stdio;
    let png = tmp("closed-pipe.png");
    let png = png.to_str().unwrap();
    for args in [
        &["describe", "--technique", "hard"][..],
        &["render", "--width", "32", "--height", "32", "--out", png][..],
    ] {
        let mut child = Command::new(env!("CARGO_BIN_EXE_softshadow"))
            .args(args)
            .arg("--validation")
            .env_remove("SOFTSHADOW_DEVICE")
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("running softshadow");
        drop(child.stdout.take());
        let o = child.wait_with_output().unwrap();
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert!(o.status.success(), "{args:?}: {:?}\n{stderr}", o.status);
        assert!(
            !stderr.contains("internal error") && !stderr.contains("panicked"),
            "{args:?}:\n{stderr}"
        );
    }
}
