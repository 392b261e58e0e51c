//! Run time against error: for each noisy feature, render its scene with 1 to
//! 1024 samples, time each render, measure relMSE and FLIP against a
//! reference, fit the log-log slope of error against samples (-1 for an
//! unbiased Monte Carlo estimator) and find the time to reach a target error;
//! then the same sweep by Mitsuba 3 on the same exported scene, measured
//! against the same reference, for an equal-time and equal-error comparison.
//!
//! **Reference.** `reference/` (Mitsuba, see [`crate::perf::mitsuba`]) when it
//! holds the feature's scene at the sweep's size and the sweep keeps the
//! scene's image ([`Feature::keeps_the_scenes_image`]); its noise (the
//! variance of its mean over seeds) is subtracted from every relMSE
//! ([`rel_mse_noise_floor`]). Otherwise rtdiff's own converged render (the
//! same scene with `reference_count` samples and an independent seed), whose
//! noise, `1 / reference_count` of the one-sample variance, floors the measured
//! error: slopes are fitted up to `fit_max` samples, where that floor is at
//! most `fit_max / reference_count` of the error (1/16 in both presets).
//!
//! **Repeats.** One render's relMSE is one draw of a random variable whose
//! expectation falls as 1/N; with few noisy pixels (a glossy box at 48 x 48:
//! ten pixels hold all the error) one draw scatters by a factor of 3 to 5.
//! Each count is therefore rendered `K(N) = repeat_budget / N` times (2 to 16)
//! with independent seeds, and the point is the mean relMSE (its min-max kept);
//! the seeds also differ between counts, so that the points of a curve are
//! independent draws rather than nested prefixes of one sample sequence.

mod feature;
mod fit;
mod mitsuba;

use std::path::{Path, PathBuf};

use serde::Serialize;

pub use feature::{Feature, MITSUBA_LIGHT_SAMPLES_PER_KERNEL};
pub use fit::{LogLogFit, crossing, error_at_time, fit_loglog, time_to_error};

use crate::error::{Error, Result};
use crate::film::Image;
use crate::render::{RenderOptions, render};
use crate::scene::Scene;
use crate::scene::export::mitsuba::force_shading_model;
use crate::scene::file::{LightSpec, SceneFile};
use crate::verify::image::metrics::rel_mse_noise_floor;
use crate::verify::image::{CompareOptions, FlipMode, compare, flip};

/// Fewest and most renders per sample count.
pub const MIN_REPEATS: u32 = 2;
/// See [`MIN_REPEATS`].
pub const MAX_REPEATS: u32 = 16;

/// Options of the sweep.
#[derive(Clone, Debug)]
pub struct ConvergenceOptions {
    /// The project root (scenes from `root/scenes`, references from `root/reference`,
    /// Mitsuba from `root/.venv` and `root/scripts/mitsuba`).
    pub root: PathBuf,
    /// Features to sweep.
    pub features: Vec<Feature>,
    /// Image width and height.
    pub size: u32,
    /// Sample counts of the sweep.
    pub counts: Vec<u32>,
    /// Samples of an rtdiff reference.
    pub reference_count: u32,
    /// Largest count used by the slope fit.
    pub fit_max: u32,
    /// Target relMSE for the time-to-error figure.
    pub target_rel_mse: f64,
    /// Renders per count: `repeat_budget / N`, clamped to [`MIN_REPEATS`]..=[`MAX_REPEATS`].
    pub repeat_budget: u32,
    /// Sweep Mitsuba too, where it is set up and the feature has a Mitsuba mapping.
    pub mitsuba: bool,
    /// Most jittered light samples Mitsuba renders ([`Feature::mitsuba_plan`]).
    pub mitsuba_jittered_max: u32,
    /// Scratch folder for Mitsuba's exported scenes and renders (removed afterwards).
    pub work: PathBuf,
    /// Where to write the side-by-side images (render at `show_count`, reference, difference, FLIP), if anywhere.
    pub images: Option<PathBuf>,
    /// The sample count shown beside the reference.
    pub show_count: u32,
    /// No progress bar.
    pub quiet: bool,
}

impl ConvergenceOptions {
    /// 128 x 128 (the size of `reference/`), counts 1..1024 (powers of 4), rtdiff references of
    /// 4096 samples, fit up to 256, 16 renders per count at most.
    pub fn full(root: &Path) -> Self {
        Self {
            root: root.to_path_buf(),
            features: Feature::ALL.to_vec(),
            size: 128,
            counts: vec![1, 4, 16, 64, 256, 1024],
            reference_count: 4096,
            fit_max: 256,
            target_rel_mse: 1e-3,
            repeat_budget: 256,
            mitsuba: true,
            mitsuba_jittered_max: 256,
            work: std::env::temp_dir().join(format!("rtdiff-convergence-{}", std::process::id())),
            images: None,
            show_count: 16,
            quiet: false,
        }
    }

    /// Small and fast (CI): 48 x 48, counts 1..64, rtdiff references of 1024 samples, fit up to 64,
    /// Mitsuba's jittered light samples up to 16 (a fresh machine compiles each count's kernel).
    pub fn quick(root: &Path) -> Self {
        Self {
            size: 48,
            counts: vec![1, 4, 16, 64],
            reference_count: 1024,
            fit_max: 64,
            repeat_budget: 64,
            mitsuba_jittered_max: 16,
            ..Self::full(root)
        }
    }

    /// Renders at `n` samples.
    pub fn repeats(&self, n: u32) -> u32 {
        (self.repeat_budget / n.max(1)).clamp(MIN_REPEATS, MAX_REPEATS)
    }

    /// The seed of render `j` at the `i`-th count; `base` separates the renderers' seeds.
    fn seed(base: u64, i: usize, j: u32) -> u64 {
        base + i as u64 * u64::from(MAX_REPEATS) + u64::from(j)
    }
}

/// The renders at one sample count.
#[derive(Clone, Debug, Serialize)]
pub struct ConvergencePoint {
    /// Samples.
    pub samples: u32,
    /// Independent renders at this count.
    pub renders: u32,
    /// Median render time in milliseconds (wall clock, all threads).
    pub ms: f64,
    /// Mean relMSE against the reference (less the reference's own noise, when it is known).
    pub rel_mse: f64,
    /// Smallest relMSE of the renders.
    pub rel_mse_min: f64,
    /// Largest relMSE of the renders.
    pub rel_mse_max: f64,
    /// Mean LDR-FLIP against the reference.
    pub flip: f64,
    /// Mitsuba: the scene's one-pass warm-up, JIT compilation included (not in `ms`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub warmup_ms: Option<f64>,
}

impl ConvergencePoint {
    /// Summarise the renders `(ms, relMSE, FLIP)` of one count.
    fn summarise(samples: u32, renders: &[(f64, f64, f64)], warmup_ms: Option<f64>) -> Self {
        let k = renders.len().max(1) as f64;
        let mut ms: Vec<f64> = renders.iter().map(|r| r.0).collect();
        ms.sort_by(f64::total_cmp);
        let median = match ms.len() {
            0 => 0.0,
            n if n % 2 == 1 => ms[n / 2],
            n => 0.5 * (ms[n / 2 - 1] + ms[n / 2]),
        };
        Self {
            samples,
            renders: renders.len() as u32,
            ms: median,
            rel_mse: renders.iter().map(|r| r.1).sum::<f64>() / k,
            rel_mse_min: renders.iter().map(|r| r.1).fold(f64::INFINITY, f64::min),
            rel_mse_max: renders.iter().map(|r| r.1).fold(f64::NEG_INFINITY, f64::max),
            flip: renders.iter().map(|r| r.2).sum::<f64>() / k,
            warmup_ms,
        }
    }
}

/// One renderer's sweep of one feature.
#[derive(Clone, Debug, Serialize)]
pub struct Curve {
    /// "rtdiff" or "Mitsuba 3.9.1 (llvm_ad_rgb)".
    pub renderer: String,
    /// One point per sample count.
    pub points: Vec<ConvergencePoint>,
    /// relMSE against samples, over the points up to `fit_max`.
    pub fit: Option<LogLogFit>,
    /// Time to reach the target relMSE (ms), if reached.
    pub time_to_target_ms: Option<f64>,
    /// How the renderer made some counts, or why it skipped them.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub notes: Vec<String>,
}

impl Curve {
    fn new(renderer: String, points: Vec<ConvergencePoint>, fit_max: u32, target: f64) -> Self {
        let fit_pts: Vec<(f64, f64)> =
            points.iter().filter(|p| p.samples <= fit_max).map(|p| (f64::from(p.samples), p.rel_mse)).collect();
        Self {
            renderer,
            fit: fit_loglog(&fit_pts),
            time_to_target_ms: time_to_error(&Self::time_error(&points), target),
            points,
            notes: Vec::new(),
        }
    }

    /// `(ms, relMSE)` in sweep order.
    fn time_error(points: &[ConvergencePoint]) -> Vec<(f64, f64)> {
        points.iter().map(|p| (p.ms, p.rel_mse)).collect()
    }
}

/// Mitsuba's side of a feature: its curve, or why there is none.
#[derive(Clone, Debug, Serialize)]
#[serde(tag = "status", rename_all = "kebab-case")]
pub enum MitsubaCurve {
    /// Swept.
    Measured(Curve),
    /// Not swept, and why.
    Missing {
        /// The kind of reason.
        why: Why,
        /// The reason in full, as shown on the plot and in the notes.
        reason: String,
    },
}

/// Why a feature has no Mitsuba curve.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Why {
    /// The options turned Mitsuba off.
    NotAsked,
    /// No `.venv` (scripts/mitsuba/setup.sh has not run).
    NotSetUp,
    /// The exporter names a construct of the sweep's scene that Mitsuba cannot reproduce yet.
    NoMapping,
    /// Mitsuba ran and failed.
    Failed,
}

impl Why {
    /// A few words for a table cell.
    pub fn label(self) -> &'static str {
        match self {
            Why::NotAsked => "not run",
            Why::NotSetUp => "not set up",
            Why::NoMapping => "no Mitsuba mapping yet",
            Why::Failed => "failed",
        }
    }
}

impl MitsubaCurve {
    /// The curve, when measured.
    pub fn curve(&self) -> Option<&Curve> {
        match self {
            MitsubaCurve::Measured(c) => Some(c),
            MitsubaCurve::Missing { .. } => None,
        }
    }
}

/// Where a feature's reference comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum ReferenceSource {
    /// `reference/` (Mitsuba).
    Mitsuba,
    /// rtdiff's own converged render.
    Rtdiff,
}

/// A feature's reference.
#[derive(Clone, Debug, Serialize)]
pub struct Reference {
    /// Where it comes from.
    pub source: ReferenceSource,
    /// What it is ("Mitsuba 3.9.1 (llvm_ad_rgb), mean of 16 seeds x 64 light samples", "rtdiff, 4096 samples").
    pub description: String,
    /// Its render time in ms (rtdiff references).
    pub ms: Option<f64>,
    /// Its own noise in relMSE, subtracted from every point (Mitsuba references with a variance).
    pub noise_floor: Option<f64>,
}

/// The reference image and how to measure against it.
struct Measure {
    image: Image,
    noise_floor: f64,
}

impl Measure {
    /// relMSE (less the reference's noise) and mean LDR-FLIP of `img`.
    fn of(&self, img: &Image) -> Result<(f64, f64)> {
        let m = compare(&self.image, img, &CompareOptions::default())?;
        let f = flip(&self.image, img, FlipMode::Ldr, crate::verify::image::flip::DEFAULT_PIXELS_PER_DEGREE)?;
        Ok((m.rel_mse - self.noise_floor, f.mean))
    }
}

/// rtdiff against Mitsuba at equal error and at equal time.
#[derive(Clone, Debug, Serialize)]
pub struct Comparison {
    /// The target relMSE of the equal-error figures.
    pub target_rel_mse: f64,
    /// rtdiff's time to the target (ms).
    pub rtdiff_ms_to_target: Option<f64>,
    /// Mitsuba's time to the target (ms).
    pub mitsuba_ms_to_target: Option<f64>,
    /// The equal time (ms): the shorter of the two renderers' times at their largest fitted count.
    pub equal_time_ms: f64,
    /// rtdiff's relMSE at the equal time (interpolated in log-log along its sweep).
    pub rtdiff_rel_mse_at_equal_time: Option<f64>,
    /// Mitsuba's relMSE at the equal time.
    pub mitsuba_rel_mse_at_equal_time: Option<f64>,
}

impl Comparison {
    fn new(rtdiff: &Curve, mitsuba: &Curve, fit_max: u32, target: f64) -> Option<Self> {
        let last = |c: &Curve| c.points.iter().rfind(|p| p.samples <= fit_max).map(|p| p.ms);
        let equal_time_ms = last(rtdiff)?.min(last(mitsuba)?);
        Some(Self {
            target_rel_mse: target,
            rtdiff_ms_to_target: rtdiff.time_to_target_ms,
            mitsuba_ms_to_target: mitsuba.time_to_target_ms,
            equal_time_ms,
            rtdiff_rel_mse_at_equal_time: error_at_time(&Curve::time_error(&rtdiff.points), equal_time_ms),
            mitsuba_rel_mse_at_equal_time: error_at_time(&Curve::time_error(&mitsuba.points), equal_time_ms),
        })
    }
}

/// The side-by-side pictures of one feature (file names relative to the images folder).
#[derive(Clone, Debug, Serialize)]
pub struct SideBySide {
    /// Samples of the shown render.
    pub samples: u32,
    /// rtdiff's render at `samples`.
    pub render: String,
    /// The reference.
    pub reference: String,
    /// Absolute difference, magma, full scale at `diff_scale`.
    pub difference: String,
    /// Full scale of the difference picture.
    pub diff_scale: f32,
    /// FLIP error map.
    pub flip_map: String,
}

/// The sweeps of one feature.
#[derive(Clone, Debug, Serialize)]
pub struct FeatureCurve {
    /// The feature.
    pub feature: Feature,
    /// Scene file.
    pub scene: String,
    /// What the sweep changes in it.
    pub setup: String,
    /// The reference both curves are measured against.
    pub reference: Reference,
    /// rtdiff's curve.
    pub rtdiff: Curve,
    /// Mitsuba's curve, or why there is none.
    pub mitsuba: MitsubaCurve,
    /// Equal-time and equal-error figures, when both curves exist.
    pub comparison: Option<Comparison>,
    /// Side-by-side pictures, when written.
    pub images: Option<SideBySide>,
}

impl FeatureCurve {
    /// The feature's short name.
    pub fn feature_name(&self) -> String {
        self.feature.name().to_string()
    }
}

/// The convergence report.
#[derive(Clone, Debug, Serialize)]
pub struct ConvergenceReport {
    /// Image width = height.
    pub size: u32,
    /// Samples of the rtdiff references.
    pub reference_count: u32,
    /// Largest count in the fits.
    pub fit_max: u32,
    /// Target relMSE.
    pub target_rel_mse: f64,
    /// relMSE's epsilon (denominator `ref^2 + eps`).
    pub rel_mse_epsilon: f64,
    /// Renders per count: `repeat_budget / N`, clamped to `MIN_REPEATS..=MAX_REPEATS`.
    pub repeat_budget: u32,
    /// One entry per feature.
    pub curves: Vec<FeatureCurve>,
    /// Total wall-clock seconds.
    pub seconds: f64,
}

/// Seeds of rtdiff's sweep renders, of Mitsuba's (clear of `reference/`'s seeds 0..16), and of
/// rtdiff's references (independent of both).
const RTDIFF_SEED: u64 = 1;
const MITSUBA_SEED: u64 = 1000;
const REFERENCE_SEED: u64 = 1_000_003;

/// The feature's scene file, configured for `n` samples at the sweep's size.
fn scene_file(opts: &ConvergenceOptions, feature: Feature, n: u32) -> Result<(SceneFile, PathBuf)> {
    let path = opts.root.join("scenes").join(feature.setup().0);
    let mut file = Scene::read_file(&path)?;
    if feature.keeps_the_scenes_image() {
        // As reference/ renders it: every material in the file's shading model.
        let model = file.shading_model;
        force_shading_model(&mut file, model);
    }
    feature.configure(&mut file, n);
    file.image.width = opts.size;
    file.image.height = opts.size;
    Ok((file, path))
}

/// The feature's scene with `n` samples and `seed`, and its lights as given in the file (for the export).
fn load(opts: &ConvergenceOptions, feature: Feature, n: u32, seed: u64) -> Result<(Scene, Vec<LightSpec>)> {
    let (mut file, path) = scene_file(opts, feature, n)?;
    file.image.seed = seed;
    let lights = file.lights.clone();
    let scene = Scene::from_file(&file, path.parent().unwrap_or(Path::new(".")), &path)?;
    Ok((scene, lights))
}

fn render_timed(scene: &Scene) -> Result<(Image, f64)> {
    let tracer = crate::backends::build_tracer(scene.prims.clone(), &scene.accel)?;
    let r = render(scene, tracer.as_ref(), &RenderOptions { threads: None, quiet: true })?;
    Ok((r.image, r.seconds * 1e3))
}

/// The feature's reference: `reference/` when it holds the sweep's image, else rtdiff at `reference_count`.
fn reference(opts: &ConvergenceOptions, feature: Feature) -> Result<(Measure, Reference)> {
    let (file, _) = scene_file(opts, feature, 1)?;
    if feature.keeps_the_scenes_image() {
        let scene = format!("scenes/{}", feature.setup().0);
        let stored = super::mitsuba::stored_reference(&opts.root, &scene, file.shading_model, opts.size, opts.size)?;
        if let Some(s) = stored {
            let noise_floor = s.variance_of_mean.as_ref().map(|v| rel_mse_noise_floor(&s.image, v)).transpose()?;
            let info = Reference {
                source: ReferenceSource::Mitsuba,
                description: format!("reference/: {}", s.description),
                ms: None,
                noise_floor,
            };
            return Ok((Measure { image: s.image, noise_floor: noise_floor.unwrap_or(0.0) }, info));
        }
    }
    let (scene, _) = load(opts, feature, opts.reference_count, REFERENCE_SEED)?;
    let (image, ms) = render_timed(&scene)?;
    let info = Reference {
        source: ReferenceSource::Rtdiff,
        description: format!("rtdiff, {} samples, seed {REFERENCE_SEED}", opts.reference_count),
        ms: Some(ms),
        noise_floor: None,
    };
    Ok((Measure { image, noise_floor: 0.0 }, info))
}

/// Run the sweep.
pub fn run(opts: &ConvergenceOptions) -> Result<ConvergenceReport> {
    if opts.counts.is_empty()
        || opts.counts.contains(&0)
        || opts.size == 0
        || opts.reference_count == 0
        || opts.repeat_budget == 0
    {
        return Err(Error::Invalid("the convergence sweep needs positive sample counts, size and repeats".into()));
    }
    let start = std::time::Instant::now();
    let renders: u64 = opts.counts.iter().map(|&n| u64::from(opts.repeats(n))).sum();
    let steps = opts.features.len() as u64 * (1 + renders);
    let bar = super::progress::bar(steps, "report convergence", opts.quiet);
    let mut curves = Vec::new();
    for &feature in &opts.features {
        bar.set_message(format!("{}: reference", feature.name()));
        let (measure, reference) = reference(opts, feature)?;
        bar.inc(1);
        let mut points = Vec::new();
        let mut images = None;
        for (i, &n) in opts.counts.iter().enumerate() {
            bar.set_message(format!("{}: rtdiff, {n} samples", feature.name()));
            let mut runs = Vec::new();
            for j in 0..opts.repeats(n) {
                let (scene, _) = load(opts, feature, n, ConvergenceOptions::seed(RTDIFF_SEED, i, j))?;
                let (img, ms) = render_timed(&scene)?;
                let (rel_mse, f) = measure.of(&img)?;
                if j == 0
                    && n == opts.show_count
                    && let Some(dir) = &opts.images
                {
                    images = Some(write_side_by_side(dir, feature, n, &measure.image, &img)?);
                }
                runs.push((ms, rel_mse, f));
                bar.inc(1);
            }
            points.push(ConvergencePoint::summarise(n, &runs, None));
        }
        let rtdiff = Curve::new("rtdiff".into(), points, opts.fit_max, opts.target_rel_mse);
        let mitsuba = mitsuba::sweep(opts, feature, &measure, &bar);
        let comparison = mitsuba.curve().and_then(|m| Comparison::new(&rtdiff, m, opts.fit_max, opts.target_rel_mse));
        let (scene, setup) = feature.setup();
        curves.push(FeatureCurve {
            feature,
            scene: format!("scenes/{scene}"),
            setup: setup.to_string(),
            reference,
            rtdiff,
            mitsuba,
            comparison,
            images,
        });
    }
    bar.finish_and_clear();
    std::fs::remove_dir_all(&opts.work).ok();
    Ok(ConvergenceReport {
        size: opts.size,
        reference_count: opts.reference_count,
        fit_max: opts.fit_max,
        target_rel_mse: opts.target_rel_mse,
        rel_mse_epsilon: crate::verify::image::metrics::REL_MSE_EPSILON,
        repeat_budget: opts.repeat_budget,
        curves,
        seconds: start.elapsed().as_secs_f64(),
    })
}

fn write_side_by_side(dir: &Path, feature: Feature, n: u32, reference: &Image, img: &Image) -> Result<SideBySide> {
    use crate::verify::image::diff_image::{write_error_png, write_flip_png};
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, &e))?;
    let name = feature.name();
    let s = SideBySide {
        samples: n,
        render: format!("conv-{name}-{n}.png"),
        reference: format!("conv-{name}-reference.png"),
        difference: format!("conv-{name}-diff.png"),
        diff_scale: 0.0,
        flip_map: format!("conv-{name}-flip.png"),
    };
    img.write(&dir.join(&s.render))?;
    reference.write(&dir.join(&s.reference))?;
    let diff = crate::verify::image::metrics::absolute_difference(reference, img)?;
    let scale = write_error_png(&diff, img.width, img.height, None, &dir.join(&s.difference))?;
    let f = flip(reference, img, FlipMode::Ldr, crate::verify::image::flip::DEFAULT_PIXELS_PER_DEGREE)?;
    write_flip_png(&f, &dir.join(&s.flip_map))?;
    Ok(SideBySide { diff_scale: scale, ..s })
}
