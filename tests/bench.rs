//! `softshadow bench`: a tiny sweep end to end through the binary (every output exists and
//! parses), bad input (one line, exit != 0, nothing written), and the pieces the report is
//! built from (SPIR-V counting, Pareto front, medians, rows, flag parsing).

use softshadow::eval::bench::{self, Motion, Radius, Stat};
use softshadow::eval::metrics;
use softshadow::eval::plot::pareto_front;
use softshadow::eval::spirv;
use softshadow::reference::{self, ReferenceParams};
use softshadow::scene::Scene;
use softshadow::settings::Settings;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("softshadow-bench-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

/// The binary on lavapipe (or SOFTSHADOW_DEVICE) with validation on.
fn softshadow(args: &[&str]) -> Output {
    let device = std::env::var("SOFTSHADOW_DEVICE").unwrap_or_else(|_| "llvmpipe".into());
    Command::new(env!("CARGO_BIN_EXE_softshadow"))
        .arg("--validation")
        .args(args)
        .env("SOFTSHADOW_DEVICE", device)
        .output()
        .expect("running softshadow")
}

fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

fn decode_png(path: &Path) -> image::DynamicImage {
    image::open(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

#[test]
fn tiny_sweep_writes_every_output_and_each_parses() {
    let out = scratch("tiny");
    let o = softshadow(&[
        "bench",
        "--scenes",
        "cylinder",
        "--techniques",
        "smoothies",
        "--resolutions",
        "128",
        "--width",
        "64",
        "--height",
        "48",
        "--frames",
        "2",
        "--warmup",
        "1",
        "--samples",
        "256",
        "--out",
        out.to_str().unwrap(),
    ]);
    let (stdout, stderr) = (text(&o.stdout), text(&o.stderr));
    assert!(o.status.success(), "bench failed:\n{stdout}\n{stderr}");
    assert!(
        stdout.contains("note: hard added"),
        "hard was not listed: the run must say it added it\n{stdout}"
    );
    let device_line = stdout
        .lines()
        .find(|l| l.starts_with("device: "))
        .expect("device line")
        .to_string();

    // results.csv: one row per technique row (hard added, smoothies twice).
    let mut csv = csv::Reader::from_path(out.join("results.csv")).expect("results.csv");
    let headers = csv.headers().expect("csv headers").clone();
    let col = |name: &str| {
        headers
            .iter()
            .position(|h| h == name)
            .unwrap_or_else(|| panic!("no column {name}"))
    };
    let rows: Vec<csv::StringRecord> = csv.records().map(|r| r.expect("csv row")).collect();
    let techniques: Vec<&str> = rows.iter().map(|r| &r[col("technique")]).collect();
    assert_eq!(techniques, ["hard", "smoothies", "smoothies t=0.02"]);
    for r in &rows {
        assert!(
            device_line.contains(&r[col("device")]),
            "csv device column {:?}",
            &r[col("device")]
        );
        assert!(!r[col("driver")].is_empty());
        let frame: f64 = r[col("frame_ms_median")].parse().expect("frame ms");
        assert!(frame > 0.0 && frame.is_finite(), "frame ms {frame}");
        let ratio: f64 = r[col("ratio_to_hard")].parse().expect("ratio");
        assert!(ratio > 0.0 && ratio.is_finite());
        for c in ["mae_lit", "p99_lit", "flip", "mae_shadow", "rmse", "p99"] {
            let e: f64 = r[col(c)].parse().expect(c);
            assert!((0.0..=1.0).contains(&e), "{c} = {e}");
        }
        assert!(r[col("covered_pixels")].parse::<usize>().unwrap() > 0);
        let lit: usize = r[col("lit_pixels")].parse().unwrap();
        assert!(lit <= r[col("shadow_pixels")].parse::<usize>().unwrap());
    }
    assert_eq!(
        &rows[0][col("ratio_to_hard")],
        "1.0",
        "hard's ratio to itself"
    );
    let t_fixed: f32 = rows[2][col("smoothie_t")].parse().expect("fixed t");
    assert_eq!(t_fixed, 0.02);
    let t_cal: f32 = rows[1][col("smoothie_t")].parse().expect("calibrated t");
    assert!(t_cal > 0.0 && t_cal != 0.02, "calibrated t {t_cal}");

    // results.json: the same rows with per-pass figures, the device, the SPIR-V table.
    let json: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(out.join("results.json")).expect("results.json"),
    )
    .expect("results.json parses");
    assert!(device_line.contains(json["device"].as_str().unwrap()));
    let results = json["results"].as_array().expect("results array");
    assert_eq!(results.len(), 3);
    let smoothies = &results[1];
    let passes: Vec<&str> = smoothies["passes"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| p["name"].as_str().unwrap())
        .collect();
    assert_eq!(
        passes,
        [
            "smoothies/shadow_map",
            "smoothies/smoothie",
            "smoothies/final"
        ]
    );
    for p in smoothies["passes"].as_array().unwrap() {
        let st = &p["gpu_ms"];
        let (lo, med, hi) = (
            st["min"].as_f64().unwrap(),
            st["median"].as_f64().unwrap(),
            st["max"].as_f64().unwrap(),
        );
        assert!(lo <= med && med <= hi && lo > 0.0, "{p}");
    }
    assert_eq!(smoothies["cpu"][0]["name"], "smoothies/silhouettes");
    let spirv = json["spirv"].as_array().expect("spirv table");
    let fin = spirv
        .iter()
        .find(|s| s["shader"] == "smoothies/final.frag")
        .expect("smoothies/final.frag in the SPIR-V table");
    assert!(fin["shipped"]["body"].as_u64().unwrap() > 0);
    assert!(fin["shipped"]["total"].as_u64().unwrap() > fin["shipped"]["body"].as_u64().unwrap());
    assert_eq!(fin["paper"], "10 (final pass)");

    // report.md: device, a table per scene with every row, the SPIR-V table.
    let md = std::fs::read_to_string(out.join("report.md")).expect("report.md");
    assert!(
        md.contains(&device_line),
        "report.md does not name the device"
    );
    assert!(md.contains("## cylinder"));
    for t in [
        "| hard |",
        "| smoothies |",
        "| smoothies t=0.02 |",
        "| smoothies/final.frag | frag |",
        "| mae_lit | p99_lit | flip | false edges ‰ | mae_shadow |",
        "Pareto front on (× hard, mae_lit): ",
    ] {
        assert!(md.contains(t), "report.md lacks {t}");
    }

    // The plot and every image decode; images have the image size; nothing left staged.
    for name in ["time_vs_error.png", "lookups_vs_error.png"] {
        let plot = decode_png(&out.join(name)).to_rgb8();
        assert!(plot.width() >= 600 && plot.height() >= 400, "{name}");
        let first = plot.get_pixel(0, 0);
        assert!(plot.pixels().any(|p| p != first), "{name} is blank");
    }
    for r in results {
        for key in [
            "image",
            "error_image",
            "flip_image",
            "reference_image",
            "reference_shaded_image",
        ] {
            let img = decode_png(&out.join(r[key].as_str().unwrap()));
            assert_eq!(
                (img.width(), img.height()),
                (64, 48),
                "{key} of {}",
                r["technique"]
            );
        }
    }
    rows_agree(&rows, &headers, &json);
    images_are_of_their_rows(&out, results, &rows, &col("mae_shadow"));

    let scale = decode_png(&out.join("images/error_scale.png"));
    assert!(scale.width() > scale.height());
    let leftovers: Vec<_> = std::fs::read_dir(&out)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with('.'))
        .collect();
    assert!(leftovers.is_empty(), "staging left behind: {leftovers:?}");
    let _ = std::fs::remove_dir_all(&out);
}

/// The reference benched against itself has no error and no ꟻLIP difference: the bench's
/// v_ref and FLIP image are the `reference` technique's frame, pixel for pixel. `hard` on the
/// same frame has both.
#[test]
fn the_reference_scores_zero_against_itself() {
    let out = scratch("self");
    let o = softshadow(&[
        "bench",
        "--scenes",
        "cylinder",
        "--techniques",
        "hard,reference",
        "--resolutions",
        "256",
        "--width",
        "64",
        "--height",
        "64",
        "--frames",
        "1",
        "--warmup",
        "0",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(
        o.status.success(),
        "{}\n{}",
        text(&o.stdout),
        text(&o.stderr)
    );
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("results.json")).unwrap()).unwrap();
    let rows = json["results"].as_array().unwrap();
    let row = |t: &str| rows.iter().find(|r| r["technique"] == t).unwrap();
    let (hard, reference) = (row("hard"), row("reference"));
    for k in ["mae_lit", "p99_lit", "mae_shadow", "max"] {
        assert_eq!(reference["errors"][k].as_f64(), Some(0.0), "{reference}");
    }
    assert_eq!(reference["flip"].as_f64(), Some(0.0), "{reference}");
    // The reference has no edge the reference lacks; its penumbra is the pixels counted.
    let fe = &reference["false_edges"];
    assert_eq!(fe["pairs"].as_u64(), Some(0), "{reference}");
    assert!(fe["penumbra_pixels"].as_u64().unwrap() > 0, "{reference}");
    assert!(reference["errors"]["lit_pixels"].as_u64().unwrap() > 50);
    let (e, flip) = (&hard["errors"], hard["flip"].as_f64().unwrap());
    assert!(e["mae_lit"].as_f64().unwrap() > 0.01, "{hard}");
    assert!(flip > 0.0 && flip < 1.0, "{hard}");
    // The FLIP map is black (magma's 0) where the images agree: all of it for the reference.
    let map = decode_png(&out.join(reference["flip_image"].as_str().unwrap())).to_rgb8();
    let first = *map.get_pixel(0, 0);
    assert!(map.pixels().all(|p| *p == first));
    let map = decode_png(&out.join(hard["flip_image"].as_str().unwrap())).to_rgb8();
    assert!(map.pixels().any(|p| *p != first));
    let _ = std::fs::remove_dir_all(&out);
}

/// results.csv and results.json say the same of every row; every pass of every row was
/// timed (minimum > 0) and every row has its ratio to `hard`.
fn rows_agree(rows: &[csv::StringRecord], headers: &csv::StringRecord, json: &serde_json::Value) {
    let results = json["results"].as_array().unwrap();
    assert_eq!(rows.len(), results.len(), "csv and json row counts");
    let hard = results
        .iter()
        .find(|r| r["technique"] == "hard")
        .expect("hard row");
    let hard_ms = hard["frame_ms"]["median"].as_f64().unwrap();
    for (row, r) in rows.iter().zip(results) {
        let what = r["technique"].to_string();
        for (h, cell) in headers.iter().zip(row.iter()) {
            let value = match h {
                "device" | "driver" => json[h].clone(),
                "frame_ms_median" | "frame_ms_min" | "frame_ms_max" => {
                    r["frame_ms"][&h["frame_ms_".len()..]].clone()
                }
                "cpu_ms_median" => r["cpu_ms"]["median"].clone(),
                "max_error" => r["errors"]["max"].clone(),
                "false_edges" => r["false_edges"]["per_1000"].clone(),
                "false_edge_pairs" => r["false_edges"]["pairs"].clone(),
                "penumbra_pixels" => r["false_edges"]["penumbra_pixels"].clone(),
                _ if h.starts_with("pass:") => r["passes"]
                    .as_array()
                    .unwrap()
                    .iter()
                    .find(|p| p["name"] == h["pass:".len()..])
                    .map_or(serde_json::Value::Null, |p| p["gpu_ms"]["median"].clone()),
                // The counters after the cpu: columns: pipeline statistics, then lookups.
                _ if h.contains(':') && !h.starts_with("cpu:") => {
                    let (prefix, pass) = h.split_once(':').unwrap();
                    let (group, field) = match prefix {
                        "frags" => ("stats", "fragment_invocations"),
                        "verts" => ("stats", "vertex_invocations"),
                        "prims" => ("stats", "clipping_primitives"),
                        "cs" => ("stats", "compute_invocations"),
                        "texels" => ("lookups", "texels"),
                        "texels_warp" => ("lookups", "texels_warp"),
                        other => panic!("{what}: unknown column group {other}"),
                    };
                    r["passes"]
                        .as_array()
                        .unwrap()
                        .iter()
                        .find(|p| p["name"] == pass)
                        .map_or(serde_json::Value::Null, |p| p[group][field].clone())
                }
                _ if h.starts_with("cpu:") => r["cpu"]
                    .as_array()
                    .unwrap()
                    .iter()
                    .find(|c| c["name"] == h["cpu:".len()..])
                    .map_or(serde_json::Value::Null, |c| c["ms"]["median"].clone()),
                _ if !r[h].is_null() || r["errors"][h].is_null() => r[h].clone(),
                _ => r["errors"][h].clone(),
            };
            let same = match &value {
                serde_json::Value::Null => cell.is_empty(),
                serde_json::Value::String(s) => s == cell,
                serde_json::Value::Bool(b) => b.to_string() == cell,
                serde_json::Value::Number(n) => {
                    let (a, b) = (n.as_f64().unwrap(), cell.parse::<f64>().unwrap_or(f64::NAN));
                    // f32 fields print shorter in the CSV than as f64 in the JSON.
                    (a - b).abs() <= 1e-6 * a.abs().max(1e-30)
                }
                other => panic!("{what}: column {h} is {other} in the json"),
            };
            assert!(same, "{what}: csv {h} = {cell:?}, json {value}");
        }
        let ms = r["frame_ms"]["median"].as_f64().unwrap();
        let ratio = r["ratio_to_hard"]
            .as_f64()
            .unwrap_or_else(|| panic!("{what}: no ratio_to_hard"));
        assert!(
            (ratio - ms / hard_ms).abs() <= 1e-12 * ratio,
            "{what}: ratio_to_hard {ratio}, frame {ms} ms, hard {hard_ms} ms"
        );
        assert!(r["frame_ms"]["min"].as_f64().unwrap() > 0.0, "{what}");
        for p in r["passes"].as_array().unwrap() {
            let min = p["gpu_ms"]["min"].as_f64();
            assert!(
                min.is_some_and(|m| m > 0.0),
                "{what}: pass {} has minimum {min:?}",
                p["name"]
            );
        }
    }
}

/// Every row's error image is the colour map of |v - v_ref| of that row's own render and the
/// reference, its reference image is v_ref and its mae_shadow theirs: each row re-rendered
/// here at the row's settings (the tiny sweep's: 64x48, buffer 128, the scene's radius).
fn images_are_of_their_rows(
    out: &Path,
    results: &[serde_json::Value],
    rows: &[csv::StringRecord],
    mae_col: &usize,
) {
    let gpu = common::Gpu::new();
    let scene = Scene::load("cylinder").unwrap();
    let params = ReferenceParams {
        samples: 256,
        seed: bench::DEFAULT_SEED,
    };
    for (r, row) in results.iter().zip(rows) {
        let what = r["technique"].to_string();
        let settings = Settings {
            width: 64,
            height: 48,
            shadow_res: 128,
            light_radius: Some(scene.light.radius),
            smoothie_t: r["smoothie_t_fixed"]
                .as_bool()
                .unwrap()
                .then(|| r["smoothie_t"].as_f64().unwrap() as f32),
            cache_light_passes: false,
            ..Settings::default()
        };
        let technique = r["technique_name"].as_str().unwrap();
        let (img, _) = gpu.render_frames(scene.clone(), technique, settings, 1);
        let v_ref = reference::visibility_cached(
            &scene,
            scene.light.radius,
            &img.position,
            &img.normal,
            &params,
        )
        .unwrap();
        // Judged: on a surface where the spot lets light fall (docs/DESIGN.md).
        let covered: Vec<bool> = img
            .position
            .iter()
            .zip(&img.spot)
            .map(|(p, &s)| p[3] > 0.5 && s > 0.0)
            .collect();
        let want = metrics::error_image(&img.visibility, &v_ref, &covered, bench::ERROR_SCALE);
        let coloured = want
            .iter()
            .filter(|&&c| c != metrics::ERROR_BACKGROUND && c != metrics::error_color(0.0, 1.0))
            .count();
        assert!(
            coloured > 20,
            "{what}: only {coloured} pixels with an error"
        );
        let got = decode_png(&out.join(r["error_image"].as_str().unwrap())).to_rgba8();
        let off = got.pixels().zip(&want).filter(|(g, w)| g.0 != **w).count();
        assert_eq!(
            off, 0,
            "{what}: {off} error-image pixels differ from |v - v_ref|"
        );
        let got = decode_png(&out.join(r["reference_image"].as_str().unwrap())).to_luma8();
        let off = got
            .pixels()
            .zip(&v_ref)
            .filter(|(g, v)| g.0[0] != (v.clamp(0.0, 1.0) * 255.0).round() as u8)
            .count();
        assert_eq!(
            off, 0,
            "{what}: {off} reference-image pixels differ from v_ref"
        );
        let facing = metrics::faces_light(&img.position, &img.normal, scene.light.position);
        let e = metrics::errors(&img.visibility, &v_ref, &covered, &facing);
        let mae: f64 = row[*mae_col].parse().unwrap();
        assert!(
            (mae - e.mae_shadow).abs() <= 1e-9,
            "{what}: csv mae_shadow {mae}, re-rendered {}",
            e.mae_shadow
        );
    }
}

/// Fails with exit != 0 and a single line on stderr, and leaves no `out` behind.
fn assert_clean_failure(args: &[&str], out: &Path, expect: &str) {
    let o = softshadow(args);
    let stderr = text(&o.stderr);
    assert!(!o.status.success(), "{args:?} succeeded");
    let lines: Vec<&str> = stderr.lines().filter(|l| !l.trim().is_empty()).collect();
    assert_eq!(
        lines.len(),
        1,
        "{args:?}: expected one line, got:\n{stderr}"
    );
    assert!(
        lines[0].contains(expect),
        "{args:?}: {:?} lacks {expect:?}",
        lines[0]
    );
    assert!(!out.exists(), "{args:?} left {}", out.display());
}

#[test]
fn bad_input_is_one_line_and_leaves_nothing() {
    let out = scratch("bad");
    let o = out.to_str().unwrap();
    let tiny = ["--width", "32", "--height", "32"];
    let with = |extra: &[&'static str]| -> Vec<String> {
        let mut v: Vec<String> = ["bench", "--out", o]
            .iter()
            .map(|s| s.to_string())
            .collect();
        v.extend(tiny.iter().map(|s| s.to_string()));
        v.extend(extra.iter().map(|s| s.to_string()));
        v
    };
    let run = |extra: &[&'static str], expect: &str| {
        let args = with(extra);
        let args: Vec<&str> = args.iter().map(|s| s.as_str()).collect();
        assert_clean_failure(&args, &out, expect);
    };
    run(
        &["--techniques", "hard,nope"],
        "invalid value 'nope' for '--techniques'",
    );
    run(&["--scenes", "cylinder,nowhere"], "unknown scene 'nowhere'");
    run(&["--samples", "0"], "--samples 0 is out of range");
    run(&["--samples", "255"], "--samples 255 is out of range");
    run(&["--frames", "0"], "--frames 0");
    run(&["--radii", "-1"], "--radii");
    run(&["--smoothie-t", "0"], "--smoothie-t 0");
    // Past every name check, the device limit stops it before the first frame.
    run(
        &[
            "--scenes",
            "cylinder",
            "--techniques",
            "hard",
            "--resolutions",
            "1000000",
        ],
        "--resolutions 1000000",
    );

    // An output folder that cannot be created: under a regular file.
    let file = scratch("bad-file");
    std::fs::write(&file, b"not a folder").unwrap();
    let under = file.join("out");
    assert_clean_failure(
        &[
            "bench",
            "--out",
            under.to_str().unwrap(),
            "--samples",
            "256",
        ],
        &under,
        "cannot create output folder",
    );
    let o = softshadow(&["bench", "--out", file.to_str().unwrap(), "--samples", "256"]);
    assert!(!o.status.success());
    assert!(
        text(&o.stderr).contains("is not a folder"),
        "{}",
        text(&o.stderr)
    );
    assert_eq!(
        std::fs::read(&file).unwrap(),
        b"not a folder",
        "the file was touched"
    );
    let _ = std::fs::remove_file(&file);
}

/// A module of the given instructions (opcode, operand words) after a 5-word header.
fn module(instrs: &[(u32, usize)]) -> Vec<u8> {
    let mut words = vec![0x0723_0203u32, 0x0001_0000, 0, 100, 0];
    for &(op, operands) in instrs {
        words.push(((operands as u32 + 1) << 16) | op);
        words.extend(std::iter::repeat_n(1, operands));
    }
    words.iter().flat_map(|w| w.to_le_bytes()).collect()
}

#[test]
fn spirv_counts_walk_the_words() {
    // OpCapability, OpMemoryModel, OpTypeFloat | OpFunction, OpLabel, OpLoad, OpFAdd,
    // OpFMul, OpStore, OpReturn, OpFunctionEnd.
    let m = module(&[
        (17, 1),
        (14, 2),
        (22, 2),
        (54, 4),
        (248, 1),
        (61, 3),
        (129, 4),
        (133, 4),
        (62, 2),
        (253, 0),
        (56, 0),
    ]);
    let c = spirv::count(&m).expect("valid module");
    assert_eq!(
        c,
        spirv::Counts {
            total: 11,
            body: 8,
            ops: 2
        }
    );
    // Big-endian modules count the same.
    let be: Vec<u8> = m.chunks(4).flat_map(|w| [w[3], w[2], w[1], w[0]]).collect();
    assert_eq!(spirv::count(&be).unwrap(), c);
    // A word count running past the end, a zero word count, a wrong magic: errors.
    let mut bad = m.clone();
    bad.truncate(bad.len() - 4);
    bad.extend_from_slice(&((3u32 << 16) | 56).to_le_bytes());
    assert!(spirv::count(&bad).is_err());
    let zero: Vec<u8> = [0x0723_0203u32, 0x0001_0000, 0, 100, 0, 0]
        .iter()
        .flat_map(|w| w.to_le_bytes())
        .collect();
    assert!(spirv::count(&zero).is_err());
    assert!(spirv::count(&[0u8; 24]).is_err());

    // Every shipped shader is listed and counted; spirv-opt never grows a module's total,
    // except where it unrolls loops of a fixed count (ssm-bitmask's edges and layers: 1059
    // words raw, 1614 shipped).
    const UNROLLED: &[&str] = &["ssm_bitmask/soft_shadow.frag"];
    let table = spirv::cost_table(softshadow::shaders::ALL).expect("every shader counts");
    assert!(table
        .iter()
        .any(|s| s.shader == "smoothies/smoothie.frag" && s.paper.is_some()));
    for s in &table {
        assert!(
            s.shipped.body > 0 && s.shipped.body <= s.shipped.total,
            "{s:?}"
        );
        if let (Some(raw), true) = (s.glslang, s.optimised) {
            if UNROLLED.contains(&s.shader.as_str()) {
                assert!(s.shipped.total > raw.total, "{s:?} is no longer unrolled");
            } else {
                assert!(s.shipped.total <= raw.total, "{s:?}");
            }
        }
    }
}

#[test]
fn pareto_front_keeps_the_points_nothing_beats() {
    let pts = [
        (1.0, 0.5),
        (1.5, 0.2),
        (1.2, 0.6),
        (3.0, 0.1),
        (2.0, 0.3),
        (f64::NAN, 0.0),
    ];
    assert_eq!(pareto_front(&pts), vec![0, 1, 3]);
    assert_eq!(pareto_front(&[]), Vec::<usize>::new());
    // Ties on x keep the more accurate point only.
    assert_eq!(pareto_front(&[(1.0, 0.5), (1.0, 0.4)]), vec![1]);
}

#[test]
fn stat_is_median_min_max() {
    let s = Stat::of(&[3.0, 1.0, 2.0, f64::NAN]).unwrap();
    assert_eq!((s.median, s.min, s.max), (2.0, 1.0, 3.0));
    assert_eq!(Stat::of(&[4.0, 1.0, 2.0, 3.0]).unwrap().median, 2.5);
    assert!(Stat::of(&[]).is_none());
}

#[test]
fn rows_put_hard_first_and_smoothies_twice() {
    let names = |v: &[&str]| v.iter().map(|s| s.to_string()).collect::<Vec<_>>();
    let (rows, added) = bench::variants(&names(&["smoothies"]), &[0.02, 0.2], &[]).unwrap();
    assert!(added);
    let labels: Vec<&str> = rows.iter().map(|r| r.label.as_str()).collect();
    assert_eq!(
        labels,
        ["hard", "smoothies", "smoothies t=0.02", "smoothies t=0.2"]
    );
    assert_eq!(rows[1].smoothie_t, None);
    assert_eq!(rows[3].smoothie_t, Some(0.2));
    let (rows, added) = bench::variants(&names(&["smoothies", "hard", "hard"]), &[], &[]).unwrap();
    assert!(!added);
    assert_eq!(rows.len(), 2);
    assert!(bench::variants(&names(&["nope"]), &[], &[]).is_err());
    assert!(!bench::default_techniques().iter().any(|t| t == "reference"));
}

#[test]
fn radius_and_motion_flags_parse() {
    assert_eq!("scene".parse::<Radius>().unwrap(), Radius::Scene);
    assert_eq!("0.5x".parse::<Radius>().unwrap(), Radius::Times(0.5));
    assert_eq!("0".parse::<Radius>().unwrap(), Radius::Abs(0.0));
    for bad in ["-1", "x", "nan", "inf", ""] {
        assert!(bad.parse::<Radius>().is_err(), "{bad}");
    }
    assert_eq!("Light".parse::<Motion>().unwrap(), Motion::Light);
    // Each motion moves what it names, and only that; frame 0 is the scene at rest.
    let base = softshadow::scene::Scene::load("boxes").unwrap();
    let at = |m: Motion, f: u32| m.apply(&base, f);
    assert_eq!(at(Motion::Static, 5).light, base.light);
    assert_eq!(at(Motion::Light, 0).light, base.light);
    assert_ne!(at(Motion::Light, 3).light.position, base.light.position);
    assert_eq!(at(Motion::Light, 3).camera, base.camera);
    assert_ne!(at(Motion::Camera, 3).camera.position, base.camera.position);
    let caster = base.objects.iter().position(|o| o.role.casts()).unwrap();
    assert_ne!(
        at(Motion::Object, 3).objects[caster].transform,
        base.objects[caster].transform
    );
    assert_eq!(at(Motion::Object, 3).light, base.light);
    assert!("wobble".parse::<Motion>().is_err());
    assert_eq!(bench::slug("smoothies t=0.02"), "smoothies-t-0.02");
}

mod common;

/// Through the library: a moving sweep times frames while moving, and measures its error
/// on the scene put back at rest, so its errors equal the static sweep's.
#[test]
fn moving_sweeps_are_timed_moving_and_measured_at_rest() {
    let gpu = common::Gpu::new();
    let out = scratch("motion");
    let config = bench::BenchConfig {
        scenes: vec!["boxes".into()],
        techniques: vec!["hard".into(), "smoothies".into()],
        resolutions: vec![128],
        radii: vec![Radius::Scene],
        smoothie_t: vec![],
        width: 64,
        height: 64,
        frames: 3,
        warmup: 1,
        samples: 256,
        motions: vec![
            Motion::Static,
            Motion::Light,
            Motion::Object,
            Motion::Camera,
        ],
        out: out.clone(),
        progress: false,
        ..bench::BenchConfig::default()
    };
    let plan = bench::prepare(config).expect("valid sweep");
    assert_eq!(plan.len(), 8);
    let outcome = bench::run(&gpu.ctx, plan).expect("sweep runs");
    let rec = |t: &str, m: Motion| {
        outcome
            .records
            .iter()
            .find(|r| r.technique == t && r.motion == m)
            .unwrap_or_else(|| panic!("no record {t} {m:?}"))
    };
    for t in ["hard", "smoothies"] {
        let still = rec(t, Motion::Static);
        for m in [Motion::Light, Motion::Object, Motion::Camera] {
            let moving = rec(t, m);
            assert_eq!(
                moving.errors, still.errors,
                "{t} {m:?}: errors not measured at rest"
            );
            assert!(moving.ratio_to_hard.is_some());
        }
    }
    // Smoothies redo their silhouettes every frame, moving or not: a CPU timing each frame.
    let s = rec("smoothies", Motion::Light);
    assert_eq!(s.cpu.len(), 1);
    assert!(s.cpu_ms.median > 0.0);
    assert!(outcome.files.iter().all(|f| out.join(f).is_file()));
    let _ = std::fs::remove_dir_all(&out);
}

/// By default every timed frame runs every pass; with reuse a static frame reuses the
/// light-space passes and says why.
#[test]
fn light_passes_are_rebuilt_unless_reuse_is_asked() {
    let gpu = common::Gpu::new();
    let run = |reuse: bool| {
        let out = scratch(&format!("reuse-{reuse}"));
        let config = bench::BenchConfig {
            scenes: vec!["cylinder".into()],
            techniques: vec!["smoothies".into()],
            resolutions: vec![128],
            smoothie_t: vec![],
            width: 64,
            height: 64,
            frames: 2,
            warmup: 1,
            reuse_light_passes: reuse,
            out: out.clone(),
            progress: false,
            ..bench::BenchConfig::default()
        };
        let outcome = bench::run(&gpu.ctx, bench::prepare(config).expect("valid")).expect("runs");
        let _ = std::fs::remove_dir_all(&out);
        outcome
            .records
            .into_iter()
            .find(|r| r.technique == "smoothies")
            .expect("smoothies row")
    };
    let full = run(false);
    assert!(
        full.passes
            .iter()
            .all(|p| p.gpu_ms.is_some() && p.frames_not_run == 0),
        "{:?}",
        full.passes
    );
    assert!(!full.cpu.is_empty(), "silhouettes not timed");
    let reused = run(true);
    let light: Vec<_> = reused
        .passes
        .iter()
        .filter(|p| p.name != "smoothies/final")
        .collect();
    assert!(!light.is_empty());
    for p in light {
        assert_eq!(p.frames_not_run, 2, "{p:?}");
        assert!(
            p.not_run_reason
                .as_deref()
                .is_some_and(|r| r.contains("unchanged")),
            "{p:?}"
        );
    }
}

/// Per-caster caches show in the report: with reuse, an object motion rebuilds one of
/// `boxes`' two casters' plateaus each frame, and report.md says so.
#[test]
fn bench_reports_partial_rebuilds() {
    let gpu = common::Gpu::new();
    let out = scratch("rebuilds");
    let config = bench::BenchConfig {
        scenes: vec!["boxes".into()],
        techniques: vec!["plateaus".into()],
        resolutions: vec![128],
        smoothie_t: vec![],
        width: 64,
        height: 64,
        frames: 3,
        warmup: 1,
        motions: vec![Motion::Object],
        reuse_light_passes: true,
        out: out.clone(),
        progress: false,
        ..bench::BenchConfig::default()
    };
    let outcome = bench::run(&gpu.ctx, bench::prepare(config).expect("valid")).expect("runs");
    let row = outcome
        .records
        .iter()
        .find(|r| r.technique == "plateaus")
        .expect("plateaus row");
    let sil = row
        .cpu
        .iter()
        .find(|c| c.name == "plateaus/silhouettes")
        .expect("silhouettes timed");
    assert_eq!(sil.casters, Some(2));
    assert_eq!(sil.rebuilt.as_ref().map(|k| k.median), Some(1.0));
    let report = std::fs::read_to_string(out.join("report.md")).expect("report.md");
    assert!(report.contains("(rebuilt 1 of 2 casters)"), "{}", report);
    let _ = std::fs::remove_dir_all(&out);
}

/// Every file under `dir` with its bytes, sorted.
fn tree(dir: &Path) -> Vec<(PathBuf, Vec<u8>)> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                out.push((p.clone(), Vec::new()));
                stack.push(p);
            } else {
                out.push((p.clone(), std::fs::read(&p).unwrap()));
            }
        }
    }
    out.sort();
    out
}

/// A sweep that fails at its second point, after the first staged its images and its
/// reference, leaves a previous run's `--out` exactly as it was (nothing added, nothing
/// replaced, no staging folder) and says why on one line.
#[test]
fn a_sweep_failing_part_way_leaves_out_as_it_was() {
    let out = scratch("midway");
    std::fs::create_dir_all(out.join("images")).unwrap();
    std::fs::write(out.join("results.csv"), b"a previous run").unwrap();
    std::fs::write(out.join("images").join("old.png"), b"a previous image").unwrap();
    let before = tree(&out);
    let args = [
        "--validation",
        "bench",
        "--scenes",
        "cylinder",
        "--techniques",
        "hard,pcf",
        "--resolutions",
        "128",
        "--width",
        "32",
        "--height",
        "32",
        "--frames",
        "1",
        "--warmup",
        "0",
        "--samples",
        "256",
        "--out",
        out.to_str().unwrap(),
    ];
    let run = |fail_at: Option<&str>| {
        let device = std::env::var("SOFTSHADOW_DEVICE").unwrap_or_else(|_| "llvmpipe".into());
        let mut c = Command::new(env!("CARGO_BIN_EXE_softshadow"));
        c.args(args).env("SOFTSHADOW_DEVICE", device);
        match fail_at {
            Some(n) => c.env("SOFTSHADOW_BENCH_FAIL_AT", n),
            None => c.env_remove("SOFTSHADOW_BENCH_FAIL_AT"),
        };
        c.output().expect("running softshadow")
    };
    let o = run(Some("1"));
    let stderr = text(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{stderr}");
    // The first point ran (its progress line), the second failed with one error line.
    assert!(stderr.contains("[1/2] cylinder / hard"), "{stderr}");
    let errors: Vec<&str> = stderr.lines().filter(|l| l.starts_with("error:")).collect();
    assert!(
        errors.len() == 1 && errors[0].contains("sweep point 1"),
        "{stderr}"
    );
    assert_eq!(tree(&out), before, "a failed sweep changed --out");
    // The same sweep without the failure replaces the previous run's results: the check
    // above could fail.
    let o = run(None);
    assert!(o.status.success(), "{}", text(&o.stderr));
    assert_ne!(tree(&out), before);
    let _ = std::fs::remove_dir_all(&out);
}
