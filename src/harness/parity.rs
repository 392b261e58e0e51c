//! Hit parity: the same rays through every native builder x traversal and a
//! reference (Embree, robust flag, HIGH quality; or brute force), with every
//! disagreement counted, classified and replayable.
//!
//! # Error bounds
//!
//! Two correct single-precision tracers do not return bit-identical hits; they
//! differ by their rounding errors. Both the watertight test (Woop et al.) and
//! Embree's robust Pluecker test compute `t` from differences `v_i - o` of
//! vertex and origin coordinates followed by about ten chained products and
//! sums, so each computes the hit's distance to the triangle's plane with an
//! absolute error of at most about `gamma(12) (|o|_inf + |p|_inf)` (pbrt-v4,
//! section 6.8: `gamma(n) = n u / (1 - n u)`, `u = 2^-24`), `p` the hit point.
//! Along a ray of unit direction `d` meeting the plane (unit normal `n`) at
//! cosine `c = |d . n|`, a plane-distance error `e` moves the hit by `e / c`.
//! The difference of two such tracers is therefore bounded by
//!
//! `|t_a - t_b| |d| <= K u (|o|_inf + |p|_inf) / c`, with `K = 32`
//!
//! (`2 x 12` for the two tests, plus headroom for Embree's `rcp` with one
//! Newton step, accurate to about 2 ulp, and the `1 / det` of the watertight
//! test). The barycentric coordinate of vertex `i` is the area of the
//! sub-triangle opposite it over the whole area; moving the hit point by
//! `delta` in the plane changes it by at most `delta L / |N|` (`L` the
//! longest edge, `|N|` twice the area), plus the relative rounding of the
//! division itself:
//!
//! `|u_a - u_b| <= K u (|o|_inf + |p|_inf) L / (|N| c) + K u`.
//!
//! These bounds are evaluated per ray in double precision, so they hold at
//! every scale (1e-4 to 1e5, far from the origin) without an absolute epsilon.
//! A disagreement within them is rounding; one outside them is a bug.

use std::collections::BTreeMap;
use std::sync::Arc;

use glam::{DVec3, Vec3};
use rayon::prelude::*;
use serde::Serialize;

use crate::accel::{AccelConfig, Backend, Builder, Tracer, Traversal, build_tracer};
use crate::geometry::{Hit, Primitives, Ray, TriangleTest};

use super::raysets::{self, RayContext, RaySet, RayTag, SetKind};

/// `K` of the module documentation: how many unit roundings the difference
/// of two correct tracers may accumulate.
pub const K_ROUNDING: f64 = 32.0;
const U: f64 = f32::EPSILON as f64 * 0.5;

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
                embree_quality: crate::accel::EmbreeQuality::High,
                ..Default::default()
            },
            Reference::Brute => {
                AccelConfig { backend: Backend::Brute, triangle_test: TriangleTest::Watertight, ..Default::default() }
            }
        }
    }
}

/// Every native builder x traversal, with the watertight test.
pub fn native_variants() -> Vec<AccelConfig> {
    use clap::ValueEnum;
    let mut v = Vec::new();
    for &builder in Builder::value_variants() {
        for &traversal in Traversal::value_variants() {
            v.push(AccelConfig { backend: Backend::Native, builder, traversal, ..Default::default() });
        }
    }
    v
}

/// A short label for a configuration (`native sah/fast`, `embree-high`, ...).
pub fn config_label(cfg: &AccelConfig) -> String {
    use clap::ValueEnum;
    let name = |v: Option<clap::builder::PossibleValue>| v.map(|p| p.get_name().to_string()).unwrap_or_default();
    let test = match cfg.triangle_test {
        TriangleTest::Watertight => "",
        TriangleTest::MollerTrumbore => " mt",
    };
    match cfg.backend {
        Backend::Native => format!(
            "native {}/{}{test}",
            name(cfg.builder.to_possible_value()),
            name(cfg.traversal.to_possible_value())
        ),
        Backend::Brute => format!("brute{test}"),
        Backend::Embree => format!("embree-{}", name(cfg.embree_quality.to_possible_value())),
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
    /// The tracers under test (default: [`native_variants`]).
    pub variants: Vec<AccelConfig>,
    /// Also run the numerical stress report (watertight vs Moller-Trumbore vs reference).
    pub stress: bool,
    /// How many disagreeing rays to keep per set and variant.
    pub max_examples: usize,
}

impl Default for ParityOptions {
    fn default() -> Self {
        Self {
            sets: SetKind::ALL.to_vec(),
            count: 100_000,
            seed: 1,
            reference: Reference::Embree,
            variants: native_variants(),
            stress: false,
            max_examples: 5,
        }
    }
}

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
    /// First disagreeing rays.
    pub examples: Vec<Example>,
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
    /// False self-intersections per million spawned rays: watertight, Moller-Trumbore, reference.
    pub self_hits_per_million: [f64; 3],
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
}

fn hit_tuple(h: &Option<Hit>) -> Option<(f32, u32, f32, f32)> {
    h.map(|h| (h.t, h.prim, h.u, h.v))
}

/// Geometry of a hit needed by the bounds: unit normal, longest edge, |N|.
struct HitGeom {
    n: DVec3,
    longest: f64,
    double_area: f64,
    is_triangle: bool,
}

fn hit_geom(prims: &Primitives, ray: &Ray, h: &Hit) -> HitGeom {
    let nt = prims.triangles.len();
    if (h.prim as usize) < nt {
        let [a, b, c] = prims.triangles[h.prim as usize].v.map(|p| p.as_dvec3());
        let nn = (b - a).cross(c - a);
        let longest = (b - a).length().max((c - b).length()).max((a - c).length());
        HitGeom { n: nn.normalize_or_zero(), longest, double_area: nn.length(), is_triangle: true }
    } else {
        let s = prims.spheres[h.prim as usize - nt];
        let n = (ray.at(h.t).as_dvec3() - s.center.as_dvec3()).normalize_or_zero();
        HitGeom { n, longest: 0.0, double_area: 0.0, is_triangle: false }
    }
}

/// Per-ray bounds `(t bound, barycentric bound)` of the module documentation.
fn bounds(ray: &Ray, h: &Hit, g: &HitGeom) -> (f64, f64) {
    let d = ray.dir.as_dvec3();
    let dl = d.length();
    let c = (d.dot(g.n) / dl).abs().max(1e-300);
    let p = ray.at(h.t).as_dvec3();
    let mag = ray.origin.as_dvec3().abs().max_element() + p.abs().max_element();
    let plane = K_ROUNDING * U * mag / c;
    let t_bound = plane / dl;
    let b_bound = if g.is_triangle && g.double_area > 0.0 {
        plane * g.longest / g.double_area + K_ROUNDING * U
    } else {
        f64::INFINITY
    };
    (t_bound, b_bound)
}

/// True when the watertight test may refuse reference hit `h` by design: it
/// rejects a computed distance below its own error bound `delta`
/// (pbrt-v4's test that keeps spawned rays off their surface), so a true
/// distance up to `2 delta` can be refused; the reference's own error adds
/// `t_bound`.
fn unprovable_t(prims: &Primitives, ray: &Ray, h: &Hit, t_bound: f64) -> bool {
    let Some(tri) = prims.triangles.get(h.prim as usize) else { return false };
    let [a, b, c] = tri.v;
    crate::geometry::triangle::watertight_t_error_for(ray, a, b, c)
        .is_some_and(|delta| (h.t as f64) <= 2.0 * delta as f64 + t_bound)
}

fn near_edge(h: &Hit, b_bound: f64) -> bool {
    let w = 1.0 - h.u as f64 - h.v as f64;
    (h.u as f64).min(h.v as f64).min(w) <= b_bound
}

fn ray_array(r: &Ray) -> [f32; 8] {
    [r.origin.x, r.origin.y, r.origin.z, r.dir.x, r.dir.y, r.dir.z, r.t_min, r.t_max]
}

/// True when a tracer's answer on a crossing ray lets it through.
fn is_leak(ray: &Ray, tag: RayTag, h: &Option<Hit>, prims: &Primitives) -> bool {
    let RayTag::Crossing { t } = tag else { return false };
    match h {
        None => true,
        Some(h) => {
            // A hit beyond the crossing point (by more than rounding) went through.
            let (tb, _) = bounds(ray, h, &hit_geom(prims, ray, h));
            (h.t as f64) > t as f64 + tb
        }
    }
}

fn is_self_hit(tag: RayTag, h: &Option<Hit>) -> bool {
    matches!((tag, h), (RayTag::Spawned { prim } | RayTag::Shadow { prim }, Some(h)) if h.prim == prim)
}

/// Leaks and false self-intersections among `hits` on `set`.
fn count_failures(set: &RaySet, hits: &[Option<Hit>]) -> (u64, u64) {
    let mut n = (0, 0);
    for ((ray, &tag), h) in set.rays.iter().zip(&set.tags).zip(hits) {
        n.0 += is_leak(ray, tag, h, &set.prims) as u64;
        n.1 += is_self_hit(tag, h) as u64;
    }
    n
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

/// Compare `hits` (with occlusion answers `occ`) with the reference's.
#[allow(clippy::too_many_arguments)]
fn compare(
    label: &str,
    set: &RaySet,
    hits: &[Option<Hit>],
    occ: &[Option<bool>],
    ref_hits: &[Option<Hit>],
    ref_occ: &[Option<bool>],
    max_examples: usize,
) -> VariantStats {
    let prims = &set.prims;
    let mut s = VariantStats { tracer: label.to_string(), rays: set.rays.len(), ..Default::default() };
    let mut rel = Vec::new();
    // The first `max_examples` disagreements, plus up to as many more that a
    // test would fail on (unclassified, leaks, beyond the bounds).
    let example = |s: &mut VariantStats, i: usize, what: &str| {
        let serious = ["unclassified", "leak", "beyond"].iter().any(|w| what.contains(w));
        if s.examples.len() < max_examples || (serious && s.examples.len() < 2 * max_examples) {
            s.examples.push(Example {
                set: set.name.clone(),
                seed: set.seed,
                index: i,
                ray: ray_array(&set.rays[i]),
                what: what.to_string(),
                native: hit_tuple(&hits[i]),
                reference: hit_tuple(&ref_hits[i]),
            });
        }
    };
    for i in 0..set.rays.len() {
        let ray = &set.rays[i];
        let tag = set.tags[i];
        if is_leak(ray, tag, &hits[i], prims) {
            s.leaks += 1;
        }
        if is_self_hit(tag, &hits[i]) {
            s.self_hits += 1;
        }
        if let (Some(a), Some(b)) = (occ[i], ref_occ[i])
            && a != b
        {
            s.occluded_disagree += 1;
            example(&mut s, i, "occluded");
        }
        match (&hits[i], &ref_hits[i]) {
            (None, None) => {}
            (Some(h), None) | (None, Some(h)) => {
                let native_missed = hits[i].is_none();
                if native_missed {
                    s.native_miss_ref_hit += 1;
                } else {
                    s.native_hit_ref_miss += 1;
                }
                let g = hit_geom(prims, ray, h);
                let (tb, bb) = bounds(ray, h, &g);
                let class = if native_missed && is_leak(ray, tag, &hits[i], prims) {
                    "leak"
                } else if tag == RayTag::Tangent {
                    "silhouette"
                } else if tag == RayTag::Degenerate {
                    "degenerate"
                } else if g.is_triangle && near_edge(h, bb) {
                    "edge"
                } else if (h.t as f64 - ray.t_max as f64).abs() <= tb || (h.t as f64 - ray.t_min as f64).abs() <= tb {
                    "interval-end"
                } else if native_missed && unprovable_t(prims, ray, h, tb) {
                    "unprovable-t"
                } else {
                    "unclassified"
                };
                *s.classes.entry(class.to_string()).or_default() += 1;
                let what = if native_missed { "native miss, reference hit" } else { "native hit, reference miss" };
                example(&mut s, i, &format!("{what} ({class})"));
            }
            (Some(a), Some(b)) => {
                let g = hit_geom(prims, ray, b);
                let (tb, bb) = bounds(ray, b, &g);
                let dt = (a.t as f64 - b.t as f64).abs();
                if a.prim != b.prim && dt > tb {
                    s.prim_diff += 1;
                    let ga = hit_geom(prims, ray, a);
                    let (_, bba) = bounds(ray, a, &ga);
                    let class = if tag == RayTag::Degenerate {
                        "degenerate"
                    } else if tag == RayTag::Tangent {
                        "silhouette"
                    } else if (g.is_triangle && near_edge(b, bb)) || (ga.is_triangle && near_edge(a, bba)) {
                        "edge"
                    } else if a.t > b.t && unprovable_t(prims, ray, b, tb) {
                        "unprovable-t"
                    } else {
                        "unclassified"
                    };
                    *s.prim_classes.entry(class.to_string()).or_default() += 1;
                    example(&mut s, i, &format!("primitive and distance differ ({class})"));
                    continue;
                }
                if a.prim != b.prim {
                    s.prim_ties += 1;
                }
                // Relative to the distance, or to its error bound for hits closer
                // than that bound (at the origin a relative error means nothing).
                let r = dt / (b.t as f64).abs().max(tb).max(f64::MIN_POSITIVE);
                rel.push(r);
                s.dist_rel_max = s.dist_rel_max.max(r);
                s.dist_bound_ratio_max = s.dist_bound_ratio_max.max(dt / tb);
                if dt > tb {
                    s.dist_over_bound += 1;
                    example(&mut s, i, "distance beyond the error bound");
                }
                if a.prim == b.prim && g.is_triangle {
                    let db = (a.u as f64 - b.u as f64).abs().max((a.v as f64 - b.v as f64).abs());
                    s.bary_max = s.bary_max.max(db);
                    s.bary_bound_ratio_max = s.bary_bound_ratio_max.max(db / bb);
                    if db > bb {
                        s.bary_over_bound += 1;
                        example(&mut s, i, "barycentrics beyond the error bound");
                    }
                }
            }
        }
    }
    if !rel.is_empty() {
        let k = ((rel.len() as f64 * 0.999).ceil() as usize).clamp(1, rel.len()) - 1;
        let (_, p, _) = rel.select_nth_unstable_by(k, |a, b| a.total_cmp(b));
        s.dist_rel_p999 = *p;
    }
    s
}

/// A reference or tracer cache keyed by the primitives it was built on.
struct Built {
    prims: Arc<Primitives>,
    tracers: Vec<Box<dyn Tracer>>,
}

/// Run parity over `ctx` with `opts`.
pub fn run(ctx: &RayContext, opts: &ParityOptions) -> crate::Result<ParityReport> {
    let ref_cfg = opts.reference.config();
    let ref_label = config_label(&ref_cfg);
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
        for set in raysets::generate(ctx, kind, opts.seed, opts.count, reference.as_ref(), &oracle_for)? {
            // Tracers for this set's primitives (the scaled sets bring their own).
            let idx = match cache.iter().position(|b| Arc::ptr_eq(&b.prims, &set.prims)) {
                Some(i) => i,
                None => {
                    let mut tracers = vec![build(&set.prims, &ref_cfg)?];
                    for cfg in opts.variants.iter().chain(&stress_cfgs) {
                        tracers.push(build(&set.prims, cfg)?);
                    }
                    cache.push(Built { prims: set.prims.clone(), tracers });
                    cache.len() - 1
                }
            };
            let tracers = &cache[idx].tracers;
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
            for (cfg, tracer) in opts.variants.iter().zip(&tracers[1..]) {
                let hits = trace_all(tracer.as_ref(), &set.rays);
                let occ = occluded_all(tracer.as_ref(), &set);
                report.variants.push(compare(
                    &config_label(cfg),
                    &set,
                    &hits,
                    &occ,
                    &ref_hits,
                    &ref_occ,
                    opts.max_examples,
                ));
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
                let per_m = |n: u64, d: usize| if d == 0 { 0.0 } else { n as f64 * 1e6 / d as f64 };
                stress.push(StressRow {
                    set: set.name.clone(),
                    rays: set.rays.len(),
                    leaks_per_million: leaks.map(|n| per_m(n, set.rays.len())),
                    self_hits_per_million: selfh.map(|n| per_m(n, report.spawned_rays)),
                    spawned_rays: report.spawned_rays,
                });
            }
            sets_out.push(report);
        }
    }
    Ok(ParityReport {
        count: opts.count,
        sets: sets_out,
        stress,
        stress_tracers: ["watertight".into(), "moller-trumbore".into(), ref_label],
    })
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
        let _ = writeln!(
            o,
            "numerical stress (leaks per million rays | false self-intersections per million spawned rays)"
        );
        let _ = writeln!(
            o,
            "  {:<14} {:>9} {:>12} {:>16} {:>12} | {:>9} {:>12} {:>16} {:>12}",
            "set", "rays", a, b, c, "spawned", a, b, c
        );
        for s in &r.stress {
            let _ = writeln!(
                o,
                "  {:<14} {:>9} {:>12.1} {:>16.1} {:>12.1} | {:>9} {:>12.1} {:>16.1} {:>12.1}",
                s.set,
                s.rays,
                s.leaks_per_million[0],
                s.leaks_per_million[1],
                s.leaks_per_million[2],
                s.spawned_rays,
                s.self_hits_per_million[0],
                s.self_hits_per_million[1],
                s.self_hits_per_million[2]
            );
        }
    }
    o
}

/// Translate and scale a mesh's vertices so that their mean is at the origin
/// and the farthest vertex at distance 1 (the default camera's framing).
pub fn normalise_to_unit_sphere(positions: &mut [Vec3]) {
    if positions.is_empty() {
        return;
    }
    let sum = positions.iter().fold(DVec3::ZERO, |a, p| a + p.as_dvec3());
    let c = sum / positions.len() as f64;
    let r = positions.iter().map(|p| (p.as_dvec3() - c).length()).fold(0.0, f64::max);
    let s = if r > 0.0 { 1.0 / r } else { 1.0 };
    for p in positions {
        *p = ((p.as_dvec3() - c) * s).as_vec3();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Triangle;

    #[test]
    fn brute_reference_agrees_with_itself() {
        let p = [
            Vec3::new(1.0, 1.0, 1.0),
            Vec3::new(1.0, -1.0, -1.0),
            Vec3::new(-1.0, 1.0, -1.0),
            Vec3::new(-1.0, -1.0, 1.0),
        ]
        .map(|v| v * 0.5);
        let f = [[0, 1, 2], [0, 3, 1], [0, 2, 3], [1, 3, 2]];
        let prims = Arc::new(Primitives {
            triangles: f.iter().map(|t| Triangle { v: t.map(|i| p[i]) }).collect(),
            spheres: vec![],
        });
        let ctx = RayContext::with_defaults(prims);
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
        let mut set = raysets::RaySet {
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
        let s = compare("dropper", &set, &nh, &none, &rh, &none, 5);
        assert_eq!(s.native_miss_ref_hit, 1);
        assert_eq!(s.classes.get("unclassified"), Some(&1));
        assert_eq!((s.examples[0].seed, s.examples[0].index), (9, 0));
        // A crossing tag turns the same miss into a leak.
        set.tags[0] = RayTag::Crossing { t: 2.0 };
        let s = compare("dropper", &set, &nh, &none, &rh, &none, 5);
        assert_eq!((s.leaks, s.classes.get("leak")), (1, Some(&1)));
    }

    #[test]
    fn normalised_mesh_fits_the_unit_sphere() {
        let mut p = vec![Vec3::new(10.0, 0.0, 0.0), Vec3::new(12.0, 0.0, 0.0), Vec3::new(11.0, 3.0, 0.0)];
        normalise_to_unit_sphere(&mut p);
        let m = p.iter().map(|v| v.length()).fold(0.0, f32::max);
        assert!((m - 1.0).abs() < 1e-6);
    }
}
