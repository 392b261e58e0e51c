//! The stability sweep as tables and SVG plots.

use std::path::{Path, PathBuf};

use super::plot::{self, Legend, Line, Scale};
use super::table::{Table, fmt_num};
use crate::error::Result;
use crate::perf::stability::{StabilityPoint, StabilityReport};

fn triple(v: [f64; 3]) -> String {
    format!("{} / {} / {}", fmt_num(v[0]), fmt_num(v[1]), fmt_num(v[2]))
}

fn placement(p: &StabilityPoint) -> String {
    if p.offset_radii == 0.0 { format!("scale {:e}", p.scale) } else { format!("moved {:e} radii", p.offset_radii) }
}

/// One table per scene: rates per placement for the three tracers.
pub fn stability_tables(r: &StabilityReport) -> Vec<Table> {
    let mut scenes: Vec<&str> = r.points.iter().map(|p| p.scene.as_str()).collect();
    scenes.dedup();
    scenes
        .into_iter()
        .map(|scene| Table {
            title: format!("Numerical stability: {scene} ({} rays per set, seed {})", r.count, r.seed),
            header: vec![
                "placement".into(),
                "leaks / M crossing rays".into(),
                "self-hits / M spawned (robust offset)".into(),
                "self-hits / M (fixed 1e-4, the reports')".into(),
            ],
            rows: r
                .points
                .iter()
                .filter(|p| p.scene == scene)
                .map(|p| {
                    vec![
                        placement(p),
                        triple(p.leaks_per_million()),
                        triple(p.self_hits_per_million()),
                        triple(p.self_hits_fixed_per_million()),
                    ]
                })
                .collect(),
            notes: vec![format!(
                "Each cell: {} / {} / {}. Leaks: rays aimed at a shared edge or a closed vertex that pass through \
                 (edges and vertices sets); self-hits: rays leaving a surface that hit it again (shadow and surface \
                 sets).",
                r.tracers[0], r.tracers[1], r.tracers[2]
            )],
        })
        .collect()
}

/// Markdown of the stability report.
pub fn stability_markdown(r: &StabilityReport) -> String {
    let mut o = String::from("## Numerical stability\n\n");
    for t in stability_tables(r) {
        o.push_str(&t.to_markdown());
        o.push('\n');
    }
    o
}

/// The plots: leaks and self-hits against scale, and against offset. Returns the files written.
pub fn stability_plots(r: &StabilityReport, dir: &Path) -> Result<Vec<PathBuf>> {
    let mut scenes: Vec<&str> = r.points.iter().map(|p| p.scene.as_str()).collect();
    scenes.dedup();
    type Rate = fn(&StabilityPoint) -> [f64; 3];
    let plots: [(&str, &str, bool, Rate, &str); 4] = [
        (
            "stability-leaks-scale.svg",
            "Leaks against mesh scale",
            false,
            StabilityPoint::leaks_per_million,
            "leaks per million rays",
        ),
        (
            "stability-selfhits-scale.svg",
            "False self-intersections against mesh scale",
            false,
            StabilityPoint::self_hits_per_million,
            "self-hits per million (robust offset)",
        ),
        (
            "stability-fixed-scale.svg",
            "Self-intersections with the reports' fixed 1e-4 offset",
            false,
            StabilityPoint::self_hits_fixed_per_million,
            "self-hits per million (fixed 1e-4)",
        ),
        (
            "stability-fixed-offset.svg",
            "Self-intersections with a fixed 1e-4 offset, mesh moved away",
            true,
            StabilityPoint::self_hits_fixed_per_million,
            "self-hits per million (fixed 1e-4)",
        ),
    ];
    let mut written = Vec::new();
    for (file, title, by_offset, rate, y_desc) in plots {
        let mut ls = Vec::new();
        for (si, scene) in scenes.iter().enumerate() {
            for k in 0..3 {
                let points: Vec<(f64, f64)> = r
                    .points
                    .iter()
                    .filter(|p| p.scene == *scene && (p.offset_radii > 0.0) == by_offset)
                    .map(|p| (f64::from(if by_offset { p.offset_radii } else { p.scale }), rate(p)[k]))
                    .collect();
                if points.is_empty() {
                    continue;
                }
                ls.push(Line {
                    name: format!("{scene}: {}", r.tracers[k]),
                    points,
                    color: si * 3 + k,
                    dashed: false,
                    spread: Vec::new(),
                });
            }
        }
        if ls.is_empty() {
            continue;
        }
        let x_desc = if by_offset { "offset (scene radii)" } else { "mesh scale" };
        let path = dir.join(file);
        plot::lines(&path, title, (x_desc, Scale::Log), (y_desc, Scale::Linear), &ls, Legend::UpperLeft)?;
        written.push(path);
    }
    Ok(written)
}
