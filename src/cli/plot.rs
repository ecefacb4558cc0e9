//! Log–log plots of error against time, as SVG.
//!
//! Why this exists: convergence is judged by the slope and offset of
//! error-vs-time curves, which a table hides. SVG through `plotters` with
//! no default features: text is emitted as SVG `<text>` (no font files or
//! system font libraries needed), so the plot builds anywhere.

use std::path::Path;

use anyhow::{Result, anyhow};
use plotters::prelude::*;

/// One curve: a name and (seconds, error) points.
pub struct Curve {
    pub name: String,
    pub points: Vec<(f64, f64)>,
}

const COLOURS: [RGBColor; 6] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
];

/// Writes a log–log plot of the curves to `path` (SVG). `floor`, if given,
/// is drawn as a dashed horizontal line (e.g. the reference's own noise).
pub fn error_vs_time(
    path: &Path,
    title: &str,
    y_label: &str,
    curves: &[Curve],
    floor: Option<(f64, &str)>,
) -> Result<()> {
    let err = |e: &dyn std::fmt::Display| anyhow!("{}: cannot write plot: {e}", path.display());
    // What a log axis can show: positive, and far enough from the ends of
    // f64 that the padded range below stays finite (the axis code loops
    // forever on an infinite end).
    let plottable = |v: f64| (1e-300..=1e300).contains(&v);
    let pts = || {
        curves
            .iter()
            .flat_map(|c| c.points.iter().copied())
            .filter(|&(x, y)| plottable(x) && plottable(y))
    };
    let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for (x, y) in pts() {
        (x0, x1, y0, y1) = (x0.min(x), x1.max(x), y0.min(y), y1.max(y));
    }
    if let Some((f, _)) = floor.filter(|(f, _)| plottable(*f)) {
        (y0, y1) = (y0.min(f), y1.max(f));
    }
    if x0 > x1 || y0 > y1 {
        return Err(anyhow!("{}: nothing to plot", path.display()));
    }
    // Pad by a fraction of a decade so end points are not on the frame.
    let (x0, x1, y0, y1) = (x0 / 1.5, x1 * 1.5, y0 / 1.5, y1 * 1.5);

    let root = SVGBackend::new(path, (720, 480)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| err(&e))?;
    let mut chart = ChartBuilder::on(&root)
        .caption(title, ("sans-serif", 20))
        .margin(12)
        .x_label_area_size(44)
        .y_label_area_size(72)
        .build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())
        .map_err(|e| err(&e))?;
    chart
        .configure_mesh()
        .x_desc("render time (s)")
        .y_desc(y_label)
        .x_label_formatter(&|v| format!("{}", (v * 1e4).round() / 1e4))
        .y_label_formatter(&|v| format!("{v:.0e}"))
        .draw()
        .map_err(|e| err(&e))?;
    for (i, c) in curves.iter().enumerate() {
        let colour = COLOURS[i % COLOURS.len()];
        let points: Vec<(f64, f64)> = c
            .points
            .iter()
            .copied()
            .filter(|&(x, y)| plottable(x) && plottable(y))
            .collect();
        chart
            .draw_series(LineSeries::new(points.clone(), colour.stroke_width(2)))
            .map_err(|e| err(&e))?
            .label(c.name.clone())
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 20, y)], colour.stroke_width(2))
            });
        chart
            .draw_series(points.iter().map(|&p| Circle::new(p, 3, colour.filled())))
            .map_err(|e| err(&e))?;
    }
    if let Some((f, name)) = floor.filter(|(f, _)| plottable(*f)) {
        let grey = RGBColor(120, 120, 120);
        chart
            .draw_series(DashedLineSeries::new(
                vec![(x0, f), (x1, f)],
                6,
                4,
                grey.stroke_width(1),
            ))
            .map_err(|e| err(&e))?
            .label(name.to_string())
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], grey));
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .position(SeriesLabelPosition::UpperRight)
        .draw()
        .map_err(|e| err(&e))?;
    root.present().map_err(|e| err(&e))?;
    Ok(())
}
