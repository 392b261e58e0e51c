//! SVG plots (plotters): points with min-max bars over named categories, and
//! lines in linear or logarithmic axes. Logarithmic axes plot `log10` of the
//! values and label the ticks with the values themselves.

use std::path::Path;

use plotters::prelude::*;

use crate::error::{Error, Result};

/// Colours of the series, by index.
const COLORS: [RGBColor; 8] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(255, 127, 14),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(23, 190, 207),
];

fn color(i: usize) -> RGBColor {
    COLORS[i % COLORS.len()]
}

fn plot_err<E: std::fmt::Display>(path: &Path) -> impl Fn(E) -> Error + '_ {
    move |e| Error::file(path, format!("cannot draw the plot: {e}"))
}

/// Points over categories: `(category index, value, min, max)`.
#[derive(Clone, Debug)]
pub struct Series {
    /// Legend entry.
    pub name: String,
    /// Points.
    pub points: Vec<(f64, f64, f64, f64)>,
    /// Hollow markers (e.g. published figures) instead of filled ones.
    pub hollow: bool,
    /// Colour index.
    pub color: usize,
}

/// A polyline (or scattered points) in an x-y plot.
#[derive(Clone, Debug)]
pub struct Line {
    /// Legend entry.
    pub name: String,
    /// Points `(x, y)`; non-positive values are dropped on logarithmic axes.
    pub points: Vec<(f64, f64)>,
    /// Colour index.
    pub color: usize,
    /// Draw as a dashed line without markers (fits, references).
    pub dashed: bool,
}

/// Axis scale.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Scale {
    /// Linear.
    Linear,
    /// Base-10 logarithmic.
    Log,
}

impl Scale {
    fn map(self, v: f64) -> Option<f64> {
        match self {
            Scale::Linear => v.is_finite().then_some(v),
            Scale::Log => (v > 0.0 && v.is_finite()).then(|| v.log10()),
        }
    }

    fn label(self, v: f64) -> String {
        match self {
            Scale::Linear => super::table::fmt_num(v),
            Scale::Log => super::table::fmt_num(10f64.powf(v)),
        }
    }
}

fn padded(lo: f64, hi: f64, scale: Scale) -> (f64, f64) {
    if !lo.is_finite() || !hi.is_finite() {
        return (0.0, 1.0);
    }
    let span = (hi - lo).max(if scale == Scale::Log { 0.5 } else { hi.abs().max(1.0) * 0.1 });
    (lo - 0.06 * span, hi + 0.06 * span)
}

/// Values (min, median, max) per category, on a logarithmic y axis.
pub fn categories(path: &Path, title: &str, y_desc: &str, labels: &[String], series: &[Series]) -> Result<()> {
    let ys = Scale::Log;
    let all: Vec<f64> =
        series.iter().flat_map(|s| s.points.iter().flat_map(|p| [p.2, p.3])).filter_map(|v| ys.map(v)).collect();
    let (y0, y1) = padded(
        all.iter().copied().fold(f64::INFINITY, f64::min),
        all.iter().copied().fold(f64::NEG_INFINITY, f64::max),
        ys,
    );
    let n = labels.len().max(1);
    let width = (140 + 95 * n as u32).max(700);
    let root = SVGBackend::new(path, (width, 520)).into_drawing_area();
    root.fill(&WHITE).map_err(plot_err(path))?;
    let mut chart = ChartBuilder::on(&root)
        .caption(title, ("sans-serif", 20))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(70)
        .build_cartesian_2d(-0.5..(n as f64 - 0.5), y0..y1)
        .map_err(plot_err(path))?;
    chart
        .configure_mesh()
        .disable_x_mesh()
        .x_labels(n)
        .x_label_formatter(&|x| {
            let i = x.round();
            if (x - i).abs() < 1e-6 && i >= 0.0 {
                labels.get(i as usize).cloned().unwrap_or_default()
            } else {
                String::new()
            }
        })
        .y_desc(y_desc)
        .y_label_formatter(&|v| ys.label(*v))
        .draw()
        .map_err(plot_err(path))?;
    let groups = series.len().max(1) as f64;
    for (k, s) in series.iter().enumerate() {
        let c = color(s.color);
        // Spread the series of one category side by side.
        let dx = (k as f64 - (groups - 1.0) / 2.0) * 0.6 / groups;
        let pts: Vec<(f64, f64, f64, f64)> = s
            .points
            .iter()
            .filter_map(|&(x, v, lo, hi)| Some((x + dx, ys.map(v)?, ys.map(lo)?, ys.map(hi)?)))
            .collect();
        chart
            .draw_series(pts.iter().map(|&(x, v, lo, hi)| ErrorBar::new_vertical(x, lo, v, hi, c, 6)))
            .map_err(plot_err(path))?;
        let hollow = s.hollow;
        chart
            .draw_series(pts.iter().map(move |&(x, v, _, _)| {
                if hollow { Circle::new((x, v), 5, c.stroke_width(2)) } else { Circle::new((x, v), 4, c.filled()) }
            }))
            .map_err(plot_err(path))?
            .label(s.name.clone())
            .legend(move |(x, y)| {
                if hollow {
                    Circle::new((x + 8, y), 5, c.stroke_width(2))
                } else {
                    Circle::new((x + 8, y), 4, c.filled())
                }
            });
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()
        .map_err(plot_err(path))?;
    root.present().map_err(plot_err(path))?;
    Ok(())
}

/// Corner of the legend.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Legend {
    /// Top left (for rising curves).
    UpperLeft,
    /// Top right (for falling curves).
    UpperRight,
}

/// Lines in an x-y plot with the given axis scales.
pub fn lines(
    path: &Path,
    title: &str,
    (x_desc, xs): (&str, Scale),
    (y_desc, ys): (&str, Scale),
    lines: &[Line],
    legend: Legend,
) -> Result<()> {
    let mapped: Vec<Vec<(f64, f64)>> =
        lines.iter().map(|l| l.points.iter().filter_map(|&(x, y)| Some((xs.map(x)?, ys.map(y)?))).collect()).collect();
    let fold = |f: fn(&(f64, f64)) -> f64, min: bool| {
        let it = mapped.iter().flatten().map(f);
        if min { it.fold(f64::INFINITY, f64::min) } else { it.fold(f64::NEG_INFINITY, f64::max) }
    };
    let (x0, x1) = padded(fold(|p| p.0, true), fold(|p| p.0, false), xs);
    let (y0, y1) = padded(fold(|p| p.1, true), fold(|p| p.1, false), ys);
    let root = SVGBackend::new(path, (760, 520)).into_drawing_area();
    root.fill(&WHITE).map_err(plot_err(path))?;
    let mut chart = ChartBuilder::on(&root)
        .caption(title, ("sans-serif", 20))
        .margin(12)
        .x_label_area_size(45)
        .y_label_area_size(75)
        .build_cartesian_2d(x0..x1, y0..y1)
        .map_err(plot_err(path))?;
    chart
        .configure_mesh()
        .x_desc(x_desc)
        .y_desc(y_desc)
        .x_label_formatter(&|v| xs.label(*v))
        .y_label_formatter(&|v| ys.label(*v))
        .draw()
        .map_err(plot_err(path))?;
    for (l, pts) in lines.iter().zip(&mapped) {
        let c = color(l.color);
        if l.dashed {
            chart
                .draw_series(DashedLineSeries::new(pts.clone(), 6, 4, c.stroke_width(1)))
                .map_err(plot_err(path))?
                .label(l.name.clone())
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], c.stroke_width(1)));
        } else {
            chart.draw_series(LineSeries::new(pts.clone(), c.stroke_width(2))).map_err(plot_err(path))?;
            chart
                .draw_series(pts.iter().map(|&p| Circle::new(p, 3, c.filled())))
                .map_err(plot_err(path))?
                .label(l.name.clone())
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], c.stroke_width(2)));
        }
    }
    chart
        .configure_series_labels()
        .position(match legend {
            Legend::UpperLeft => SeriesLabelPosition::UpperLeft,
            Legend::UpperRight => SeriesLabelPosition::UpperRight,
        })
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()
        .map_err(plot_err(path))?;
    root.present().map_err(plot_err(path))?;
    Ok(())
}
