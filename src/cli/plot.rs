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

/// What a log axis can show: positive, and far enough from the ends of
/// f64 that the padded range stays finite (the axis code loops forever on
/// an infinite end).
fn plottable(v: f64) -> bool {
    (1e-300..=1e300).contains(&v)
}

/// Whether any point of `curves` can be drawn on log–log axes.
pub fn has_plottable_point(curves: &[Curve]) -> bool {
    curves
        .iter()
        .flat_map(|c| &c.points)
        .any(|&(x, y)| plottable(x) && plottable(y))
}

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
        return Err(anyhow!(
            "{}: nothing to plot (no point has a positive, finite time and error; an error \
             of 0, images that agree exactly, has no place on a log axis)",
            path.display()
        ));
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

#[cfg(test)]
mod tests {
    use super::*;

    /// The values of the attribute `name` in every `<tag …>` of `svg`.
    fn attributes(svg: &str, tag: &str, name: &str) -> Vec<String> {
        svg.split(&format!("<{tag} "))
            .skip(1)
            .filter_map(|t| {
                let t = format!(" {t}");
                let value = t.split(&format!(" {name}=\"")).nth(1)?;
                Some(value.split('"').next()?.to_string())
            })
            .collect()
    }

    fn plot(curves: &[Curve], floor: Option<(f64, &str)>) -> Result<String> {
        // A folder per call: the tests run at once.
        let dir =
            crate::cli::scratch_dir(&format!("plot-{}-{:?}", curves.len(), floor.map(|f| f.0)));
        let path = dir.join("plot.svg");
        let result = error_vs_time(&path, "t", "relMSE", curves, floor)
            .map(|_| std::fs::read_to_string(&path).unwrap());
        let _ = std::fs::remove_dir_all(&dir);
        result
    }

    /// Each point sits where the log–log axes put it: the axes span the
    /// points' range padded by a factor of 1.5 at each end (so no point
    /// is on the frame); points a log axis cannot show are left out; each
    /// curve has its own colour.
    #[test]
    fn points_land_where_the_padded_log_axes_put_them() {
        let curves = [
            Curve {
                name: "a".into(),
                points: vec![(0.01, 1e-1), (0.1, 1e-2), (1.0, 1e-3), (0.5, f64::NAN)],
            },
            Curve {
                name: "b".into(),
                points: vec![(0.1, 0.0), (0.1, 1e-2)],
            },
        ];
        let svg = plot(&curves, None).unwrap();
        // The axes: the longest black vertical and horizontal lines.
        let lines = attributes(&svg, "polyline", "points");
        let ends: Vec<[f64; 4]> = lines
            .iter()
            .filter_map(|p| {
                let v: Vec<f64> = p.split([',', ' ']).filter_map(|s| s.parse().ok()).collect();
                (v.len() == 4).then(|| [v[0], v[1], v[2], v[3]])
            })
            .collect();
        let y_axis = ends
            .iter()
            .filter(|e| e[0] == e[2])
            .max_by_key(|e| (e[3] - e[1]).abs() as i64)
            .unwrap();
        let x_axis = ends
            .iter()
            .filter(|e| e[1] == e[3])
            .max_by_key(|e| (e[2] - e[0]).abs() as i64)
            .unwrap();
        let (left, right) = (x_axis[0].min(x_axis[2]), x_axis[0].max(x_axis[2]));
        let (top, bottom) = (y_axis[1].min(y_axis[3]), y_axis[1].max(y_axis[3]));
        // Two decades and 2·log10(1.5) of padding on each axis.
        let span = 2.0 + 2.0 * 1.5f64.log10();
        let pad = 1.5f64.log10();
        let want_x = |x: f64| left + (x.log10() + 2.0 + pad) / span * (right - left);
        let want_y = |y: f64| bottom - (y.log10() + 3.0 + pad) / span * (bottom - top);
        let cx = attributes(&svg, "circle", "cx");
        let cy = attributes(&svg, "circle", "cy");
        let fill = attributes(&svg, "circle", "fill");
        let want = [(0.01, 1e-1), (0.1, 1e-2), (1.0, 1e-3), (0.1, 1e-2)];
        assert_eq!(cx.len(), want.len(), "one circle per plottable point");
        for (i, (x, y)) in want.into_iter().enumerate() {
            let (px, py): (f64, f64) = (cx[i].parse().unwrap(), cy[i].parse().unwrap());
            assert!(
                (px - want_x(x)).abs() <= 2.0,
                "x {x}: {px} vs {}",
                want_x(x)
            );
            assert!(
                (py - want_y(y)).abs() <= 2.0,
                "y {y}: {py} vs {}",
                want_y(y)
            );
        }
        assert_eq!(fill[0], fill[2]);
        assert_ne!(fill[0], fill[3], "the second curve's colour");
    }

    /// One point is a plot (a range of zero width, padded); no plottable
    /// point is an error, even with a floor to draw.
    #[test]
    fn one_point_plots_and_none_is_an_error() {
        let one = [Curve {
            name: "a".into(),
            points: vec![(0.2, 3e-3)],
        }];
        let svg = plot(&one, Some((1e-3, "floor"))).unwrap();
        assert_eq!(attributes(&svg, "circle", "cx").len(), 1);
        let none = [Curve {
            name: "a".into(),
            points: vec![(0.0, 1e-2), (0.1, f64::INFINITY)],
        }];
        for floor in [None, Some((1e-3, "floor"))] {
            let e = plot(&none, floor).unwrap_err().to_string();
            assert!(e.contains("nothing to plot"), "{e}");
        }
    }
}
