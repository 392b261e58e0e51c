//! Build and trace speed of several tracers on one input, for campaigns: in each of
//! `runs` rounds every tracer is built and traces the same camera and incoherent rays,
//! one after the other (interleaved, so that a noisy machine slows every tracer alike);
//! each figure is the median over the rounds. All threads of the calling pool, wall clock.

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::backends::{AccelConfig, build_tracer};
use crate::error::Result;
use crate::geometry::Ray;
use crate::rays::RayContext;

use super::clock::{Clock, median};

/// What to time.
#[derive(Clone, Debug)]
pub struct SpeedOptions {
    /// Camera rays: `size` x `size` through the pixel centres of the context's camera.
    pub size: u32,
    /// Incoherent rays (random origins in the bounds, random directions; seed 2024).
    pub incoherent: usize,
    /// Rounds.
    pub runs: usize,
}

/// One tracer's medians.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SpeedRow {
    /// Tracer label.
    pub tracer: String,
    /// Build time, milliseconds.
    pub build_ms: f64,
    /// Million camera rays per second (closest hit).
    pub primary_mrays_per_s: f64,
    /// Million incoherent rays per second (closest hit).
    pub incoherent_mrays_per_s: f64,
    /// Rays whose hit primitive (or hit/miss) differs from the first tracer's.
    pub differences: usize,
}

/// Every tracer's medians, in the order asked for.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SpeedReport {
    /// Threads of the pool.
    pub threads: usize,
    /// Rounds.
    pub runs: usize,
    /// Camera rays.
    pub primary_rays: usize,
    /// Incoherent rays.
    pub incoherent_rays: usize,
    /// One row per tracer.
    pub rows: Vec<SpeedRow>,
}

/// Time every tracer of `tracers` on `ctx`'s primitives.
pub fn run(ctx: &RayContext, tracers: &[AccelConfig], opts: &SpeedOptions) -> Result<SpeedReport> {
    let (w, h) = ctx.image;
    let n = opts.size.max(1);
    let primary: Vec<Ray> = (0..n * n)
        .map(|i| {
            let (x, y) = ((i % n) as f32 + 0.5, (i / n) as f32 + 0.5);
            (ctx.camera)(x * w as f32 / n as f32, y * h as f32 / n as f32)
        })
        .collect();
    let incoherent =
        crate::rays::incoherent_rays(&ctx.prims.world_bounds(), opts.incoherent, super::bench::INCOHERENT_SEED);
    let clock = Clock { cpu: false };
    let mut times = vec![[Vec::new(), Vec::new(), Vec::new()]; tracers.len()];
    let mut answers: Vec<Option<Vec<Option<u32>>>> = vec![None; tracers.len()];
    for _ in 0..opts.runs.max(1) {
        for (k, cfg) in tracers.iter().enumerate() {
            let t0 = clock.now();
            let tracer = build_tracer(ctx.prims.clone(), cfg)?;
            times[k][0].push(clock.since(t0));
            for (j, rays) in [&primary, &incoherent].into_iter().enumerate() {
                let t0 = clock.now();
                let hits: Vec<Option<u32>> =
                    rays.par_iter().with_min_len(256).map(|r| tracer.intersect(r).map(|h| h.prim)).collect();
                times[k][j + 1].push(clock.since(t0));
                if j == 0 && answers[k].is_none() {
                    answers[k] = Some(hits);
                }
            }
        }
    }
    let first = answers[0].clone().unwrap_or_default();
    let rate = |rays: usize, t: f64| if t > 0.0 { rays as f64 / t / 1e6 } else { 0.0 };
    let rows = tracers
        .iter()
        .zip(times)
        .zip(&answers)
        .map(|((cfg, [b, p, i]), a)| SpeedRow {
            tracer: cfg.label(),
            build_ms: median(b) * 1e3,
            primary_mrays_per_s: rate(primary.len(), median(p)),
            incoherent_mrays_per_s: rate(incoherent.len(), median(i)),
            differences: a.as_ref().map_or(0, |a| a.iter().zip(&first).filter(|(x, y)| x != y).count()),
        })
        .collect();
    Ok(SpeedReport {
        threads: rayon::current_num_threads(),
        runs: opts.runs.max(1),
        primary_rays: primary.len(),
        incoherent_rays: incoherent.len(),
        rows,
    })
}
