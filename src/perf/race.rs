//! The race behind `rtdiff bench --race ROUNDS`: the `sah` build with the `fast` traversal
//! against Embree's MEDIUM build with rtcIntersect1 / rtcOccluded1, single
//! threaded, on the same rays, interleaved round by round in one process.
//!
//! On a shared machine the load changes from second to second, so lone
//! absolute times mean little. Each round times both contenders back to back
//! (alternating which goes first) and records their ratio; the report gives
//! the median ratio and its spread over the rounds. A ratio above 1 means
//! rtdiff is faster (throughput ratio for rays, time ratio Embree / rtdiff for
//! builds).

use std::sync::Arc;

use serde::Serialize;

use crate::error::Result;
use crate::geometry::{Primitives, Ray};

use super::clock::quartiles;

/// Rays per alternation between the two tracers (256 KiB of rays, which
/// stay in the second-level cache for both).
pub const CHUNK: usize = 8192;

/// One contest over the rounds.
#[derive(Clone, Debug, Serialize)]
pub struct Contest {
    /// `build`, or the ray set's name.
    pub name: String,
    /// Rays in the set (0 for the build).
    pub rays: usize,
    /// Per-round seconds, rtdiff then Embree.
    pub times: Vec<(f64, f64)>,
}

/// Summary of a contest: medians and the spread of the per-round ratio.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct ContestSummary {
    /// Median seconds of rtdiff.
    pub rtdiff_s: f64,
    /// Median seconds of Embree.
    pub embree_s: f64,
    /// Median of Embree time / rtdiff time (above 1: rtdiff faster).
    pub ratio: f64,
    /// First quartile of the ratio.
    pub q1: f64,
    /// Third quartile of the ratio.
    pub q3: f64,
    /// Rounds rtdiff won.
    pub wins: usize,
}

impl Contest {
    /// Medians and ratio quartiles over the rounds.
    pub fn summary(&self) -> ContestSummary {
        let mut ratio: Vec<f64> = self.times.iter().map(|(r, e)| e / r).collect();
        let mut ours: Vec<f64> = self.times.iter().map(|t| t.0).collect();
        let mut theirs: Vec<f64> = self.times.iter().map(|t| t.1).collect();
        let (m, q1, q3) = quartiles(&mut ratio);
        let wins = ratio.iter().filter(|&&r| r > 1.0).count();
        let (mo, _, _) = quartiles(&mut ours);
        let (me, _, _) = quartiles(&mut theirs);
        ContestSummary { rtdiff_s: mo, embree_s: me, ratio: m, q1, q3, wins }
    }
}

/// Everything a race measured.
#[derive(Clone, Debug, Serialize)]
pub struct RaceReport {
    /// Interleaved rounds.
    pub rounds: usize,
    /// `build`, then one contest per ray set.
    pub contests: Vec<Contest>,
    /// Sets on which the two tracers' hit counts differ: `(set, rtdiff, Embree)`.
    pub hit_count_differences: Vec<(String, usize, usize)>,
}

/// [`race`] on the benchmark's ray sets of `prims` ([`super::bench::RaySets`]:
/// `size` x `size` primary rays, `incoherent` incoherent rays, and shadow rays
/// from the primary hits of the default configuration).
pub fn race_bench_sets(prims: &Arc<Primitives>, size: u32, incoherent: usize, rounds: usize) -> Result<RaceReport> {
    let reference = crate::backends::build_tracer(prims.clone(), &crate::backends::AccelConfig::default())?;
    let sets = super::bench::RaySets::new(prims, size, incoherent, reference.as_ref());
    race(prims, &sets.list(), rounds)
}

/// Run `rounds` interleaved rounds on `prims` with the given ray sets.
#[cfg(feature = "embree")]
pub fn race(prims: &Arc<Primitives>, sets: &[(&'static str, &[Ray], bool)], rounds: usize) -> Result<RaceReport> {
    use super::clock::{cpu_seconds, single_pool};
    use crate::accel::Tracer;
    use crate::backends::{AccelConfig, Builder, EmbreeQuality, Traversal, build_tracer};
    use crate::embree::{Device, EmbreeTracer};
    if rounds == 0 {
        return Err(crate::Error::Invalid("--race needs at least one round".into()));
    }
    let one = single_pool()?;
    let device = Device::new("threads=1")?;
    let cfg = AccelConfig { builder: Builder::Sah, traversal: Traversal::Fast, ..Default::default() };
    let ours = one.install(|| build_tracer(prims.clone(), &cfg))?;
    let theirs = EmbreeTracer::with_device(&device, prims.clone(), EmbreeQuality::Medium)?;
    let mut contests = vec![Contest { name: "build".into(), rays: 0, times: Vec::new() }];
    let mut hit_count_differences = Vec::new();
    contests.extend(sets.iter().map(|(name, rays, _)| Contest {
        name: name.to_string(),
        rays: rays.len(),
        times: Vec::new(),
    }));

    let run_set = |t: &dyn Tracer, rays: &[Ray], any: bool| -> usize {
        if any {
            rays.iter().filter(|r| t.occluded(r)).count()
        } else {
            rays.iter().filter(|r| t.intersect(r).is_some()).count()
        }
    };
    for round in 0..rounds {
        let ours_first = round % 2 == 0;
        // Build: rtdiff's sah + 8-wide collapse + packets on a one-thread pool,
        // Embree MEDIUM on a threads=1 device; both CPU time of the building
        // thread, construction only (the structures are dropped after timing).
        let build_ours = || one.install(|| cpu_seconds(|| build_tracer(prims.clone(), &cfg)));
        let build_theirs =
            || one.install(|| cpu_seconds(|| EmbreeTracer::with_device(&device, prims.clone(), EmbreeQuality::Medium)));
        let (a, b) = if ours_first {
            let a = build_ours();
            (a, build_theirs())
        } else {
            let b = build_theirs();
            (build_ours(), b)
        };
        drop(a.1?);
        drop(b.1?);
        contests[0].times.push((a.0, b.0));
        for (k, (_, rays, any)) in sets.iter().enumerate() {
            // Chunks of rays alternate between the two tracers, so a change of
            // the machine's load hits both alike.
            let (mut ta, mut tb, mut ha, mut hb) = (0.0, 0.0, 0, 0);
            for (c, chunk) in rays.chunks(CHUNK).enumerate() {
                // Load the chunk before either tracer runs: otherwise whoever
                // goes first pays for bringing the rays into the cache.
                std::hint::black_box(chunk.iter().map(|r| r.origin.x + r.dir.x + r.t_max).sum::<f32>());
                let go_ours = || one.install(|| cpu_seconds(|| run_set(ours.as_ref(), chunk, *any)));
                let go_theirs = || one.install(|| cpu_seconds(|| run_set(&theirs, chunk, *any)));
                let (a, b) = if (round + c) % 2 == 0 {
                    let a = go_ours();
                    (a, go_theirs())
                } else {
                    let b = go_theirs();
                    (go_ours(), b)
                };
                (ta, tb, ha, hb) = (ta + a.0, tb + b.0, ha + a.1, hb + b.1);
            }
            if ha != hb {
                hit_count_differences.push((sets[k].0.to_string(), ha, hb));
            }
            contests[k + 1].times.push((ta, tb));
        }
    }
    Ok(RaceReport { rounds, contests, hit_count_differences })
}

/// Without the Embree backend there is nothing to race.
#[cfg(not(feature = "embree"))]
pub fn race(_: &Arc<Primitives>, _: &[(&'static str, &[Ray], bool)], _: usize) -> Result<RaceReport> {
    Err(crate::Error::Invalid(
        "--race needs the Embree backend: run scripts/setup-embree.sh and build with --features embree".into(),
    ))
}
