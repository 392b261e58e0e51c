//! SVG plots (plotters): points with min-max bars over named categories, and
//! lines in linear or logarithmic axes. Logarithmic axes plot `log10` of the
//! values and label the ticks with the values themselves.

use std::path::Path;

use plotters::coord::ranged1d::{DefaultFormatting, KeyPointHint, Ranged};
use plotters::coord::types::RangedCoordf64;
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
    /// A vertical bar `(low, high)` per point (e.g. the min-max of repeated renders), or empty.
    pub spread: Vec<(f64, f64)>,
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
            Scale::Linear => tick_label(v),
            Scale::Log => tick_label(10f64.powf(v)),
        }
    }

    /// The labelled ticks and the grid lines over `lo..hi` (mapped values): on a log axis
    /// 1, 2 and 5 per decade (1 only past three decades) and every integer multiple as
    /// grid; on a linear axis a 1-2-5 step giving at most eight ticks, with five grid
    /// lines per step.
    fn ticks(self, lo: f64, hi: f64) -> (Vec<f64>, Vec<f64>) {
        let within = |v: &f64| *v >= lo - 1e-9 && *v <= hi + 1e-9;
        match self {
            Scale::Log => {
                let decades = (lo.floor() as i32)..=(hi.ceil() as i32);
                let marks: &[f64] = if hi - lo > 3.0 { &[1.0] } else { &[1.0, 2.0, 5.0] };
                let at = |ms: &[f64]| -> Vec<f64> {
                    decades
                        .clone()
                        .flat_map(|d| ms.iter().map(move |m| m.log10() + f64::from(d)))
                        .filter(within)
                        .collect()
                };
                let grid: Vec<f64> = (1..10).map(f64::from).collect();
                (at(marks), at(if hi - lo > 6.0 { &[1.0] } else { &grid }))
            }
            Scale::Linear => {
                let raw = ((hi - lo) / 8.0).max(f64::MIN_POSITIVE);
                let mag = 10f64.powf(raw.log10().floor());
                let step = [1.0, 2.0, 5.0, 10.0].into_iter().map(|m| m * mag).find(|s| *s >= raw).unwrap_or(10.0 * mag);
                let at = |step: f64| -> Vec<f64> {
                    ((lo / step).ceil() as i64..=(hi / step).floor() as i64).map(|k| k as f64 * step).collect()
                };
                (at(step), at(step / 5.0))
            }
        }
    }
}

/// A tick label: three significant digits without trailing zeros ("2", "0.25", "1500", "2e-5").
fn tick_label(v: f64) -> String {
    let a = v.abs();
    if v == 0.0 || !v.is_finite() {
        return format!("{v}");
    }
    let trim = |s: String| if s.contains('.') { s.trim_end_matches('0').trim_end_matches('.').to_string() } else { s };
    if (1e-3..1e6).contains(&a) {
        let digits = (2 - a.log10().floor() as i32).max(0) as usize;
        trim(format!("{v:.digits$}"))
    } else {
        let s = format!("{v:.2e}");
        let (m, e) = s.split_once('e').unwrap_or((&s, "0"));
        format!("{}e{e}", trim(m.to_string()))
    }
}

/// The axis range around data from `lo` to `hi` (mapped values), with a margin. A linear axis
/// whose data are all zero spans 0 to 1 (not a sliver around zero with negative ticks), and one
/// whose data are not negative keeps its margin below zero small.
fn padded(lo: f64, hi: f64, scale: Scale) -> (f64, f64) {
    if !lo.is_finite() || !hi.is_finite() {
        return (0.0, 1.0);
    }
    if scale == Scale::Linear && lo >= 0.0 {
        let span = if hi > lo { hi - lo } else { hi.max(1.0) };
        return (lo - 0.03 * span, hi.max(lo + span) + 0.06 * span);
    }
    let span = (hi - lo).max(if scale == Scale::Log { 0.5 } else { hi.abs().max(1.0) * 0.1 });
    (lo - 0.06 * span, hi + 0.06 * span)
}

/// Raise the top of a y range `y0..y1` so that a legend of `entries` lines in an upper corner sits
/// above the data instead of on it (a legend line is about 15 of the plot's ~420 pixels).
fn legend_headroom(y0: f64, y1: f64, entries: usize) -> f64 {
    let share = ((entries as f64 * 15.0 + 20.0) / 420.0).min(0.6);
    y0 + (y1 - y0) / (1.0 - share)
}

/// An axis over `lo..hi` (mapped values) with the scale's labelled ticks and grid lines
/// (plotters' own key points fall on round mapped values: 10^0.2 on a log axis).
struct Axis {
    inner: RangedCoordf64,
    ticks: Vec<f64>,
    grid: Vec<f64>,
}

impl Ranged for Axis {
    type FormatOption = DefaultFormatting;
    type ValueType = f64;

    fn map(&self, value: &f64, limit: (i32, i32)) -> i32 {
        self.inner.map(value, limit)
    }

    fn key_points<Hint: KeyPointHint>(&self, hint: Hint) -> Vec<f64> {
        if hint.weight().allow_light_points() { self.grid.clone() } else { self.ticks.clone() }
    }

    fn range(&self) -> std::ops::Range<f64> {
        self.inner.range()
    }
}

fn keyed(lo: f64, hi: f64, scale: Scale) -> Axis {
    let (ticks, grid) = scale.ticks(lo, hi);
    Axis { inner: (lo..hi).into(), ticks, grid }
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
    let y1 = legend_headroom(y0, y1, series.len());
    let n = labels.len().max(1);
    let width = (140 + 95 * n as u32).max(700);
    let mut svg = String::new();
    let root = SVGBackend::with_string(&mut svg, (width, 520)).into_drawing_area();
    root.fill(&WHITE).map_err(plot_err(path))?;
    let mut chart = ChartBuilder::on(&root)
        .caption(title, ("sans-serif", 20))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(70)
        .build_cartesian_2d(-0.5..(n as f64 - 0.5), keyed(y0, y1, ys))
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
    drop(chart);
    drop(root);
    crate::output::write(path, svg)
}

/// Corner of the legend.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Legend {
    /// Top left (for rising curves).
    UpperLeft,
    /// Top right (for falling curves).
    UpperRight,
}

/// One x-y chart of a figure.
#[derive(Clone, Copy, Debug)]
pub struct Panel<'a> {
    /// Chart caption.
    pub title: &'a str,
    /// x axis: description and scale.
    pub x: (&'a str, Scale),
    /// y axis: description and scale.
    pub y: (&'a str, Scale),
    /// The lines.
    pub lines: &'a [Line],
    /// Where the legend goes.
    pub legend: Legend,
}

/// Width of one panel, in SVG pixels (two fit a 1400-pixel window).
const PANEL_WIDTH: u32 = 660;
/// Height of one panel.
const PANEL_HEIGHT: u32 = 520;
/// Height of one line of notes under the panels.
const NOTE_LINE: u32 = 18;
/// Characters per line of notes (wrapped at spaces).
const NOTE_CHARS: usize = 100;

/// Lines in an x-y plot with the given axis scales.
pub fn lines(
    path: &Path,
    title: &str,
    (x_desc, xs): (&str, Scale),
    (y_desc, ys): (&str, Scale),
    lines: &[Line],
    legend: Legend,
) -> Result<()> {
    panels(path, &[Panel { title, x: (x_desc, xs), y: (y_desc, ys), lines, legend }], &[])
}

/// Wrap `text` at spaces into lines of at most `width` characters (longer words stay whole).
fn wrap(text: &str, width: usize) -> Vec<String> {
    let mut out: Vec<String> = Vec::new();
    for word in text.split_whitespace() {
        match out.last_mut() {
            Some(line) if line.len() + 1 + word.len() <= width => {
                line.push(' ');
                line.push_str(word);
            }
            _ => out.push(word.to_string()),
        }
    }
    out
}

/// Panels side by side in one SVG, with `notes` (wrapped) under them.
pub fn panels(path: &Path, panels: &[Panel], notes: &[String]) -> Result<()> {
    let note_lines: Vec<String> = notes.iter().flat_map(|n| wrap(n, NOTE_CHARS * panels.len().max(1))).collect();
    let notes_height = if note_lines.is_empty() { 0 } else { 12 + NOTE_LINE * note_lines.len() as u32 };
    let size = (PANEL_WIDTH * panels.len().max(1) as u32, PANEL_HEIGHT + notes_height);
    let mut svg = String::new();
    let root = SVGBackend::with_string(&mut svg, size).into_drawing_area();
    root.fill(&WHITE).map_err(plot_err(path))?;
    let (charts, under) = root.split_vertically(PANEL_HEIGHT);
    let areas = charts.split_evenly((1, panels.len().max(1)));
    for (panel, area) in panels.iter().zip(&areas) {
        draw_panel(path, area, panel)?;
    }
    for (i, line) in note_lines.iter().enumerate() {
        under
            .draw(&Text::new(line.clone(), (14, 6 + NOTE_LINE as i32 * i as i32), ("sans-serif", 14).into_font()))
            .map_err(plot_err(path))?;
    }
    root.present().map_err(plot_err(path))?;
    drop((charts, under, areas, root));
    crate::output::write(path, svg)
}

fn draw_panel<DB: DrawingBackend>(path: &Path, area: &DrawingArea<DB, plotters::coord::Shift>, p: &Panel) -> Result<()>
where
    DB::ErrorType: 'static,
{
    let (xs, ys) = (p.x.1, p.y.1);
    let map = |&(x, y): &(f64, f64)| Some((xs.map(x)?, ys.map(y)?));
    let mapped: Vec<Vec<(f64, f64)>> = p.lines.iter().map(|l| l.points.iter().filter_map(map).collect()).collect();
    // The bars count in the axis ranges too (those on a log axis without a positive end are dropped).
    let bar_ends = p.lines.iter().flat_map(|l| {
        l.points.iter().zip(&l.spread).flat_map(|(&(x, _), &(lo, hi))| [map(&(x, lo)), map(&(x, hi))]).flatten()
    });
    let all: Vec<(f64, f64)> = mapped.iter().flatten().copied().chain(bar_ends).collect();
    let fold = |f: fn(&(f64, f64)) -> f64, min: bool| {
        let it = all.iter().map(f);
        if min { it.fold(f64::INFINITY, f64::min) } else { it.fold(f64::NEG_INFINITY, f64::max) }
    };
    let (x0, x1) = padded(fold(|p| p.0, true), fold(|p| p.0, false), xs);
    let (y0, y1) = padded(fold(|p| p.1, true), fold(|p| p.1, false), ys);
    let y1 = legend_headroom(y0, y1, p.lines.len());
    let mut chart = ChartBuilder::on(area)
        .caption(p.title, ("sans-serif", 20))
        .margin(12)
        .x_label_area_size(45)
        .y_label_area_size(75)
        .build_cartesian_2d(keyed(x0, x1, xs), keyed(y0, y1, ys))
        .map_err(plot_err(path))?;
    chart
        .configure_mesh()
        .x_desc(p.x.0)
        .y_desc(p.y.0)
        .x_label_formatter(&|v| xs.label(*v))
        .y_label_formatter(&|v| ys.label(*v))
        .draw()
        .map_err(plot_err(path))?;
    for (l, pts) in p.lines.iter().zip(&mapped) {
        let c = color(l.color);
        let bars: Vec<(f64, f64, f64, f64)> = l
            .points
            .iter()
            .zip(&l.spread)
            .filter_map(|(&(x, y), &(lo, hi))| {
                let (mx, my) = map(&(x, y))?;
                // A non-positive end on a log axis: the bar runs to the axis.
                let lo = ys.map(lo).unwrap_or(y0).max(y0);
                let hi = ys.map(hi).unwrap_or(my);
                Some((mx, lo.min(my), my, hi.max(my)))
            })
            .collect();
        chart
            .draw_series(bars.iter().map(|&(x, lo, mid, hi)| ErrorBar::new_vertical(x, lo, mid, hi, c.mix(0.6), 6)))
            .map_err(plot_err(path))?;
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
        .position(match p.legend {
            Legend::UpperLeft => SeriesLabelPosition::UpperLeft,
            Legend::UpperRight => SeriesLabelPosition::UpperRight,
        })
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()
        .map_err(plot_err(path))?;
    Ok(())
}
