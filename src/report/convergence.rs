//! The convergence sweep as tables and SVG plots: rtdiff's and Mitsuba's
//! curves per feature on one plot, with the equal-time and equal-error figures.

use std::path::{Path, PathBuf};

use super::plot::{self, Legend, Line, Panel, Scale};
use super::table::{Table, fmt_num};
use crate::error::Result;
use crate::perf::convergence::{
    ConvergencePoint, ConvergenceReport, Curve, FeatureCurve, MitsubaCurve, ReferenceSource,
};

fn ms(v: Option<f64>) -> String {
    v.map_or_else(|| "not reached".into(), |t| format!("{} ms", fmt_num(t)))
}

fn ratio(a: Option<f64>, b: Option<f64>) -> String {
    match (a, b) {
        (Some(a), Some(b)) if b > 0.0 => format!("{}x", fmt_num(a / b)),
        _ => "-".into(),
    }
}

fn slope(c: &Curve) -> String {
    c.fit.map_or_else(|| "-".into(), |f| format!("{:.3}", f.slope))
}

/// The short name of a feature's reference, for table cells.
fn reference_label(c: &FeatureCurve) -> String {
    match c.reference.source {
        ReferenceSource::Mitsuba => "Mitsuba (reference/)".into(),
        ReferenceSource::Rtdiff => "rtdiff, converged".into(),
    }
}

/// What the report's figures mean (shared by the table and the plots).
fn method_notes(r: &ConvergenceReport) -> Vec<String> {
    vec![
        format!(
            "Each point is the mean relMSE of K independent renders (K = {} / samples, from {} to {}; bars: min-max), \
             each with its own seed; time is their median. relMSE = mean of (test - ref)^2 / (ref^2 + {}); against \
             a noisy Mitsuba reference its own noise (the variance of its mean) is subtracted.",
            r.repeat_budget,
            crate::perf::convergence::MIN_REPEATS,
            crate::perf::convergence::MAX_REPEATS,
            r.rel_mse_epsilon
        ),
        format!(
            "Slope: least squares of log10 relMSE against log10 samples over counts up to {} (an unbiased estimator \
             gives -1; an rtdiff reference's own noise, 1/{} of one sample's variance, would flatten it beyond that).",
            r.fit_max, r.reference_count
        ),
        "Times: rtdiff's render (tracer built beforehand), wall clock, all threads. Mitsuba's: the render with its \
         JIT kernels already compiled (the warm-up pass that compiles them is in the sweep tables), the Python \
         integrator's tracing of each pass included; Python start-up and scene loading excluded."
            .into(),
        format!(
            "Equal error: the time to relMSE {}, interpolated in log-log along each sweep. Equal time: the relMSE \
             each renderer reaches at the shorter of their two times at the largest fitted count ('-': that \
             renderer's first render takes longer).",
            fmt_num(r.target_rel_mse)
        ),
    ]
}

/// The summary table and one sweep table per feature.
pub fn convergence_tables(r: &ConvergenceReport) -> Vec<Table> {
    let mut tables = vec![summary_table(r)];
    tables.extend(r.curves.iter().map(sweep_table));
    tables
}

/// Per feature: the reference, both slopes, the equal-error and the equal-time figures.
pub fn summary_table(r: &ConvergenceReport) -> Table {
    let target = fmt_num(r.target_rel_mse);
    let mut notes = method_notes(r);
    // One line per reference, naming the features measured against it.
    let mut refs: Vec<(&str, Vec<String>)> = Vec::new();
    for c in &r.curves {
        match refs.iter_mut().find(|(d, _)| *d == c.reference.description) {
            Some((_, fs)) => fs.push(c.feature_name()),
            None => refs.push((&c.reference.description, vec![c.feature_name()])),
        }
    }
    notes.extend(refs.iter().map(|(d, fs)| format!("Reference of {}: {d}.", fs.join(", "))));
    for c in &r.curves {
        if let MitsubaCurve::Missing { reason, .. } = &c.mitsuba {
            notes.push(format!("{}: no Mitsuba curve: {reason}.", c.feature_name()));
        }
    }
    Table {
        title: format!("Convergence, rtdiff against Mitsuba ({}x{})", r.size, r.size),
        header: vec![
            "feature".into(),
            "reference".into(),
            "slope rtdiff".into(),
            "slope Mitsuba".into(),
            format!("time to relMSE {target}: rtdiff"),
            "Mitsuba".into(),
            "Mitsuba / rtdiff".into(),
            "equal time".into(),
            "relMSE at equal time: rtdiff".into(),
            "Mitsuba".into(),
            "Mitsuba / rtdiff".into(),
        ],
        rows: r
            .curves
            .iter()
            .map(|c| {
                let mut row = vec![c.feature_name(), reference_label(c), slope(&c.rtdiff)];
                match (&c.mitsuba, &c.comparison) {
                    (MitsubaCurve::Measured(m), Some(k)) => row.extend([
                        slope(m),
                        ms(k.rtdiff_ms_to_target),
                        ms(k.mitsuba_ms_to_target),
                        ratio(k.mitsuba_ms_to_target, k.rtdiff_ms_to_target),
                        format!("{} ms", fmt_num(k.equal_time_ms)),
                        k.rtdiff_rel_mse_at_equal_time.map_or_else(|| "-".into(), fmt_num),
                        k.mitsuba_rel_mse_at_equal_time.map_or_else(|| "-".into(), fmt_num),
                        ratio(k.mitsuba_rel_mse_at_equal_time, k.rtdiff_rel_mse_at_equal_time),
                    ]),
                    (m, _) => {
                        let label = match m {
                            MitsubaCurve::Missing { why, .. } => why.label(),
                            MitsubaCurve::Measured(_) => "no common range",
                        };
                        row.extend([label.to_string(), ms(c.rtdiff.time_to_target_ms)]);
                        row.extend(std::iter::repeat_n("-".to_string(), 6));
                    }
                }
                row
            })
            .collect(),
        notes,
    }
}

/// Every count of one feature: both renderers' time, relMSE (min-max) and FLIP.
pub fn sweep_table(c: &FeatureCurve) -> Table {
    let mitsuba = c.mitsuba.curve();
    let mut header = vec!["samples".to_string(), "rtdiff renders".into(), "ms".into(), "relMSE".into()];
    header.extend(["min-max".into(), "FLIP".into()]);
    if mitsuba.is_some() {
        header.extend(["Mitsuba renders", "ms", "warm-up ms", "relMSE", "min-max", "FLIP"].map(String::from));
    }
    let cells = |p: &ConvergencePoint| {
        vec![
            p.renders.to_string(),
            fmt_num(p.ms),
            fmt_num(p.rel_mse),
            format!("{} - {}", fmt_num(p.rel_mse_min), fmt_num(p.rel_mse_max)),
            fmt_num(p.flip),
        ]
    };
    let rows = c
        .rtdiff
        .points
        .iter()
        .map(|p| {
            let mut row = vec![p.samples.to_string()];
            row.extend(cells(p));
            if let Some(m) = mitsuba {
                match m.points.iter().find(|q| q.samples == p.samples) {
                    Some(q) => {
                        let mut v = cells(q);
                        v.insert(2, q.warmup_ms.map_or_else(|| "-".into(), fmt_num));
                        row.extend(v);
                    }
                    None => row.extend(std::iter::repeat_n("-".to_string(), 6)),
                }
            }
            row
        })
        .collect();
    let mut notes = vec![format!("`{}` with {}; reference: {}.", c.scene, c.setup, c.reference.description)];
    match &c.mitsuba {
        MitsubaCurve::Measured(m) => {
            notes.push(format!("Mitsuba: {}, the scene as `rtdiff export` writes it.", m.renderer));
            notes.extend(m.notes.iter().map(|n| format!("Mitsuba: {n}.")));
        }
        MitsubaCurve::Missing { reason, .. } => notes.push(format!("No Mitsuba curve: {reason}.")),
    }
    Table { title: format!("Convergence sweep: {}", c.feature_name()), header, rows, notes }
}

/// Markdown of the convergence report.
pub fn convergence_markdown(r: &ConvergenceReport) -> String {
    let mut o = String::from("## Convergence (time against error)\n\n");
    for t in convergence_tables(r) {
        o.push_str(&t.to_markdown());
        o.push('\n');
    }
    o
}

/// The lines of one curve: the points (with their min-max), and the fit when `fit_max` is given.
fn curve_lines(name: &str, c: &Curve, color: usize, fit_max: Option<u32>, by_time: bool) -> Vec<Line> {
    let x = |p: &ConvergencePoint| if by_time { p.ms } else { f64::from(p.samples) };
    let mut v = vec![Line {
        name: name.to_string(),
        points: c.points.iter().map(|p| (x(p), p.rel_mse)).collect(),
        color,
        dashed: false,
        spread: c.points.iter().map(|p| (p.rel_mse_min, p.rel_mse_max)).collect(),
    }];
    if let (Some(f), Some(max)) = (c.fit, fit_max) {
        v.push(Line {
            name: format!("{name} fit, slope {:.2}", f.slope),
            points: c.points.iter().filter(|p| p.samples <= max).map(|p| (x(p), f.at(f64::from(p.samples)))).collect(),
            color,
            dashed: true,
            spread: Vec::new(),
        });
    }
    v
}

/// A dashed horizontal line at `y` across the x range of `lines`.
fn level(name: String, y: f64, lines: &[Line]) -> Option<Line> {
    let xs = lines.iter().flat_map(|l| l.points.iter().map(|p| p.0)).filter(|x| *x > 0.0);
    let (lo, hi) = xs.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| (a.min(x), b.max(x)));
    lo.is_finite().then(|| Line { name, points: vec![(lo, y), (hi, y)], color: 7, dashed: true, spread: Vec::new() })
}

/// One feature's figure, `DIR/convergence-FEATURE.svg`: relMSE against samples and against time,
/// rtdiff and Mitsuba, with the reference, Mitsuba's notes or why it is missing, and the
/// equal-error and equal-time figures under the plots; and its caption.
pub fn feature_plot(r: &ConvergenceReport, c: &FeatureCurve, dir: &Path) -> Result<(PathBuf, String)> {
    let path = dir.join(format!("convergence-{}.svg", c.feature_name()));
    let mut by_samples = curve_lines("rtdiff", &c.rtdiff, 0, Some(r.fit_max), false);
    let mut by_time = curve_lines("rtdiff", &c.rtdiff, 0, None, true);
    let mut notes = vec![format!("Reference: {}.", c.reference.description)];
    match &c.mitsuba {
        MitsubaCurve::Measured(m) => {
            by_samples.extend(curve_lines(&m.renderer, m, 1, Some(r.fit_max), false));
            by_time.extend(curve_lines(&m.renderer, m, 1, None, true));
            notes.extend(m.notes.iter().map(|n| format!("Mitsuba: {n}.")));
        }
        MitsubaCurve::Missing { reason, .. } => notes.push(format!("No Mitsuba curve: {reason}.")),
    }
    if let Some(k) = &c.comparison {
        notes.push(format!(
            "Equal error (relMSE {}): rtdiff {}, Mitsuba {}. Equal time ({} ms): relMSE rtdiff {}, Mitsuba {}.",
            fmt_num(k.target_rel_mse),
            ms(k.rtdiff_ms_to_target),
            ms(k.mitsuba_ms_to_target),
            fmt_num(k.equal_time_ms),
            k.rtdiff_rel_mse_at_equal_time.map_or_else(|| "-".into(), fmt_num),
            k.mitsuba_rel_mse_at_equal_time.map_or_else(|| "-".into(), fmt_num),
        ));
    }
    by_time.extend(level(format!("target relMSE {}", fmt_num(r.target_rel_mse)), r.target_rel_mse, &by_time));
    let title_s = format!("{}: relMSE against samples", c.feature_name());
    let title_t = format!("{}: relMSE against render time", c.feature_name());
    plot::panels(
        &path,
        &[
            Panel {
                title: &title_s,
                x: ("samples", Scale::Log),
                y: ("relMSE", Scale::Log),
                lines: &by_samples,
                legend: Legend::UpperRight,
            },
            Panel {
                title: &title_t,
                x: ("render time (ms)", Scale::Log),
                y: ("relMSE", Scale::Log),
                lines: &by_time,
                legend: Legend::UpperRight,
            },
        ],
        &notes,
    )?;
    let caption = match &c.mitsuba {
        MitsubaCurve::Measured(m) => format!(
            "{}: rtdiff (blue) and {} (red) on the same exported scene, against the same reference.",
            c.feature_name(),
            m.renderer
        ),
        MitsubaCurve::Missing { why, .. } => {
            format!("{}: rtdiff only (Mitsuba: {}; the note under the plot says why).", c.feature_name(), why.label())
        }
    };
    Ok((path, caption))
}

/// rtdiff's features together, with their captions: relMSE against samples with the fits,
/// against time, and FLIP against samples.
pub fn overview_plots(r: &ConvergenceReport, dir: &Path) -> Result<Vec<(PathBuf, String)>> {
    let mut by_samples = Vec::new();
    let mut by_time = Vec::new();
    let mut flip = Vec::new();
    for (i, c) in r.curves.iter().enumerate() {
        let name = c.feature_name();
        by_samples.extend(curve_lines(&name, &c.rtdiff, i, Some(r.fit_max), false));
        by_time.extend(curve_lines(&name, &c.rtdiff, i, None, true));
        flip.push(Line {
            name,
            points: c.rtdiff.points.iter().map(|p| (f64::from(p.samples), p.flip)).collect(),
            color: i,
            dashed: false,
            spread: Vec::new(),
        });
    }
    by_time.extend(level(format!("target relMSE {}", fmt_num(r.target_rel_mse)), r.target_rel_mse, &by_time));
    let mut written = Vec::new();
    for (file, title, x, y, ls, caption) in [
        (
            "convergence-samples.svg",
            "rtdiff: relMSE against samples",
            ("samples", Scale::Log),
            ("relMSE", Scale::Log),
            &by_samples,
            "rtdiff: relMSE against samples per feature (solid, bars: min-max of the renders) with the fitted power \
             law (dashed).",
        ),
        (
            "convergence-time.svg",
            "rtdiff: relMSE against render time",
            ("render time (ms)", Scale::Log),
            ("relMSE", Scale::Log),
            &by_time,
            "rtdiff: relMSE against render time, the time to reach an error (dashed: the target).",
        ),
        (
            "convergence-flip.svg",
            "rtdiff: FLIP against samples",
            ("samples", Scale::Log),
            ("mean FLIP", Scale::Log),
            &flip,
            "rtdiff: mean LDR-FLIP against samples.",
        ),
    ] {
        let path = dir.join(file);
        plot::lines(&path, title, x, y, ls, Legend::UpperRight)?;
        written.push((path, caption.to_string()));
    }
    Ok(written)
}
