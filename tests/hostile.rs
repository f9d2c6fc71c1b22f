//! Hostile input (issue 25): outputs that are device nodes, FIFOs, folders or unwritable are
//! refused before any work and left untouched; a failure at any point leaves the output
//! folder exactly as it was; OBJ and flag mistakes are one `error:` line naming the line or
//! the flag.

use softshadow::output::Publish;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn softshadow(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_softshadow"))
        .args(args)
        .arg("--validation")
        .env_remove("SOFTSHADOW_DEVICE")
        .output()
        .expect("running softshadow")
}

/// A fresh folder of its own per test.
fn scratch(name: &str) -> PathBuf {
    let dir =
        std::env::temp_dir().join(format!("softshadow-hostile-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Every entry under `dir` (hidden ones too), with a file's bytes or the kind of entry.
fn snapshot(dir: &Path) -> BTreeMap<PathBuf, Vec<u8>> {
    let mut out = BTreeMap::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap().flatten() {
            let p = e.path();
            let ft = e.file_type().unwrap();
            let v = if ft.is_dir() {
                stack.push(p.clone());
                b"<dir>".to_vec()
            } else if ft.is_file() {
                std::fs::read(&p).unwrap()
            } else if ft.is_symlink() {
                format!("<link {}>", std::fs::read_link(&p).unwrap().display()).into_bytes()
            } else {
                b"<special>".to_vec()
            };
            out.insert(p.strip_prefix(dir).unwrap().to_path_buf(), v);
        }
    }
    out
}

/// A failed command: non-zero exit, exactly one `error:` line containing `expect`, no panic,
/// no validation message.
fn assert_one_error(o: &Output, args: &[&str], expect: &str) {
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success(), "{args:?} succeeded:\n{stderr}");
    assert!(!stderr.contains("panicked"), "{args:?} panicked:\n{stderr}");
    assert!(
        !stderr.to_lowercase().contains("validation message"),
        "{args:?}: {stderr}"
    );
    let errors: Vec<&str> = stderr.lines().filter(|l| l.starts_with("error")).collect();
    assert_eq!(
        errors.len(),
        1,
        "{args:?}: one error line expected:\n{stderr}"
    );
    assert!(
        errors[0].contains(expect),
        "{args:?}: '{}' does not say '{expect}'",
        errors[0]
    );
}

/// Runs `args` in `dir` expecting a failure saying `expect`, and checks that `dir` is as it was.
fn fails_untouched(dir: &Path, args: &[&str], expect: &str) {
    let before = snapshot(dir);
    let o = Command::new(env!("CARGO_BIN_EXE_softshadow"))
        .args(args)
        .arg("--validation")
        .current_dir(dir)
        .env_remove("SOFTSHADOW_DEVICE")
        .output()
        .expect("running softshadow");
    assert_one_error(&o, args, expect);
    assert_eq!(snapshot(dir), before, "{args:?} changed {}", dir.display());
}

fn mkfifo(path: &Path) {
    let ok = Command::new("mkfifo").arg(path).status().unwrap().success();
    assert!(ok, "mkfifo {}", path.display());
}

const SMALL: [&str; 8] = [
    "render",
    "--width",
    "24",
    "--height",
    "24",
    "--shadow-res",
    "64",
    "--technique=hard",
];

fn small(extra: &[&str]) -> Vec<String> {
    SMALL.iter().chain(extra).map(|s| s.to_string()).collect()
}

/// `SMALL` without its shadow map side and technique.
fn tiny(extra: &[&str]) -> Vec<String> {
    SMALL[..5]
        .iter()
        .chain(extra)
        .map(|s| s.to_string())
        .collect()
}

/// A device node (through a link, as `--out` must name a .png) and a FIFO are refused before
/// any work and stay what they were; so is a folder, a missing folder and a .jpg name.
#[test]
fn special_outputs_are_refused_and_untouched() {
    let dir = scratch("special");
    std::os::unix::fs::symlink("/dev/full", dir.join("full.png")).unwrap();
    mkfifo(&dir.join("fifo.png"));
    mkfifo(&dir.join("fifo.obj"));
    mkfifo(&dir.join("pair.json"));
    std::fs::write(dir.join("pair.obj"), b"keep").unwrap();
    std::fs::create_dir(dir.join("adir.png")).unwrap();
    std::fs::write(dir.join("afile"), b"keep").unwrap();
    let cases: &[(&[&str], &str)] = &[
        (&["--out", "full.png"], "not a regular file"),
        (&["--out", "fifo.png"], "not a regular file"),
        (&["--out", "adir.png"], "is a folder"),
        (&["--out", "nowhere/x.png"], "does not exist"),
        (&["--out", "x.jpg"], ".jpg is not supported"),
        (&["--out", "/dev/full"], "not a regular file"),
        (
            &["--out", "x.png", "--aov", "afile"],
            "--aov afile: it exists and is not a folder",
        ),
        (
            &["--out", "x.png", "--buffers", "afile/sub"],
            "afile is not a folder",
        ),
        (&["--out", "x.png", "--aov", "fifo.png"], "not a folder"),
    ];
    for (extra, expect) in cases {
        let args = small(extra);
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        fails_untouched(&dir, &args, expect);
    }
    for (args, expect) in [
        (&["export", "--obj", "fifo.obj"][..], "not a regular file"),
        (&["export", "--obj", "pair.obj"][..], "not a regular file"),
        (&["export", "--obj", "/dev/full"][..], "not a regular file"),
        (&["stress", "--quick", "--out", "afile"][..], "not a folder"),
        (&["bench", "--out", "fifo.png"][..], "not a folder"),
    ] {
        fails_untouched(&dir, args, expect);
    }
    use std::os::unix::fs::FileTypeExt;
    assert!(std::fs::metadata("/dev/full")
        .unwrap()
        .file_type()
        .is_char_device());
    assert!(std::fs::symlink_metadata(dir.join("fifo.png"))
        .unwrap()
        .file_type()
        .is_fifo());
    let _ = std::fs::remove_dir_all(&dir);
}

/// `render --out --aov --buffers` publishes every file or none; a second render replaces them.
#[test]
fn render_outputs_are_published_together() {
    let dir = scratch("together");
    let args = small(&["--out", "o.png", "--aov", "aov", "--buffers", "buf"]);
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    let o = Command::new(env!("CARGO_BIN_EXE_softshadow"))
        .args(&args)
        .arg("--validation")
        .current_dir(&dir)
        .env_remove("SOFTSHADOW_DEVICE")
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let names: Vec<String> = snapshot(&dir)
        .keys()
        .map(|p| p.display().to_string())
        .collect();
    assert_eq!(
        names,
        [
            "aov",
            "aov/normal.exr",
            "aov/position.exr",
            "aov/visibility.exr",
            "buf",
            "buf/shadow_map.exr",
            "o.png"
        ],
        "no temporary file left"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// A write that fails half way, and a rename that fails after others succeeded, both leave the
/// folders exactly as they were: the first new files and folders removed, replaced files back.
#[test]
fn a_late_failure_leaves_the_folder_as_it_was() {
    let dir = scratch("late");
    std::fs::write(dir.join("a.txt"), b"old a").unwrap();
    std::fs::create_dir(dir.join("keep")).unwrap();
    std::fs::write(dir.join("keep/b.txt"), b"old b").unwrap();
    let before = snapshot(&dir);

    // The third of three writes fails (as a full disk would) after writing some bytes.
    let mut p = Publish::new();
    p.stage(&dir.join("a.txt"), |t| Ok(std::fs::write(t, b"new a")?))
        .unwrap();
    p.create_dir(&dir.join("new/deeper")).unwrap();
    p.stage(&dir.join("new/deeper/c.txt"), |t| {
        Ok(std::fs::write(t, b"c")?)
    })
    .unwrap();
    let e = p
        .stage(&dir.join("keep/b.txt"), |t| {
            std::fs::write(t, b"half")?;
            Err(std::io::Error::from_raw_os_error(28).into())
        })
        .unwrap_err();
    assert!(format!("{e:#}").contains("keep/b.txt"), "{e:#}");
    drop(p);
    assert_eq!(snapshot(&dir), before, "after a failed write");

    // Every write succeeds but the last rename fails (its staged file vanished): the files
    // already renamed are put back.
    let mut p = Publish::new();
    p.stage(&dir.join("a.txt"), |t| Ok(std::fs::write(t, b"new a")?))
        .unwrap();
    p.create_dir(&dir.join("fresh")).unwrap();
    p.stage(&dir.join("fresh/d.txt"), |t| Ok(std::fs::write(t, b"d")?))
        .unwrap();
    p.stage(&dir.join("keep/b.txt"), |t| {
        std::fs::write(t, b"new b")?;
        // Removed behind Publish's back: its rename into place fails.
        std::fs::remove_file(t)?;
        Ok(())
    })
    .unwrap();
    assert!(p.commit().is_err());
    assert_eq!(snapshot(&dir), before, "after a failed rename");

    // And a commit that works replaces both.
    let mut p = Publish::new();
    p.stage(&dir.join("a.txt"), |t| Ok(std::fs::write(t, b"new a")?))
        .unwrap();
    p.stage(&dir.join("keep/b.txt"), |t| {
        Ok(std::fs::write(t, b"new b")?)
    })
    .unwrap();
    p.commit().unwrap();
    assert_eq!(std::fs::read(dir.join("a.txt")).unwrap(), b"new a");
    assert_eq!(std::fs::read(dir.join("keep/b.txt")).unwrap(), b"new b");
    assert_eq!(snapshot(&dir).len(), before.len(), "no temporary file left");
    let _ = std::fs::remove_dir_all(&dir);
}

/// A sweep killed before it finished left `.bench-partial-PID/`; the next bench run into the
/// same folder removes it (its process is gone) and leaves everything else alone, even when
/// it fails itself.
#[test]
fn stale_bench_staging_is_removed() {
    let dir = scratch("stale");
    let out = dir.join("out");
    // Above the kernel's pid_max (4194304): no live process has it.
    let stale = out.join(".bench-partial-999999999");
    std::fs::create_dir_all(stale.join("images")).unwrap();
    std::fs::write(stale.join("results.csv"), b"half").unwrap();
    std::fs::write(out.join("results.csv"), b"earlier run").unwrap();
    let mine = out.join(format!(".bench-partial-{}", std::process::id()));
    std::fs::create_dir_all(&mine).unwrap();
    let args = [
        "bench",
        "--out",
        out.to_str().unwrap(),
        "--scenes",
        "cylinder",
        "--techniques",
        "hard",
        "--resolutions",
        "99999",
    ];
    let o = softshadow(&args);
    // The buffer side is past the device limit: named by the flag the user gave.
    assert_one_error(&o, &args, "--resolutions 99999");
    assert!(!stale.exists(), "the dead sweep's staging is still there");
    assert!(mine.exists(), "a live process's staging was removed");
    assert_eq!(
        std::fs::read(out.join("results.csv")).unwrap(),
        b"earlier run"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// OBJ mistakes name their line; the ground a bare OBJ gets is named as the loader's.
#[test]
fn obj_errors_name_the_line() {
    let dir = scratch("obj");
    let cases: &[(&str, &str)] = &[
        (
            "v 0 0 0\nv 1 2\nv 0 1 0\nf 1 2 3\n",
            "line 2: vertex 2 has 2 numbers",
        ),
        (
            "v 0 0 0\nv 1 0 0\nv 0 1 0\njunk here\nf 1 2 3\n",
            "line 4: unknown statement 'junk'",
        ),
        (
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2\n",
            "line 4: face has 2 vertices",
        ),
        (
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvn 0 1 0\nf 1/1/1 2/9/9 3\n",
            "line 6: face texture coordinate index 9",
        ),
        // Far enough out that the ground, four times the mesh's size, overflows.
        (
            "v -1e38 0 0\nv 1e38 0 0\nv 0 0 1e38\nf 1 2 3\n",
            "the ground plane the loader adds",
        ),
    ];
    for (i, (text, expect)) in cases.iter().enumerate() {
        let path = dir.join(format!("m{i}.obj"));
        std::fs::write(&path, text).unwrap();
        let out = dir.join("o.png");
        let args = small(&[
            "--scene",
            path.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ]);
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        assert_one_error(&softshadow(&args), &args, expect);
        assert!(!out.exists());
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// Flag values: negative sizes say the value is invalid, a giant token is echoed clipped, the
/// occluder map is capped, a broken driver manifest says the driver failed to load.
#[test]
fn flag_values_get_one_clear_line() {
    let dir = scratch("flags");
    let huge = "9".repeat(100_000);
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (
            vec!["render", "--width", "-1"],
            "invalid value '-1' for '--width",
        ),
        (
            vec!["render", "--shadow-res", "-3"],
            "invalid value '-3' for '--shadow-res",
        ),
        (
            vec!["bench", "--resolutions", "-1"],
            "invalid value '-1' for '--resolutions",
        ),
        (vec!["render", "--width", &huge], "for '--width"),
        (
            vec![
                "render",
                "--technique",
                "ssm",
                "--occluder-res",
                "4096",
                "--out",
                "o.png",
            ],
            "--occluder-res 4096 is out of range: allowed 32..=2048",
        ),
    ];
    for (args, expect) in &cases {
        fails_untouched(&dir, args, expect);
    }
    let o = softshadow(&["render", "--width", &huge]);
    assert!(o.stderr.len() < 1000, "{} bytes of stderr", o.stderr.len());

    let icd = dir.join("broken_icd.json");
    std::fs::write(&icd, b"{ not json").unwrap();
    let o = Command::new(env!("CARGO_BIN_EXE_softshadow"))
        .args(["render", "--out", dir.join("o.png").to_str().unwrap()])
        .env("VK_ICD_FILENAMES", &icd)
        .env("VK_DRIVER_FILES", &icd)
        .env_remove("SOFTSHADOW_DEVICE")
        .output()
        .unwrap();
    assert_one_error(&o, &["broken ICD"], "driver failed to load");
    let _ = std::fs::remove_dir_all(&dir);
}

/// A TOML scene: a ground and a box under a light, with `light` and `extra` spliced in.
fn toml_scene(dir: &Path, name: &str, light: &str, box_line: &str) -> PathBuf {
    let path = dir.join(format!("{name}.toml"));
    let text = format!(
        "name = \"{name}\"\n[[object]]\nprimitive = \"plane\"\nsize = [12, 12]\nrole = \"receiver\"\n\
         [[object]]\nprimitive = \"box\"\nsize = [1, 1, 1]\ntranslate = [0, 0.5, 0]\n{box_line}\n\
         [light]\nposition = [-3, 7, 2]\ntarget = [0, 0, 0]\nradius = 0.2\n{light}\n\
         [camera]\nposition = [6, 5, 8]\ntarget = [0, 0, 0]\nfov_deg = 50\n"
    );
    std::fs::write(&path, text).unwrap();
    path
}

/// The edges of the numeric range (docs/CLI.md "Numeric range") that are refused: one `error:` line
/// naming the limit, nothing written.
#[test]
fn out_of_range_numbers_are_refused_with_the_limit() {
    let dir = scratch("range");
    let wide = toml_scene(&dir, "wide", "fov_deg = 178", "");
    let huge = toml_scene(&dir, "huge", "fov_deg = 60", "scale = 1e8");
    let flat = dir.join("flat.obj");
    // Collinear corners: zero area.
    std::fs::write(&flat, "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n").unwrap();
    let specks = dir.join("tiny.obj");
    std::fs::write(&specks, "v 0 0 0\nv 1e-40 0 0\nv 0 1e-40 0\nf 1 2 3\n").unwrap();
    let scene = |p: &Path| p.to_str().unwrap().to_string();
    let cases: Vec<(Vec<String>, String)> = vec![
        (
            tiny(&["--shadow-res", "1"]),
            "--shadow-res 1 is out of range: allowed 64..=".into(),
        ),
        (
            tiny(&["--shadow-res", "3"]),
            "--shadow-res 3 is out of range: allowed 64..=".into(),
        ),
        (
            tiny(&["--technique", "ssm", "--occluder-res", "1"]),
            "--occluder-res 1 is out of range: allowed 32..=2048".into(),
        ),
        (
            tiny(&["--technique", "ssm", "--occluder-res", "3"]),
            "--occluder-res 3 is out of range: allowed 32..=2048".into(),
        ),
        (
            small(&["--scene", &scene(&wide)]),
            "light fov_deg 178 is out of range: allowed (0, 120]".into(),
        ),
        (
            small(&["--scene", &scene(&huge)]),
            "bounding radius 8.66".into(),
        ),
        (
            small(&["--scene", &scene(&flat)]),
            "every triangle is degenerate".into(),
        ),
        (
            small(&["--scene", &scene(&specks)]),
            "every triangle is degenerate".into(),
        ),
        (
            small(&["--light-radius", "1e30"]),
            "is out of range: allowed 0..=".into(),
        ),
    ];
    for (args, expect) in &cases {
        let mut args: Vec<&str> = args.iter().map(String::as_str).collect();
        args.extend(["--out", "o.png"]);
        fails_untouched(&dir, &args, expect);
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// A light sphere that reaches a caster renders, with one `warning:` line saying what will
/// differ.
#[test]
fn a_light_reaching_a_caster_renders_with_one_warning() {
    let dir = scratch("warn");
    let out = dir.join("o.png");
    let args = small(&["--light-radius", "20", "--out", out.to_str().unwrap()]);
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    let o = softshadow(&args);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{stderr}");
    let warnings: Vec<&str> = stderr
        .lines()
        .filter(|l| l.starts_with("warning:"))
        .collect();
    assert_eq!(warnings.len(), 1, "{stderr}");
    assert!(warnings[0].contains("reaches a caster"), "{stderr}");
    assert!(out.is_file());
    let _ = std::fs::remove_dir_all(&dir);
}

/// The numeric-range cases of `stress` at the documented edges (scene radii 1e-5 and 2e7, each
/// against its own reference, a caster 1e6 away, a light 1e3 scene sizes away, the widest
/// cone, the smallest maps) pass their tolerance on every technique.
#[test]
fn numeric_range_edges_render_within_tolerance() {
    use softshadow::eval::stress::{self, StressOptions};
    let ctx = softshadow::vk::Context::new(&softshadow::vk::ContextOptions {
        device: Some("llvmpipe".into()),
        validation: true,
    })
    .unwrap();
    let cases = [
        "scene-1e-5",
        "scene-2e7",
        "far-caster",
        "far-light",
        "fov-limit",
        "shadow-res-min",
        "occluder-res-min",
    ];
    let opts = StressOptions {
        quick: true,
        cases: cases.iter().map(|c| c.to_string()).collect(),
        ..Default::default()
    };
    let report = stress::run(&ctx, &opts, &mut |_| {}).unwrap();
    let failed: Vec<String> = report
        .failed()
        .iter()
        .map(|r| format!("{} / {}: {} {:?}", r.case, r.technique, r.note, r.error))
        .collect();
    assert!(failed.is_empty(), "failed rows:\n{}", failed.join("\n"));
    assert_eq!(
        report.rows.len(),
        cases.len() * stress::technique_names().len()
    );
    for r in &report.rows {
        if r.case.starts_with("scale-") {
            assert!(
                r.metric.is_some(),
                "{} / {}: no scale figure",
                r.case,
                r.technique
            );
        } else {
            assert!(
                r.errors.is_some(),
                "{} / {}: no error figure",
                r.case,
                r.technique
            );
        }
    }
    assert!(ctx.validation_messages().is_empty());
}

const BOX_SCENE: &str =
    "[[object]]\nprimitive = \"box\"\n[[object]]\nprimitive = \"plane\"\nrole = \"receiver\"\n";

/// An output that is one of the command's inputs, by the same name, another spelling, a
/// symlink or a hard link, is refused before any work with one line naming both, and
/// nothing is written.
#[test]
fn outputs_that_are_inputs_are_refused() {
    let dir = scratch("out-is-in");
    std::fs::write(dir.join("s.toml"), BOX_SCENE).unwrap();
    std::os::unix::fs::symlink("s.toml", dir.join("link.png")).unwrap();
    std::os::unix::fs::symlink("s.toml", dir.join("link.obj")).unwrap();
    std::fs::hard_link(dir.join("s.toml"), dir.join("hard.gltf")).unwrap();
    // Inputs for compare: a render's AOVs and its image, made first.
    let o = Command::new(env!("CARGO_BIN_EXE_softshadow"))
        .args(tiny(&["--technique", "hard", "--scene", "s.toml"]))
        .args(["--aov", "a", "--out", "a.png"])
        .current_dir(&dir)
        .env_remove("SOFTSHADOW_DEVICE")
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    std::fs::copy(dir.join("a.png"), dir.join("b.png")).unwrap();
    std::os::unix::fs::symlink("a/visibility.exr", dir.join("v.png")).unwrap();
    std::os::unix::fs::symlink("a/normal.exr", dir.join("n.png")).unwrap();
    let cases: Vec<(Vec<String>, &str)> = vec![
        (
            tiny(&[
                "--technique",
                "hard",
                "--scene",
                "s.toml",
                "--out",
                "link.png",
            ]),
            "--out link.png: it is the same file as --scene s.toml",
        ),
        (
            ["export", "--scene", "s.toml", "--obj", "link.obj"]
                .map(String::from)
                .to_vec(),
            "--obj link.obj: it is the same file as --scene s.toml",
        ),
        (
            ["export", "--scene", "s.toml", "--gltf", "hard.gltf"]
                .map(String::from)
                .to_vec(),
            "--gltf hard.gltf: it is the same file as --scene s.toml",
        ),
        (
            [
                "compare",
                "--reference",
                "a",
                "--test",
                "a/visibility.exr",
                "--light",
                "0,5,0",
                "--reference-image",
                "a.png",
                "--test-image",
                "b.png",
                "--out",
                "./b.png",
            ]
            .map(String::from)
            .to_vec(),
            "--out ./b.png: it is the same file as --test-image b.png",
        ),
        (
            [
                "compare",
                "--reference",
                "a",
                "--test",
                "a",
                "--light",
                "0,5,0",
                "--out",
                "v.png",
            ]
            .map(String::from)
            .to_vec(),
            "--out v.png: it is the same file as --reference a/visibility.exr",
        ),
        (
            [
                "compare",
                "--reference",
                "a",
                "--test",
                "a",
                "--light",
                "0,5,0",
                "--out",
                "n.png",
            ]
            .map(String::from)
            .to_vec(),
            "--out n.png: it is the same file as --reference a/normal.exr",
        ),
    ];
    for (args, expect) in cases {
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        fails_untouched(&dir, &args, expect);
    }
    // A render's AOV folder whose normal.exr is the scene file (a symlink).
    std::fs::create_dir(dir.join("aov")).unwrap();
    std::os::unix::fs::symlink("../s.toml", dir.join("aov/normal.exr")).unwrap();
    let args = tiny(&["--technique", "hard", "--scene", "s.toml", "--aov", "aov"]);
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    fails_untouched(
        &dir,
        &args,
        "--aov aov/normal.exr: it is the same file as --scene s.toml",
    );
    // A render's light-space buffer folder whose shadow_map.exr is the scene file (a hard
    // link); refused before any work, as --out and --aov are.
    std::fs::create_dir(dir.join("buf")).unwrap();
    std::fs::hard_link(dir.join("s.toml"), dir.join("buf/shadow_map.exr")).unwrap();
    let args = tiny(&[
        "--technique",
        "hard",
        "--scene",
        "s.toml",
        "--buffers",
        "buf",
    ]);
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    fails_untouched(
        &dir,
        &args,
        "--buffers buf/shadow_map.exr: it is the same file as --scene s.toml",
    );
    // An export whose JSON sidecar is the scene through another spelling.
    std::fs::write(dir.join("t.toml"), BOX_SCENE).unwrap();
    std::os::unix::fs::symlink("t.toml", dir.join("u.json")).unwrap();
    fails_untouched(
        &dir,
        &["export", "--scene", "./t.toml", "--obj", "u.obj"],
        "--obj's JSON u.json: it is the same file as --scene ./t.toml",
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// Two scenes of one name, or names that reduce to the same or an empty file name, are
/// refused before the sweep with one line naming them, and the output folder is not made.
#[test]
fn bench_scene_name_clashes_are_refused_before_the_sweep() {
    let dir = scratch("names");
    std::fs::write(
        dir.join("cyl.toml"),
        format!("name = \"cylinder\"\n{BOX_SCENE}"),
    )
    .unwrap();
    std::fs::write(dir.join("a.toml"), format!("name = \"a b\"\n{BOX_SCENE}")).unwrap();
    std::fs::write(dir.join("b.toml"), format!("name = \"a/b\"\n{BOX_SCENE}")).unwrap();
    std::fs::write(dir.join("bang.toml"), format!("name = \"!!\"\n{BOX_SCENE}")).unwrap();
    std::fs::write(dir.join("what.toml"), format!("name = \"??\"\n{BOX_SCENE}")).unwrap();
    for (scenes, expect) in [
        ("cylinder,cyl.toml", "--scenes cylinder and cyl.toml: their names \"cylinder\" and \"cylinder\""),
        ("a.toml,b.toml", "--scenes a.toml and b.toml: their names \"a b\" and \"a/b\" give the same image file names (a-b_...)"),
        ("bang.toml,what.toml", "--scenes bang.toml: its name \"!!\" has no letter or digit"),
    ] {
        fails_untouched(
            &dir,
            &["bench", "--scenes", scenes, "--techniques", "hard", "--out", "out"],
            expect,
        );
        assert!(!dir.join("out").exists(), "{scenes}: --out was made");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// Every hidden partial file in `dir`.
fn partials(dir: &Path) -> Vec<String> {
    std::fs::read_dir(dir)
        .unwrap()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.contains(".partial-"))
        .collect()
}

/// An export of the largest built-in interrupted while it writes its OBJ (SIGINT, then
/// SIGTERM): the staged `.o.obj.partial-PID` is removed, nothing is published, the exit is
/// non-zero with one `error:` line.
#[test]
fn interrupted_export_removes_its_partial_files() {
    for (signal, name) in [(libc::SIGINT, "sigint"), (libc::SIGTERM, "sigterm")] {
        let dir = scratch(&format!("interrupt-{name}"));
        let mut child = Command::new(env!("CARGO_BIN_EXE_softshadow"))
            .args(["export", "--scene", "dense-1m", "--obj", "o.obj"])
            .current_dir(&dir)
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::piped())
            .spawn()
            .unwrap();
        // Signalled once the partial OBJ exists and has grown (mid-write).
        let partial = dir.join(format!(".o.obj.partial-{}", child.id()));
        let mut waited = 0;
        while std::fs::metadata(&partial).map_or(0, |m| m.len()) < 1 << 20 {
            assert!(
                child.try_wait().unwrap().is_none(),
                "{name}: export ended before it was signalled"
            );
            std::thread::sleep(std::time::Duration::from_millis(20));
            waited += 1;
            assert!(waited < 15_000, "{name}: no partial file after 300 s");
        }
        // SAFETY: kill(2) on our own child's pid.
        assert_eq!(unsafe { libc::kill(child.id() as i32, signal) }, 0);
        let out = child.wait_with_output().unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{name}: exit {:?}", out.status);
        assert_eq!(
            stderr.lines().filter(|l| l.starts_with("error:")).count(),
            1,
            "{name}: {stderr}"
        );
        assert!(!stderr.contains("panicked"), "{name}: {stderr}");
        assert_eq!(partials(&dir), Vec::<String>::new(), "{name}: partial left");
        assert!(
            !dir.join("o.obj").exists() && !dir.join("o.json").exists(),
            "{name}"
        );
        let _ = std::fs::remove_dir_all(&dir);
    }
}

/// A process killed outright (SIGKILL) cannot clean up: its partial file carries its process
/// id, and the next export into that folder removes it (a live process's is kept).
#[test]
fn stale_partial_files_of_dead_processes_are_removed() {
    let dir = scratch("stale-partial");
    // Above the kernel's pid_max (4194304): no live process has it.
    let stale = dir.join(".o.obj.partial-999999999");
    std::fs::write(&stale, b"half an obj").unwrap();
    let live = dir.join(format!(".o.obj.partial-{}", std::process::id()));
    std::fs::write(&live, b"in progress").unwrap();
    let o = Command::new(env!("CARGO_BIN_EXE_softshadow"))
        .args(["export", "--scene", "cylinder", "--obj", "o.obj"])
        .current_dir(&dir)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(
        !stale.exists(),
        "the dead export's partial file is still there"
    );
    assert!(live.exists(), "a live process's partial file was removed");
    assert!(dir.join("o.obj").is_file());
    let _ = std::fs::remove_dir_all(&dir);
}

// ---------------------------------------------------------------------------------------
// Hostile input files: what a scene file or a compare input may make softshadow read.
// ---------------------------------------------------------------------------------------

/// A one-triangle-over-a-plane glTF with its buffer in `NAME.bin`; `edit` changes the JSON.
fn tri_gltf(dir: &Path, name: &str, edit: impl FnOnce(&mut serde_json::Value)) -> PathBuf {
    let positions: [[f32; 3]; 6] = [
        [0.0, 1.0, 0.0],
        [1.0, 1.0, 0.0],
        [0.0, 1.0, 1.0],
        [-4.0, 0.0, -4.0],
        [4.0, 0.0, 4.0],
        [4.0, 0.0, -4.0],
    ];
    let bin: Vec<u8> = positions
        .iter()
        .flatten()
        .flat_map(|f| f.to_le_bytes())
        .collect();
    let bin_name = format!("{name}.bin");
    std::fs::write(dir.join(&bin_name), &bin).unwrap();
    let mut doc = serde_json::json!({
        "asset": {"version": "2.0"},
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
        "accessors": [{"bufferView": 0, "componentType": 5126, "count": 6, "type": "VEC3",
                       "min": [-4.0, 0.0, -4.0], "max": [4.0, 1.0, 4.0]}],
        "bufferViews": [{"buffer": 0, "byteLength": bin.len()}],
        "buffers": [{"byteLength": bin.len(), "uri": bin_name}]
    });
    edit(&mut doc);
    let p = dir.join(name);
    std::fs::write(&p, serde_json::to_vec(&doc).unwrap()).unwrap();
    p
}

/// A scanline EXR header declaring `w` x `h` pixels of one float channel, padded to
/// `len` bytes: no pixel data behind it.
fn exr_header(w: i32, h: i32, len: usize) -> Vec<u8> {
    let mut b = vec![0x76, 0x2f, 0x31, 0x01, 2, 0, 0, 0];
    let mut attr = |name: &str, kind: &str, value: &[u8]| {
        b.extend_from_slice(name.as_bytes());
        b.push(0);
        b.extend_from_slice(kind.as_bytes());
        b.push(0);
        b.extend_from_slice(&(value.len() as i32).to_le_bytes());
        b.extend_from_slice(value);
    };
    let mut ch = b"Y\0".to_vec();
    for v in [2i32, 0, 1, 1] {
        ch.extend_from_slice(&v.to_le_bytes());
    }
    ch.push(0);
    attr("channels", "chlist", &ch);
    attr("compression", "compression", &[0]);
    let window: Vec<u8> = [0, 0, w - 1, h - 1]
        .iter()
        .flat_map(|v: &i32| v.to_le_bytes())
        .collect();
    attr("dataWindow", "box2i", &window);
    attr("displayWindow", "box2i", &window);
    attr("lineOrder", "lineOrder", &[0]);
    attr("pixelAspectRatio", "float", &1f32.to_le_bytes());
    attr("screenWindowCenter", "v2f", &[0; 8]);
    attr("screenWindowWidth", "float", &1f32.to_le_bytes());
    b.push(0);
    b.resize(len.max(b.len()), 0);
    b
}

#[test]
fn hostile_scene_and_compare_inputs_give_one_line_and_no_panic_text() {
    let dir = scratch("files");
    tri_gltf(&dir, "ok.gltf", |_| {});
    tri_gltf(&dir, "stride.gltf", |d| {
        d["bufferViews"][0]["byteStride"] = 4.into()
    });
    tri_gltf(&dir, "twice.gltf", |d| {
        d["nodes"] = serde_json::json!([{"mesh": 0, "children": [1, 1]}, {}]);
    });
    mkfifo(&dir.join("fifo.toml"));
    mkfifo(&dir.join("fifo.png"));
    std::fs::write(dir.join("big.exr"), exr_header(1_000_000, 1_000_000, 2048)).unwrap();
    std::fs::write(dir.join("short.exr"), exr_header(4000, 4000, 2048)).unwrap();
    std::fs::create_dir(dir.join("sub")).unwrap();
    std::fs::write(
        dir.join("sub/up.toml"),
        "[[object]]\nmesh = \"../tri.obj\"\n[[object]]\nprimitive = \"plane\"\nrole = \"receiver\"\n",
    )
    .unwrap();
    std::fs::write(dir.join("tri.obj"), "v 0 1 0\nv 1 1 0\nv 0 1 1\nf 1 2 3\n").unwrap();
    let cases: &[(Vec<String>, &str)] = &[
        (tiny(&["--scene", "stride.gltf"]), "byteStride 4"),
        (tiny(&["--scene", "twice.gltf"]), "at most one parent"),
        (tiny(&["--scene", "fifo.toml"]), "FIFO"),
        (tiny(&["--scene", "sub/up.toml"]), "--allow-outside-paths"),
        (tiny(&["--scene", "no\nsuch.toml"]), "no\\nsuch.toml"),
        (
            [
                "compare",
                "--reference",
                "big.exr",
                "--test",
                "big.exr",
                "--light",
                "0,5,0",
            ]
            .map(String::from)
            .to_vec(),
            "above the limit",
        ),
        (
            [
                "compare",
                "--reference",
                "short.exr",
                "--test",
                "short.exr",
                "--light",
                "0,5,0",
            ]
            .map(String::from)
            .to_vec(),
            "more than its 2048 bytes can hold",
        ),
        (
            [
                "compare",
                "--reference",
                "big.exr",
                "--test",
                "big.exr",
                "--light",
                "0,5,0",
                "--reference-image",
                "fifo.png",
                "--test-image",
                "fifo.png",
                "--out",
                "c.png",
            ]
            .map(String::from)
            .to_vec(),
            "fifo.png: is a FIFO",
        ),
    ];
    for (args, expect) in cases {
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        fails_untouched(&dir, &args, expect);
    }
    // The flag lets the scene reach its parent folder: the export is written.
    let o = Command::new(env!("CARGO_BIN_EXE_softshadow"))
        .args([
            "export",
            "--scene",
            "sub/up.toml",
            "--obj",
            "up.obj",
            "--allow-outside-paths",
        ])
        .current_dir(&dir)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(dir.join("up.obj").is_file());
}

/// A panic, here one on a worker thread injected by the test hook, gives exactly one
/// `error: internal error: ... (please report)` line, escaped and clipped, a non-zero exit,
/// none of the default report and none of the output; with RUST_BACKTRACE set the default
/// report is kept for developers, still with a non-zero exit.
#[test]
fn a_panic_gives_one_internal_error_line() {
    let dir = scratch("panic");
    let long = "x".repeat(1000);
    let run = |msg: &str, backtrace: Option<&str>| {
        let mut c = Command::new(env!("CARGO_BIN_EXE_softshadow"));
        c.args(["export", "--scene", "cylinder", "--obj", "o.obj"])
            .current_dir(&dir)
            .env("SOFTSHADOW_TEST_PANIC", msg)
            .env_remove("RUST_BACKTRACE");
        if let Some(b) = backtrace {
            c.env("RUST_BACKTRACE", b);
        }
        c.output().unwrap()
    };
    for backtrace in [None, Some("0")] {
        let o = run("first\nsecond \u{1b}[31m", backtrace);
        assert!(!o.status.success());
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert_eq!(
            stderr,
            "error: internal error: first\\nsecond \\u{1b}[31m (please report)\n"
        );
        let o = run(&long, backtrace);
        assert!(!o.status.success());
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert_eq!(stderr.lines().count(), 1, "{stderr}");
        assert!(stderr.starts_with("error: internal error: xxx"), "{stderr}");
        assert!(stderr.ends_with("... (please report)\n"), "{stderr}");
        assert!(stderr.len() < 300, "not clipped: {} bytes", stderr.len());
    }
    let o = run("for developers", Some("1"));
    assert!(!o.status.success());
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(stderr.contains("panicked at"), "{stderr}");
    assert!(stderr.contains("for developers"), "{stderr}");
    assert!(!stderr.contains("internal error"), "{stderr}");
    assert!(
        std::fs::read_dir(&dir).unwrap().next().is_none(),
        "a panicking export left files"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// The reference cache's files in `dir`: (partial copies, finished entries).
fn cache_files(dir: &Path) -> (Vec<String>, Vec<String>) {
    let names: Vec<String> = std::fs::read_dir(dir)
        .map(|d| {
            d.flatten()
                .map(|e| e.file_name().to_string_lossy().into_owned())
                .collect()
        })
        .unwrap_or_default();
    names.into_iter().partition(|n| n.contains(".partial"))
}

/// A reference render interrupted (SIGINT, SIGTERM) while its cache file's partial copy
/// exists (held open by the test hook) removes that copy and exits non-zero with one
/// `error:` line; one killed outright (SIGKILL) leaves it, and the next render of the same
/// inputs removes it and caches its entry.
#[test]
fn interrupted_reference_cache_write_removes_its_partial_file() {
    let dir = scratch("cache-interrupt");
    let cache = dir.join("cache");
    let spawn = |pause: bool| {
        let mut c = Command::new(env!("CARGO_BIN_EXE_softshadow"));
        c.args(tiny(&["--technique", "reference", "--scene", "cylinder"]))
            .current_dir(&dir)
            .env("SOFTSHADOW_CACHE", &cache)
            .env_remove("SOFTSHADOW_DEVICE")
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::piped());
        if pause {
            c.env("SOFTSHADOW_TEST_CACHE_PAUSE", "300");
        }
        c.spawn().unwrap()
    };
    for (signal, name) in [
        (libc::SIGINT, "sigint"),
        (libc::SIGTERM, "sigterm"),
        (libc::SIGKILL, "sigkill"),
    ] {
        let mut child = spawn(true);
        let mut waited = 0;
        while cache_files(&cache).0.is_empty() {
            assert!(
                child.try_wait().unwrap().is_none(),
                "{name}: render ended before it was signalled"
            );
            std::thread::sleep(std::time::Duration::from_millis(20));
            waited += 1;
            assert!(waited < 15_000, "{name}: no partial file after 300 s");
        }
        assert_eq!(
            cache_files(&cache).0,
            vec![format!(
                "{}.partial{}",
                cache_files(&cache).0[0].split(".partial").next().unwrap(),
                child.id()
            )],
            "{name}"
        );
        // SAFETY: kill(2) on our own child's pid.
        assert_eq!(unsafe { libc::kill(child.id() as i32, signal) }, 0);
        let out = child.wait_with_output().unwrap();
        assert!(!out.status.success(), "{name}: exit {:?}", out.status);
        let (partial, done) = cache_files(&cache);
        assert!(done.is_empty(), "{name}: {done:?}");
        if signal == libc::SIGKILL {
            assert_eq!(partial.len(), 1, "{name}: {partial:?}");
        } else {
            let stderr = String::from_utf8_lossy(&out.stderr);
            assert_eq!(
                stderr.lines().filter(|l| l.starts_with("error:")).count(),
                1,
                "{name}: {stderr}"
            );
            assert!(partial.is_empty(), "{name}: partial left: {partial:?}");
        }
    }
    // The killed process's partial file goes with the next write of the same entry.
    let out = spawn(false).wait_with_output().unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let (partial, done) = cache_files(&cache);
    assert!(partial.is_empty(), "stale partial left: {partial:?}");
    assert_eq!(done.len(), 1, "{done:?}");
    let _ = std::fs::remove_dir_all(&dir);
}
