//! The bench's text outputs: `results.csv` (one flat row per sweep point, a column per
//! pass), `results.json` (everything, per pass; both documented in docs/RESULTS.md), and
//! `report.md` (a table per scene, the images, the SPIR-V cost
//! table; written to be pasted into BENCHMARKS.md). Every one names the device and driver.

use super::bench::{Motion, Record, Results, BASELINE, ERROR_SCALE_IMAGE};
use super::spirv::{Counts, ShaderCost};
use anyhow::{Context as _, Result};
use std::fmt::Write as _;
use std::path::Path;

/// The fixed columns of results.csv, in order (documented in docs/RESULTS.md). After them
/// come one `pass:NAME` column per GPU pass and one `cpu:NAME` column per named CPU work
/// seen anywhere in the run, in first-seen order: the median ms, empty where a row has no
/// such pass or every timed frame skipped it.
pub const CSV_COLUMNS: &[&str] = &[
    "device",
    "driver",
    "scene",
    "technique",
    "technique_name",
    "width",
    "height",
    "shadow_res",
    "light_kind",
    "angular_radius_deg",
    "radius_spec",
    "light_radius",
    "motion",
    "smoothie_t",
    "smoothie_t_fixed",
    "spirv",
    "silhouettes",
    "frames",
    "warmup",
    "frame_ms_median",
    "frame_ms_min",
    "frame_ms_max",
    "ratio_to_hard",
    "cpu_ms_median",
    "mae_lit",
    "p99_lit",
    "flip",
    "false_edges",
    "false_edge_pairs",
    "penumbra_pixels",
    "mae_shadow",
    "rmse",
    "p99",
    "max_error",
    "lit_pixels",
    "shadow_pixels",
    "covered_pixels",
    "image",
    "error_image",
    "flip_image",
];

/// A float as a CSV cell: the shortest text that reads back to the same value, always
/// with a decimal point so that readers type the column as floating point.
fn num(v: impl Into<f64> + std::fmt::Display + Copy) -> String {
    let s = v.to_string();
    if v.into().is_finite() && !s.contains('.') {
        s + ".0"
    } else {
        s
    }
}

fn opt_num<T: Into<f64> + std::fmt::Display + Copy>(v: Option<T>) -> String {
    v.map(num).unwrap_or_default()
}

/// The fixed cells of a row, in `CSV_COLUMNS` order.
fn csv_cells(res: &Results<'_>, r: &Record) -> Vec<String> {
    let e = &r.errors;
    vec![
        res.device.clone(),
        res.driver.clone(),
        r.scene.clone(),
        r.technique.clone(),
        r.technique_name.clone(),
        r.width.to_string(),
        r.height.to_string(),
        r.shadow_res.to_string(),
        r.light_kind.into(),
        opt_num(r.angular_radius_deg),
        r.radius_spec.clone(),
        num(r.light_radius),
        r.motion.name().into(),
        opt_num(r.smoothie_t),
        r.smoothie_t_fixed.to_string(),
        r.spirv.name().into(),
        r.silhouettes.into(),
        r.frames.to_string(),
        r.warmup.to_string(),
        num(r.frame_ms.median),
        num(r.frame_ms.min),
        num(r.frame_ms.max),
        opt_num(r.ratio_to_hard),
        num(r.cpu_ms.median),
        num(e.mae_lit),
        num(e.p99_lit),
        num(r.flip),
        num(r.false_edges.per_1000),
        r.false_edges.pairs.to_string(),
        r.false_edges.penumbra_pixels.to_string(),
        num(e.mae_shadow),
        num(e.rmse),
        num(e.p99),
        num(e.max),
        e.lit_pixels.to_string(),
        e.shadow_pixels.to_string(),
        e.covered_pixels.to_string(),
        r.image.clone(),
        r.error_image.clone(),
        r.flip_image.clone(),
    ]
}

pub fn write_csv(path: &Path, res: &Results<'_>) -> Result<()> {
    let mut passes: Vec<&str> = Vec::new();
    let mut cpu: Vec<&str> = Vec::new();
    for r in res.results {
        for p in &r.passes {
            if !passes.contains(&p.name.as_str()) {
                passes.push(&p.name);
            }
        }
        for c in &r.cpu {
            if !cpu.contains(&c.name.as_str()) {
                cpu.push(&c.name);
            }
        }
    }
    let header: Vec<String> = CSV_COLUMNS
        .iter()
        .map(|c| c.to_string())
        .chain(passes.iter().map(|p| format!("pass:{p}")))
        .chain(cpu.iter().map(|c| format!("cpu:{c}")))
        .chain(
            STATS_COLUMNS
                .iter()
                .flat_map(|(prefix, _)| passes.iter().map(move |p| format!("{prefix}:{p}"))),
        )
        .chain(
            LOOKUP_COLUMNS
                .iter()
                .flat_map(|(prefix, _)| passes.iter().map(move |p| format!("{prefix}:{p}"))),
        )
        .collect();
    let mut w =
        csv::Writer::from_path(path).with_context(|| format!("writing {}", path.display()))?;
    w.write_record(&header)
        .with_context(|| format!("writing {}", path.display()))?;
    for r in res.results {
        let mut cells = csv_cells(res, r);
        debug_assert_eq!(cells.len(), CSV_COLUMNS.len());
        cells.extend(passes.iter().map(|name| {
            let p = r.passes.iter().find(|p| p.name == *name);
            opt_num(p.and_then(|p| p.gpu_ms).map(|s| s.median))
        }));
        cells.extend(cpu.iter().map(|name| {
            let c = r.cpu.iter().find(|c| c.name == *name);
            opt_num(c.map(|c| c.ms.median))
        }));
        for (_, counter) in STATS_COLUMNS {
            cells.extend(passes.iter().map(|name| {
                let p = r.passes.iter().find(|p| p.name == *name);
                p.and_then(|p| p.stats)
                    .map(|s| counter(&s).to_string())
                    .unwrap_or_default()
            }));
        }
        for (_, counter) in LOOKUP_COLUMNS {
            cells.extend(passes.iter().map(|name| {
                let p = r.passes.iter().find(|p| p.name == *name);
                p.and_then(|p| p.lookups)
                    .map(|l| counter(&l).to_string())
                    .unwrap_or_default()
            }));
        }
        w.write_record(&cells)
            .with_context(|| format!("writing {}", path.display()))?;
    }
    w.flush()
        .with_context(|| format!("writing {}", path.display()))
}

/// The per-pass counter columns of results.csv after the `cpu:` ones, one group per counter
/// (`frags:NAME` for every pass, then `verts:NAME`, ...): docs/RESULTS.md.
type Counter = fn(&crate::vk::PassStats) -> u64;
const STATS_COLUMNS: [(&str, Counter); 4] = [
    ("frags", |s| s.fragment_invocations),
    ("verts", |s| s.vertex_invocations),
    ("prims", |s| s.clipping_primitives),
    ("cs", |s| s.compute_invocations),
];

/// Then the counted lookups of the final passes (`results[].passes[].lookups`).
type LookupCounter = fn(&super::bench::Lookups) -> u64;
const LOOKUP_COLUMNS: [(&str, LookupCounter); 2] =
    [("texels", |l| l.texels), ("texels_warp", |l| l.texels_warp)];

pub fn write_json(path: &Path, res: &Results<'_>) -> Result<()> {
    let text = serde_json::to_string_pretty(res).context("serialising results")?;
    std::fs::write(path, text + "\n").with_context(|| format!("writing {}", path.display()))
}

/// `technique/pass` -> `pass`, the technique being the row.
fn short(name: &str) -> &str {
    name.rsplit_once('/').map_or(name, |(_, p)| p)
}

fn ms(v: f64) -> String {
    if v >= 100.0 {
        format!("{v:.1}")
    } else if v >= 10.0 {
        format!("{v:.2}")
    } else {
        format!("{v:.3}")
    }
}

/// A world-unit length with 4 significant digits.
fn length(v: f32) -> String {
    if v == 0.0 || !v.is_finite() {
        return format!("{v}");
    }
    let digits = (3 - v.abs().log10().floor() as i32).clamp(0, 8) as usize;
    format!("{v:.digits$}")
}

fn radius_cell(r: &Record) -> String {
    if r.radius_spec.parse::<f32>().is_ok() {
        length(r.light_radius)
    } else {
        format!("{} ({})", length(r.light_radius), r.radius_spec)
    }
}

fn t_cell(r: &Record) -> String {
    match r.smoothie_t {
        Some(t) if r.smoothie_t_fixed => format!("{t} fixed"),
        Some(t) => format!("{t:.4} calibrated"),
        None => String::new(),
    }
}

fn counts_cells(c: Option<Counts>) -> String {
    match c {
        Some(c) => format!("{} | {} | {}", c.total, c.body, c.ops),
        None => "– | – | –".into(),
    }
}

/// Everything as Markdown.
pub fn markdown(res: &Results<'_>) -> String {
    let mut s = String::new();
    let moving = res.results.iter().any(|r| r.motion != Motion::Static);
    let _ = writeln!(s, "# softshadow bench\n");
    let _ = writeln!(s, "- {}", res.device_line);
    if !res.command.is_empty() {
        let _ = writeln!(s, "- command: `{}`", res.command);
    }
    let _ = writeln!(
        s,
        "- image {}x{}; per sweep point {} warm-up frames, then {} timed frames; a figure is the median (min–max) over the timed frames; frame time is the sum of the GPU time of the passes",
        res.image_size[0], res.image_size[1], res.warmup, res.frames
    );
    let _ = writeln!(
        s,
        "- errors against the ray-cast reference ({} samples per pixel, seed {:#x}; docs/DESIGN.md): `mae_lit` (the headline) and `p99_lit`, the mean and 99th percentile of |v − v_ref| over the shadow-and-penumbra pixels whose surface faces the light (n·l ≥ 0.2); `flip`, the mean NVIDIA ꟻLIP error of the shaded image against the reference's shaded image (ambient 0.12 + 0.88·n·l·v·spot, gamma 2.2; 67 pixels per degree); `mae_shadow` over every shadow-and-penumbra pixel (Atty et al. Sec. 5.2.1); `rmse` over all covered pixels; `p99` and `max` of the shadow-and-penumbra pixels",
        res.reference_samples, res.reference_seed
    );
    for n in &res.notes {
        let _ = writeln!(s, "- {n}");
    }
    let _ = writeln!(
        s,
        "- compare techniques only inside this run (ratios to `{BASELINE}`): absolute times differ between machines and runs\n"
    );

    let mut scenes: Vec<&str> = Vec::new();
    for r in res.results {
        if !scenes.contains(&r.scene.as_str()) {
            scenes.push(&r.scene);
        }
    }
    for scene in &scenes {
        let rows: Vec<&Record> = res.results.iter().filter(|r| r.scene == *scene).collect();
        let _ = writeln!(s, "## {scene}\n");
        let motion_h = if moving { " motion |" } else { "" };
        let motion_a = if moving { ":---|" } else { "" };
        let _ = writeln!(
            s,
            "| technique | buffer | R |{motion_h} smoothie t | frame ms (min–max) | × {BASELINE} | CPU ms | mae_lit | p99_lit | flip | false edges ‰ | mae_shadow | rmse | p99 | max |"
        );
        let _ = writeln!(
            s,
            "|:---|---:|---:|{motion_a}:---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"
        );
        for r in &rows {
            let motion = if moving {
                format!(" {} |", r.motion.name())
            } else {
                String::new()
            };
            let _ = writeln!(
                s,
                "| {} | {} | {} |{motion} {} | {} ({}–{}) | {} | {} | {:.4} | {:.3} | {:.4} | {:.1} | {:.4} | {:.4} | {:.4} | {:.3} |",
                r.technique,
                r.shadow_res,
                radius_cell(r),
                t_cell(r),
                ms(r.frame_ms.median),
                ms(r.frame_ms.min),
                ms(r.frame_ms.max),
                r.ratio_to_hard.map_or("–".into(), |x| format!("{x:.2}")),
                if r.cpu.is_empty() { "–".into() } else { ms(r.cpu_ms.median) },
                r.errors.mae_lit,
                r.errors.p99_lit,
                r.flip,
                r.false_edges.per_1000,
                r.errors.mae_shadow,
                r.errors.rmse,
                r.errors.p99,
                r.errors.max,
            );
        }
        ranking(&mut s, &rows);
        let _ = writeln!(s, "\nPer pass, median GPU ms (CPU work marked `cpu`):\n");
        let _ = writeln!(s, "| technique | buffer | R |{motion_h} passes |");
        let _ = writeln!(s, "|:---|---:|---:|{motion_a}:---|");
        for r in &rows {
            let motion = if moving {
                format!(" {} |", r.motion.name())
            } else {
                String::new()
            };
            let mut cells: Vec<String> = r
                .passes
                .iter()
                .map(|p| match (&p.gpu_ms, &p.not_run_reason) {
                    (Some(st), _) => format!("{} {}", short(&p.name), ms(st.median)),
                    (None, Some(why)) => format!("{} skipped ({why})", short(&p.name)),
                    (None, None) => format!("{} n/a", short(&p.name)),
                })
                .collect();
            cells.extend(r.cpu.iter().map(|c| match (&c.rebuilt, c.casters) {
                (Some(k), Some(n)) => format!(
                    "cpu {} {} (rebuilt {} of {n} casters)",
                    short(&c.name),
                    ms(c.ms.median),
                    k.median
                ),
                _ => format!("cpu {} {}", short(&c.name), ms(c.ms.median)),
            }));
            let _ = writeln!(
                s,
                "| {} | {} | {} |{motion} {} |",
                r.technique,
                r.shadow_res,
                radius_cell(r),
                cells.join(" · ")
            );
        }
        // Images of one point per technique: the largest buffer, the first radius, at rest.
        if let Some(first) = rows.first() {
            let res_max = rows
                .iter()
                .map(|r| r.shadow_res)
                .max()
                .unwrap_or(first.shadow_res);
            let shown: Vec<&&Record> = rows
                .iter()
                .filter(|r| {
                    r.shadow_res == res_max
                        && r.radius_spec == first.radius_spec
                        && r.motion == first.motion
                })
                .collect();
            let _ = writeln!(
                s,
                "\nImages at buffer {res_max}, R {}: the rendered image, |v − v_ref| ![colour scale]({ERROR_SCALE_IMAGE}) black 0, blue, cyan, green, yellow, red at {} and above (grey: background), and the ꟻLIP error map against the reference's image (magma: black no visible difference, yellow-white the largest); every sweep point's images are in `images/`. The reference: ![reference image]({}) ![reference visibility]({})\n",
                radius_cell(first),
                res.error_image_scale,
                first.reference_shaded_image,
                first.reference_image
            );
            let _ = writeln!(s, "| technique | image | abs(v − v_ref) | ꟻLIP |");
            let _ = writeln!(s, "|:---|:---:|:---:|:---:|");
            for r in shown {
                let t = &r.technique;
                let _ = writeln!(
                    s,
                    "| {t} | ![{t} image]({}) | ![{t} error]({}) | ![{t} flip]({}) |",
                    r.image, r.error_image, r.flip_image
                );
            }
        }
        let _ = writeln!(s);
    }

    let _ = writeln!(s, "## Time against error\n");
    let _ = writeln!(
        s,
        "Per scene: x = frame time as a ratio to `{BASELINE}`, y = `mae_lit`; the line is the Pareto front (no other point is both faster and more accurate on lit surfaces).\n"
    );
    let _ = writeln!(s, "![time against error](time_vs_error.png)\n");
    let _ = writeln!(s, "![warp lookups against error](lookups_vs_error.png)\n");

    let _ = writeln!(s, "## SPIR-V instruction counts\n");
    let _ = writeln!(
        s,
        "Per shader file: instructions in the whole module (total), from the first OpFunction on (body), and in the body less labels, branches, merges, function framing, variables, loads, stores and access chains (ops, the nearest to the paper's assembly counts). \"glslang\" is glslangValidator's output, \"shipped\" what the renderer runs by default (spirv-opt -O), \"tuned\" the hand-tuned `.spvasm` beside the shader that `--spirv tuned` runs (rows `... spirv=tuned` above). The last column is the smoothie paper's Fig. 11 count for the same job.\n"
    );
    let _ = writeln!(
        s,
        "| shader | stage | glslang total | body | ops | shipped total | body | ops | shipped is | tuned total | body | ops | paper (Fig. 11) |"
    );
    let _ = writeln!(
        s,
        "|:---|:---|---:|---:|---:|---:|---:|---:|:---|---:|---:|---:|:---|"
    );
    // A hand-tuned module is shown in its shader's row.
    let shown_beside = |c: &ShaderCost| {
        c.hand_tuned
            && res
                .spirv
                .iter()
                .any(|g| g.tuned.is_some() && format!("{}.spvasm", g.shader) == c.shader)
    };
    for c in res.spirv.iter().filter(|c| !shown_beside(c)) {
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {} | {} | {} |",
            c.shader,
            c.stage,
            counts_cells(c.glslang),
            counts_cells(Some(c.shipped)),
            shipped_is(c),
            counts_cells(c.tuned),
            c.paper.unwrap_or("")
        );
    }
    let _ = writeln!(s, "\n## Reproducing\n");
    let _ = writeln!(
        s,
        "- default sweep (a few minutes on lavapipe): `softshadow bench --out DIR` = scenes cylinder, boxes, primitives; 512x512 image; buffers 512 and 1024; the scene's light radius; every technique but `reference`; 2 warm-up + 5 timed frames; 256 reference samples"
    );
    let _ = writeln!(
        s,
        "- full sweep: `softshadow bench --full --out DIR` = every built-in scene; 1024x1024 image; buffers 256, 512, 1024, 2048; radii 0, 0.5x, scene, 2x; 20 timed frames (any flag given overrides the preset's value)"
    );
    s
}

/// One line per group of comparable rows (same buffer, radius and motion): the Pareto front
/// on (× hard, mae_lit), fastest first, then every row from the most to the least accurate.
fn ranking(s: &mut String, rows: &[&Record]) {
    let mut groups: Vec<(u32, &str, Motion)> = Vec::new();
    for r in rows {
        let k = (r.shadow_res, r.radius_spec.as_str(), r.motion);
        if !groups.contains(&k) {
            groups.push(k);
        }
    }
    for (res, radius, motion) in &groups {
        let g: Vec<&Record> = rows
            .iter()
            .copied()
            .filter(|r| r.shadow_res == *res && r.radius_spec == *radius && r.motion == *motion)
            .collect();
        let pts: Vec<(f64, f64)> = g
            .iter()
            .map(|r| (r.ratio_to_hard.unwrap_or(f64::NAN), r.errors.mae_lit))
            .collect();
        let front: Vec<String> = super::plot::pareto_front(&pts)
            .into_iter()
            .map(|i| format!("{} ({:.2}×, {:.4})", g[i].technique, pts[i].0, pts[i].1))
            .collect();
        let mut by_error = g.clone();
        by_error.sort_by(|a, b| a.errors.mae_lit.total_cmp(&b.errors.mae_lit));
        let order: Vec<&str> = by_error.iter().map(|r| r.technique.as_str()).collect();
        let mut at = format!("buffer {res}, R {radius}");
        if *motion != Motion::Static {
            at += &format!(", {}", motion.name());
        }
        let _ = writeln!(
            s,
            "\n{at}: Pareto front on (× {BASELINE}, mae_lit): {}. By mae_lit, best first: {}.",
            front.join(" → "),
            order.join(", ")
        );
    }
}

fn shipped_is(c: &ShaderCost) -> &'static str {
    if c.hand_tuned {
        "hand-tuned"
    } else if c.optimised {
        "spirv-opt -O"
    } else {
        "glslang (no spirv-opt)"
    }
}

pub fn write_markdown(path: &Path, res: &Results<'_>) -> Result<()> {
    std::fs::write(path, markdown(res)).with_context(|| format!("writing {}", path.display()))
}
