//! One work item run, and its typed result: one JSON file per item in the output folder.
//! A result holds what the item found (the input's load result, parity verdicts with the
//! arbiter's judgement, speed) and the digest of the plan it belongs to; only `seconds` and
//! the speed figures depend on the machine and the moment.

use std::path::Path;

use serde::{Deserialize, Serialize};

use super::plan::{Item, ItemKind, Plan};
use crate::perf::speed::{SpeedOptions, SpeedReport};
use crate::rays::SetKind;
use crate::verify::hits::{ParityOptions, ParityReport};

/// The result format this build writes and reads.
pub const RESULT_FORMAT: u32 = 1;

/// This build's version, recorded in every result and manifest.
pub const RTDIFF_VERSION: &str = env!("CARGO_PKG_VERSION");

/// Disagreeing rays kept per set and tracer (replayable lines).
pub const MAX_DISPUTES: usize = 3;

/// What became of loading the input.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct LoadSummary {
    /// Loaded.
    pub ok: bool,
    /// Triangles traced (zero-area ones included or not as the mesh reader decides).
    pub triangles: usize,
    /// Analytic spheres (scenes).
    pub spheres: usize,
    /// Zero-area triangles the reader dropped.
    pub degenerate: usize,
    /// The error, with paths relative to the plan's folder.
    pub error: Option<String>,
}

/// A ray one tracer or the reference got wrong, as the arbiter judged it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Dispute {
    /// Index of the ray in its set.
    pub index: usize,
    /// The arbiter's class (`reference-right`, `ill-conditioned`, ...).
    pub class: String,
    /// The tracer's verdict: `exact`, `within-bound` or `wrong`.
    pub tracer: String,
    /// The reference's verdict.
    pub reference: String,
    /// The ray, replayable: `ox oy oz dx dy dz tmin tmax` in hexadecimal floats, then decimal.
    pub line: String,
}

/// One tracer against the reference on one set.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TracerParity {
    /// Tracer label.
    pub tracer: String,
    /// Rays compared.
    pub rays: usize,
    /// Rays whose closest hit differs (hit against miss, or another primitive, at another
    /// distance or at the same one).
    pub disagreements: u64,
    /// Shadow rays whose occlusion answer differs.
    pub occluded: u64,
    /// Rays through a shared edge or closed vertex the tracer let through.
    pub leaks: u64,
    /// Rays leaving a surface that hit it again.
    pub self_hits: u64,
    /// Same-primitive hits whose distance differs beyond the error bound.
    pub dist_over_bound: u64,
    /// Same-primitive hits whose barycentrics differ beyond the bound.
    pub bary_over_bound: u64,
    /// Disagreements the arbiter judged.
    pub judged: u64,
    /// Of those, rays where the tracer is wrong (beyond its rounding bound of the exact answer).
    pub tracer_wrong: u64,
    /// Every ray the tracer answered wrong ([`crate::verify::hits::VariantVerdict::wrong`]):
    /// a primitive the arbiter judged wrong, a distance or barycentrics beyond their bound of
    /// the exact ones on the right primitive, or a hit that is no hit (an id that names nothing,
    /// a distance outside the interval, NaN).
    #[serde(default)]
    pub wrong: u64,
    /// `wrong` by class (`primitive`, `distance`, `barycentrics`, `no-such-primitive`, ...).
    #[serde(default)]
    pub wrong_by: std::collections::BTreeMap<String, u64>,
    /// Rays where the tracer is not exact but within the bound.
    pub tracer_within_bound: u64,
    /// Rays where the reference is wrong (a primitive the arbiter judged wrong, or a distance
    /// or barycentrics beyond their bound of the exact ones).
    pub reference_wrong: u64,
    /// Rays where the reference is not exact but within the bound.
    pub reference_within_bound: u64,
    /// Judged rays decided by the last bit of the inputs (ill-conditioned).
    pub ill_conditioned: u64,
    /// The first rays where the tracer is not exact, replayable.
    pub disputes: Vec<Dispute>,
}

/// Every tracer on one ray set (the `scaled` set gives three: one per transformed copy).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SetParity {
    /// Set name.
    pub set: String,
    /// Rays in the set.
    pub rays: usize,
    /// Reference label.
    pub reference: String,
    /// Rays the reference hits.
    pub reference_hits: usize,
    /// One entry per tracer, in the plan's order.
    pub tracers: Vec<TracerParity>,
}

/// The result of one item.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ItemResult {
    /// [`RESULT_FORMAT`].
    pub format: u32,
    /// The rtdiff version that made it.
    pub rtdiff: String,
    /// The plan's digest.
    pub plan: String,
    /// The item.
    pub item: Item,
    /// The input's load result.
    pub load: LoadSummary,
    /// Parity items: the sets.
    pub parity: Vec<SetParity>,
    /// Speed items: every tracer's figures, the reference first.
    pub speed: Option<SpeedReport>,
    /// A failure after the input loaded (a tracer that cannot be built, an internal error).
    pub error: Option<String>,
    /// Wall-clock seconds of the item (a timing).
    pub seconds: f64,
    /// CPU seconds of the process over the item, every thread counted (a timing: what the item
    /// costs in core-seconds, whatever else the machine runs).
    #[serde(default)]
    pub cpu_seconds: f64,
}

impl ItemResult {
    /// The result with every timing set to zero (for comparisons and timing-free reports).
    pub fn without_timings(&self) -> Self {
        let mut r = self.clone();
        r.seconds = 0.0;
        r.cpu_seconds = 0.0;
        if let Some(s) = &mut r.speed {
            for row in &mut s.rows {
                row.build_ms = 0.0;
                row.primary_mrays_per_s = 0.0;
                row.incoherent_mrays_per_s = 0.0;
            }
            s.threads = 0;
        }
        r
    }
}

/// `msg` with the plan folder's part of paths removed, so that results name inputs as the
/// plan lists them, whatever the folder on each machine.
fn relative_message(msg: &str, plan: &Plan, input: &Path) -> String {
    let full = input.display().to_string();
    let rel = full.strip_prefix(&format!("{}/", plan.dir.display())).unwrap_or(&full).to_string();
    let mut m = msg.replace(&full, &rel);
    let dir = plan.dir.display().to_string();
    if dir != "." && !dir.is_empty() {
        m = m.replace(&format!("{dir}/"), "");
    }
    m
}

/// Run `item` of `plan`. Never fails: a load error, a failing tracer or a panic is recorded
/// in the result, so that a campaign over hostile inputs finishes and a resumed one does not
/// redo (or crash on) such an item again.
pub fn run(plan: &Plan, item: &Item) -> ItemResult {
    let start = std::time::Instant::now();
    let path = plan.dir.join(&item.input);
    let mut result = ItemResult {
        format: RESULT_FORMAT,
        rtdiff: RTDIFF_VERSION.to_string(),
        plan: plan.digest.clone(),
        item: item.clone(),
        load: LoadSummary { ok: false, triangles: 0, spheres: 0, degenerate: 0, error: None },
        parity: Vec::new(),
        speed: None,
        error: None,
        seconds: 0.0,
        cpu_seconds: 0.0,
    };
    let cpu_start = crate::perf::clock::process_cpu_seconds();
    let body = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| -> crate::Result<()> {
        let (ctx, skipped) = match crate::rays::load_context_counted(&path) {
            Ok(c) => c,
            Err(e) => {
                result.load.error = Some(relative_message(&e.to_string(), plan, &path));
                return Ok(());
            }
        };
        result.load = LoadSummary {
            ok: true,
            triangles: ctx.prims.triangles.len(),
            spheres: ctx.prims.spheres.len(),
            degenerate: skipped,
            error: None,
        };
        match item.kind {
            ItemKind::Parity => result.parity = parity(plan, item, &ctx)?,
            ItemKind::Speed => result.speed = Some(speed(plan, &ctx)?),
        }
        Ok(())
    }));
    match body {
        Ok(Ok(())) => {}
        Ok(Err(e)) => result.error = Some(relative_message(&e.to_string(), plan, &path)),
        Err(p) => {
            let what = p
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| p.downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "unknown".into());
            result.error = Some(format!("internal error (panic): {what}"));
        }
    }
    result.seconds = start.elapsed().as_secs_f64();
    result.cpu_seconds = crate::perf::clock::process_cpu_seconds() - cpu_start;
    result
}

fn parity(plan: &Plan, item: &Item, ctx: &crate::rays::RayContext) -> crate::Result<Vec<SetParity>> {
    use clap::ValueEnum;
    let set = item.set.as_deref().unwrap_or_default();
    let kind = SetKind::from_str(set, false).map_err(|_| crate::Error::Invalid(format!("unknown ray set '{set}'")))?;
    let opts = ParityOptions {
        sets: vec![kind],
        count: plan.file.rays.count,
        seed: plan.file.rays.seed,
        reference: plan.reference,
        variants: plan.tracers.clone(),
        sweep_count: None,
        stress: false,
        max_examples: 0,
        arbiter: true,
    };
    let report = crate::verify::hits::run(ctx, &opts)?;
    Ok(summarise(&report))
}

fn summarise(report: &ParityReport) -> Vec<SetParity> {
    report
        .sets
        .iter()
        .map(|s| SetParity {
            set: s.set.clone(),
            rays: s.rays,
            reference: s.reference.clone(),
            reference_hits: s.reference_hits,
            tracers: s
                .variants
                .iter()
                .map(|v| {
                    let verdict = crate::verify::hits::VariantVerdict::of(s, v);
                    let a = v.arbiter.clone().unwrap_or_default();
                    let count = |m: &std::collections::BTreeMap<String, u64>, k: &str| m.get(k).copied().unwrap_or(0);
                    TracerParity {
                        tracer: v.tracer.clone(),
                        rays: v.rays,
                        disagreements: v.native_miss_ref_hit + v.native_hit_ref_miss + v.prim_diff + v.prim_ties,
                        occluded: v.occluded_disagree,
                        leaks: v.leaks,
                        self_hits: v.self_hits,
                        dist_over_bound: v.dist_over_bound,
                        bary_over_bound: v.bary_over_bound,
                        judged: a.judged,
                        tracer_wrong: count(&a.native, "wrong"),
                        wrong: verdict.wrong,
                        wrong_by: verdict.wrong_by,
                        tracer_within_bound: count(&a.native, "within-bound"),
                        reference_wrong: count(&a.reference, "wrong") + a.beyond_bound.reference_wrong,
                        reference_within_bound: count(&a.reference, "within-bound"),
                        ill_conditioned: count(&a.classes, "ill-conditioned"),
                        disputes: a
                            .replays
                            .iter()
                            .take(MAX_DISPUTES)
                            .map(|r| Dispute {
                                index: r.index,
                                class: r.class.name().to_string(),
                                tracer: name_of(&r.native),
                                reference: name_of(&r.reference),
                                line: r.line.clone(),
                            })
                            .collect(),
                    }
                })
                .collect(),
        })
        .collect()
}

/// The serde name of a unit enum value (`within-bound`).
fn name_of<T: Serialize>(v: &T) -> String {
    serde_json::to_value(v).ok().and_then(|v| v.as_str().map(str::to_string)).unwrap_or_default()
}

fn speed(plan: &Plan, ctx: &crate::rays::RayContext) -> crate::Result<SpeedReport> {
    let s = &plan.file.speed;
    let mut tracers = vec![plan.reference.config()];
    tracers.extend(plan.tracers.iter().copied());
    crate::perf::speed::run(ctx, &tracers, &SpeedOptions { size: s.size, incoherent: s.incoherent, runs: s.runs })
}
