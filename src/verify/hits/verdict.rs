//! The verdict a person reads first: per tracer and set, how many rays agree
//! with the reference, how many differ and are still right (exact where the
//! reference is not, or within the bound), how many are wrong and why, and the
//! leaks and false self-intersections; then pass or fail over the whole run.
//!
//! A tracer fails when any of its answers is wrong (the exact arbiter's
//! `wrong`, a hit that is no hit, a distance or barycentrics beyond their
//! bounds), when it leaks through a shared edge or vertex, or when a ray
//! spawned from a surface hits that surface again.

use std::collections::BTreeMap;
use std::fmt::Write as _;

use serde::Serialize;

use super::report::{ParityReport, SetReport, VariantStats};

/// One tracer on one set.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct VariantVerdict {
    /// Tracer label.
    pub tracer: String,
    /// Set name.
    pub set: String,
    /// Rays compared.
    pub rays: usize,
    /// Same primitive as the reference (or both miss), distance and barycentrics within their bounds.
    pub agree: u64,
    /// A different answer that the exact arbiter finds exact (a tie, or the reference is the one that is off).
    pub differ_exact: u64,
    /// A different answer that is not exact but within the bound of `K` roundings.
    pub within_bound: u64,
    /// Wrong answers (rays; one ray may be in two classes of `wrong_by`).
    pub wrong: u64,
    /// Wrong answers by class: `primitive` (the arbiter's `wrong`), `distance` and
    /// `barycentrics` (beyond their bounds on the right primitive), and the faults of
    /// [`crate::geometry::HitFault`] (`no-such-primitive`, `t-outside-interval`, ...).
    pub wrong_by: BTreeMap<String, u64>,
    /// Different answers the arbiter did not judge (`--no-arbiter`).
    pub unjudged: u64,
    /// Rays through a shared edge or closed vertex let through.
    pub leaks: u64,
    /// Rays spawned from a surface that hit it again.
    pub false_self_hits: u64,
}

impl VariantVerdict {
    /// The verdict of `v` on `set`.
    pub fn of(set: &SetReport, v: &VariantStats) -> Self {
        let mut wrong_by = BTreeMap::new();
        let mut add = |k: &str, n: u64| {
            if n > 0 {
                *wrong_by.entry(k.to_string()).or_insert(0) += n;
            }
        };
        for (k, n) in &v.invalid_classes {
            add(k, *n);
        }
        let differ = v.native_miss_ref_hit + v.native_hit_ref_miss + v.prim_diff + v.prim_ties;
        let (mut differ_exact, mut within_bound, mut unjudged) = (0, 0, 0);
        // Distances and barycentrics beyond their bounds: wrong where the arbiter finds the
        // tracer's beyond its bound of the exact hit (the reference is off on the others:
        // the tracer is within the bound), all wrong without the arbiter.
        let beyond_wrong = match &v.arbiter {
            Some(a) => {
                let get = |k: &str| a.native.get(k).copied().unwrap_or(0);
                add("primitive", get("wrong"));
                differ_exact = get("exact");
                within_bound = get("within-bound") + a.beyond_bound.tracer_right;
                add("distance", a.beyond_bound.tracer_distance_wrong);
                add("barycentrics", a.beyond_bound.tracer_barycentrics_wrong);
                a.beyond_bound.tracer_wrong
            }
            None => {
                unjudged = differ;
                add("distance", v.dist_over_bound);
                add("barycentrics", v.bary_over_bound);
                v.beyond_bound
            }
        };
        let wrong_primitive = wrong_by.get("primitive").copied().unwrap_or(0);
        // A ray beyond both bounds is one wrong ray (in two classes).
        let wrong = v.invalid + wrong_primitive + beyond_wrong;
        let agree = (v.rays as u64).saturating_sub(differ + v.invalid + v.beyond_bound);
        Self {
            tracer: v.tracer.clone(),
            set: set.set.clone(),
            rays: v.rays,
            agree,
            differ_exact,
            within_bound,
            wrong,
            wrong_by,
            unjudged,
            leaks: v.leaks,
            false_self_hits: v.self_hits,
        }
    }

    /// True when nothing is wrong: no wrong answer, no leak, no false self-intersection.
    pub fn passed(&self) -> bool {
        self.wrong == 0 && self.leaks == 0 && self.false_self_hits == 0
    }

    /// True when every ray agrees with the reference.
    pub fn all_agree(&self) -> bool {
        self.passed() && self.agree == self.rays as u64
    }
}

/// The verdict of a whole run: every tracer on every set.
#[derive(Clone, Debug, Default, Serialize)]
pub struct Verdict {
    /// True when no tracer failed on any set.
    pub passed: bool,
    /// One entry per tracer and set, in the report's order.
    pub rows: Vec<VariantVerdict>,
}

impl Verdict {
    /// The verdict of `r`.
    pub fn of(r: &ParityReport) -> Self {
        let rows: Vec<VariantVerdict> =
            r.sets.iter().flat_map(|s| s.variants.iter().map(move |v| VariantVerdict::of(s, v))).collect();
        Self { passed: rows.iter().all(VariantVerdict::passed), rows }
    }
}

fn count_by(rows: &[&VariantVerdict], f: impl Fn(&VariantVerdict) -> u64) -> u64 {
    rows.iter().map(|r| f(r)).sum()
}

fn classes(m: &BTreeMap<String, u64>) -> String {
    m.iter().map(|(k, n)| format!("{k} {n}")).collect::<Vec<_>>().join(", ")
}

/// The verdict as text: the pass or fail line first (what failed, for which tracer,
/// on which sets), then one line per set where something differs (sets and tracers
/// that agree on every ray folded into one line), then the first wrong rays, each
/// replayable. `reference` names what the tracers were compared with.
pub fn format_verdict(r: &ParityReport, reference: &str, max_replays: usize) -> String {
    let v = Verdict::of(r);
    let mut o = String::new();
    let tracers: Vec<&str> = {
        let mut t: Vec<&str> = Vec::new();
        for row in &v.rows {
            if !t.contains(&row.tracer.as_str()) {
                t.push(&row.tracer);
            }
        }
        t
    };
    let total_rays: usize = r.sets.iter().map(|s| s.rays).sum();
    if v.passed {
        let rows: Vec<&VariantVerdict> = v.rows.iter().collect();
        let _ = writeln!(
            o,
            "PASS: {} vs {reference} on {} sets ({total_rays} rays): no wrong hit, no leak, no false self-intersection \
             ({} answers differ from the reference: {} exact, {} within the bound{})",
            if tracers.len() == 1 { tracers[0].to_string() } else { format!("{} tracers", tracers.len()) },
            r.sets.len(),
            count_by(&rows, |x| x.differ_exact + x.within_bound + x.unjudged),
            count_by(&rows, |x| x.differ_exact),
            count_by(&rows, |x| x.within_bound),
            match count_by(&rows, |x| x.unjudged) {
                0 => String::new(),
                n => format!(", {n} not judged (--no-arbiter)"),
            }
        );
    } else {
        let _ = writeln!(o, "FAIL vs {reference}:");
        for t in &tracers {
            let rows: Vec<&VariantVerdict> = v.rows.iter().filter(|x| x.tracer == *t && !x.passed()).collect();
            if rows.is_empty() {
                continue;
            }
            let mut by = BTreeMap::new();
            for x in &rows {
                for (k, n) in &x.wrong_by {
                    *by.entry(k.clone()).or_insert(0) += n;
                }
            }
            let sets: Vec<&str> = rows.iter().map(|x| x.set.as_str()).collect();
            let mut what = Vec::new();
            let wrong = count_by(&rows, |x| x.wrong);
            if wrong > 0 {
                what.push(format!("{wrong} wrong hits ({})", classes(&by)));
            }
            let leaks = count_by(&rows, |x| x.leaks);
            if leaks > 0 {
                what.push(format!("{leaks} leaks"));
            }
            let selfh = count_by(&rows, |x| x.false_self_hits);
            if selfh > 0 {
                what.push(format!("{selfh} false self-intersections"));
            }
            let _ = writeln!(o, "  {t}: {} on {}", what.join(", "), sets.join(", "));
        }
    }
    // One screen of what differs.
    let _ = writeln!(
        o,
        "{:<13} {:<28} {:>8} {:>8} {:>8} {:>8} {:>8} {:>6} {:>6}  wrong by class",
        "set", "tracer", "rays", "agree", "exact", "within", "wrong", "leaks", "self"
    );
    let _ = writeln!(
        o,
        "(agree: the reference's answer; exact, within: another answer the arbiter finds exact, or within \
         the bound; self: false self-intersections)"
    );
    let mut quiet_sets = Vec::new();
    for s in &r.sets {
        let rows: Vec<&VariantVerdict> = v.rows.iter().filter(|x| x.set == s.set).collect();
        if rows.iter().all(|x| x.all_agree()) {
            quiet_sets.push(s.set.as_str());
            continue;
        }
        // Failing tracers one row each; the passing ones that still differ from the reference
        // (rounding: exact or within the bound) summed into one row.
        let quiet = rows.iter().filter(|x| x.all_agree()).count();
        for x in rows.iter().filter(|x| !x.passed()) {
            let mut rest = classes(&x.wrong_by);
            if x.unjudged > 0 {
                rest = format!("{rest}{}{} not judged", if rest.is_empty() { "" } else { "; " }, x.unjudged);
            }
            let _ = writeln!(
                o,
                "{:<13} {:<28} {:>8} {:>8} {:>8} {:>8} {:>8} {:>6} {:>6}  {}",
                s.set,
                short(&x.tracer, 28),
                x.rays,
                x.agree,
                x.differ_exact,
                x.within_bound,
                x.wrong,
                x.leaks,
                x.false_self_hits,
                rest
            );
        }
        let pass: Vec<&&VariantVerdict> = rows.iter().filter(|x| x.passed() && !x.all_agree()).collect();
        if !pass.is_empty() {
            let sum = |f: &dyn Fn(&VariantVerdict) -> u64| pass.iter().map(|x| f(x)).sum::<u64>();
            let name =
                if pass.len() == 1 { short(&pass[0].tracer, 28) } else { format!("{} tracers (pass)", pass.len()) };
            let unjudged = sum(&|x| x.unjudged);
            let _ = writeln!(
                o,
                "{:<13} {:<28} {:>8} {:>8} {:>8} {:>8} {:>8} {:>6} {:>6}  {}",
                s.set,
                name,
                sum(&|x| x.rays as u64),
                sum(&|x| x.agree),
                sum(&|x| x.differ_exact),
                sum(&|x| x.within_bound),
                0,
                0,
                0,
                if unjudged > 0 { format!("{unjudged} not judged") } else { String::new() }
            );
        }
        if quiet > 0 {
            let _ = writeln!(o, "{:<13} ({quiet} more tracers agree with the reference on every ray)", s.set);
        }
    }
    if !quiet_sets.is_empty() {
        let _ = writeln!(o, "every tracer agrees with {reference} on every ray of: {}", quiet_sets.join(", "));
    }
    // The first wrong rays, replayable.
    let mut shown = 0;
    for s in &r.sets {
        for vs in &s.variants {
            for e in vs.examples.iter().filter(|e| e.what.starts_with("invalid") || e.what.contains("beyond")) {
                if shown < max_replays {
                    let _ = writeln!(
                        o,
                        "  wrong: {} {} #{} {}: {:?}, reference {:?}; ray {}",
                        vs.tracer,
                        s.set,
                        e.index,
                        e.what,
                        e.native,
                        e.reference,
                        csv(&e.ray)
                    );
                }
                shown += 1;
            }
            if let Some(a) = &vs.arbiter {
                for rp in a.replays.iter().filter(|rp| rp.native == super::arbiter::Verdict::Wrong) {
                    if shown < max_replays {
                        let _ = writeln!(
                            o,
                            "  wrong: {} {} #{}: returned {:?}, exact {:?} at {:?} (margin {:.2}); replay: {}",
                            vs.tracer, s.set, rp.index, rp.native_prim, rp.truth, rp.truth_t, rp.margin, rp.line
                        );
                    }
                    shown += 1;
                }
            }
        }
    }
    if shown > max_replays {
        let _ = writeln!(
            o,
            "  ... {} more wrong rays (--examples N shows more; --verbose the full tables)",
            shown - max_replays
        );
    }
    o
}

fn short(s: &str, n: usize) -> String {
    if s.chars().count() <= n { s.to_string() } else { format!("{}~", s.chars().take(n - 1).collect::<String>()) }
}

fn csv(r: &[f32; 8]) -> String {
    r.iter().map(|x| x.to_string()).collect::<Vec<_>>().join(",")
}
