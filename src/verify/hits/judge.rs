//! The program path: rays written for a tracer rtdiff cannot link
//! ([`generate_for_file`], `rtdiff rays`), and that tracer's hits judged
//! ([`judge`], `rtdiff judge`) with the same bounds, classes, exact arbiter and
//! verdict as [`super::run`] compares the linked tracers with.

use rayon::prelude::*;

use crate::backends::{AccelConfig, build_tracer_unchecked};
use crate::error::{Error, Result};
use crate::geometry::{Hit, Ray};
use crate::rays::{RayContext, RaySet, RayTag, SetKind};

use super::arbiter::{Arbiter, Verdict as ArbiterVerdict, replay_line};
use super::arbitrate::{TruthCache, arbitrate};
use super::classify::{Answers, compare, count_failures};
use super::report::{ParityReport, SetReport};
use super::run::Reference;

/// The ray sets of `kinds` over `ctx` (seed, count per set), the shadow and surface sets
/// started at the hits of `reference`. The `scaled` set traces transformed copies of the
/// scene, which a ray file for the scene cannot carry: it is refused.
pub fn generate_for_file(
    ctx: &RayContext,
    kinds: &[SetKind],
    seed: u64,
    count: usize,
    reference: Reference,
) -> Result<Vec<RaySet>> {
    if kinds.contains(&SetKind::Scaled) {
        return Err(Error::Invalid(
            "the scaled set traces scaled and moved copies of the scene, which a ray file cannot carry: \
             choose another set (all means every set but scaled here)"
                .into(),
        ));
    }
    let cfg = reference.config();
    let oracle = build_tracer_unchecked(ctx.prims.clone(), &cfg)?;
    let oracle_for = |p| build_tracer_unchecked(p, &cfg);
    let mut out = Vec::new();
    for &k in kinds {
        out.extend(crate::rays::generate(ctx, k, seed, count, oracle.as_ref(), &oracle_for)?);
    }
    Ok(out)
}

/// What a judge run is given besides the scene.
pub struct JudgeInput {
    /// The rays, in file order.
    pub rays: Vec<Ray>,
    /// Per ray its set name and tag (from `rtdiff rays`' tags file); `None`: one set `rays`, no tags.
    pub tags: Option<Vec<(String, RayTag)>>,
    /// The tracer's answer per ray.
    pub hits: Vec<Option<Hit>>,
    /// Label of the tracer in the report.
    pub tracer: String,
}

/// A ray the judged tracer did not answer as the reference did, judged, as lines of a ray file:
/// a `#` line with the verdict, then the ray (`ox,oy,oz,dx,dy,dz,tnear,tfar`, exact decimal).
#[derive(Clone, Debug, serde::Serialize)]
pub struct Dispute {
    /// Set name.
    pub set: String,
    /// Index of the ray in the ray file.
    pub index: usize,
    /// The verdict in words.
    pub verdict: String,
    /// The ray as a line of the ray file.
    pub ray: String,
    /// The ray in hexadecimal floats (`arbiter::parse_replay_line` reads it).
    pub replay: String,
}

/// Judge `input` on `ctx` against `reference`: per set the same comparison, classes and arbiter
/// as `rtdiff parity` (leaks and false self-intersections where the tags say which rays cross a
/// shared edge or leave a surface; no any-hit answers), and every disputed ray.
pub fn judge(
    ctx: &RayContext,
    input: &JudgeInput,
    reference: Reference,
    arbiter: bool,
    max_examples: usize,
) -> Result<(ParityReport, Vec<Dispute>)> {
    let start = std::time::Instant::now();
    let n = input.rays.len();
    if input.hits.len() != n {
        return Err(Error::Invalid(format!(
            "{} rays but {} hits: one hit line per ray, in order",
            n,
            input.hits.len()
        )));
    }
    if let Some(t) = &input.tags
        && t.len() != n
    {
        return Err(Error::Invalid(format!(
            "{} rays but {} tags: the tags file belongs to another ray file",
            n,
            t.len()
        )));
    }
    let cfg: AccelConfig = reference.config();
    let ref_label = cfg.label();
    let tracer = build_tracer_unchecked(ctx.prims.clone(), &cfg)?;
    let arb = Arbiter::new(ctx.prims.clone());
    // Consecutive rays of one set name form a set.
    let mut groups: Vec<(String, std::ops::Range<usize>)> = Vec::new();
    for i in 0..n {
        let name = input.tags.as_ref().map_or("rays", |t| t[i].0.as_str());
        match groups.last_mut() {
            Some((g, r)) if g == name => r.end = i + 1,
            _ => groups.push((name.to_string(), i..i + 1)),
        }
    }
    let mut sets = Vec::new();
    let mut disputes = Vec::new();
    for (name, range) in groups {
        let set = RaySet {
            name: name.clone(),
            kind: SetKind::ALL.into_iter().find(|k| k.name() == name).unwrap_or(SetKind::Primary),
            seed: 0,
            prims: ctx.prims.clone(),
            rays: input.rays[range.clone()].to_vec(),
            tags: input
                .tags
                .as_ref()
                .map_or_else(|| vec![RayTag::Plain; range.len()], |t| t[range.clone()].iter().map(|x| x.1).collect()),
        };
        let ref_hits: Vec<Option<Hit>> = set.rays.par_iter().with_min_len(256).map(|r| tracer.intersect(r)).collect();
        let hits = &input.hits[range.clone()];
        let none = vec![None; set.rays.len()];
        let ours = Answers { hits, occluded: &none };
        let theirs = Answers { hits: &ref_hits, occluded: &none };
        let mut stats = compare(&input.tracer, &set, ours, theirs, max_examples);
        if arbiter {
            let a = arbitrate(&set, ours, theirs, &arb, &TruthCache::default(), usize::MAX);
            for rp in &a.replays {
                let leak =
                    super::classify::is_leak(&set.rays[rp.index], set.tags[rp.index], &hits[rp.index], &set.prims);
                let verdict = match (leak, rp.native) {
                    (true, _) => "a leak through a shared edge or vertex; the arbiter judges one ray at a time",
                    (false, ArbiterVerdict::Wrong) => "wrong",
                    (false, ArbiterVerdict::WithinBound) => "within the bound",
                    (false, ArbiterVerdict::Exact) => "exact",
                };
                disputes.push(Dispute {
                    set: name.clone(),
                    index: range.start + rp.index,
                    verdict: format!(
                        "{verdict} ({}): returned {:?}, exact {:?} at {:?}, margin {:.2}",
                        rp.class.name(),
                        rp.native_prim,
                        rp.truth,
                        rp.truth_t,
                        rp.margin
                    ),
                    ray: csv_line(&set.rays[rp.index]),
                    replay: rp.line.clone(),
                });
            }
            stats.arbiter = Some(a);
        }
        // Faults and distances or barycentrics beyond their bounds, which the arbiter does not list.
        for (i, (r, h)) in set.rays.iter().zip(hits).enumerate() {
            let why = match h {
                Some(h) => match h.fault(r, ctx.prims.len()) {
                    Some(f) => {
                        Some(format!("wrong ({}): t {}, primitive {}, u {}, v {}", f.name(), h.t, h.prim, h.u, h.v))
                    }
                    None => beyond_bound(&set, i, h, ref_hits[i].as_ref(), arbiter.then_some(&arb)),
                },
                None => None,
            };
            if let Some(why) = why {
                disputes.push(Dispute {
                    set: name.clone(),
                    index: range.start + i,
                    verdict: why,
                    ray: csv_line(r),
                    replay: replay_line(r),
                });
            }
        }
        let (leaks, selfh) = count_failures(&set, &ref_hits);
        sets.push(SetReport {
            set: name,
            kind: set.kind,
            seed: 0,
            rays: set.rays.len(),
            crossing_rays: set.tags.iter().filter(|t| matches!(t, RayTag::Crossing { .. })).count(),
            spawned_rays: set
                .tags
                .iter()
                .filter(|t| matches!(t, RayTag::Spawned { .. } | RayTag::Shadow { .. }))
                .count(),
            reference: ref_label.clone(),
            reference_hits: ref_hits.iter().flatten().count(),
            reference_leaks: leaks,
            reference_self_hits: selfh,
            variants: vec![stats],
        });
    }
    disputes.sort_by_key(|d| d.index);
    let mut report = ParityReport {
        count: n,
        sets,
        stress: Vec::new(),
        stress_tracers: [String::new(), String::new(), ref_label],
        seconds: start.elapsed().as_secs_f64(),
        verdict: Default::default(),
    };
    report.verdict = super::verdict::Verdict::of(&report);
    Ok((report, disputes))
}

/// Why a hit on the reference's primitive differs: its distance or barycentrics beyond their
/// bounds of the reference's, judged (with `arb`) against the exact hit on that primitive: wrong
/// when beyond its own bound of the exact one, else the reference is the one off.
fn beyond_bound(
    set: &RaySet,
    i: usize,
    h: &Hit,
    r: Option<&Hit>,
    arb: Option<&super::arbiter::Arbiter>,
) -> Option<String> {
    let r = r?;
    if r.prim != h.prim || !super::classify::beyond_bounds(&set.prims, &set.rays[i], h, r) {
        return None;
    }
    let ray = &set.rays[i];
    let (tb, bb) = super::bounds::of_hit(&set.prims, ray, r);
    let what = if (h.t as f64 - r.t as f64).abs() > tb {
        format!("t {} on primitive {}, reference t {} (bound {:.3e})", h.t, h.prim, r.t, tb)
    } else {
        format!("u {} v {}, reference u {} v {} (bound {:.3e})", h.u, h.v, r.u, r.v, bb)
    };
    let Some(arb) = arb else {
        let class = if what.starts_with('t') { "distance" } else { "barycentrics" };
        return Some(format!("wrong ({class}): {what}"));
    };
    let exact = arb.evaluate(ray, h.prim);
    let (t_ok, b_ok) = super::arbitrate::right_against(set, i, h, &exact);
    let truth = format!("exact t {:.9e}, u {:.9e}, v {:.9e}", exact.t_f64, exact.bary[1], exact.bary[2]);
    Some(match (t_ok, b_ok) {
        (true, true) => format!("within the bound of the exact hit (the reference is off): {what}; {truth}"),
        (false, _) => format!("wrong (distance): {what}; {truth}"),
        (true, false) => format!("wrong (barycentrics): {what}; {truth}"),
    })
}

/// A ray as a line of a ray file.
pub fn csv_line(r: &Ray) -> String {
    format!("{},{},{},{},{},{},{},{}", r.origin.x, r.origin.y, r.origin.z, r.dir.x, r.dir.y, r.dir.z, r.t_min, r.t_max)
}

/// The disputes as a ray file `rtdiff trace` reads: a `#` verdict line before each ray.
pub fn disputes_file(disputes: &[Dispute]) -> String {
    let mut o = String::from("# rays where the judged tracer differs from the reference, each with its verdict\n");
    for d in disputes {
        o.push_str(&format!("# {} #{}: {} (hex: {})\n{}\n", d.set, d.index, d.verdict, d.replay, d.ray));
    }
    o
}
