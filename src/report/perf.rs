//! The performance table as Markdown/HTML tables and an SVG plot.

use std::path::Path;

use super::plot::{self, Series};
use super::table::{Table, fmt_num};
use crate::error::Result;
use crate::perf::machine::MachineFacts;
use crate::perf::table::{Cell, PerfReport, RowKind, Unit};

/// The machine facts as a two-column table.
pub fn machine_table(m: &MachineFacts) -> Table {
    let rows = [
        ("CPU", m.cpu.clone()),
        ("cores (threads used)", format!("{} ({})", m.cores, m.threads)),
        ("rustc", m.rustc.clone()),
        ("commit", m.commit.clone()),
        ("Embree", m.embree.clone()),
        ("OS", m.os.clone()),
    ];
    Table {
        title: "Machine".into(),
        header: vec!["fact".into(), "value".into()],
        rows: rows.into_iter().map(|(k, v)| vec![k.to_string(), v]).collect(),
        notes: Vec::new(),
    }
}

fn cell_text(c: &Cell, unit: Unit) -> String {
    match (&c.measured, &c.note) {
        (Some(m), _) if unit == Unit::Ms => {
            format!("{}{} [{}-{}]", fmt_num(m.median), unit.suffix(), fmt_num(m.min), fmt_num(m.max))
        }
        (Some(m), _) => format!("{:.0}", m.median),
        (None, Some(n)) => n.clone(),
        (None, None) => "-".into(),
    }
}

/// The reports' table with rtdiff's figures, the reports' figures and the speed-up per scene.
pub fn perf_table(r: &PerfReport) -> Table {
    let mut header = vec!["".to_string()];
    for c in &r.columns {
        header.push(format!("{} ({} tris): rtdiff", c.name, c.triangles));
        header.push("reports".into());
        header.push("speed-up".into());
    }
    let rows = r
        .rows
        .iter()
        .map(|row| {
            let mut v = vec![row.spec.label.clone()];
            for c in &row.cells {
                v.push(cell_text(c, row.spec.unit));
                v.push(c.published.map_or_else(
                    || "-".into(),
                    |p| match row.spec.unit {
                        Unit::Ms => format!("{}{}", fmt_num(p), row.spec.unit.suffix()),
                        Unit::Count => format!("{p:.0}"),
                    },
                ));
                v.push(c.speedup.map_or_else(|| "-".into(), |s| format!("{}x", fmt_num(s))));
            }
            v
        })
        .collect();
    Table {
        title: format!("Performance ({}x{} pixels, median [min-max] of {} runs)", r.size, r.size, r.runs),
        header,
        rows,
        notes: vec![
            format!(
                "Times are wall clock; renders use the scene's features and all {} threads unless the row says 1 \
                 thread. Speed-up = the reports' figure / rtdiff's median (the reports' laptop and configuration \
                 are unknown, and they rendered at 800x800: compare only at that size). Measured in {:.1} s.",
                r.machine.threads, r.seconds
            ),
            "Rows up to 'Max tris per leaf node (SAH)' are the reports'; 'SAH' there is their volume-cost \
             SAH (sah-volume). The rows after it (surface-area SAH, the 8-wide fast traversal, Embree, brute \
             force, 1 thread) are new."
                .into(),
        ],
    }
}

/// Markdown of the whole performance report.
pub fn perf_markdown(r: &PerfReport) -> String {
    format!("## Performance\n\n{}\n{}", machine_table(&r.machine).to_markdown(), perf_table(r).to_markdown())
}

/// Plot of every render row: rtdiff's median with its min-max per scene, and the reports' figures.
pub fn perf_plot(r: &PerfReport, path: &Path) -> Result<()> {
    let renders: Vec<_> = r.rows.iter().filter(|row| matches!(row.spec.kind, RowKind::Render { .. })).collect();
    let labels: Vec<String> =
        renders.iter().map(|row| row.spec.key.trim_start_matches("render-").to_string()).collect();
    let mut series = Vec::new();
    for (ci, col) in r.columns.iter().enumerate() {
        let pts = renders
            .iter()
            .enumerate()
            .filter_map(|(i, row)| row.cells[ci].measured.map(|m| (i as f64, m.median, m.min, m.max)))
            .collect();
        series.push(Series { name: format!("{} (rtdiff)", col.name), points: pts, hollow: false, color: ci });
        let pts = renders
            .iter()
            .enumerate()
            .filter_map(|(i, row)| row.cells[ci].published.map(|p| (i as f64, p, p, p)))
            .collect();
        series.push(Series { name: format!("{} (reports)", col.name), points: pts, hollow: true, color: ci });
    }
    plot::categories(
        path,
        &format!("Render time, {}x{} (log scale)", r.size, r.size),
        "render time (ms)",
        &labels,
        &series,
    )
}
