//! The convergence sweep as tables and SVG plots.

use std::path::{Path, PathBuf};

use super::plot::{self, Legend, Line, Scale};
use super::table::{Table, fmt_num};
use crate::error::Result;
use crate::perf::convergence::ConvergenceReport;

/// Summary per feature (slope, time to target) and the full sweep.
pub fn convergence_tables(r: &ConvergenceReport) -> Vec<Table> {
    let summary = Table {
        title: format!(
            "Convergence: relMSE against samples ({}x{}, reference {} samples)",
            r.size, r.size, r.reference_count
        ),
        header: vec![
            "feature".into(),
            "scene".into(),
            "log-log slope".into(),
            format!("time to relMSE {}", fmt_num(r.target_rel_mse)),
            "reference time".into(),
        ],
        rows: r
            .curves
            .iter()
            .map(|c| {
                vec![
                    c.feature_name(),
                    c.scene.clone(),
                    c.fit.map_or_else(|| "-".into(), |f| format!("{:.3} ({} points)", f.slope, f.points)),
                    c.time_to_target_ms.map_or_else(|| "not reached".into(), |t| format!("{} ms", fmt_num(t))),
                    format!("{} ms", fmt_num(c.reference_ms)),
                ]
            })
            .collect(),
        notes: vec![
            format!(
                "Slope: least squares of log10 relMSE against log10 samples over counts up to {} (an unbiased \
                 estimator gives -1; the reference's own noise, 1/{} of one sample's variance, would flatten it \
                 beyond that). relMSE = mean of (test - ref)^2 / (ref^2 + {}). Times are wall clock, all threads; \
                 time to target is interpolated in log-log between sweep points.",
                r.fit_max, r.reference_count, r.rel_mse_epsilon
            ),
            format!("Mitsuba: {}", r.mitsuba),
        ],
    };
    let mut header = vec!["samples".to_string()];
    for c in &r.curves {
        header.push(format!("{}: ms", c.feature_name()));
        header.push("relMSE".into());
        header.push("FLIP".into());
    }
    let counts: Vec<u32> = r.curves.first().map(|c| c.points.iter().map(|p| p.samples).collect()).unwrap_or_default();
    let rows = counts
        .iter()
        .enumerate()
        .map(|(i, n)| {
            let mut v = vec![n.to_string()];
            for c in &r.curves {
                match c.points.get(i) {
                    Some(p) => v.extend([fmt_num(p.ms), fmt_num(p.rel_mse), fmt_num(p.flip)]),
                    None => v.extend(["-".into(), "-".into(), "-".into()]),
                }
            }
            v
        })
        .collect();
    let sweep = Table { title: "Convergence: every render of the sweep".into(), header, rows, notes: Vec::new() };
    vec![summary, sweep]
}

/// Markdown of the convergence report.
pub fn convergence_markdown(r: &ConvergenceReport) -> String {
    let mut o = String::from("## Convergence (time against error)\n\n");
    for t in convergence_tables(r) {
        o.push_str(&t.to_markdown());
        o.push('\n');
    }
    for c in &r.curves {
        o.push_str(&format!("- {}: `{}` with {}; reference: {}\n", c.feature_name(), c.scene, c.setup, c.reference));
    }
    o
}

/// The plots: relMSE against samples (with the fits), relMSE against time, FLIP against samples.
pub fn convergence_plots(r: &ConvergenceReport, dir: &Path) -> Result<Vec<PathBuf>> {
    let mut by_samples = Vec::new();
    let mut by_time = Vec::new();
    let mut flip = Vec::new();
    for (i, c) in r.curves.iter().enumerate() {
        let name = c.feature_name();
        by_samples.push(Line {
            name: name.clone(),
            points: c.points.iter().map(|p| (f64::from(p.samples), p.rel_mse)).collect(),
            color: i,
            dashed: false,
        });
        if let Some(f) = c.fit {
            let ns: Vec<f64> =
                c.points.iter().map(|p| f64::from(p.samples)).filter(|&n| n <= f64::from(r.fit_max)).collect();
            by_samples.push(Line {
                name: format!("{name} fit, slope {:.2}", f.slope),
                points: ns.iter().map(|&n| (n, f.at(n))).collect(),
                color: i,
                dashed: true,
            });
        }
        by_time.push(Line {
            name: name.clone(),
            points: c.points.iter().map(|p| (p.ms, p.rel_mse)).collect(),
            color: i,
            dashed: false,
        });
        flip.push(Line {
            name,
            points: c.points.iter().map(|p| (f64::from(p.samples), p.flip)).collect(),
            color: i,
            dashed: false,
        });
    }
    let target = r.target_rel_mse;
    if let Some(first) = by_time.iter().flat_map(|l| l.points.iter().map(|p| p.0)).reduce(f64::min) {
        let last = by_time.iter().flat_map(|l| l.points.iter().map(|p| p.0)).fold(first, f64::max);
        by_time.push(Line {
            name: format!("target relMSE {}", fmt_num(target)),
            points: vec![(first, target), (last, target)],
            color: 7,
            dashed: true,
        });
    }
    let mut written = Vec::new();
    for (file, title, x, y, ls) in [
        (
            "convergence-samples.svg",
            "relMSE against samples",
            ("samples", Scale::Log),
            ("relMSE", Scale::Log),
            &by_samples,
        ),
        (
            "convergence-time.svg",
            "relMSE against render time",
            ("render time (ms)", Scale::Log),
            ("relMSE", Scale::Log),
            &by_time,
        ),
        ("convergence-flip.svg", "FLIP against samples", ("samples", Scale::Log), ("mean FLIP", Scale::Log), &flip),
    ] {
        let path = dir.join(file);
        plot::lines(&path, title, x, y, ls, Legend::UpperRight)?;
        written.push(path);
    }
    Ok(written)
}
