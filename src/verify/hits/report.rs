//! What a parity run found, as typed serialisable data, and its plain-text table.

use std::collections::BTreeMap;

use serde::Serialize;

use crate::rays::SetKind;

/// A disagreeing ray, replayable from `(set, seed, index)` or from its numbers.
#[derive(Clone, Debug, Serialize)]
pub struct Example {
    /// Set name.
    pub set: String,
    /// Seed of the set.
    pub seed: u64,
    /// Index of the ray in the set.
    pub index: usize,
    /// `ox oy oz dx dy dz tnear tfar`, the `rtdiff trace` CSV columns.
    pub ray: [f32; 8],
    /// What kind of disagreement.
    pub what: String,
    /// The tracer's hit `(t, prim, u, v)`.
    pub native: Option<(f32, u32, f32, f32)>,
    /// The reference's hit.
    pub reference: Option<(f32, u32, f32, f32)>,
}

/// Comparison of one tracer with the reference on one set.
#[derive(Clone, Debug, Default, Serialize)]
pub struct VariantStats {
    /// Tracer label.
    pub tracer: String,
    /// Rays traced.
    pub rays: usize,
    /// The tracer misses where the reference hits.
    pub native_miss_ref_hit: u64,
    /// The tracer hits where the reference misses.
    pub native_hit_ref_miss: u64,
    /// `occluded` answers differing from the reference's (shadow rays).
    pub occluded_disagree: u64,
    /// Hit/miss disagreements by class: `leak` (through a crossing), `silhouette`
    /// (aimed at a silhouette edge or vertex), `degenerate` (aimed at triangles
    /// thinner than rounding), `edge` (hit within rounding of an edge),
    /// `interval-end` (hit within rounding of `t_min` or `t_max`), `unprovable-t`
    /// (a reference hit closer than twice the watertight test's own `t` error
    /// bound, which that test refuses by design), `unclassified`.
    pub classes: BTreeMap<String, u64>,
    /// Rays crossing a shared edge or closed vertex that this tracer let through.
    pub leaks: u64,
    /// Rays spawned from a surface that hit their own primitive again.
    pub self_hits: u64,
    /// Largest relative distance error `|t - t_ref| / max(t_ref, t bound)` over
    /// rays hitting at equal distance (within the bound).
    pub dist_rel_max: f64,
    /// 99.9th percentile of the same.
    pub dist_rel_p999: f64,
    /// Rays whose distance error exceeds the float error bound (module docs).
    pub dist_over_bound: u64,
    /// Largest ratio of distance error to its bound.
    pub dist_bound_ratio_max: f64,
    /// Primitive-id disagreements at different distances (classified in `prim_classes`).
    pub prim_diff: u64,
    /// Primitive-id disagreements at equal distance (coincident triangles, shared edges).
    pub prim_ties: u64,
    /// Classes of `prim_diff` (`edge`: one hit within rounding of an edge; `unclassified`).
    pub prim_classes: BTreeMap<String, u64>,
    /// Largest barycentric difference on rays hitting the same triangle.
    pub bary_max: f64,
    /// Rays whose barycentric difference exceeds its bound.
    pub bary_over_bound: u64,
    /// Largest ratio of barycentric difference to its bound.
    pub bary_bound_ratio_max: f64,
    /// Rays on the reference's primitive whose distance or barycentrics lie beyond their bounds.
    pub beyond_bound: u64,
    /// Hits that are no hits at all ([`crate::geometry::Hit::fault`]: a primitive
    /// that does not exist, a distance outside the interval or not finite, NaN
    /// barycentrics): wrong on every ray, not compared further.
    pub invalid: u64,
    /// `invalid` by fault (`no-such-primitive`, `t-outside-interval`, `t-not-finite`, `uv-not-finite`).
    pub invalid_classes: BTreeMap<String, u64>,
    /// First disagreeing rays.
    pub examples: Vec<Example>,
    /// The exact arbiter's judgement of every disagreement (when run).
    pub arbiter: Option<super::arbitrate::ArbiterStats>,
}

/// All comparisons on one set.
#[derive(Clone, Debug, Serialize)]
pub struct SetReport {
    /// Set name.
    pub set: String,
    /// Set kind.
    pub kind: SetKind,
    /// Seed.
    pub seed: u64,
    /// Rays in the set.
    pub rays: usize,
    /// Rays tagged as crossing a shared edge or closed vertex.
    pub crossing_rays: usize,
    /// Rays spawned from a surface (surface and shadow rays).
    pub spawned_rays: usize,
    /// Reference label.
    pub reference: String,
    /// Reference hits.
    pub reference_hits: usize,
    /// Leaks and self-hits of the reference itself.
    pub reference_leaks: u64,
    /// Self-hits of the reference.
    pub reference_self_hits: u64,
    /// One entry per tracer under test.
    pub variants: Vec<VariantStats>,
}

/// One row of the numerical stress report.
#[derive(Clone, Debug, Serialize)]
pub struct StressRow {
    /// Set name.
    pub set: String,
    /// Rays in the set.
    pub rays: usize,
    /// Leaks per million rays: watertight, Moller-Trumbore, reference.
    pub leaks_per_million: [f64; 3],
    /// False self-intersections per million spawned rays (robust offset):
    /// watertight, Moller-Trumbore, reference.
    pub self_hits_per_million: [f64; 3],
    /// The same with the reports' fixed offset (origin + 1e-4 along the unit direction).
    pub self_hits_fixed_offset_per_million: [f64; 3],
    /// The same with no offset (origin on the surface).
    pub self_hits_no_offset_per_million: [f64; 3],
    /// Spawned rays in the set.
    pub spawned_rays: usize,
}

/// Everything a parity run found.
#[derive(Clone, Debug, Serialize)]
pub struct ParityReport {
    /// Rays requested per set (with the seed, what replays a set).
    pub count: usize,
    /// Per-set comparisons.
    pub sets: Vec<SetReport>,
    /// The stress report, when asked for.
    pub stress: Vec<StressRow>,
    /// Column labels of the stress report.
    pub stress_tracers: [String; 3],
    /// Wall-clock seconds of the whole run (sets, tracers, arbiter and stress report).
    pub seconds: f64,
    /// Pass or fail, per tracer and set ([`super::verdict`]).
    pub verdict: super::verdict::Verdict,
}

/// The report as a plain-text table.
pub fn format_report(r: &ParityReport) -> String {
    use std::fmt::Write;
    let mut o = String::new();
    for s in &r.sets {
        let _ = writeln!(
            o,
            "set {} (seed {}): {} rays, {} hit by {}, {} crossing, {} spawned; reference leaks {}, self-hits {}",
            s.set,
            s.seed,
            s.rays,
            s.reference_hits,
            s.reference,
            s.crossing_rays,
            s.spawned_rays,
            s.reference_leaks,
            s.reference_self_hits
        );
        let _ = writeln!(
            o,
            "  {:<32} {:>8} {:>8} {:>6} {:>6} {:>10} {:>10} {:>8} {:>6} {:>6} {:>10} {:>7}  classes",
            "tracer",
            "miss/hit",
            "hit/miss",
            "occl",
            "leaks",
            "t-rel max",
            "t-rel p999",
            "t/bound",
            "prim",
            "ties",
            "bary max",
            "b/bound"
        );
        for v in &s.variants {
            let classes: Vec<String> = v
                .classes
                .iter()
                .map(|(k, n)| format!("{k}={n}"))
                .chain(v.prim_classes.iter().map(|(k, n)| format!("prim-{k}={n}")))
                .collect();
            let _ = writeln!(
                o,
                "  {:<32} {:>8} {:>8} {:>6} {:>6} {:>10.2e} {:>10.2e} {:>8.3} {:>6} {:>6} {:>10.2e} {:>7.3}  {}",
                v.tracer,
                v.native_miss_ref_hit,
                v.native_hit_ref_miss,
                v.occluded_disagree,
                v.leaks,
                v.dist_rel_max,
                v.dist_rel_p999,
                v.dist_bound_ratio_max,
                v.prim_diff,
                v.prim_ties,
                v.bary_max,
                v.bary_bound_ratio_max,
                classes.join(" ")
            );
        }
        for v in s.variants.iter() {
            if let Some(a) = &v.arbiter {
                o.push_str(&super::arbitrate::format_stats(&v.tracer, &s.reference, a));
            }
        }
        // Replayable examples, once per distinct set of disagreements.
        let mut shown: Vec<Vec<usize>> = Vec::new();
        for v in &s.variants {
            let idx: Vec<usize> = v.examples.iter().map(|e| e.index).collect();
            if idx.is_empty() || shown.contains(&idx) {
                continue;
            }
            shown.push(idx);
            let _ = writeln!(
                o,
                "  first disagreeing rays of {} (replay: --rays {} --seed {}, ray index):",
                v.tracer,
                s.kind.name(),
                s.seed
            );
            for e in &v.examples {
                let _ = writeln!(
                    o,
                    "    {} #{}: {:?} -> {}; native {:?}, reference {:?}",
                    e.set, e.index, e.ray, e.what, e.native, e.reference
                );
            }
        }
    }
    if !r.stress.is_empty() {
        let [a, b, c] = &r.stress_tracers;
        let _ = writeln!(o, "numerical stress: leaks per million rays ({a} / {b} / {c})");
        for s in &r.stress {
            let [x, y, z] = s.leaks_per_million;
            let _ = writeln!(o, "  {:<14} {:>9} rays: {:>10.1} {:>10.1} {:>10.1}", s.set, s.rays, x, y, z);
        }
        let _ = writeln!(
            o,
            "false self-intersections per million spawned rays ({a} / {b} / {c}), by offset: robust | fixed 1e-4 | none"
        );
        for s in r.stress.iter().filter(|s| s.spawned_rays > 0) {
            let f = |v: [f64; 3]| format!("{:>9.1} {:>9.1} {:>9.1}", v[0], v[1], v[2]);
            let _ = writeln!(
                o,
                "  {:<14} {:>9} spawned: {} | {} | {}",
                s.set,
                s.spawned_rays,
                f(s.self_hits_per_million),
                f(s.self_hits_fixed_offset_per_million),
                f(s.self_hits_no_offset_per_million)
            );
        }
    }
    o
}
