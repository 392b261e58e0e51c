//! Hit parity: the same rays through every native builder x traversal and a
//! reference (Embree, robust flag, HIGH quality; or brute force), with every
//! disagreement counted, classified (see [`super::classify`], within the
//! bounds of [`super::bounds`]) and replayable.

use std::sync::Arc;

use rayon::prelude::*;
use serde::Serialize;

use crate::accel::Tracer;
use crate::backends::{AccelConfig, Backend, build_tracer_unchecked as build_tracer, native_variants};
use crate::geometry::{Hit, Primitives, Ray, TriangleTest};
use crate::rays::{self, RayContext, RaySet, RayTag, SetKind};

use super::arbiter::Arbiter;
use super::arbitrate::{TruthCache, arbitrate};
use super::classify::{Answers, compare, count_failures};
use super::report::{ParityReport, SetReport, StressRow};

/// What the native tracers are compared with.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Reference {
    /// Intel Embree 4 with the robust flag and HIGH build quality (needs the `embree` feature).
    #[default]
    Embree,
    /// The brute-force loop with the watertight test.
    Brute,
}

impl Reference {
    /// The accelerator configuration of this reference.
    pub fn config(self) -> AccelConfig {
        match self {
            Reference::Embree => AccelConfig {
                backend: Backend::Embree,
                embree_quality: crate::backends::EmbreeQuality::High,
                ..Default::default()
            },
            Reference::Brute => {
                AccelConfig { backend: Backend::Brute, triangle_test: TriangleTest::Watertight, ..Default::default() }
            }
        }
    }
}

/// What a parity run does.
#[derive(Clone, Debug)]
pub struct ParityOptions {
    /// Sets to generate.
    pub sets: Vec<SetKind>,
    /// Rays per set.
    pub count: usize,
    /// Seed of every set.
    pub seed: u64,
    /// The reference.
    pub reference: Reference,
    /// The tracers under test (default: [`native_variants`], the default
    /// configuration first).
    pub variants: Vec<AccelConfig>,
    /// Rays per set for every variant after the first (`None`: all rays).
    pub sweep_count: Option<usize>,
    /// Also run the numerical stress report (watertight vs Moller-Trumbore vs reference).
    pub stress: bool,
    /// How many disagreeing rays to keep per set and variant.
    pub max_examples: usize,
    /// Judge every disagreement with the exact arbiter ([`super::arbitrate`]).
    pub arbiter: bool,
}

impl Default for ParityOptions {
    fn default() -> Self {
        Self {
            sets: SetKind::ALL.to_vec(),
            count: 100_000,
            seed: 1,
            reference: Reference::Embree,
            variants: native_variants(),
            sweep_count: None,
            stress: false,
            max_examples: 5,
            arbiter: true,
        }
    }
}

fn trace_all(tracer: &dyn Tracer, rays: &[Ray]) -> Vec<Option<Hit>> {
    rays.par_iter().with_min_len(256).map(|r| tracer.intersect(r)).collect()
}

fn occluded_all(tracer: &dyn Tracer, set: &RaySet) -> Vec<Option<bool>> {
    set.rays
        .par_iter()
        .zip(set.tags.par_iter())
        .with_min_len(256)
        .map(|(r, t)| if matches!(t, RayTag::Shadow { .. }) { Some(tracer.occluded(r)) } else { None })
        .collect()
}
/// A reference or tracer cache keyed by the primitives it was built on.
struct Built {
    prims: Arc<Primitives>,
    tracers: Vec<Box<dyn Tracer>>,
    arbiter: Arbiter,
}

/// Run parity over `ctx` with `opts`.
pub fn run(ctx: &RayContext, opts: &ParityOptions) -> crate::Result<ParityReport> {
    let start = std::time::Instant::now();
    let ref_cfg = opts.reference.config();
    let ref_label = ref_cfg.label();
    let build = |prims: &Arc<Primitives>, cfg: &AccelConfig| build_tracer(prims.clone(), cfg);
    let reference = build(&ctx.prims, &ref_cfg)?;
    let oracle_for = |p: Arc<Primitives>| build_tracer(p, &ref_cfg);
    let mut stress_cfgs = Vec::new();
    if opts.stress {
        let base = AccelConfig { backend: Backend::Native, ..Default::default() };
        stress_cfgs.push(AccelConfig { triangle_test: TriangleTest::Watertight, ..base });
        stress_cfgs.push(AccelConfig { triangle_test: TriangleTest::MollerTrumbore, ..base });
    }
    let mut cache: Vec<Built> = Vec::new();
    let mut sets_out = Vec::new();
    let mut stress = Vec::new();
    for &kind in &opts.sets {
        for set in rays::generate(ctx, kind, opts.seed, opts.count, reference.as_ref(), &oracle_for)? {
            // Tracers for this set's primitives (the scaled sets bring their own).
            let idx = match cache.iter().position(|b| Arc::ptr_eq(&b.prims, &set.prims)) {
                Some(i) => i,
                None => {
                    let mut tracers = vec![build(&set.prims, &ref_cfg)?];
                    for cfg in opts.variants.iter().chain(&stress_cfgs) {
                        tracers.push(build(&set.prims, cfg)?);
                    }
                    let arbiter = Arbiter::new(set.prims.clone());
                    cache.push(Built { prims: set.prims.clone(), tracers, arbiter });
                    cache.len() - 1
                }
            };
            let tracers = &cache[idx].tracers;
            let truths = TruthCache::default();
            let ref_hits = trace_all(tracers[0].as_ref(), &set.rays);
            let ref_occ = occluded_all(tracers[0].as_ref(), &set);
            let count_tag = |f: &dyn Fn(RayTag) -> bool| set.tags.iter().filter(|&&t| f(t)).count();
            let mut report = SetReport {
                set: set.name.clone(),
                kind,
                seed: set.seed,
                rays: set.rays.len(),
                crossing_rays: count_tag(&|t| matches!(t, RayTag::Crossing { .. })),
                spawned_rays: count_tag(&|t| matches!(t, RayTag::Spawned { .. } | RayTag::Shadow { .. })),
                reference: ref_label.clone(),
                reference_hits: ref_hits.iter().filter(|h| h.is_some()).count(),
                reference_leaks: 0,
                reference_self_hits: 0,
                variants: Vec::new(),
            };
            let (leaks, selfh) = count_failures(&set, &ref_hits);
            report.reference_leaks = leaks;
            report.reference_self_hits = selfh;
            // The first variant sees every ray; the others the first
            // `sweep_count` (the slow reference traversals would otherwise
            // dominate the run).
            let sweep = opts.sweep_count.unwrap_or(usize::MAX).min(set.rays.len());
            let sub = RaySet {
                rays: set.rays[..sweep].to_vec(),
                tags: set.tags[..sweep].to_vec(),
                prims: set.prims.clone(),
                name: set.name.clone(),
                kind: set.kind,
                seed: set.seed,
            };
            for (i, (cfg, tracer)) in opts.variants.iter().zip(&tracers[1..]).enumerate() {
                let (s, n) = if i == 0 { (&set, set.rays.len()) } else { (&sub, sweep) };
                let hits = trace_all(tracer.as_ref(), &s.rays);
                let occ = occluded_all(tracer.as_ref(), s);
                let ours = Answers { hits: &hits, occluded: &occ };
                let theirs = Answers { hits: &ref_hits[..n], occluded: &ref_occ[..n] };
                let mut stats = compare(&cfg.label(), s, ours, theirs, opts.max_examples);
                if opts.arbiter {
                    stats.arbiter = Some(arbitrate(s, ours, theirs, &cache[idx].arbiter, &truths, opts.max_examples));
                }
                report.variants.push(stats);
            }
            if opts.stress && kind != SetKind::Primary && kind != SetKind::Incoherent {
                let mut leaks = [0u64; 3];
                let mut selfh = [0u64; 3];
                let stress_tracers = &tracers[1 + opts.variants.len()..];
                for (k, t) in stress_tracers.iter().enumerate() {
                    (leaks[k], selfh[k]) = count_failures(&set, &trace_all(t.as_ref(), &set.rays));
                }
                leaks[2] = report.reference_leaks;
                selfh[2] = report.reference_self_hits;
                // The same spawned rays leaving from the unoffset hit point,
                // moved by the reports' fixed epsilon or not at all.
                let respawn = |eps: f32| {
                    let mut s = set.clone();
                    for (r, t) in s.rays.iter_mut().zip(&s.tags) {
                        if let RayTag::Spawned { from, .. } | RayTag::Shadow { from, .. } = *t {
                            r.origin = from + eps * r.dir.normalize();
                        }
                    }
                    s
                };
                let mut fixed = [0u64; 3];
                let mut none = [0u64; 3];
                if report.spawned_rays > 0 {
                    for (eps, out) in [(1e-4_f32, &mut fixed), (0.0, &mut none)] {
                        let s = respawn(eps);
                        let all = [&stress_tracers[0], &stress_tracers[1], &tracers[0]];
                        for (k, t) in all.iter().enumerate() {
                            out[k] = count_failures(&s, &trace_all(t.as_ref(), &s.rays)).1;
                        }
                    }
                }
                let per_m = |n: u64, d: usize| if d == 0 { 0.0 } else { n as f64 * 1e6 / d as f64 };
                stress.push(StressRow {
                    set: set.name.clone(),
                    rays: set.rays.len(),
                    leaks_per_million: leaks.map(|n| per_m(n, set.rays.len())),
                    self_hits_per_million: selfh.map(|n| per_m(n, report.spawned_rays)),
                    self_hits_fixed_offset_per_million: fixed.map(|n| per_m(n, report.spawned_rays)),
                    self_hits_no_offset_per_million: none.map(|n| per_m(n, report.spawned_rays)),
                    spawned_rays: report.spawned_rays,
                });
            }
            sets_out.push(report);
        }
    }
    let mut report = ParityReport {
        count: opts.count,
        sets: sets_out,
        stress,
        stress_tracers: ["watertight".into(), "moller-trumbore".into(), ref_label],
        seconds: start.elapsed().as_secs_f64(),
        verdict: Default::default(),
    };
    report.verdict = super::verdict::Verdict::of(&report);
    Ok(report)
}

#[cfg(test)]
mod tests {
    use super::super::report::format_report;
    use super::*;
    use crate::geometry::Triangle;
    use glam::Vec3;

    #[test]
    fn brute_reference_agrees_with_itself() {
        let ctx = RayContext::with_defaults(crate::rays::sets::tetra());
        let opts = ParityOptions {
            count: 3000,
            reference: Reference::Brute,
            variants: vec![AccelConfig { backend: Backend::Brute, ..Default::default() }],
            stress: true,
            ..Default::default()
        };
        let r = run(&ctx, &opts).unwrap();
        assert_eq!(r.sets.len(), 11); // 8 sets + 3 scaled parts
        for s in &r.sets {
            let v = &s.variants[0];
            assert_eq!(
                v.native_miss_ref_hit + v.native_hit_ref_miss + v.prim_diff + v.occluded_disagree,
                0,
                "{}",
                s.set
            );
            assert_eq!(v.dist_rel_max, 0.0);
            assert_eq!((v.leaks, v.self_hits), (0, 0), "{}", s.set);
        }
        assert!(r.sets.iter().any(|s| s.crossing_rays > 0) && r.sets.iter().any(|s| s.spawned_rays > 0));
        assert!(!format_report(&r).is_empty());
    }

    #[test]
    fn a_tracer_that_drops_hits_is_caught_and_replayable() {
        struct Dropper(crate::accel::BruteForce);
        impl Tracer for Dropper {
            fn name(&self) -> String {
                "dropper".into()
            }
            fn intersect(&self, ray: &Ray) -> Option<Hit> {
                self.0.intersect(ray).filter(|h| h.prim != 0)
            }
            fn occluded(&self, ray: &Ray) -> bool {
                self.0.occluded(ray)
            }
        }
        let prims = Arc::new(Primitives {
            triangles: vec![Triangle {
                v: [Vec3::new(-1.0, -1.0, 0.0), Vec3::new(1.0, -1.0, 0.0), Vec3::new(0.0, 1.0, 0.0)],
            }],
            spheres: vec![],
        });
        let mut set = rays::RaySet {
            name: "t".into(),
            kind: SetKind::Primary,
            seed: 9,
            prims: prims.clone(),
            rays: vec![Ray::new(Vec3::new(0.0, 0.0, 2.0), Vec3::new(0.0, 0.0, -1.0))],
            tags: vec![RayTag::Plain],
        };
        let b = crate::accel::BruteForce::new(prims.clone(), TriangleTest::Watertight);
        let d = Dropper(crate::accel::BruteForce::new(prims.clone(), TriangleTest::Watertight));
        let rh = trace_all(&b, &set.rays);
        let nh = trace_all(&d, &set.rays);
        let none = vec![None; 1];
        let s =
            compare("dropper", &set, Answers { hits: &nh, occluded: &none }, Answers { hits: &rh, occluded: &none }, 5);
        assert_eq!(s.native_miss_ref_hit, 1);
        assert_eq!(s.classes.get("unclassified"), Some(&1));
        assert_eq!((s.examples[0].seed, s.examples[0].index), (9, 0));
        // A crossing tag turns the same miss into a leak.
        set.tags[0] = RayTag::Crossing { t: 2.0 };
        let s =
            compare("dropper", &set, Answers { hits: &nh, occluded: &none }, Answers { hits: &rh, occluded: &none }, 5);
        assert_eq!((s.leaks, s.classes.get("leak")), (1, Some(&1)));
    }
}
