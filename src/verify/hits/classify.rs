//! Classification of disagreements between a tracer and the reference:
//! leaks through crossings, false self-intersections, hit/miss and primitive
//! differences by cause, and distance and barycentric errors against their
//! bounds.

use crate::geometry::{Hit, Primitives, Ray};
use crate::rays::{RaySet, RayTag};

use super::bounds::{bounds, hit_geom, near_edge, unprovable_t};
use super::report::{Example, VariantStats};

/// `(t, prim, u, v)` of a hit.
pub fn hit_tuple(h: &Option<Hit>) -> Option<(f32, u32, f32, f32)> {
    h.map(|h| (h.t, h.prim, h.u, h.v))
}

/// `ox oy oz dx dy dz tnear tfar` of a ray.
pub fn ray_array(r: &Ray) -> [f32; 8] {
    [r.origin.x, r.origin.y, r.origin.z, r.dir.x, r.dir.y, r.dir.z, r.t_min, r.t_max]
}

/// True when a tracer's answer on a crossing ray lets it through.
pub fn is_leak(ray: &Ray, tag: RayTag, h: &Option<Hit>, prims: &Primitives) -> bool {
    let RayTag::Crossing { t } = tag else { return false };
    match h {
        None => true,
        Some(h) => {
            // A hit beyond the crossing point (by more than rounding) went through.
            let (tb, _) = super::bounds::of_hit(prims, ray, h);
            (h.t as f64) > t as f64 + tb
        }
    }
}

pub fn is_self_hit(tag: RayTag, h: &Option<Hit>) -> bool {
    matches!((tag, h), (RayTag::Spawned { prim, .. } | RayTag::Shadow { prim, .. }, Some(h)) if h.prim == prim)
}

/// Leaks and false self-intersections among `hits` on `set`.
pub fn count_failures(set: &RaySet, hits: &[Option<Hit>]) -> (u64, u64) {
    let mut n = (0, 0);
    for ((ray, &tag), h) in set.rays.iter().zip(&set.tags).zip(hits) {
        n.0 += is_leak(ray, tag, h, &set.prims) as u64;
        n.1 += is_self_hit(tag, h) as u64;
    }
    n
}

/// The heuristic class of a disagreement between `ours` and the reference's
/// `theirs` (see [`VariantStats::classes`]): for a hit/miss difference `leak`,
/// `silhouette`, `degenerate`, `edge`, `interval-end`, `unprovable-t` or
/// `unclassified`; for different primitives at equal distance (within the
/// bound) `tie`, at different distances `degenerate`, `silhouette`, `edge`,
/// `unprovable-t` or `unclassified`. `None` when both miss or hit the same
/// primitive. The exact arbiter ([`super::arbiter`]) checks these.
pub fn heuristic_class(
    ray: &Ray,
    tag: RayTag,
    ours: &Option<Hit>,
    theirs: &Option<Hit>,
    prims: &Primitives,
) -> Option<&'static str> {
    match (ours, theirs) {
        (None, None) => None,
        (Some(h), None) | (None, Some(h)) => {
            let native_missed = ours.is_none();
            let g = hit_geom(prims, ray, h);
            let (tb, bb) = bounds(ray, h, &g);
            Some(if native_missed && is_leak(ray, tag, ours, prims) {
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
            })
        }
        (Some(a), Some(b)) => {
            if a.prim == b.prim {
                return None;
            }
            let g = hit_geom(prims, ray, b);
            let (tb, bb) = bounds(ray, b, &g);
            if (a.t as f64 - b.t as f64).abs() <= tb {
                return Some("tie");
            }
            let ga = hit_geom(prims, ray, a);
            let (_, bba) = bounds(ray, a, &ga);
            Some(if tag == RayTag::Degenerate {
                "degenerate"
            } else if tag == RayTag::Tangent {
                "silhouette"
            } else if (g.is_triangle && near_edge(b, bb)) || (ga.is_triangle && near_edge(a, bba)) {
                "edge"
            } else if a.t > b.t && unprovable_t(prims, ray, b, tb) {
                "unprovable-t"
            } else {
                "unclassified"
            })
        }
    }
}

/// One tracer's answers on a set: closest hits, and `occluded` answers on
/// the shadow rays (`None` elsewhere).
#[derive(Clone, Copy)]
pub struct Answers<'a> {
    /// Closest hit per ray.
    pub hits: &'a [Option<Hit>],
    /// `occluded` per shadow ray.
    pub occluded: &'a [Option<bool>],
}

/// Compare a tracer's answers `ours` with the reference's.
pub fn compare(label: &str, set: &RaySet, ours: Answers, reference: Answers, max_examples: usize) -> VariantStats {
    let (hits, occ) = (ours.hits, ours.occluded);
    let (ref_hits, ref_occ) = (reference.hits, reference.occluded);
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
        // A hit that is no hit at all (an id naming no primitive, a distance outside the
        // interval, NaN) is wrong whatever the reference says, and nothing else is asked of it.
        if let Some(f) = hits[i].and_then(|h| h.fault(ray, prims.len())) {
            s.invalid += 1;
            *s.invalid_classes.entry(f.name().to_string()).or_default() += 1;
            example(&mut s, i, &format!("invalid hit ({})", f.name()));
            continue;
        }
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
            (Some(_), None) | (None, Some(_)) => {
                let native_missed = hits[i].is_none();
                if native_missed {
                    s.native_miss_ref_hit += 1;
                } else {
                    s.native_hit_ref_miss += 1;
                }
                let class = heuristic_class(ray, tag, &hits[i], &ref_hits[i], prims).unwrap_or("unclassified");
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
                    let class = heuristic_class(ray, tag, &hits[i], &ref_hits[i], prims).unwrap_or("unclassified");
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
                let mut beyond = dt > tb;
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
                        beyond = true;
                        example(&mut s, i, "barycentrics beyond the error bound");
                    }
                }
                s.beyond_bound += beyond as u64;
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

/// True when `a` (the tracer's) and `b` (the reference's) name the same primitive, or tie
/// within the distance bound, and their distances or (same primitive) barycentrics differ
/// beyond the bounds of [`super::bounds`]: the rays [`compare`] counts in `beyond_bound`.
pub(crate) fn beyond_bounds(prims: &Primitives, ray: &Ray, a: &Hit, b: &Hit) -> bool {
    let g = hit_geom(prims, ray, b);
    let (tb, bb) = bounds(ray, b, &g);
    let dt = (a.t as f64 - b.t as f64).abs();
    if a.prim != b.prim && dt > tb {
        return false;
    }
    let db = (a.u as f64 - b.u as f64).abs().max((a.v as f64 - b.v as f64).abs());
    dt > tb || (a.prim == b.prim && g.is_triangle && db > bb)
}
