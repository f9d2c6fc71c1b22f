//! `time_vs_error.png`: per scene, frame time as a ratio to `hard` against `mae_shadow`,
//! one colour per technique, the Pareto front drawn. Rendered with plotters' bitmap
//! backend into memory and saved with `image`; text uses DejaVu Sans compiled in
//! (assets/fonts, via plotters' `ab_glyph` feature), so no system font is needed.

use super::bench::{Results, BASELINE};
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
const HEADER: u32 = 56;
const COLUMNS: usize = 3;

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

/// Draws the plot for every scene of `res` into `path`.
pub fn time_vs_error(path: &Path, res: &Results<'_>) -> Result<()> {
    fonts()?;
    let mut scenes: Vec<&str> = Vec::new();
    let mut labels: Vec<&str> = Vec::new();
    for r in res.results {
        if !scenes.contains(&r.scene.as_str()) {
            scenes.push(&r.scene);
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
                "Frame time (ratio to hard) against mae_shadow",
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
        let panels = body.split_evenly((rows, cols));
        for (scene, area) in scenes.iter().zip(panels.iter()) {
            let pts: Vec<_> = res
                .results
                .iter()
                .filter(|r| r.scene == *scene)
                .filter_map(|r| r.ratio_to_hard.map(|x| (r, x, r.errors.mae_shadow)))
                .filter(|(_, x, y)| x.is_finite() && y.is_finite())
                .collect();
            let x_max = pts.iter().map(|p| p.1).fold(1.0f64, f64::max) * 1.15;
            let y_max = pts.iter().map(|p| p.2).fold(0.0f64, f64::max).max(1e-3) * 1.4;
            let mut chart = ChartBuilder::on(area)
                .caption(*scene, ("sans-serif", 18))
                .margin(12)
                .x_label_area_size(36)
                .y_label_area_size(56)
                .build_cartesian_2d(0.0..x_max, 0.0..y_max)
                .map_err(plot_err)?;
            chart
                .configure_mesh()
                .x_desc(format!("frame time / {BASELINE}"))
                .y_desc("mae_shadow")
                .label_style(("sans-serif", 12))
                .axis_desc_style(("sans-serif", 14))
                .draw()
                .map_err(plot_err)?;
            // Name the radius beside the buffer side when a scene was swept over several.
            let radii = pts
                .iter()
                .filter(|p| p.0.radius_spec != pts[0].0.radius_spec)
                .count()
                > 0;
            let xy: Vec<(f64, f64)> = pts.iter().map(|p| (p.1, p.2)).collect();
            let front: Vec<(f64, f64)> = pareto_front(&xy).into_iter().map(|i| xy[i]).collect();
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
                    .map_err(plot_err)?
                    .label(*label)
                    .legend(move |(x, y)| Circle::new((x + 8, y), 5, colour.filled()));
                // The buffer resolution beside each point tells the sweep points apart.
                chart
                    .draw_series(mine.iter().map(|p| {
                        EmptyElement::at((p.1, p.2))
                            + Text::new(
                                if radii {
                                    format!("{} R{}", p.0.shadow_res, p.0.radius_spec)
                                } else {
                                    format!("{}", p.0.shadow_res)
                                },
                                (8, -14),
                                ("sans-serif", 11).into_font().color(&colour),
                            )
                    }))
                    .map_err(plot_err)?;
            }
            chart
                .configure_series_labels()
                .position(SeriesLabelPosition::UpperRight)
                .background_style(WHITE.mix(0.85))
                .border_style(BLACK)
                .label_font(("sans-serif", 12))
                .draw()
                .map_err(plot_err)?;
        }
        root.present().map_err(plot_err)?;
    }
    let img = image::RgbImage::from_raw(w, h, buf).context("plot buffer size")?;
    img.save_with_format(path, image::ImageFormat::Png)
        .with_context(|| format!("writing {}", path.display()))
}
