//! The exact arbiter applied to a parity comparison: every ray on which a
//! tracer and the reference return different primitives (or one misses) is
//! judged by [`Arbiter`], classified ([`ArbiterClass`]), checked against the
//! heuristic class of [`super::classify::heuristic_class`], and, where the
//! tracer is not exact, printed as a replayable hex-float line.

use std::collections::{BTreeMap, HashMap};
use std::sync::{Arc, Mutex};

use rayon::prelude::*;
use serde::Serialize;

use super::arbiter::{Arbiter, ArbiterClass, K_TRACER, Truth, Verdict, replay_line};
use super::classify::{Answers, heuristic_class};
use crate::geometry::Hit;
use crate::rays::RaySet;

/// Exact answers already computed for a set, by ray index (shared by the
/// variants compared on the same set).
#[derive(Default)]
pub struct TruthCache(Mutex<HashMap<usize, Arc<Truth>>>);

impl TruthCache {
    fn get(&self, arbiter: &Arbiter, set: &RaySet, i: usize) -> Arc<Truth> {
        if let Some(t) = self.0.lock().expect("truth cache").get(&i) {
            return t.clone();
        }
        let t = Arc::new(arbiter.truth(&set.rays[i]));
        self.0.lock().expect("truth cache").insert(i, t.clone());
        t
    }
}

/// A ray the tracer got wrong (not exact), replayable.
#[derive(Clone, Debug, Serialize)]
pub struct Replay {
    /// Set name.
    pub set: String,
    /// Seed of the set.
    pub seed: u64,
    /// Index of the ray in the set.
    pub index: usize,
    /// `ox oy oz dx dy dz tmin tmax` as hexadecimal floats (exact), then in decimal.
    pub line: String,
    /// The arbiter's class.
    pub class: ArbiterClass,
    /// The tracer's verdict.
    pub native: Verdict,
    /// The reference's verdict.
    pub reference: Verdict,
    /// The heuristic class.
    pub heuristic: String,
    /// Conditioning margin in units of one rounding.
    pub margin: f64,
    /// The exact answer's primitives (empty: a miss).
    pub truth: Vec<u32>,
    /// The exact distance.
    pub truth_t: Option<f64>,
    /// The tracer's primitive.
    pub native_prim: Option<u32>,
    /// The reference's primitive.
    pub reference_prim: Option<u32>,
}

/// What the arbiter found on one set for one tracer.
#[derive(Clone, Debug, Default, Serialize)]
pub struct ArbiterStats {
    /// Rays judged (different primitives, or a hit against a miss).
    pub judged: u64,
    /// Rays by [`ArbiterClass`] name.
    pub classes: BTreeMap<String, u64>,
    /// The tracer's verdicts (`exact`, `within-bound`, `wrong`).
    pub native: BTreeMap<String, u64>,
    /// The reference's verdicts.
    pub reference: BTreeMap<String, u64>,
    /// Rays where the tracer is not exact and the ray is not ill-conditioned.
    pub native_wrong_outside_ill_conditioned: u64,
    /// The same for the reference.
    pub reference_wrong_outside_ill_conditioned: u64,
    /// The tracer's verdicts on the rays that are not ill-conditioned (those
    /// counted in `native_wrong_outside_ill_conditioned`, by verdict:
    /// `within-bound` or `wrong`).
    pub native_well_conditioned: BTreeMap<String, u64>,
    /// The same for the reference.
    pub reference_well_conditioned: BTreeMap<String, u64>,
    /// Heuristic class -> arbiter class, `heuristic>arbiter` keys.
    pub heuristic_check: BTreeMap<String, u64>,
    /// Rays the heuristic explained as rounding (any class but `unclassified`
    /// and `leak`) where the arbiter finds the tracer beyond the bound.
    pub heuristic_misses: u64,
    /// The rays where the tracer is not exact: all of them on well-conditioned
    /// rays, the first `max_replays` ill-conditioned ones.
    pub replays: Vec<Replay>,
    /// Rays on which both return the same primitive (or tie) but their
    /// distances or barycentrics differ beyond the bounds of
    /// [`super::bounds`], each judged against the exact distance and
    /// barycentrics of the tracer's primitive ([`Arbiter::evaluate`]).
    pub beyond_bound: BeyondBound,
}

/// The arbiter's judgment of the rays whose distances or barycentrics differ beyond
/// their bounds ([`ArbiterStats::beyond_bound`]): each side is right when its answer is
/// within the bound of [`super::bounds`] (taken at its own hit) of the exact one.
#[derive(Clone, Debug, Default, Serialize)]
pub struct BeyondBound {
    /// Rays judged.
    pub judged: u64,
    /// Rays where the tracer's distance and barycentrics are within their bounds of the exact ones.
    pub tracer_right: u64,
    /// Rays where the tracer's distance is beyond its bound of the exact one.
    pub tracer_distance_wrong: u64,
    /// Rays where the tracer's barycentrics are beyond their bound of the exact ones.
    pub tracer_barycentrics_wrong: u64,
    /// Rays where the tracer is wrong (either way, or the exact distance does not exist).
    pub tracer_wrong: u64,
    /// Rays where the reference's distance or barycentrics are beyond their bounds of the exact ones.
    pub reference_wrong: u64,
}

/// True when `h`'s distance is within its bound (`bounds`, at `h`) of `exact`'s, and
/// `(distance right, barycentrics right)` (barycentrics: triangles only).
pub(crate) fn right_against(set: &RaySet, i: usize, h: &Hit, exact: &super::arbiter::Exact) -> (bool, bool) {
    let ray = &set.rays[i];
    if exact.t.is_none() || !exact.t_f64.is_finite() {
        return (false, false);
    }
    let g = super::bounds::hit_geom(&set.prims, ray, h);
    let (tb, bb) = super::bounds::bounds(ray, h, &g);
    let t_ok = (h.t as f64 - exact.t_f64).abs() <= tb;
    let b_ok = !g.is_triangle || (h.u as f64 - exact.bary[1]).abs().max((h.v as f64 - exact.bary[2]).abs()) <= bb;
    (t_ok, b_ok)
}

fn verdict_name(v: Verdict) -> &'static str {
    match v {
        Verdict::Exact => "exact",
        Verdict::WithinBound => "within-bound",
        Verdict::Wrong => "wrong",
    }
}

/// Judge every disagreement between `ours` and `reference` on `set`.
pub fn arbitrate(
    set: &RaySet,
    ours: Answers,
    reference: Answers,
    arbiter: &Arbiter,
    cache: &TruthCache,
    max_replays: usize,
) -> ArbiterStats {
    let n = ours.hits.len().min(reference.hits.len());
    // Hits that are no hits ([`Hit::fault`]) are counted by `compare`, not judged here.
    let disagree: Vec<usize> = (0..n)
        .filter(|&i| ours.hits[i].is_none_or(|h| h.fault(&set.rays[i], set.prims.len()).is_none()))
        .filter(|&i| match (&ours.hits[i], &reference.hits[i]) {
            (None, None) => false,
            (Some(a), Some(b)) => a.prim != b.prim,
            _ => true,
        })
        .collect();
    let judged: Vec<(usize, Arc<Truth>, Verdict, Verdict)> = disagree
        .par_iter()
        .map(|&i| {
            let ray = &set.rays[i];
            let truth = cache.get(arbiter, set, i);
            // A hit that is no hit ([`Hit::fault`]) is wrong without evaluation (its id may name nothing).
            let judge = |h: Option<Hit>| match h {
                Some(h) if h.fault(ray, set.prims.len()).is_some() => Verdict::Wrong,
                h => arbiter.judge(ray, &truth, h.map(|h| h.prim)),
            };
            let vn = judge(ours.hits[i]);
            let vr = judge(reference.hits[i]);
            (i, truth, vn, vr)
        })
        .collect();
    let mut s = ArbiterStats { judged: judged.len() as u64, ..Default::default() };
    // Same primitive (or a tie) with distances or barycentrics beyond their bounds
    // (`super::classify::compare`'s `beyond_bound`): judged against the exact hit on the
    // tracer's primitive.
    let beyond: Vec<usize> = (0..n)
        .filter(|&i| match (&ours.hits[i], &reference.hits[i]) {
            (Some(a), Some(b)) if a.fault(&set.rays[i], set.prims.len()).is_none() => {
                super::classify::beyond_bounds(&set.prims, &set.rays[i], a, b)
            }
            _ => false,
        })
        .collect();
    let verdicts: Vec<((bool, bool), (bool, bool))> = beyond
        .par_iter()
        .map(|&i| {
            let (a, b) = (ours.hits[i].expect("a hit"), reference.hits[i].expect("a hit"));
            let exact = arbiter.evaluate(&set.rays[i], a.prim);
            let theirs = if b.prim == a.prim { exact.clone() } else { arbiter.evaluate(&set.rays[i], b.prim) };
            (right_against(set, i, &a, &exact), right_against(set, i, &b, &theirs))
        })
        .collect();
    for ((t_ok, b_ok), (rt_ok, rb_ok)) in verdicts {
        let bb = &mut s.beyond_bound;
        bb.judged += 1;
        bb.tracer_right += (t_ok && b_ok) as u64;
        bb.tracer_distance_wrong += !t_ok as u64;
        bb.tracer_barycentrics_wrong += !b_ok as u64;
        bb.tracer_wrong += !(t_ok && b_ok) as u64;
        bb.reference_wrong += !(rt_ok && rb_ok) as u64;
    }
    for (i, truth, vn, vr) in judged {
        let ray = &set.rays[i];
        let class = ArbiterClass::of(vn, vr, truth.ill_conditioned());
        *s.classes.entry(class.name().into()).or_default() += 1;
        *s.native.entry(verdict_name(vn).into()).or_default() += 1;
        *s.reference.entry(verdict_name(vr).into()).or_default() += 1;
        let well = !truth.ill_conditioned();
        s.native_wrong_outside_ill_conditioned += (well && vn != Verdict::Exact) as u64;
        s.reference_wrong_outside_ill_conditioned += (well && vr != Verdict::Exact) as u64;
        if well && vn != Verdict::Exact {
            *s.native_well_conditioned.entry(verdict_name(vn).into()).or_default() += 1;
        }
        if well && vr != Verdict::Exact {
            *s.reference_well_conditioned.entry(verdict_name(vr).into()).or_default() += 1;
        }
        let faulty = |h: &Option<Hit>| h.and_then(|h| h.fault(ray, set.prims.len()));
        let heuristic = match (faulty(&ours.hits[i]), faulty(&reference.hits[i])) {
            (Some(f), _) | (None, Some(f)) => f.name(),
            _ => heuristic_class(ray, set.tags[i], &ours.hits[i], &reference.hits[i], &set.prims).unwrap_or("none"),
        };
        *s.heuristic_check.entry(format!("{heuristic}>{}", class.name())).or_default() += 1;
        s.heuristic_misses += (vn == Verdict::Wrong
            && faulty(&ours.hits[i]).is_none()
            && !matches!(heuristic, "unclassified" | "leak")) as u64;
        // Every ray where the tracer is not exact on a well-conditioned ray,
        // and the first `max_replays` ill-conditioned ones.
        let shown_ill = s.replays.iter().filter(|r| r.class == ArbiterClass::IllConditioned).count();
        if vn != Verdict::Exact && (well || shown_ill < max_replays) {
            s.replays.push(Replay {
                set: set.name.clone(),
                seed: set.seed,
                index: i,
                line: replay_line(ray),
                class,
                native: vn,
                reference: vr,
                heuristic: heuristic.into(),
                margin: truth.margin,
                truth: truth.prims.clone(),
                truth_t: truth.t_f64(),
                native_prim: ours.hits[i].map(|h| h.prim),
                reference_prim: reference.hits[i].map(|h| h.prim),
            });
        }
    }
    s
}

/// The arbiter's findings as text lines (two-space indented), for
/// [`super::report::format_report`].
pub fn format_stats(tracer: &str, reference: &str, s: &ArbiterStats) -> String {
    use std::fmt::Write;
    let mut o = String::new();
    let join = |m: &BTreeMap<String, u64>| m.iter().map(|(k, n)| format!("{k}={n}")).collect::<Vec<_>>().join(" ");
    let _ = writeln!(
        o,
        "  arbiter, {tracer} vs {reference}: {} rays judged; {}; {tracer}: {}; {reference}: {}; \
         not exact outside ill-conditioned: {tracer} {} ({}), {reference} {} ({}) (bound K = {K_TRACER})",
        s.judged,
        join(&s.classes),
        join(&s.native),
        join(&s.reference),
        s.native_wrong_outside_ill_conditioned,
        join(&s.native_well_conditioned),
        s.reference_wrong_outside_ill_conditioned,
        join(&s.reference_well_conditioned)
    );
    if s.judged > 0 {
        let _ = writeln!(
            o,
            "    heuristic>arbiter: {}; heuristic rounding classes the arbiter finds wrong: {}",
            join(&s.heuristic_check),
            s.heuristic_misses
        );
    }
    for r in &s.replays {
        let _ = writeln!(
            o,
            "    {tracer} not exact on {} #{} ({}, {tracer} {:?}, {reference} {:?}, heuristic {}, margin {:.3}, exact {:?} at {:?}, {tracer} {:?}, {reference} {:?}): {}",
            r.set,
            r.index,
            r.class.name(),
            r.native,
            r.reference,
            r.heuristic,
            r.margin,
            r.truth,
            r.truth_t,
            r.native_prim,
            r.reference_prim,
            r.line
        );
    }
    o
}
