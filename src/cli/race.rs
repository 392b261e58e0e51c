//! `rtdiff bench --race ROUNDS`: the `sah` build with the `fast` traversal
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

use crate::accel::{AccelConfig, Builder, EmbreeQuality, Tracer, Traversal, build_tracer};
use crate::embree::{Device, EmbreeTracer};
use crate::error::Result;
use crate::geometry::{Primitives, Ray};

use super::bench::{Clock, single_pool};

/// Rays per alternation between the two tracers (256 KiB of rays, which
/// stay in the second-level cache for both).
const CHUNK: usize = 8192;

/// Median, first and last quartile of `v` (sorted in place).
fn quartiles(v: &mut [f64]) -> (f64, f64, f64) {
    v.sort_by(f64::total_cmp);
    let at = |q: f64| v[((v.len() - 1) as f64 * q).round() as usize];
    (at(0.5), at(0.25), at(0.75))
}

/// Thread CPU seconds of one call of `f`.
fn cpu_seconds<T>(f: impl FnOnce() -> T) -> (f64, T) {
    let clock = Clock { cpu: true };
    let start = clock.now();
    let r = f();
    (clock.since(start), r)
}

/// One contest: a name and the per-round (rtdiff, Embree) seconds.
struct Contest {
    name: &'static str,
    rays: usize,
    times: Vec<(f64, f64)>,
}

impl Contest {
    fn print(&self) {
        let mut ratio: Vec<f64> = self.times.iter().map(|(r, e)| e / r).collect();
        let mut ours: Vec<f64> = self.times.iter().map(|t| t.0).collect();
        let mut theirs: Vec<f64> = self.times.iter().map(|t| t.1).collect();
        let (m, q1, q3) = quartiles(&mut ratio);
        let wins = ratio.iter().filter(|&&r| r > 1.0).count();
        let (mo, _, _) = quartiles(&mut ours);
        let (me, _, _) = quartiles(&mut theirs);
        let (a, b) = if self.rays > 0 {
            (
                format!("{:.2} Mrays/s", self.rays as f64 / mo / 1e6),
                format!("{:.2} Mrays/s", self.rays as f64 / me / 1e6),
            )
        } else {
            (format!("{:.2} ms", mo * 1e3), format!("{:.2} ms", me * 1e3))
        };
        println!(
            "{:<12} {:>16} {:>16} {:>7.3} {:>7.3} {:>7.3} {:>5}/{}",
            self.name,
            a,
            b,
            m,
            q1,
            q3,
            wins,
            ratio.len()
        );
    }
}

/// Run `rounds` interleaved rounds on `prims` with the given ray sets.
pub fn race(prims: &Arc<Primitives>, sets: &[(&'static str, &[Ray], bool)], rounds: usize) -> Result<()> {
    let one = single_pool()?;
    let device = Device::new("threads=1")?;
    let cfg = AccelConfig { builder: Builder::Sah, traversal: Traversal::Fast, ..Default::default() };
    let ours = one.install(|| build_tracer(prims.clone(), &cfg))?;
    let theirs = EmbreeTracer::with_device(&device, prims.clone(), EmbreeQuality::Medium)?;
    let mut contests = vec![Contest { name: "build", rays: 0, times: Vec::new() }];
    contests.extend(sets.iter().map(|(name, rays, _)| Contest { name, rays: rays.len(), times: Vec::new() }));

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
                eprintln!("note: {} hits differ on {}: rtdiff {ha}, Embree {hb}", ha.abs_diff(hb), sets[k].0);
            }
            contests[k + 1].times.push((ta, tb));
        }
    }
    println!(
        "\n### rtdiff sah/fast against Embree MEDIUM (rtcIntersect1 / rtcOccluded1), 1 thread, {rounds} interleaved rounds"
    );
    println!("ratio = Embree time / rtdiff time in the same round (above 1: rtdiff faster); CPU time of the thread");
    println!(
        "{:<12} {:>16} {:>16} {:>7} {:>7} {:>7} {:>7}",
        "", "rtdiff (median)", "Embree (median)", "ratio", "q1", "q3", "wins"
    );
    for c in &contests {
        c.print();
    }
    Ok(())
}
