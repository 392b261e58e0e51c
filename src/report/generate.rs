//! `rtdiff report perf|convergence|stability|all`: run the measurements and
//! write their files into one folder.

use std::path::{Path, PathBuf};
use std::time::Instant;

use serde::Serialize;

use super::html::{Block, Figure, PictureRow, Section};
use super::table::{Table, fmt_num};
use crate::error::{Error, Result};
use crate::perf::convergence::{ConvergenceOptions, ConvergenceReport};
use crate::perf::mitsuba::MitsubaReport;
use crate::perf::stability::{StabilityOptions, StabilityReport};
use crate::perf::table::{PerfOptions, PerfReport};

/// Which report to make.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum ReportKind {
    /// The reports' performance table.
    Perf,
    /// Run time against error.
    Convergence,
    /// Leaks and self-intersections against mesh scale and offset.
    Stability,
    /// All three and `index.html`.
    All,
}

/// How to make it.
#[derive(Clone, Debug)]
pub struct ReportOptions {
    /// Which report.
    pub kind: ReportKind,
    /// Output folder.
    pub out: PathBuf,
    /// The project root (scenes are read from `root/scenes`).
    pub root: PathBuf,
    /// Small sizes and few runs (CI).
    pub quick: bool,
    /// Runs per performance figure (default: 3).
    pub runs: Option<usize>,
    /// Image size of the performance table (default: 800, 64 with `quick`).
    pub size: Option<u32>,
    /// No progress bars.
    pub quiet: bool,
    /// Tracers added to the performance table (`--tracer plugin:PATH`).
    pub tracers: Vec<crate::backends::Backend>,
}

/// What was written.
#[derive(Clone, Debug)]
pub struct Generated {
    /// Every file written.
    pub files: Vec<PathBuf>,
    /// The Markdown of the reports made.
    pub markdown: String,
    /// Wall-clock seconds.
    pub seconds: f64,
}

fn write(path: &Path, text: &str, files: &mut Vec<PathBuf>) -> Result<()> {
    crate::output::write(path, text)?;
    files.push(path.to_path_buf());
    Ok(())
}

fn write_json<T: Serialize>(path: &Path, v: &T, files: &mut Vec<PathBuf>) -> Result<()> {
    let s = serde_json::to_string_pretty(v).map_err(|e| Error::file(path, format!("cannot serialise: {e}")))?;
    write(path, &s, files)
}

fn rel(dir: &Path, p: &Path) -> String {
    p.strip_prefix(dir).unwrap_or(p).to_string_lossy().replace('\\', "/")
}

fn command(part: &str, opts: &ReportOptions) -> String {
    let mut c = format!("rtdiff report {part} -o {}", opts.out.display());
    if opts.quick {
        c.push_str(" --quick");
    }
    if let Some(r) = opts.runs {
        c.push_str(&format!(" --runs {r}"));
    }
    if let Some(s) = opts.size {
        c.push_str(&format!(" --size {s}"));
    }
    c
}

/// Run the report(s) `opts.kind` asks for and write them into `opts.out`.
pub fn generate(opts: &ReportOptions) -> Result<Generated> {
    let start = Instant::now();
    let dir = &opts.out;
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, &e))?;
    let all = opts.kind == ReportKind::All;
    let mut files = Vec::new();
    let mut markdown = String::new();
    let mut e = Emit { opts, files: &mut files, md: &mut markdown };
    let mut sections = Vec::new();
    let mut machine = None;
    if all || opts.kind == ReportKind::Perf {
        let mut po = if opts.quick { PerfOptions::quick(&opts.root) } else { PerfOptions::full(&opts.root) };
        po.runs = opts.runs.unwrap_or(po.runs);
        po.size = opts.size.unwrap_or(po.size);
        po.quiet = opts.quiet;
        po.tracers = opts.tracers.clone();
        let r = crate::perf::table::run(&po)?;
        machine = Some(super::perf::machine_table(&r.machine));
        sections.push(perf_files(&r, &mut e)?);
    }
    if all || opts.kind == ReportKind::Convergence {
        let mut co =
            if opts.quick { ConvergenceOptions::quick(&opts.root) } else { ConvergenceOptions::full(&opts.root) };
        co.images = Some(dir.join("images"));
        co.work = dir.join(".convergence-work");
        co.quiet = opts.quiet;
        let r = crate::perf::convergence::run(&co)?;
        sections.push(convergence_files(&r, &mut e)?);
    }
    if all || opts.kind == ReportKind::Stability {
        let mut so = if opts.quick { StabilityOptions::quick(&opts.root) } else { StabilityOptions::full(&opts.root) };
        so.quiet = opts.quiet;
        let r = crate::perf::stability::run(&so)?;
        sections.push(stability_files(&r, &mut e)?);
    }
    if all {
        let images = dir.join("images");
        if let Some(r) = crate::perf::mitsuba::run(&opts.root, &images, opts.quiet)? {
            sections.push(mitsuba_files(&r, &mut e)?);
        }
        sections.push(heatmap_files(&mut e)?);
        let header: Vec<_> = machine.into_iter().collect();
        let page = super::html::page("rtdiff report", &header, &sections);
        write(&dir.join("index.html"), &page, &mut files)?;
        write(&dir.join("report.md"), &format!("# rtdiff report\n\n{markdown}"), &mut files)?;
    }
    Ok(Generated { files, markdown, seconds: start.elapsed().as_secs_f64() })
}

/// What every section writes, in one place: its typed result as `NAME.json` (when it has one), its
/// Markdown as `NAME.md` (also added to the combined Markdown), the files its figures and pictures
/// show (recorded as written); and the section, with its data links.
struct Emit<'a> {
    opts: &'a ReportOptions,
    files: &'a mut Vec<PathBuf>,
    md: &'a mut String,
}

impl Emit<'_> {
    /// A block of figures written at `paths` (with their captions).
    fn figures(&mut self, paths: Vec<(PathBuf, String)>) -> Block {
        Block::Figures(
            paths
                .into_iter()
                .map(|(path, caption)| {
                    let file = rel(&self.opts.out, &path);
                    self.files.push(path);
                    Figure { file, caption }
                })
                .collect(),
        )
    }

    /// A picture row whose files are in `images/`.
    fn pictures(&mut self, row: PictureRow) -> Block {
        for f in [&row.render, &row.reference, &row.difference.0, &row.flip.0] {
            self.files.push(self.opts.out.join(f));
        }
        Block::Pictures(row)
    }

    fn section<T: Serialize>(
        &mut self,
        name: &str,
        data: Option<&T>,
        markdown: &str,
        section: Section,
    ) -> Result<Section> {
        let dir = &self.opts.out;
        let mut links = Vec::new();
        if let Some(v) = data {
            write_json(&dir.join(format!("{name}.json")), v, self.files)?;
            links.push(format!("{name}.json"));
        }
        write(&dir.join(format!("{name}.md")), markdown, self.files)?;
        links.push(format!("{name}.md"));
        self.md.push_str(markdown);
        self.md.push('\n');
        Ok(Section { id: name.into(), data: links, ..section })
    }
}

fn perf_files(r: &PerfReport, e: &mut Emit) -> Result<Section> {
    let svg = e.opts.out.join("perf.svg");
    super::perf::perf_plot(r, &svg)?;
    let caption = "Render time per builder/traversal and scene: rtdiff's median with its min-max (filled) and the \
                   reports' figure (hollow).";
    let figure = e.figures(vec![(svg, caption.into())]);
    e.section(
        "perf",
        Some(r),
        &super::perf::perf_markdown(r),
        Section {
            title: "Performance".into(),
            intro: "The reports' performance table (\"Performance Test\" in ../shared/seeds/), measured on this \
                    machine, with the reports' published figures beside it."
                .into(),
            blocks: vec![Block::Table(super::perf::perf_table(r)), figure],
            command: command("perf", e.opts),
            ..Default::default()
        },
    )
}

fn convergence_files(r: &ConvergenceReport, e: &mut Emit) -> Result<Section> {
    use super::convergence::{feature_plot, overview_plots, summary_table, sweep_table};
    // The summary, each feature's plot (rtdiff and Mitsuba) with its sweep, rtdiff's features
    // together, then the pictures.
    let mut blocks = vec![Block::Table(summary_table(r))];
    for c in &r.curves {
        let plot = feature_plot(r, c, &e.opts.out)?;
        blocks.push(e.figures(vec![plot]));
        blocks.push(Block::Table(sweep_table(c)));
    }
    let overview = overview_plots(r, &e.opts.out)?;
    blocks.push(e.figures(overview));
    for c in &r.curves {
        let Some(s) = &c.images else { continue };
        let img = |f: &str| format!("images/{f}");
        let p = c.rtdiff.points.iter().find(|p| p.samples == s.samples);
        blocks.push(e.pictures(PictureRow {
            title: format!("{}: rtdiff at {} samples against the reference", c.feature_name(), s.samples),
            render_label: format!("rtdiff, {} samples", s.samples),
            render: img(&s.render),
            reference_label: format!("reference: {}", c.reference.description),
            reference: img(&s.reference),
            difference: (img(&s.difference), format!("|difference|, full scale {}", fmt_num(f64::from(s.diff_scale)))),
            flip: (img(&s.flip_map), "FLIP map (LDR)".into()),
            metrics: p.map_or_else(String::new, |p| {
                format!(
                    "At {} samples, over {} renders (the first is shown): mean relMSE {}, mean FLIP {}, median {} \
                     ms. Scene {} ({}).",
                    p.samples,
                    p.renders,
                    fmt_num(p.rel_mse),
                    fmt_num(p.flip),
                    fmt_num(p.ms),
                    c.scene,
                    c.setup
                )
            }),
        }));
    }
    e.section(
        "convergence",
        Some(r),
        &super::convergence::convergence_markdown(r),
        Section {
            title: "Convergence (time against error)".into(),
            intro: "Each noisy feature swept over sample counts by rtdiff and, on the same scene exported with \
                    `rtdiff export`, by Mitsuba 3 (the rtdiff_whitted plugin); both measured against the same \
                    reference: reference/ (Mitsuba) where it holds the sweep's image, else a converged rtdiff \
                    render (each plot says which)."
                .into(),
            blocks,
            command: command("convergence", e.opts),
            ..Default::default()
        },
    )
}

fn stability_files(r: &StabilityReport, e: &mut Emit) -> Result<Section> {
    let figures: Vec<(PathBuf, String)> = super::stability::stability_plots(r, &e.opts.out)?
        .into_iter()
        .map(|p| {
            let caption = format!(
                "{}: per million rays, {} / {} / {}.",
                p.file_stem().and_then(|s| s.to_str()).unwrap_or_default(),
                r.tracers[0],
                r.tracers[1],
                r.tracers[2]
            );
            (p, caption)
        })
        .collect();
    let mut blocks: Vec<Block> = super::stability::stability_tables(r).into_iter().map(Block::Table).collect();
    blocks.push(e.figures(figures));
    e.section(
        "stability",
        Some(r),
        &super::stability::stability_markdown(r),
        Section {
            title: "Numerical stability".into(),
            intro: "parity's stress report on each mesh scaled and moved: leaks through shared edges and vertices, \
                    and false self-intersections of rays leaving a surface (robust offset, and the reports' fixed \
                    1e-4)."
                .into(),
            blocks,
            command: command("stability", e.opts),
            ..Default::default()
        },
    )
}

fn mitsuba_files(r: &MitsubaReport, e: &mut Emit) -> Result<Section> {
    let table = Table {
        title: format!("rtdiff against {} ({}x{})", r.mitsuba, r.size.0, r.size.1),
        header: vec![
            "scene".into(),
            "model".into(),
            "reference".into(),
            "relMSE".into(),
            "mean FLIP".into(),
            "pixels over 1e-3 relative".into(),
            "rtdiff ms".into(),
        ],
        rows: r
            .rows
            .iter()
            .map(|row| {
                vec![
                    row.scene.clone(),
                    format!("{}{}", model_name(row.model), if row.native { ", Mitsuba's own plugins" } else { "" }),
                    if row.deterministic {
                        "pixel centres".into()
                    } else {
                        format!("mean of {} seeds", row.reference_seeds)
                    },
                    fmt_num(row.rel_mse),
                    fmt_num(row.flip),
                    format!("{:.3}%", 100.0 * row.over_rel_threshold_fraction),
                    fmt_num(row.rtdiff_ms),
                ]
            })
            .collect(),
        notes: vec![
            "Each scene rendered by rtdiff in the reference's shading model, size, feature switches, camera samples \
             and depth (seed 0); \"Mitsuba's own plugins\": the native references (docs/oracles.md). Area-light scenes \
             are noisy in both renderers: their differences include both renderers' noise (tests/mitsuba_reference.rs \
             checks them statistically)."
                .into(),
        ],
    };
    let mut blocks = vec![Block::Table(table.clone())];
    for row in &r.rows {
        let img = |f: &str| format!("images/{f}");
        blocks.push(e.pictures(PictureRow {
            title: format!(
                "{} ({}{})",
                row.scene,
                model_name(row.model),
                if row.native { ", Mitsuba's own plugins" } else { "" }
            ),
            render_label: "rtdiff".into(),
            render: img(&row.pictures[0]),
            reference_label: r.mitsuba.clone(),
            reference: img(&row.pictures[1]),
            difference: (
                img(&row.pictures[2]),
                format!("|difference|, full scale {}", fmt_num(f64::from(row.diff_scale))),
            ),
            flip: (img(&row.pictures[3]), "FLIP map (LDR)".into()),
            metrics: format!(
                "relMSE {}, mean FLIP {}, {:.3}% of pixels over 1e-3 relative.",
                fmt_num(row.rel_mse),
                fmt_num(row.flip),
                100.0 * row.over_rel_threshold_fraction
            ),
        }));
    }
    e.section(
        "mitsuba",
        Some(r),
        &format!("## Against Mitsuba 3\n\n{}", table.to_markdown()),
        Section {
            title: "Against Mitsuba 3".into(),
            intro: "Every scene of reference/manifest.json: rtdiff | Mitsuba (hover the first picture to flip \
                    between the two) | absolute difference | FLIP map."
                .into(),
            blocks,
            command: command("all", e.opts),
            ..Default::default()
        },
    )
}

/// The reports' BVH variants side by side as pictures of their cost: per-pixel node visits of the
/// dragon's render for median/basic, sah/basic and sah/fast (counted by the traversals themselves,
/// [`crate::debug::heatmap`]), on one colour scale, with the totals per ray.
fn heatmap_files(e: &mut Emit) -> Result<Section> {
    use crate::backends::{AccelConfig, Builder, Traversal};
    use crate::debug::heatmap::Metric;
    let opts = e.opts;
    let dir = &opts.out;
    let images = dir.join("images");
    std::fs::create_dir_all(&images).map_err(|e| Error::io(&images, &e))?;
    let size = if opts.quick { 160 } else { 400 };
    let scene_path = opts.root.join("scenes").join("dragon.json");
    let ov = crate::scene::Overrides { width: Some(size), height: Some(size), ..Default::default() };
    let scene = crate::scene::Scene::load_with(&scene_path, &ov)?;
    let variants =
        [(Builder::Median, Traversal::Basic), (Builder::Sah, Traversal::Basic), (Builder::Sah, Traversal::Fast)];
    let ropts = crate::render::RenderOptions { quiet: true, ..Default::default() };
    let maps = variants
        .iter()
        .map(|&(builder, traversal)| {
            let cfg = AccelConfig { builder, traversal, ..Default::default() };
            crate::debug::heatmap(&scene, &cfg, &ropts).map(|h| (cfg.label(), h))
        })
        .collect::<Result<Vec<_>>>()?;
    // One scale for the three pictures, so that colours compare across variants.
    let scale = maps.iter().flat_map(|(_, h)| h.counts(Metric::Nodes)).max().unwrap_or(1).max(1);
    let mut figures = Vec::new();
    let mut rows = Vec::new();
    for (label, h) in &maps {
        let name = format!("heatmap-dragon-{}.png", label.replace('/', "-"));
        let path = images.join(&name);
        h.write_png(Metric::Nodes, Some(scale), &path)?;
        let per_ray = |v: u64| v as f64 / h.totals.rays.max(1) as f64;
        figures.push((
            path,
            format!(
                "{label}: {} node visits per ray{} (scale 0 to {scale})",
                fmt_num(per_ray(h.totals.nodes)),
                if h.wide { " (8-wide nodes)" } else { "" }
            ),
        ));
        rows.push(vec![
            label.clone(),
            h.totals.rays.to_string(),
            fmt_num(per_ray(h.totals.nodes)),
            fmt_num(per_ray(h.totals.triangles)),
        ]);
    }
    let table = Table {
        title: format!("Traversal cost on the dragon ({size}x{size}, every ray the render traces)"),
        header: vec!["tracer".into(), "rays".into(), "node visits per ray".into(), "triangle tests per ray".into()],
        rows,
        notes: vec!["`fast` counts 8-wide nodes: one visit tests up to eight boxes.".into()],
    };
    let markdown = format!("## Heatmaps\n\n{}", table.to_markdown());
    let blocks = vec![Block::Table(table), e.figures(figures)];
    e.section(
        "heatmaps",
        None::<&()>,
        &markdown,
        Section {
            title: "BVH variants as pictures of their cost".into(),
            intro: "Per-pixel node visits of the dragon's render, counted by the traversal code itself, one colour \
                    scale for all three."
                .into(),
            blocks,
            command: format!(
                "{} (one picture: rtdiff debug scenes/dragon.json --heatmap nodes --builder sah --traversal fast -o \
                 h.png)",
                command("all", opts)
            ),
            ..Default::default()
        },
    )
}

fn model_name(m: crate::shading::ShadingModelKind) -> &'static str {
    if m == crate::shading::ShadingModelKind::Phong { "phong" } else { "physical" }
}
