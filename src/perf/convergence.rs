//! Run time against error: for each noisy feature, render its scene with
//! 1 to 1024 samples, time each render, measure relMSE and FLIP against a
//! reference, fit the log-log slope of error against samples (-1 for an
//! unbiased Monte Carlo estimator) and find the time to reach a target error.
//!
//! The reference is rtdiff's own converged render (the same scene with
//! `reference_count` samples and an independent seed): it carries noise of
//! its own, `1 / reference_count` of the one-sample variance, which floors the
//! measured error; the slope is therefore fitted only up to `fit_max`
//! samples, where that floor is at most `fit_max / reference_count` of the
//! error (1/16 in both presets).

use std::path::{Path, PathBuf};

use serde::Serialize;

use crate::error::{Error, Result};
use crate::film::Image;
use crate::light::LightSampling;
use crate::render::{RenderOptions, render};
use crate::scene::Scene;
use crate::scene::file::SceneFile;
use crate::verify::image::{CompareOptions, FlipMode, compare, flip};

/// A noisy feature and the scene it is measured on.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Feature {
    /// Area light, independent uniform samples (`light_samples`).
    AreaRandom,
    /// Area light, jittered samples (`light_samples`).
    AreaJittered,
    /// Glossy reflection (`glossy_samples`).
    Glossy,
    /// Depth of field (`dof_samples`).
    DepthOfField,
    /// Pixel anti-aliasing (`spp`, jittered strata).
    PixelAa,
}

impl Feature {
    /// Every feature, in report order.
    pub const ALL: [Feature; 5] =
        [Feature::AreaRandom, Feature::AreaJittered, Feature::Glossy, Feature::DepthOfField, Feature::PixelAa];

    /// Short name (file names, JSON).
    pub fn name(self) -> &'static str {
        match self {
            Feature::AreaRandom => "area-random",
            Feature::AreaJittered => "area-jittered",
            Feature::Glossy => "glossy",
            Feature::DepthOfField => "depth-of-field",
            Feature::PixelAa => "pixel-aa",
        }
    }

    /// The scene file (under `scenes/`) and what is changed in it.
    pub fn setup(self) -> (&'static str, &'static str) {
        match self {
            Feature::AreaRandom => ("cornell_box_parallelogram_light.json", "light_sampling random, light_samples = N"),
            Feature::AreaJittered => {
                ("cornell_box_parallelogram_light.json", "light_sampling jittered, light_samples = N")
            }
            Feature::Glossy => {
                ("cornell_box.json", "glossy on, tall box glossy (ks 0.9, shininess 40), glossy_samples = N")
            }
            Feature::DepthOfField => {
                ("spheres.json", "depth_of_field on, aperture 0.15, focus 6 (blue sphere), dof_samples = N")
            }
            Feature::PixelAa => ("cornell_box.json", "spp = N (N x N jittered strata for square N)"),
        }
    }

    /// Apply the feature with `n` samples to a scene file.
    fn configure(self, f: &mut SceneFile, n: u32) {
        match self {
            Feature::AreaRandom | Feature::AreaJittered => {
                f.features.soft_shadows = true;
                f.params.light_samples = n;
                f.params.light_sampling =
                    if self == Feature::AreaRandom { LightSampling::Random } else { LightSampling::Jittered };
            }
            Feature::Glossy => {
                f.features.glossy = true;
                f.params.glossy_samples = n;
                f.materials.insert(
                    "glossy_mirror".into(),
                    crate::scene::file::MaterialSpec {
                        kd: Some(glam::Vec3::splat(0.01)),
                        ks: Some(glam::Vec3::splat(0.9)),
                        shininess: Some(40.0),
                        ..Default::default()
                    },
                );
                for m in &mut f.meshes {
                    m.material_overrides.insert("tallbox".into(), "glossy_mirror".into());
                }
            }
            Feature::DepthOfField => {
                f.features.depth_of_field = true;
                f.camera.aperture = 0.15;
                f.camera.focus_distance = Some(6.0);
                f.params.dof_samples = n;
            }
            Feature::PixelAa => f.image.spp = n,
        }
    }
}

/// Options of the sweep.
#[derive(Clone, Debug)]
pub struct ConvergenceOptions {
    /// The project root (scenes are read from `root/scenes`).
    pub root: PathBuf,
    /// Features to sweep.
    pub features: Vec<Feature>,
    /// Image width and height.
    pub size: u32,
    /// Sample counts of the sweep.
    pub counts: Vec<u32>,
    /// Samples of the reference render.
    pub reference_count: u32,
    /// Largest count used by the slope fit.
    pub fit_max: u32,
    /// Target relMSE for the time-to-error figure.
    pub target_rel_mse: f64,
    /// Where to write the side-by-side images (render at `show_count`, reference, difference, FLIP), if anywhere.
    pub images: Option<PathBuf>,
    /// The sample count shown beside the reference.
    pub show_count: u32,
    /// No progress bar.
    pub quiet: bool,
}

impl ConvergenceOptions {
    /// 128 x 128, counts 1..1024 (powers of 4), reference 4096 samples, fit up to 256.
    pub fn full(root: &Path) -> Self {
        Self {
            root: root.to_path_buf(),
            features: Feature::ALL.to_vec(),
            size: 128,
            counts: vec![1, 4, 16, 64, 256, 1024],
            reference_count: 4096,
            fit_max: 256,
            target_rel_mse: 1e-3,
            images: None,
            show_count: 16,
            quiet: false,
        }
    }

    /// Small and fast (CI): 48 x 48, counts 1..64, reference 1024 samples, fit up to 64.
    pub fn quick(root: &Path) -> Self {
        Self { size: 48, counts: vec![1, 4, 16, 64], reference_count: 1024, fit_max: 64, ..Self::full(root) }
    }
}

/// One render of the sweep.
#[derive(Clone, Debug, Serialize)]
pub struct ConvergencePoint {
    /// Samples.
    pub samples: u32,
    /// Render time in milliseconds (wall clock, all threads).
    pub ms: f64,
    /// relMSE against the reference.
    pub rel_mse: f64,
    /// Mean LDR-FLIP against the reference.
    pub flip: f64,
}

/// A least-squares line through `(log10 x, log10 y)`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct LogLogFit {
    /// Slope (error exponent).
    pub slope: f64,
    /// Intercept: `log10 y` at `x = 1`.
    pub intercept: f64,
    /// Points used.
    pub points: usize,
}

impl LogLogFit {
    /// The fitted `y` at `x`.
    pub fn at(&self, x: f64) -> f64 {
        10f64.powf(self.intercept + self.slope * x.log10())
    }
}

/// Fit `log10 y = intercept + slope log10 x` by least squares over the points
/// with positive coordinates; `None` with fewer than two such points or a
/// single distinct x.
pub fn fit_loglog(points: &[(f64, f64)]) -> Option<LogLogFit> {
    let p: Vec<(f64, f64)> =
        points.iter().filter(|(x, y)| *x > 0.0 && *y > 0.0).map(|(x, y)| (x.log10(), y.log10())).collect();
    let n = p.len() as f64;
    if p.len() < 2 {
        return None;
    }
    let mx = p.iter().map(|q| q.0).sum::<f64>() / n;
    let my = p.iter().map(|q| q.1).sum::<f64>() / n;
    let sxx: f64 = p.iter().map(|q| (q.0 - mx).powi(2)).sum();
    let sxy: f64 = p.iter().map(|q| (q.0 - mx) * (q.1 - my)).sum();
    if sxx == 0.0 {
        return None;
    }
    let slope = sxy / sxx;
    Some(LogLogFit { slope, intercept: my - slope * mx, points: p.len() })
}

/// The time at which the error first falls to `target`, interpolated in
/// log-log between the two sweep points around it; `None` if it never does.
pub fn time_to_error(points: &[ConvergencePoint], target: f64) -> Option<f64> {
    let first = points.first()?;
    if first.rel_mse <= target {
        return Some(first.ms);
    }
    points.windows(2).find(|w| w[1].rel_mse <= target).map(|w| {
        let (t0, t1) = (w[0].ms.max(1e-9).log10(), w[1].ms.max(1e-9).log10());
        let (e0, e1) = (w[0].rel_mse.log10(), w[1].rel_mse.log10());
        let f = if e1 == e0 { 1.0 } else { (target.log10() - e0) / (e1 - e0) };
        10f64.powf(t0 + f * (t1 - t0))
    })
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

/// The sweep of one feature.
#[derive(Clone, Debug, Serialize)]
pub struct FeatureCurve {
    /// The feature.
    pub feature: Feature,
    /// Scene file.
    pub scene: String,
    /// What the sweep changes in it.
    pub setup: String,
    /// What the reference is.
    pub reference: String,
    /// Reference render time in milliseconds.
    pub reference_ms: f64,
    /// One point per sample count.
    pub points: Vec<ConvergencePoint>,
    /// relMSE against samples, over the points up to `fit_max`.
    pub fit: Option<LogLogFit>,
    /// Time to reach the target relMSE (ms), if reached.
    pub time_to_target_ms: Option<f64>,
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
    /// Reference samples.
    pub reference_count: u32,
    /// Largest count in the fits.
    pub fit_max: u32,
    /// Target relMSE.
    pub target_rel_mse: f64,
    /// relMSE's epsilon (denominator `ref^2 + eps`).
    pub rel_mse_epsilon: f64,
    /// Mitsuba curves: why there are none, or where they come from.
    pub mitsuba: String,
    /// One curve per feature.
    pub curves: Vec<FeatureCurve>,
    /// Total wall-clock seconds.
    pub seconds: f64,
}

/// Seed of the sweep renders; the reference uses another so that its noise is independent.
const SWEEP_SEED: u64 = 1;
const REFERENCE_SEED: u64 = 1_000_003;

fn load(opts: &ConvergenceOptions, feature: Feature, n: u32, seed: u64) -> Result<Scene> {
    let path = opts.root.join("scenes").join(feature.setup().0);
    let text = std::fs::read_to_string(&path).map_err(|e| Error::io(&path, &e))?;
    let mut file: SceneFile =
        serde_json::from_str(&text).map_err(|e| Error::file(&path, format!("invalid scene: {e}")))?;
    feature.configure(&mut file, n);
    file.image.width = opts.size;
    file.image.height = opts.size;
    file.image.seed = seed;
    Scene::from_file(&file, path.parent().unwrap_or(Path::new(".")), &path)
}

fn render_timed(scene: &Scene) -> Result<(Image, f64)> {
    let tracer = crate::accel::build_tracer(scene.prims.clone(), &scene.accel)?;
    let r = render(scene, tracer.as_ref(), &RenderOptions { threads: None, quiet: true })?;
    Ok((r.image, r.seconds * 1e3))
}

/// Run the sweep.
pub fn run(opts: &ConvergenceOptions) -> Result<ConvergenceReport> {
    if opts.counts.is_empty() || opts.counts.contains(&0) || opts.size == 0 || opts.reference_count == 0 {
        return Err(Error::Invalid("the convergence sweep needs positive sample counts and size".into()));
    }
    let start = std::time::Instant::now();
    let steps = opts.features.len() * (opts.counts.len() + 1);
    let bar = super::progress::bar(steps as u64, "report convergence", opts.quiet);
    let cmp = CompareOptions::default();
    let mut curves = Vec::new();
    for &feature in &opts.features {
        bar.set_message(format!("{}: reference ({} samples)", feature.name(), opts.reference_count));
        let (reference, reference_ms) = render_timed(&load(opts, feature, opts.reference_count, REFERENCE_SEED)?)?;
        bar.inc(1);
        let mut points = Vec::new();
        let mut images = None;
        for &n in &opts.counts {
            bar.set_message(format!("{}: {n} samples", feature.name()));
            let (img, ms) = render_timed(&load(opts, feature, n, SWEEP_SEED)?)?;
            let m = compare(&reference, &img, &cmp)?;
            let f = flip(&reference, &img, FlipMode::Ldr, crate::verify::image::flip::DEFAULT_PIXELS_PER_DEGREE)?;
            if n == opts.show_count
                && let Some(dir) = &opts.images
            {
                images = Some(write_side_by_side(dir, feature, n, &reference, &img, &f)?);
            }
            points.push(ConvergencePoint { samples: n, ms, rel_mse: m.rel_mse, flip: f.mean });
            bar.inc(1);
        }
        let fit_pts: Vec<(f64, f64)> =
            points.iter().filter(|p| p.samples <= opts.fit_max).map(|p| (f64::from(p.samples), p.rel_mse)).collect();
        let (scene, setup) = feature.setup();
        curves.push(FeatureCurve {
            feature,
            scene: format!("scenes/{scene}"),
            setup: setup.to_string(),
            reference: format!("rtdiff, {} samples, seed {REFERENCE_SEED}", opts.reference_count),
            reference_ms,
            fit: fit_loglog(&fit_pts),
            time_to_target_ms: time_to_error(&points, opts.target_rel_mse),
            points,
            images,
        });
    }
    bar.finish_and_clear();
    Ok(ConvergenceReport {
        size: opts.size,
        reference_count: opts.reference_count,
        fit_max: opts.fit_max,
        target_rel_mse: opts.target_rel_mse,
        rel_mse_epsilon: crate::verify::image::metrics::REL_MSE_EPSILON,
        mitsuba: "no Mitsuba curve yet: reference/ holds Mitsuba renders of the scenes as they are (pixel centres, \
                  fixed light samples), not of these sweeps (random or jittered light samples, the reports' glossy \
                  lobe, which Mitsuba lacks, an aperture, N pixel samples); a curve needs one Mitsuba run per \
                  sample count through scripts/mitsuba, which is not done, so the reference is rtdiff's converged \
                  render"
            .into(),
        curves,
        seconds: start.elapsed().as_secs_f64(),
    })
}

fn write_side_by_side(
    dir: &Path,
    feature: Feature,
    n: u32,
    reference: &Image,
    img: &Image,
    f: &crate::verify::image::Flip,
) -> Result<SideBySide> {
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
    write_flip_png(f, &dir.join(&s.flip_map))?;
    Ok(SideBySide { diff_scale: scale, ..s })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Pcg32;

    #[test]
    fn exact_inverse_n_has_slope_minus_one() {
        let pts: Vec<(f64, f64)> = [1.0, 4.0, 16.0, 64.0, 256.0, 1024.0].iter().map(|&n| (n, 0.3 / n)).collect();
        let f = fit_loglog(&pts).unwrap();
        // Exact data: only rounding of log10 (a few ulps).
        assert!((f.slope + 1.0).abs() < 1e-12, "{f:?}");
        assert!((f.at(1.0) - 0.3).abs() < 1e-12);
        assert!(fit_loglog(&[(1.0, 1.0)]).is_none());
        assert!(fit_loglog(&[(2.0, 1.0), (2.0, 3.0)]).is_none());
    }

    #[test]
    fn monte_carlo_mse_has_slope_minus_one() {
        // 4096 "pixels", each the mean of n uniform samples (variance 1/12);
        // the MSE against the true mean 0.5 has expectation 1/(12 n) and a
        // relative standard deviation of about sqrt(2/4096) = 2.2% per point
        // (the squared error of a near-Gaussian mean is a scaled chi^2_1), i.e.
        // 0.0096 in log10. Over log10 n = 0, 0.6, ..., 3 (sum of squared
        // deviations 6.3) the slope's standard error is 0.0096 / sqrt(6.3) =
        // 0.004: 0.03 is over seven standard errors.
        let pixels = 4096;
        let mut pts = Vec::new();
        for (k, n) in [1u32, 4, 16, 64, 256, 1024].into_iter().enumerate() {
            let mut sum = 0.0f64;
            for p in 0..pixels {
                let mut rng = Pcg32::new(p as u64, k as u64);
                let mean = (0..n).map(|_| f64::from(rng.next_f32())).sum::<f64>() / f64::from(n);
                sum += (mean - 0.5).powi(2);
            }
            pts.push((f64::from(n), sum / pixels as f64));
        }
        let f = fit_loglog(&pts).unwrap();
        assert!((f.slope + 1.0).abs() < 0.03, "slope {} from {pts:?}", f.slope);
        // The intercept is the one-sample variance 1/12: its standard error is
        // 0.0096 * sqrt(1/6 + 1.5^2/6.3) = 0.007 in log10 (1.6%); 10% is six.
        assert!((f.at(1.0) * 12.0 - 1.0).abs() < 0.1, "{f:?}");
    }

    #[test]
    fn time_to_error_interpolates_in_log_log() {
        let p = |samples, ms, rel_mse| ConvergencePoint { samples, ms, rel_mse, flip: 0.0 };
        let pts = [p(1, 10.0, 1e-1), p(4, 40.0, 1e-2), p(16, 160.0, 1e-3)];
        // 10^-1.5 lies halfway (in log10) between 1e-1 and 1e-2: halfway between 10 and 40 ms in log10 is 20.
        let t = time_to_error(&pts, 10f64.powf(-1.5)).unwrap();
        assert!((t - 20.0).abs() < 1e-9, "{t}");
        assert_eq!(time_to_error(&pts, 1e-1), Some(10.0));
        assert_eq!(time_to_error(&pts, 1e-4), None);
    }
}
