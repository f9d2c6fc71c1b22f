//! `time_vs_error.png`: per scene, frame time as a ratio to `hard` against `mae_lit`,
//! one colour per technique, the Pareto front drawn, its points named; and its twin
//! `lookups_vs_error.png`, the frame's warp lookups (light passes included) as a ratio to `hard`'s on x. Both x
//! axes are logarithmic: the costly rows (64x and beyond) would otherwise squeeze the rest
//! into the left edge. Rendered with plotters' bitmap
//! backend into memory and saved with `image`; text uses DejaVu Sans compiled in
//! (assets/fonts, via plotters' `ab_glyph` feature), so no system font is needed.

use super::bench::{Motion, Record, Results, BASELINE};
use anyhow::{anyhow, Context as _, Result};
use plotters::prelude::*;
use plotters::style::{register_font, FontStyle};
use std::path::Path;
use std::sync::Once;

const FONT: &[u8] = include_bytes!(concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/assets/fonts/DejaVuSans.ttf"
));
const PANEL: (u32, u32) = (640, 480);
const HEADER: u32 = 84;
const COLUMNS: usize = 3;

/// One colour per row of a full bench (every technique, smoothies twice): a colour shared by
/// two rows would make their points indistinguishable.
const COLOURS: &[RGBColor] = &[
    RGBColor(0, 0, 0),
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
    RGBColor(188, 189, 34),
    RGBColor(23, 190, 207),
    RGBColor(0, 0, 128),
    RGBColor(230, 190, 0),
    RGBColor(0, 128, 128),
    RGBColor(128, 0, 0),
    RGBColor(255, 0, 255),
    RGBColor(96, 160, 255),
];

fn fonts() -> Result<()> {
    static ONCE: Once = Once::new();
    let mut ok = true;
    ONCE.call_once(|| ok = register_font("sans-serif", FontStyle::Normal, FONT).is_ok());
    if ok {
        Ok(())
    } else {
        Err(anyhow!("the compiled-in DejaVu Sans font did not load"))
    }
}

/// Indices of the points no other point beats on both axes (smaller is better), in order
/// of increasing x.
pub fn pareto_front(points: &[(f64, f64)]) -> Vec<usize> {
    let mut idx: Vec<usize> = (0..points.len())
        .filter(|&i| points[i].0.is_finite() && points[i].1.is_finite())
        .collect();
    idx.sort_by(|&a, &b| {
        points[a]
            .0
            .total_cmp(&points[b].0)
            .then(points[a].1.total_cmp(&points[b].1))
    });
    let mut front = Vec::new();
    let mut best = f64::INFINITY;
    for i in idx {
        if points[i].1 < best {
            best = points[i].1;
            front.push(i);
        }
    }
    front
}

fn plot_err<E: std::error::Error + Send + Sync + 'static>(e: E) -> anyhow::Error {
    anyhow!("drawing the time/error plot: {e}")
}

/// Frame time against error for every scene of `res`, into `path`.
pub fn time_vs_error(path: &Path, res: &Results<'_>) -> Result<()> {
    scatter(
        path,
        res,
        "Frame time (ratio to hard) against mae_lit",
        &format!("frame time / {BASELINE} (log)"),
        |r, _| r.ratio_to_hard,
    )
}

/// The frame's warp lookups of a row: every counted pass's (`Lookups::texels_warp`), the
/// light passes' included.
fn warp_lookups(r: &Record) -> Option<f64> {
    let counted: Vec<f64> = r
        .passes
        .iter()
        .filter_map(|p| p.lookups)
        .map(|l| l.texels_warp as f64)
        .collect();
    (!counted.is_empty()).then(|| counted.iter().sum())
}

/// The twin of `time_vs_error`: the frame's warp lookups (light passes and final pass) as a
/// ratio to `hard`'s in the same panel, against error.
pub fn lookups_vs_error(path: &Path, res: &Results<'_>) -> Result<()> {
    scatter(
        path,
        res,
        "Warp lookups of the frame (ratio to hard) against mae_lit",
        &format!("warp lookups / {BASELINE} (log)"),
        |r, panel| {
            let hard = panel
                .iter()
                .find(|h| h.technique == BASELINE && h.shadow_res == r.shadow_res)
                .and_then(|h| warp_lookups(h))?;
            (hard > 0.0).then(|| warp_lookups(r).map(|x| x / hard))?
        },
    )
}

/// One panel per scene (and radius and motion): `x_of(row, the panel's rows)` against
/// `mae_lit`, log x, the Pareto front drawn and its points named.
fn scatter(
    path: &Path,
    res: &Results<'_>,
    title: &str,
    x_desc: &str,
    x_of: impl Fn(&Record, &[&Record]) -> Option<f64>,
) -> Result<()> {
    fonts()?;
    // One panel per scene, and per radius and motion when the sweep had several: a Pareto
    // front only compares points that render the same thing.
    let mut scenes: Vec<(&str, &str, Motion)> = Vec::new();
    let mut labels: Vec<&str> = Vec::new();
    for r in res.results {
        let key = (r.scene.as_str(), r.radius_spec.as_str(), r.motion);
        if !scenes.contains(&key) {
            scenes.push(key);
        }
        if !labels.contains(&r.technique.as_str()) {
            labels.push(&r.technique);
        }
    }
    let cols = scenes.len().clamp(1, COLUMNS);
    let rows = scenes.len().div_ceil(cols).max(1);
    let (w, h) = (PANEL.0 * cols as u32, PANEL.1 * rows as u32 + HEADER);
    let mut buf = vec![255u8; (w * h * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(plot_err)?;
        let (header, body) = root.split_vertically(HEADER);
        header
            .draw_text(
                title,
                &("sans-serif", 20).into_font().color(&BLACK),
                (10, 6),
            )
            .map_err(plot_err)?;
        header
            .draw_text(
                &res.device_line,
                &("sans-serif", 14).into_font().color(&BLACK),
                (10, 32),
            )
            .map_err(plot_err)?;
        // One legend for every panel (colours are per technique everywhere), so none hides a point.
        let mut x = 10;
        let grey = RGBColor(110, 110, 110);
        header
            .draw(&PathElement::new(
                vec![(x, 66), (x + 18, 66)],
                grey.stroke_width(2),
            ))
            .map_err(plot_err)?;
        header
            .draw(&Circle::new((x + 9, 66), 8, grey.stroke_width(2)))
            .map_err(plot_err)?;
        let legend_font = ("sans-serif", 13).into_font().color(&BLACK);
        header
            .draw_text("Pareto front", &legend_font, (x + 24, 59))
            .map_err(plot_err)?;
        x += 130;
        for (k, label) in labels.iter().enumerate() {
            let colour = COLOURS[k % COLOURS.len()];
            header
                .draw(&Circle::new((x + 6, 66), 5, colour.filled()))
                .map_err(plot_err)?;
            header
                .draw_text(label, &legend_font, (x + 16, 59))
                .map_err(plot_err)?;
            x += 30 + 8 * label.chars().count() as i32;
        }
        let panels = body.split_evenly((rows, cols));
        let many_radii = scenes.iter().any(|k| k.1 != scenes[0].1);
        let many_motions = scenes.iter().any(|k| k.2 != scenes[0].2);
        for (&(scene, radius, motion), area) in scenes.iter().zip(panels.iter()) {
            let panel: Vec<&Record> = res
                .results
                .iter()
                .filter(|r| r.scene == scene && r.radius_spec == radius && r.motion == motion)
                .collect();
            let pts: Vec<_> = panel
                .iter()
                .filter_map(|r| x_of(r, &panel).map(|x| (*r, x, r.errors.mae_lit)))
                .filter(|(_, x, y)| x.is_finite() && *x > 0.0 && y.is_finite())
                .collect();
            let x_max = pts.iter().map(|p| p.1).fold(1.0f64, f64::max) * 1.5;
            let x_min = pts.iter().map(|p| p.1).fold(1.0f64, f64::min) / 1.5;
            let y_max = pts.iter().map(|p| p.2).fold(0.0f64, f64::max).max(1e-3) * 1.15;
            let mut caption = scene.to_string();
            if many_radii {
                caption += &format!(", R {radius}");
            }
            if many_motions {
                caption += &format!(", {}", motion.name());
            }
            let mut chart = ChartBuilder::on(area)
                .caption(caption, ("sans-serif", 18))
                .margin(12)
                .x_label_area_size(36)
                .y_label_area_size(56)
                .build_cartesian_2d((x_min..x_max).log_scale(), 0.0..y_max)
                .map_err(plot_err)?;
            chart
                .configure_mesh()
                .x_desc(x_desc)
                // A log axis labels and grids every unit of every decade: few labels, a faint
                // grid, so the decades stay readable.
                .x_labels(8)
                .x_label_formatter(&|v| format!("{v:.2}"))
                .light_line_style(RGBColor(242, 242, 242))
                .y_desc("mae_lit")
                .label_style(("sans-serif", 12))
                .axis_desc_style(("sans-serif", 14))
                .draw()
                .map_err(plot_err)?;
            let xy: Vec<(f64, f64)> = pts.iter().map(|p| (p.1, p.2)).collect();
            let front_idx = pareto_front(&xy);
            let front: Vec<(f64, f64)> = front_idx.iter().map(|&i| xy[i]).collect();
            // The front as a staircase (what is reachable for a time budget), its points ringed.
            let mut stairs = Vec::new();
            for (k, p) in front.iter().enumerate() {
                if k > 0 {
                    stairs.push((p.0, front[k - 1].1));
                }
                stairs.push(*p);
            }
            if let Some(last) = front.last() {
                stairs.push((x_max, last.1));
            }
            let grey = RGBColor(110, 110, 110);
            chart
                .draw_series(LineSeries::new(stairs, grey.stroke_width(2)))
                .map_err(plot_err)?
                .label("Pareto front")
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 16, y)], grey.stroke_width(2))
                });
            chart
                .draw_series(
                    front
                        .iter()
                        .map(|&p| Circle::new(p, 9, grey.stroke_width(2))),
                )
                .map_err(plot_err)?;
            // The front's points carry their technique's name: 16 colours are hard to tell
            // apart.
            chart
                .draw_series(front_idx.iter().map(|&i| {
                    EmptyElement::at(xy[i])
                        + Text::new(
                            pts[i].0.technique.clone(),
                            (10, 4),
                            ("sans-serif", 12).into_font().color(&BLACK),
                        )
                }))
                .map_err(plot_err)?;
            for (k, label) in labels.iter().enumerate() {
                let colour = COLOURS[k % COLOURS.len()];
                let mine: Vec<_> = pts.iter().filter(|p| p.0.technique == *label).collect();
                if mine.is_empty() {
                    continue;
                }
                chart
                    .draw_series(
                        mine.iter()
                            .map(|p| Circle::new((p.1, p.2), 5, colour.filled())),
                    )
                    .map_err(plot_err)?;
                // The buffer resolution beside each point tells the sweep points apart.
                chart
                    .draw_series(mine.iter().map(|p| {
                        EmptyElement::at((p.1, p.2))
                            + Text::new(
                                format!("{}", p.0.shadow_res),
                                (8, -14),
                                ("sans-serif", 11).into_font().color(&colour),
                            )
                    }))
                    .map_err(plot_err)?;
            }
        }
        root.present().map_err(plot_err)?;
    }
    let img = image::RgbImage::from_raw(w, h, buf).context("plot buffer size")?;
    img.save_with_format(path, image::ImageFormat::Png)
        .with_context(|| format!("writing {}", path.display()))
}

#[cfg(test)]
mod tests {
    use super::COLOURS;

    #[test]
    fn every_row_of_a_full_bench_has_its_own_colour() {
        // Every technique, plus smoothies' second row at the paper's fixed width.
        let rows = crate::technique::TECHNIQUES.len() + 1;
        assert!(
            COLOURS.len() >= rows,
            "{} colours for {rows} rows",
            COLOURS.len()
        );
        for (i, a) in COLOURS.iter().enumerate() {
            assert!(!COLOURS[..i].contains(a), "colour {i} repeats");
        }
    }
}
