//! Mitsuba's curve of a feature: the sweep's scenes exported
//! ([`crate::scene::export::mitsuba`]), rendered by the `rtdiff_whitted`
//! plugin ([`crate::perf::mitsuba_python`]) with the same sample counts and
//! numbers of renders, and measured against the same reference as rtdiff's.

use indicatif::ProgressBar;

use super::{ConvergenceOptions, ConvergencePoint, Curve, Feature, MITSUBA_SEED, Measure, MitsubaCurve, Why, load};
use crate::error::Error;
use crate::perf::mitsuba_python::{self, SweepJob};
use crate::scene::export::mitsuba::{OracleChoice, export_mitsuba};
use crate::verify::image::read_image;

/// Mitsuba's curve of `feature`, or why there is none (never an error: a
/// failed Mitsuba run is reported on the plot and on stderr).
pub(super) fn sweep(opts: &ConvergenceOptions, feature: Feature, measure: &Measure, bar: &ProgressBar) -> MitsubaCurve {
    if !opts.mitsuba {
        return MitsubaCurve::Missing { why: Why::NotAsked, reason: "Mitsuba was not asked for".into() };
    }
    if let Some(reason) = mitsuba_python::missing_environment(&opts.root) {
        return MitsubaCurve::Missing { why: Why::NotSetUp, reason };
    }
    let dir = opts.work.join(feature.name());
    let result = run(opts, feature, measure, &dir, bar);
    std::fs::remove_dir_all(&dir).ok();
    match result {
        Ok(curve) => MitsubaCurve::Measured(curve),
        Err(Missing(why, reason)) => MitsubaCurve::Missing { why, reason },
    }
}

/// Why a Mitsuba curve is missing.
struct Missing(Why, String);

impl From<Error> for Missing {
    fn from(e: Error) -> Self {
        let reason = format!("Mitsuba's sweep failed: {e}");
        eprintln!("rtdiff report convergence: {reason}");
        Missing(Why::Failed, reason)
    }
}

fn run(
    opts: &ConvergenceOptions,
    feature: Feature,
    measure: &Measure,
    dir: &std::path::Path,
    bar: &ProgressBar,
) -> std::result::Result<Curve, Missing> {
    // Export every count's scene; the exporter names what Mitsuba cannot reproduce.
    let mut jobs = Vec::new();
    let mut counts = Vec::new();
    let mut notes = Vec::new();
    for (i, &n) in opts.counts.iter().enumerate() {
        let (in_scene, passes) = match feature.mitsuba_plan(n, opts.mitsuba_jittered_max) {
            Ok(plan) => plan,
            Err(why) => {
                notes.push(why);
                (0..opts.repeats(n)).for_each(|_| bar.inc(1));
                continue;
            }
        };
        let (scene, lights) = load(opts, feature, in_scene, MITSUBA_SEED)?;
        let scene_dir = dir.join(format!("n{n}"));
        let export = export_mitsuba(&scene, &lights, &scene_dir, OracleChoice::Plugin)?;
        if !export.warnings.is_empty() {
            return Err(Missing(Why::NoMapping, format!("no Mitsuba mapping yet: {}", export.warnings.join("; "))));
        }
        if let Some(p) = passes {
            notes.push(format!("{n} random light samples: {p} passes of {in_scene} (the same estimator)"));
        }
        let seeds: Vec<u64> = (0..opts.repeats(n)).map(|j| ConvergenceOptions::seed(MITSUBA_SEED, i, j)).collect();
        let outputs = seeds.iter().map(|s| scene_dir.join(format!("seed{s}.exr"))).collect();
        jobs.push(SweepJob { scene_dir, seeds, outputs, passes });
        counts.push(n);
    }
    bar.set_message(format!("{}: Mitsuba", feature.name()));
    let result = mitsuba_python::sweep(&opts.root, &jobs, dir, || bar.inc(1))?;
    let mut renders = result.renders.iter();
    let mut points = Vec::new();
    for (job, &n) in jobs.iter().zip(&counts) {
        let mut runs = Vec::new();
        let mut warmup = 0.0;
        for out in &job.outputs {
            let r = renders
                .next()
                .filter(|r| &r.output == out)
                .ok_or_else(|| Error::file(out, "sweep.py reported its renders out of order"))?;
            let img = read_image(&r.output)?;
            let (rel_mse, f) = measure.of(&img)?;
            runs.push((r.render_seconds * 1e3, rel_mse, f));
            warmup = r.warmup_seconds * 1e3;
        }
        points.push(ConvergencePoint::summarise(n, &runs, Some(warmup)));
    }
    let mut curve = Curve::new(result.mitsuba, points, opts.fit_max, opts.target_rel_mse);
    curve.notes = notes;
    Ok(curve)
}
