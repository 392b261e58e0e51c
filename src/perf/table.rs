//! The reports' performance table ("Performance Test" in `../shared/seeds/`),
//! measured: build times per builder, render times per traversal, BVH levels
//! and leaf sizes on the Cornell box, the monkey and the dragon, plus the rows
//! the reports could not have (the `sah` builder, the `fast` traversal,
//! Embree, brute force, 1 thread against all threads).

use std::path::{Path, PathBuf};
use std::time::Instant;

use serde::{Deserialize, Serialize};

use super::machine::MachineFacts;
use super::summary::Measure;
use crate::backends::{AccelConfig, Backend, Builder, Traversal, build_tracer};
use crate::error::{Error, Result};
use crate::render::{RenderOptions, render};
use crate::scene::{Overrides, Scene};

/// Unit of a row's figures.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Unit {
    /// Milliseconds (wall clock).
    Ms,
    /// A count (triangles, levels, primitives).
    Count,
}

impl Unit {
    /// Suffix printed after a figure.
    pub fn suffix(self) -> &'static str {
        match self {
            Unit::Ms => " ms",
            Unit::Count => "",
        }
    }
}

/// What one row measures.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case", tag = "kind")]
pub enum RowKind {
    /// Number of triangles.
    Triangles,
    /// Time to build the acceleration structure.
    Build {
        /// The configuration built.
        accel: AccelSpec,
    },
    /// Time to render the scene.
    Render {
        /// The configuration traced.
        accel: AccelSpec,
        /// Worker threads (`None`: all).
        threads: Option<usize>,
    },
    /// Levels of the binary BVH.
    Levels {
        /// The builder.
        builder: Builder,
    },
    /// Largest primitive count of a leaf.
    MaxLeaf {
        /// The builder.
        builder: Builder,
    },
}

/// The acceleration-structure choice of a row (a subset of [`AccelConfig`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct AccelSpec {
    /// Backend.
    pub backend: Backend,
    /// BVH builder (native backend).
    pub builder: Builder,
    /// BVH traversal (native backend).
    pub traversal: Traversal,
}

impl AccelSpec {
    const fn native(builder: Builder, traversal: Traversal) -> Self {
        Self { backend: Backend::Native, builder, traversal }
    }

    /// The full configuration on top of a scene's own.
    pub fn apply(&self, base: &AccelConfig) -> AccelConfig {
        AccelConfig { backend: self.backend, builder: self.builder, traversal: self.traversal, ..*base }
    }
}

/// One row of the table: what it measures, its label and the reports' figures.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RowSpec {
    /// Stable identifier (JSON consumers, tests).
    pub key: String,
    /// Row label as printed.
    pub label: String,
    /// What is measured.
    pub kind: RowKind,
    /// Unit of the figures.
    pub unit: Unit,
    /// The reports' published figures, one per column (Cornell box, monkey, dragon), where they had the row.
    pub published: Option<[f64; 3]>,
}

/// The reports' figures (seeds 000 and 002, "6.4 Performance Test"; both publish the same table).
const PUBLISHED: [(&str, [f64; 3]); 12] = [
    ("triangles", [32.0, 968.0, 87_000.0]),
    ("build-median", [0.1073, 1.581, 166.793]),
    ("build-sah-volume", [0.0991, 2.6324, 345.769]),
    ("render-median-basic", [1064.87, 1665.16, 2020.08]),
    ("render-median-priority-queue", [1985.43, 2949.06, 8216.78]),
    ("render-median-nth-element", [2923.67, 4290.63, 7065.35]),
    ("render-median-sorted-vector", [2717.67, 3403.93, 6743.01]),
    ("render-sah-volume-basic", [1034.82, 1210.08, 1580.00]),
    ("levels-median", [6.0, 11.0, 17.0]),
    ("levels-sah-volume", [9.0, 17.0, 24.0]),
    ("max-leaf-median", [1.0, 1.0, 1.0]),
    ("max-leaf-sah-volume", [10.0, 21.0, 17.0]),
];

fn published(key: &str) -> Option<[f64; 3]> {
    PUBLISHED.iter().find(|(k, _)| *k == key).map(|(_, v)| *v)
}

/// The rows in print order: the reports' rows first, then the new ones.
pub fn rows() -> Vec<RowSpec> {
    use Builder::{Median, Sah, SahVolume};
    use Traversal::{Basic, Fast, NthElement, PriorityQueue, SortedVector};
    let mut v: Vec<(String, String, RowKind, Unit)> = vec![
        ("triangles".into(), "Num triangles".into(), RowKind::Triangles, Unit::Count),
        (
            "build-median".into(),
            "Time to create (median split)".into(),
            RowKind::Build { accel: AccelSpec::native(Median, Basic) },
            Unit::Ms,
        ),
        (
            "build-sah-volume".into(),
            "Time to create with SAH (reports' volume cost)".into(),
            RowKind::Build { accel: AccelSpec::native(SahVolume, Basic) },
            Unit::Ms,
        ),
    ];
    for (t, name) in [
        (Basic, "basic"),
        (PriorityQueue, "priority queue"),
        (NthElement, "vector (nth element)"),
        (SortedVector, "vector (sort)"),
    ] {
        v.push((
            format!("render-median-{}", value_name(&t)),
            format!("Time to render for {name}"),
            RowKind::Render { accel: AccelSpec::native(Median, t), threads: None },
            Unit::Ms,
        ));
    }
    v.push((
        "render-sah-volume-basic".into(),
        "Time to render with SAH for basic".into(),
        RowKind::Render { accel: AccelSpec::native(SahVolume, Basic), threads: None },
        Unit::Ms,
    ));
    for (b, name) in [(Median, "BVH levels"), (SahVolume, "BVH with SAH levels")] {
        v.push((format!("levels-{}", value_name(&b)), name.into(), RowKind::Levels { builder: b }, Unit::Count));
    }
    for (b, name) in [(Median, "Max tris per leaf node"), (SahVolume, "Max tris per leaf node (SAH)")] {
        v.push((format!("max-leaf-{}", value_name(&b)), name.into(), RowKind::MaxLeaf { builder: b }, Unit::Count));
    }
    // Rows the reports could not have.
    v.push((
        "build-sah".into(),
        "Time to create with surface-area SAH (sah)".into(),
        RowKind::Build { accel: AccelSpec::native(Sah, Basic) },
        Unit::Ms,
    ));
    v.push((
        "build-sah-fast".into(),
        "Time to create sah + 8-wide collapse (fast)".into(),
        RowKind::Build { accel: AccelSpec::native(Sah, Fast) },
        Unit::Ms,
    ));
    v.push((
        "build-embree".into(),
        "Time to create Embree (HIGH, robust)".into(),
        RowKind::Build { accel: AccelSpec { backend: Backend::Embree, builder: Sah, traversal: Fast } },
        Unit::Ms,
    ));
    v.push((
        "render-sah-basic".into(),
        "Time to render sah, basic".into(),
        RowKind::Render { accel: AccelSpec::native(Sah, Basic), threads: None },
        Unit::Ms,
    ));
    v.push((
        "render-sah-fast".into(),
        "Time to render sah, fast (all threads)".into(),
        RowKind::Render { accel: AccelSpec::native(Sah, Fast), threads: None },
        Unit::Ms,
    ));
    v.push((
        "render-sah-fast-1t".into(),
        "Time to render sah, fast (1 thread)".into(),
        RowKind::Render { accel: AccelSpec::native(Sah, Fast), threads: Some(1) },
        Unit::Ms,
    ));
    v.push((
        "render-embree".into(),
        "Time to render Embree (all threads)".into(),
        RowKind::Render { accel: AccelSpec { backend: Backend::Embree, builder: Sah, traversal: Fast }, threads: None },
        Unit::Ms,
    ));
    v.push((
        "render-embree-1t".into(),
        "Time to render Embree (1 thread)".into(),
        RowKind::Render {
            accel: AccelSpec { backend: Backend::Embree, builder: Sah, traversal: Fast },
            threads: Some(1),
        },
        Unit::Ms,
    ));
    v.push((
        "render-brute".into(),
        "Time to render brute force (BVH off)".into(),
        RowKind::Render { accel: AccelSpec { backend: Backend::Brute, builder: Sah, traversal: Fast }, threads: None },
        Unit::Ms,
    ));
    v.push(("levels-sah".into(), "sah levels".into(), RowKind::Levels { builder: Sah }, Unit::Count));
    v.push((
        "max-leaf-sah".into(),
        "Max tris per leaf node (sah)".into(),
        RowKind::MaxLeaf { builder: Sah },
        Unit::Count,
    ));
    v.into_iter()
        .map(|(key, label, kind, unit)| RowSpec { published: published(&key), key, label, kind, unit })
        .collect()
}

/// A build row and a render row (all threads) for each of `tracers` (plugins named on the command line).
pub fn tracer_rows(tracers: &[Backend]) -> Vec<RowSpec> {
    let mut v = Vec::new();
    for &backend in tracers {
        let label = AccelConfig { backend, ..Default::default() }.label();
        let accel = AccelSpec { backend, builder: Builder::Sah, traversal: Traversal::Fast };
        v.push(RowSpec {
            key: format!("build-{label}"),
            label: format!("Time to create {label}"),
            kind: RowKind::Build { accel },
            unit: Unit::Ms,
            published: None,
        });
        v.push(RowSpec {
            key: format!("render-{label}"),
            label: format!("Time to render {label} (all threads)"),
            kind: RowKind::Render { accel, threads: None },
            unit: Unit::Ms,
            published: None,
        });
    }
    v
}

/// Options of the performance table.
#[derive(Clone, Debug)]
pub struct PerfOptions {
    /// The three column scenes (the reports: Cornell box, monkey, dragon).
    pub scenes: Vec<PathBuf>,
    /// Image width and height (the reports: 800 x 800).
    pub size: u32,
    /// Timed runs per figure.
    pub runs: usize,
    /// Brute force is skipped on scenes with more triangles than this (its cost is triangles x rays).
    pub brute_max_triangles: usize,
    /// No progress bar.
    pub quiet: bool,
    /// Tracers given on the command line (`--tracer plugin:PATH`): a build row and a render row each.
    pub tracers: Vec<Backend>,
}

impl PerfOptions {
    /// The reports' setup: 800 x 800, 3 runs, the three scenes of `root/scenes`; brute force up to
    /// 100 triangles (the monkey's 968 took 142 s a run at 800 x 800 on 2 shared cores).
    pub fn full(root: &Path) -> Self {
        Self {
            scenes: default_scenes(root),
            size: 800,
            runs: 3,
            brute_max_triangles: 100,
            quiet: false,
            tracers: Vec::new(),
        }
    }

    /// Small and fast (CI): 64 x 64, 3 runs, brute force up to 1,000 triangles.
    pub fn quick(root: &Path) -> Self {
        Self { size: 64, runs: 3, brute_max_triangles: 1_000, ..Self::full(root) }
    }
}

/// The reports' columns: the Cornell box from the course's camera, the monkey, the dragon.
pub fn default_scenes(root: &Path) -> Vec<PathBuf> {
    ["cornell_box_course.json", "monkey.json", "dragon.json"].iter().map(|s| root.join("scenes").join(s)).collect()
}

/// One measured cell.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Cell {
    /// The figure (median, min, max over the runs), when measured.
    pub measured: Option<Measure>,
    /// The reports' figure for this row and column.
    pub published: Option<f64>,
    /// `published / measured median` for times (above 1: rtdiff is faster).
    pub speedup: Option<f64>,
    /// Why there is no figure, or a remark.
    pub note: Option<String>,
}

/// One row of the measured table.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PerfRow {
    /// What the row measures.
    pub spec: RowSpec,
    /// One cell per scene column.
    pub cells: Vec<Cell>,
}

/// One scene column.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Column {
    /// Short name (file stem).
    pub name: String,
    /// Scene file as given.
    pub path: String,
    /// Triangles.
    pub triangles: usize,
    /// Spheres.
    pub spheres: usize,
}

/// The whole performance report.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PerfReport {
    /// Where it was measured.
    pub machine: MachineFacts,
    /// Image width = height.
    pub size: u32,
    /// Runs per figure.
    pub runs: usize,
    /// Scene columns.
    pub columns: Vec<Column>,
    /// Rows in print order.
    pub rows: Vec<PerfRow>,
    /// Total wall-clock seconds of the measurement.
    pub seconds: f64,
}

fn value_name<T: clap::ValueEnum>(v: &T) -> String {
    v.to_possible_value().map_or_else(String::new, |p| p.get_name().to_string())
}

/// Measure the table.
pub fn run(opts: &PerfOptions) -> Result<PerfReport> {
    if opts.runs == 0 || opts.size == 0 {
        return Err(Error::Invalid("the performance table needs at least 1 run and a non-zero size".into()));
    }
    if opts.scenes.len() != 3 {
        return Err(Error::Invalid(format!(
            "the performance table has three scene columns (Cornell box, monkey, dragon); got {}",
            opts.scenes.len()
        )));
    }
    let start = Instant::now();
    let mut specs = rows();
    specs.extend(tracer_rows(&opts.tracers));
    let bar = super::progress::bar((specs.len() * opts.scenes.len()) as u64, "report perf", opts.quiet);
    let mut columns = Vec::new();
    let mut cells: Vec<Vec<Cell>> = vec![Vec::new(); specs.len()];
    for (col, path) in opts.scenes.iter().enumerate() {
        let ov = Overrides { width: Some(opts.size), height: Some(opts.size), ..Default::default() };
        let scene = Scene::load_with(path, &ov)?;
        let name = path.file_stem().and_then(|s| s.to_str()).unwrap_or("scene").to_string();
        columns.push(Column {
            name: name.clone(),
            path: path.display().to_string(),
            triangles: scene.prims.triangles.len(),
            spheres: scene.prims.spheres.len(),
        });
        for (r, spec) in specs.iter().enumerate() {
            bar.set_message(format!("{name}: {}", spec.label));
            let (measured, note) = measure(&scene, spec, opts)?;
            let published = spec.published.map(|p| p[col]);
            let speedup = match (spec.unit, measured, published) {
                (Unit::Ms, Some(m), Some(p)) if m.median > 0.0 => Some(p / m.median),
                _ => None,
            };
            cells[r].push(Cell { measured, published, speedup, note });
            bar.inc(1);
        }
    }
    bar.finish_and_clear();
    let rows = specs.into_iter().zip(cells).map(|(spec, cells)| PerfRow { spec, cells }).collect();
    Ok(PerfReport {
        machine: MachineFacts::gather(),
        size: opts.size,
        runs: opts.runs,
        columns,
        rows,
        seconds: start.elapsed().as_secs_f64(),
    })
}

fn measure(scene: &Scene, spec: &RowSpec, opts: &PerfOptions) -> Result<(Option<Measure>, Option<String>)> {
    let prims = &scene.prims;
    let bvh_stats =
        |builder| crate::bvh::stats_for(prims, &AccelSpec::native(builder, Traversal::Basic).apply(&scene.accel));
    Ok(match spec.kind {
        RowKind::Triangles => (Some(Measure::exact(prims.triangles.len() as f64)), None),
        RowKind::Levels { builder } => (Some(Measure::exact(f64::from(bvh_stats(builder).levels))), None),
        RowKind::MaxLeaf { builder } => (Some(Measure::exact(f64::from(bvh_stats(builder).max_prims_per_leaf))), None),
        RowKind::Build { accel } => {
            let cfg = accel.apply(&scene.accel);
            let mut times = Vec::with_capacity(opts.runs);
            for _ in 0..opts.runs {
                let t0 = Instant::now();
                match build_tracer(prims.clone(), &cfg) {
                    Ok(t) => std::hint::black_box(t),
                    Err(e) if accel.backend == Backend::Embree => return Ok((None, Some(e.to_string()))),
                    Err(e) => return Err(e),
                };
                times.push(t0.elapsed().as_secs_f64() * 1e3);
            }
            (Measure::of(&times), None)
        }
        RowKind::Render { accel, threads } => {
            if accel.backend == Backend::Brute && prims.len() > opts.brute_max_triangles {
                return Ok((
                    None,
                    Some(format!(
                        "not run: {} primitives (brute force, whose cost is primitives x rays, runs up to {})",
                        prims.len(),
                        opts.brute_max_triangles
                    )),
                ));
            }
            let cfg = accel.apply(&scene.accel);
            let tracer = match build_tracer(prims.clone(), &cfg) {
                Ok(t) => t,
                Err(e) if accel.backend == Backend::Embree => return Ok((None, Some(e.to_string()))),
                Err(e) => return Err(e),
            };
            let ro = RenderOptions { threads, quiet: true };
            let mut times = Vec::with_capacity(opts.runs);
            for _ in 0..opts.runs {
                times.push(render(scene, tracer.as_ref(), &ro)?.seconds * 1e3);
            }
            (Measure::of(&times), None)
        }
    })
}
