//! The exact arbiter: who is right when two tracers disagree on a ray.
//!
//! [`Arbiter::truth`] computes the true closest hit of a ray from its float32
//! inputs (origin, direction, `t_min`, `t_max`, vertices, sphere centres and
//! radii taken as exact numbers) with exact integer arithmetic
//! ([`super::exact`]):
//!
//! - **Triangles.** With `A, B, C` the vertices relative to the origin and `d`
//!   the direction, the ray's line meets the triangle iff the three edge
//!   volumes `w0 = d.(B x C)`, `w1 = d.(C x A)`, `w2 = d.(A x B)` have no two of
//!   opposite signs and their sum `d.N` is not zero (the exact form of the
//!   watertight test's edge functions, which are these volumes divided by
//!   `d_z`); the barycentrics are `w_i / (w0 + w1 + w2)` and
//!   `t = det(A, B, C) / d.N`, a fraction of exact integers. A point exactly
//!   on an edge or vertex counts as a hit (both neighbours hit, a tie).
//!   Triangles of exactly zero area and rays exactly in a triangle's plane are
//!   never hit (the tracers skip them too).
//! - **Spheres.** `t` solves `a t^2 - 2 b t + c = 0` exactly (`a = d.d`,
//!   `b = -(o - centre).d`, `c = |o - centre|^2 - r^2`); the roots
//!   `(b -+ sqrt(b^2 - a c)) / a` are kept as exact quadratic irrationals and
//!   compared by squaring. The nearest root inside `[t_min, t_max]` is the hit,
//!   as in [`crate::geometry::Sphere::intersect`].
//!
//! The interval is closed. The *answer* of a ray is the set of primitives it
//! hits at the smallest exact distance (empty: a miss); distances are ordered
//! exactly, the rational `t`s by cross-multiplication, sphere roots by
//! squaring ([`ExactT::cmp_exact`]), however close they are. Two primitives
//! with the same vertices (or the same centre and radius) are the same
//! surface and always tie.
//!
//! # Ill-conditioned rays, precisely
//!
//! The answer is fixed by the signs of a few exact quantities, its
//! *decisions*: for every primitive near the ray, the three edge volumes
//! (for a sphere, the discriminant `b^2 - a c`), `t - t_min` and `t_max - t`;
//! and for every pair of hit primitives, `t_1 - t_2`. A *one-unit
//! perturbation* moves every float32 input `x` to `x (1 + delta)`,
//! `|delta| <= u = 2^-24`, independently, and every distance a tracer
//! compares (`t` against `t_min`, `t_max` or another `t`) by one rounding to
//! float32 as well. To first order it moves a decision `q` by at most
//! `u kappa(q)`, with `kappa(q) = sum_i |dq/dx_i| |x_i|` over the inputs
//! (plus `|t|` for each distance compared; [`super::condition`]). The
//! decision's margin is `q / (u kappa(q))`, the number of such
//! perturbations it takes to change its sign, signed `+` on the side of the
//! exact answer (0 when `q` is exactly 0).
//!
//! The ray's **conditioning margin** is the smallest number of units of
//! perturbation that can change the answer, to first order and decision by
//! decision: the smallest of
//!
//! - for each primitive of the answer, its margin to being missed (smallest of
//!   its edge-volume, `t - t_min` and `t_max - t` margins), and its distance
//!   margin to each other primitive of the answer (0 for an exact tie between
//!   different surfaces);
//! - for every other primitive near the ray, the margin it takes to enter the
//!   answer: the largest of its violated decisions' margins (edge volumes of
//!   the wrong sign, a distance outside the interval), and, if its exact
//!   distance lies behind the answer's, its distance margin to the nearer of
//!   the answer's primitives.
//!
//! A ray is **ill-conditioned** when its margin is at most 1: some decision
//! of its answer can flip under a one-unit perturbation of the inputs, so the
//! answer is decided by the last bit of the inputs and no float32 tracer can
//! be held to it. A ray with a margin above 1 is well-conditioned: no
//! one-unit perturbation changes its answer (to first order), and a tracer
//! that does not return it is not exact.
//!
//! A tracer's answer is [`Verdict::Exact`] when it is one of the exact
//! answer's primitives (or both miss). Otherwise the arbiter counts the units
//! it takes to produce that answer: for the returned primitive its margin to
//! enter (all its violated decisions), and for every primitive hit exactly no
//! farther than it, the smaller of its margin to be missed and its distance
//! margin to the returned one. [`Verdict::WithinBound`] when that takes at
//! most [`K_TRACER`] units (what a correct float32 tracer may accumulate),
//! [`Verdict::Wrong`] beyond.

use std::cmp::Ordering;
use std::sync::Arc;

use glam::DVec3;
use num_bigint::BigInt;
use num_traits::{Signed, Zero};
use serde::Serialize;

use super::condition::{self, Sensitivity, U, units};
use super::exact::{self, BigVec, ExactT, fixed, fixed3};
use super::line_index::LineIndex;
use crate::geometry::{Prim, Primitives, Ray};

/// Units of rounding a correct float32 tracer may accumulate (the parity
/// harness's `K`, `hits::bounds` / module docs of the parity harness).
pub const K_TRACER: f64 = 32.0;

/// One primitive evaluated exactly against a ray's line.
#[derive(Clone, Debug)]
pub struct Exact {
    /// Global primitive id.
    pub prim: u32,
    /// Exact distance where the line meets the triangle's plane, or the
    /// sphere's root nearest the interval (its closest approach when the line
    /// misses); `None` when the line is parallel to the plane.
    pub t: Option<ExactT>,
    /// `t` rounded to `f64` (NaN when `t` is `None`).
    pub t_f64: f64,
    /// The ray hits the primitive exactly within `[t_min, t_max]`.
    pub hit: bool,
    /// Exact barycentrics of the line/plane point, rounded to `f64`
    /// (triangles); for spheres the signed half chord `sqrt(b^2 - a c) / a`
    /// in the first slot (negative: the line misses by that much).
    pub bary: [f64; 3],
    /// Signed margin, in units (module docs), of the line passing inside the
    /// primitive: the smallest edge-volume margin of a triangle (negative
    /// outside), the discriminant's for a sphere.
    pub inside: f64,
    /// Signed margin of `t >= t_min`.
    pub lo: f64,
    /// Signed margin of `t <= t_max`.
    pub hi: f64,
    /// Gradient of `t` over the inputs (`None` without a distance).
    pub dt: Option<Sensitivity>,
}

impl Exact {
    /// Units it takes to miss this primitive (0 when it is not hit).
    pub fn miss_units(&self) -> f64 {
        self.inside.min(self.lo).min(self.hi).max(0.0)
    }

    /// Units it takes to hit this primitive somewhere in the interval (0 when
    /// it is hit): the largest margin among its violated decisions.
    pub fn enter_units(&self) -> f64 {
        (-self.inside).max(-self.lo).max(-self.hi).max(0.0)
    }
}

/// The exact answer for one ray, with every primitive near the ray's line.
#[derive(Clone, Debug)]
pub struct Truth {
    /// Exact distance of the closest hit (`None`: the ray misses everything).
    pub t: Option<ExactT>,
    /// Every primitive at that distance, ascending.
    pub prims: Vec<u32>,
    /// Every primitive the exact evaluation looked at (all that the line hits
    /// or nearly hits in the interval).
    pub candidates: Vec<Exact>,
    /// Conditioning margin in units of one rounding (module docs).
    pub margin: f64,
}

impl Truth {
    /// True when the margin is at most one unit (module docs).
    pub fn ill_conditioned(&self) -> bool {
        self.margin <= 1.0
    }

    /// The closest exact distance as `f64`.
    pub fn t_f64(&self) -> Option<f64> {
        self.t.as_ref().map(|t| t.to_f64())
    }
}

/// How a tracer's answer compares with the exact one.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Verdict {
    /// One of the exact answer's primitives, or both miss.
    Exact,
    /// Not exact, but within [`K_TRACER`] units of rounding of it.
    WithinBound,
    /// Beyond that bound.
    Wrong,
}

/// What the arbiter says about a disagreement between a tracer under test
/// ("native") and a reference.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum ArbiterClass {
    /// The margin is at most one unit: decided by the last bit of the inputs.
    IllConditioned,
    /// Native exact, the reference not.
    NativeRight,
    /// The reference exact, native not.
    ReferenceRight,
    /// Both exact (different primitives of an exact tie).
    BothRight,
    /// Neither exact, both within [`K_TRACER`] units.
    BothWithinBound,
    /// Neither exact, at least one beyond the bound.
    BothWrong,
}

impl ArbiterClass {
    /// The class's name in reports.
    pub fn name(self) -> &'static str {
        match self {
            Self::IllConditioned => "ill-conditioned",
            Self::NativeRight => "native-right",
            Self::ReferenceRight => "reference-right",
            Self::BothRight => "both-right",
            Self::BothWithinBound => "both-within-bound",
            Self::BothWrong => "both-wrong",
        }
    }

    /// Classify from the two verdicts and the ray's conditioning.
    pub fn of(native: Verdict, reference: Verdict, ill_conditioned: bool) -> Self {
        use Verdict::*;
        match (native, reference) {
            (Exact, Exact) => Self::BothRight,
            _ if ill_conditioned => Self::IllConditioned,
            (Exact, _) => Self::NativeRight,
            (_, Exact) => Self::ReferenceRight,
            (WithinBound, WithinBound) => Self::BothWithinBound,
            _ => Self::BothWrong,
        }
    }
}

/// Per-triangle data for the floating-point prefilter and the bounds.
struct TriPre {
    /// Unnormalised normal `(v1 - v0) x (v2 - v0)`.
    n: DVec3,
    /// Its length (twice the area).
    n_len: f64,
    /// Longest edge.
    longest: f64,
}

/// Exact closest hits over a fixed set of primitives.
pub struct Arbiter {
    prims: Arc<Primitives>,
    pre: Vec<TriPre>,
    index: LineIndex,
}

impl Arbiter {
    /// An arbiter over `prims`.
    pub fn new(prims: Arc<Primitives>) -> Self {
        let pre = prims
            .triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.v.map(|p| p.as_dvec3());
                let n = (b - a).cross(c - a);
                let longest = (b - a).length().max((c - b).length()).max((a - c).length());
                TriPre { n, n_len: n.length(), longest }
            })
            .collect();
        let boxes: Vec<(DVec3, DVec3)> = prims
            .triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.v.map(|p| p.as_dvec3());
                (a.min(b).min(c), a.max(b).max(c))
            })
            .collect();
        Self { index: LineIndex::new(&boxes), prims, pre }
    }

    /// The primitives judged.
    pub fn prims(&self) -> &Arc<Primitives> {
        &self.prims
    }

    /// The parity harness's per-ray bounds ([`super::bounds`]) with `K = 1`,
    /// `(tb, bb)` at parameter `t` on primitive `prim`: the hit point may move
    /// by `u (|o|_inf + |p|_inf) / c` along the ray (`c` the cosine between
    /// ray and normal), i.e. `t` by `tb = u (|o| + |p|) / (c |d|)` and a
    /// barycentric by `bb = u (|o| + |p|) L / (|N| c) + u` (`L` longest edge,
    /// `|N|` twice the area). The candidate search measures "near" in these.
    pub fn unit_bounds(&self, ray: &Ray, prim: u32, t: f64) -> (f64, f64) {
        let o = ray.origin.as_dvec3();
        let d = ray.dir.as_dvec3();
        let dl = d.length();
        let p = o + d * t;
        let mag = o.abs().max_element() + p.abs().max_element();
        let (n, bb_geom) = match self.prims.get(prim as usize) {
            Prim::Triangle(_) => {
                let pre = &self.pre[prim as usize];
                (pre.n / pre.n_len, pre.longest / pre.n_len)
            }
            Prim::Sphere(s) => ((p - s.center.as_dvec3()).normalize_or_zero(), f64::INFINITY),
        };
        let c = (d.dot(n) / dl).abs().max(1e-300);
        let plane = U * mag / c;
        (plane / dl, plane * bb_geom + U)
    }

    /// Signed margins of `t - t_min` and `t_max - t` (module docs): the
    /// inputs through `dt`, `t_min` or `t_max` themselves, and one rounding
    /// of the computed `t`.
    fn interval_units(ray: &Ray, t: &ExactT, t_f64: f64, dt: &Sensitivity) -> (f64, f64) {
        let k = dt.kappa(ray.origin.as_dvec3(), ray.dir.as_dvec3()) + t_f64.abs();
        let side = |x: f32, sign_if_inside: i32| {
            if x.is_infinite() {
                return f64::INFINITY;
            }
            let s = match t.cmp_f32(x) {
                Ordering::Less => -1,
                Ordering::Equal => 0,
                Ordering::Greater => 1,
            };
            units(s * sign_if_inside, (t_f64 - x as f64).abs(), k + (x as f64).abs())
        };
        (side(ray.t_min, 1), side(ray.t_max, -1))
    }

    /// Exact evaluation of triangle `i`.
    fn exact_triangle(&self, ray: &Ray, i: usize, o: &BigVec, d: &BigVec) -> Exact {
        let v = self.prims.triangles[i].v;
        let a = exact::sub(&fixed3(v[0]), o);
        let b = exact::sub(&fixed3(v[1]), o);
        let c = exact::sub(&fixed3(v[2]), o);
        let bc = exact::cross(&b, &c);
        let w = [exact::dot(d, &bc), exact::dot(d, &exact::cross(&c, &a)), exact::dot(d, &exact::cross(&a, &b))];
        let sum: BigInt = &w[0] + &w[1] + &w[2];
        let det = exact::dot(&a, &bc);
        let (od, dd) = (ray.origin.as_dvec3(), ray.dir.as_dvec3());
        if sum.is_zero() {
            // The line is parallel to the plane (or the triangle has zero
            // area): never hit. It can enter under a perturbation only when it
            // lies in the plane (det = 0) and meets the closed triangle there,
            // i.e. its three vertices are not strictly on one side of it
            // (side of v: sign of N.(d x (v - o)), N the exact normal).
            let n = exact::cross(&exact::sub(&b, &a), &exact::sub(&c, &a));
            let dn = exact::cross(d, &n);
            let sides = [&a, &b, &c].map(|p| exact::sign(&exact::dot(&dn, p)));
            let apart = sides.iter().all(|&s| s > 0) || sides.iter().all(|&s| s < 0);
            let in_plane = det.is_zero() && n.iter().any(|x| !x.is_zero()) && !apart;
            return Exact {
                prim: i as u32,
                t: None,
                t_f64: f64::NAN,
                hit: false,
                bary: [f64::NAN; 3],
                inside: if in_plane { 0.0 } else { f64::NEG_INFINITY },
                lo: f64::INFINITY,
                hi: f64::INFINITY,
                dt: None,
            };
        }
        let t = ExactT::rational(det, sum.clone());
        let hit_side = exact::sign(&sum);
        let inside_edges = [(1, 2), (2, 0), (0, 1)].iter().zip(&w).fold(f64::INFINITY, |m, (&(p, q), wk)| {
            let k = condition::edge_volume_kappa(od, dd, v[p], v[q]);
            m.min(units(exact::sign(wk) * hit_side, exact::scaled_f64(wk, 3).abs(), k))
        });
        let bary = [0, 1, 2].map(|k| exact::ratio_f64(&w[k], &sum));
        let t_f64 = t.to_f64();
        let s = exact::scaled_f64(&sum, 3);
        let dt = Sensitivity::triangle(&v, self.pre[i].n, s, t_f64, bary);
        let (lo, hi) = Self::interval_units(ray, &t, t_f64, &dt);
        let inside = w.iter().all(|x| !x.is_negative()) || w.iter().all(|x| !x.is_positive());
        let in_range = t.cmp_f32(ray.t_min).is_ge() && t.cmp_f32(ray.t_max).is_le();
        Exact {
            prim: i as u32,
            t: Some(t),
            t_f64,
            hit: inside && in_range,
            bary,
            inside: inside_edges,
            lo,
            hi,
            dt: Some(dt),
        }
    }

    /// Exact evaluation of sphere `j` (global id `nt + j`).
    fn exact_sphere(&self, ray: &Ray, j: usize, o: &BigVec, d: &BigVec) -> Exact {
        let s = self.prims.spheres[j];
        let prim = self.prims.sphere_id(j);
        let f = exact::sub(o, &fixed3(s.center));
        let a = exact::dot(d, d);
        let b = -exact::dot(&f, d);
        let r = fixed(s.radius);
        let c = exact::dot(&f, &f) - &r * &r;
        let disc: BigInt = &b * &b - &a * &c;
        let (od, dd) = (ray.origin.as_dvec3(), ray.dir.as_dvec3());
        let inside = units(
            exact::sign(&disc),
            exact::scaled_f64(&disc, 4).abs(),
            condition::sphere_disc_kappa(od, dd, s.center, s.radius),
        );
        let root_disc = exact::scaled_f64(&disc.abs().sqrt(), 2);
        let half_chord = {
            let h = exact::ratio_f64(&disc.abs().sqrt(), &a);
            if disc.is_negative() { -h } else { h }
        };
        let base = |t: ExactT, sign: i32, hit: bool| {
            let t_f64 = t.to_f64();
            // g = o + t d - centre has g.d = a t - b = sign sqrt(disc) at the root (b -+ sqrt disc) / a.
            let (lo, hi, dt) = if disc.is_negative() {
                (f64::INFINITY, f64::INFINITY, None)
            } else {
                let g = od + t_f64 * dd - s.center.as_dvec3();
                let dt = Sensitivity::sphere(prim, s.center, s.radius, t_f64, g, sign as f64 * root_disc);
                let (lo, hi) = Self::interval_units(ray, &t, t_f64, &dt);
                (lo, hi, Some(dt))
            };
            Exact { prim, t: Some(t), t_f64, hit, bary: [half_chord, f64::NAN, f64::NAN], inside, lo, hi, dt }
        };
        if disc.is_negative() {
            // The line misses: report the closest approach's parameter b / a.
            return base(ExactT::rational(b, a), 0, false);
        }
        let root = |sgn: i64| ExactT { p: b.clone(), q: BigInt::from(sgn), d: disc.clone(), m: a.clone() };
        let in_range = |t: &ExactT| t.cmp_f32(ray.t_min).is_ge() && t.cmp_f32(ray.t_max).is_le();
        let (t0, t1) = (root(-1), root(1));
        if in_range(&t0) {
            base(t0, -1, true)
        } else if in_range(&t1) {
            base(t1, 1, true)
        } else if t1.cmp_f32(ray.t_min).is_lt() {
            // Neither root inside: the nearer root to the interval.
            base(t1, 1, false)
        } else {
            base(t0, -1, false)
        }
    }

    /// True when triangle `i` could be hit or nearly hit (within
    /// `2 K_TRACER` units) by the ray's line in its interval, judged in
    /// double precision with a generous allowance for its rounding.
    fn near(&self, ray: &Ray, i: usize) -> bool {
        let pre = &self.pre[i];
        if pre.n_len == 0.0 {
            return false; // exactly zero area (the f64 cross product of f32 data is exact enough to tell 0)
        }
        let o = ray.origin.as_dvec3();
        let d = ray.dir.as_dvec3();
        let [a, b, c] = self.prims.triangles[i].v.map(|p| p.as_dvec3() - o);
        let w = [d.dot(b.cross(c)), d.dot(c.cross(a)), d.dot(a.cross(b))];
        let sum = w[0] + w[1] + w[2];
        let (la, lb, lc) = (a.length(), b.length(), c.length());
        // Double-precision rounding of the volumes, very generously (1e-10
        // relative to the magnitude of their terms, the true error is ~1e-15).
        let err = 1e-10 * d.length() * (la * lb + lb * lc + lc * la);
        if sum.abs() <= err {
            return true; // nearly parallel: let the exact evaluation decide
        }
        let t = a.dot(b.cross(c)) / sum;
        let (tb, bb) = self.unit_bounds(ray, i as u32, t);
        let slack_b = 2.0 * K_TRACER * bb + err / sum.abs();
        let slack_t = 2.0 * K_TRACER * tb + 1e-10 * la * lb * lc / sum.abs();
        w.iter().all(|x| x / sum >= -slack_b) && t >= ray.t_min as f64 - slack_t && t <= ray.t_max as f64 + slack_t
    }

    /// Exact evaluation of primitive `prim` (its exact hit, or where the line
    /// passes it).
    pub fn evaluate(&self, ray: &Ray, prim: u32) -> Exact {
        let o = fixed3(ray.origin);
        let d = fixed3(ray.dir);
        match self.prims.sphere_index(prim as usize) {
            None => self.exact_triangle(ray, prim as usize, &o, &d),
            Some(j) => self.exact_sphere(ray, j, &o, &d),
        }
    }

    /// The exact closest hit of `ray`, with its conditioning margin.
    pub fn truth(&self, ray: &Ray) -> Truth {
        // Candidates: triangles whose box comes within the slack of the line.
        // A triangle the line meets is always found (any slack >= 0 keeps it;
        // this one also absorbs the index's own double rounding). The slack
        // reaches the triangles that are within 2 K units of being hit (a
        // plane error of 2 K u (|o| + |p|) moves the line by at most that
        // much towards a triangle, here with a factor 64 to spare for thin
        // triangles), which only the conditioning margin needs.
        let oo = ray.origin.as_dvec3();
        let slack = |lo: DVec3, hi: DVec3| {
            64.0 * K_TRACER * U * (oo.abs().max_element() + lo.abs().max(hi.abs()).max_element() + (hi - lo).length())
        };
        let mut near = Vec::new();
        self.index.visit(oo, ray.dir.as_dvec3(), slack, |i| {
            if self.near(ray, i as usize) {
                near.push(i as usize);
            }
        });
        near.sort_unstable();
        self.truth_over(ray, &near)
    }

    /// The exact closest hit of `ray` over the triangles `tris` (and every
    /// sphere), with its conditioning margin.
    fn truth_over(&self, ray: &Ray, tris: &[usize]) -> Truth {
        let o = fixed3(ray.origin);
        let d = fixed3(ray.dir);
        let mut candidates: Vec<Exact> = tris.iter().map(|&i| self.exact_triangle(ray, i, &o, &d)).collect();
        candidates.extend((0..self.prims.spheres.len()).map(|j| self.exact_sphere(ray, j, &o, &d)));
        let mut best: Option<ExactT> = None;
        let mut prims = Vec::new();
        for e in candidates.iter().filter(|e| e.hit) {
            let t = e.t.as_ref().expect("a hit has a distance");
            match best.as_ref().map(|b| t.cmp_exact(b)) {
                None | Some(Ordering::Less) => {
                    best = Some(t.clone());
                    prims = vec![e.prim];
                }
                Some(Ordering::Equal) => prims.push(e.prim),
                Some(Ordering::Greater) => {}
            }
        }
        prims.sort_unstable();
        let mut truth = Truth { t: best, prims, candidates, margin: f64::INFINITY };
        truth.margin = self.margin(ray, &truth);
        truth
    }

    /// True when primitives `p` and `q` are the same surface: triangles with
    /// the same three vertices (in any order or winding), or spheres with the
    /// same centre and radius. They tie at every ray, under every
    /// perturbation.
    fn identical(&self, p: u32, q: u32) -> bool {
        if p == q {
            return true;
        }
        match (self.prims.get(p as usize), self.prims.get(q as usize)) {
            (Prim::Triangle(a), Prim::Triangle(b)) => {
                let key = |t: &crate::geometry::Triangle| {
                    let mut k = t.v.map(|v| [v.x, v.y, v.z].map(f32::to_bits));
                    k.sort_unstable();
                    k
                };
                key(a) == key(b)
            }
            (Prim::Sphere(a), Prim::Sphere(b)) => {
                a.center.to_array().map(f32::to_bits) == b.center.to_array().map(f32::to_bits)
                    && a.radius.to_bits() == b.radius.to_bits()
            }
            _ => false,
        }
    }

    /// Unsigned margin of the order of the distances of `e` and `f` (module
    /// docs): `|t_e - t_f| / (u kappa)`, `kappa` over the inputs of both
    /// (shared ones once) plus one rounding of each distance; infinite for
    /// the same surface, 0 for an exact tie between different surfaces.
    fn order_units(&self, ray: &Ray, e: &Exact, f: &Exact) -> f64 {
        if self.identical(e.prim, f.prim) {
            return f64::INFINITY;
        }
        let (Some(te), Some(tf), Some(de), Some(df)) = (&e.t, &f.t, &e.dt, &f.dt) else {
            return f64::INFINITY;
        };
        let sign = if te.cmp_exact(tf) == Ordering::Equal { 0 } else { 1 };
        let kappa = de.minus(df).kappa(ray.origin.as_dvec3(), ray.dir.as_dvec3()) + e.t_f64.abs() + f.t_f64.abs();
        units(sign, te.diff_f64(tf).abs(), kappa)
    }

    /// Units it takes `e` to come in front of `f` (0 if it already is).
    fn front_units(&self, ray: &Ray, e: &Exact, f: &Exact) -> f64 {
        match (&e.t, &f.t) {
            (Some(te), Some(tf)) if te.cmp_exact(tf).is_le() => 0.0,
            _ => self.order_units(ray, e, f),
        }
    }

    /// The conditioning margin of `truth` (module docs).
    fn margin(&self, ray: &Ray, truth: &Truth) -> f64 {
        let answer: Vec<&Exact> = truth.candidates.iter().filter(|e| truth.prims.contains(&e.prim)).collect();
        let mut m = f64::INFINITY;
        for (k, a) in answer.iter().enumerate() {
            m = m.min(a.miss_units());
            for b in &answer[k + 1..] {
                m = m.min(self.order_units(ray, a, b));
            }
        }
        for e in truth.candidates.iter().filter(|e| !truth.prims.contains(&e.prim)) {
            let front = answer.iter().map(|a| self.front_units(ray, e, a)).fold(f64::INFINITY, f64::min);
            m = m.min(e.enter_units().max(if answer.is_empty() { 0.0 } else { front }));
        }
        m
    }

    /// The verdict on a tracer's answer `answer` (primitive id; `None` for a miss).
    pub fn judge(&self, ray: &Ray, truth: &Truth, answer: Option<u32>) -> Verdict {
        let exact = match answer {
            None => truth.t.is_none(),
            Some(p) => truth.prims.contains(&p),
        };
        if exact {
            return Verdict::Exact;
        }
        // Units it takes to produce this answer: bring the returned primitive
        // into the interval, and skip every exact hit no farther than it, by
        // missing it or by reversing the order of the two distances. Exact
        // ties are skipped only if each can be missed on its own: a ray
        // through a shared edge that misses both neighbours (a leak) is not
        // judged wrong here, the leak check of crossing rays catches it.
        let returned = answer
            .map(|p| truth.candidates.iter().find(|e| e.prim == p).cloned().unwrap_or_else(|| self.evaluate(ray, p)));
        let mut need = returned.as_ref().map_or(0.0, |r| if r.t.is_none() { f64::INFINITY } else { r.enter_units() });
        for e in truth.candidates.iter().filter(|e| e.hit) {
            let skip = match &returned {
                None => e.miss_units(),
                Some(r) if self.identical(e.prim, r.prim) => continue,
                Some(r) => match (&e.t, &r.t) {
                    (Some(te), Some(tr)) if te.cmp_exact(tr).is_le() => e.miss_units().min(self.order_units(ray, e, r)),
                    (Some(_), Some(_)) => continue,
                    _ => e.miss_units(),
                },
            };
            need = need.max(skip);
        }
        if need <= K_TRACER { Verdict::WithinBound } else { Verdict::Wrong }
    }
}

/// A ray as one replayable line: `ox oy oz dx dy dz tmin tmax` in hexadecimal
/// floating point (exact), then the same in decimal.
pub fn replay_line(ray: &Ray) -> String {
    let v = [ray.origin.x, ray.origin.y, ray.origin.z, ray.dir.x, ray.dir.y, ray.dir.z, ray.t_min, ray.t_max];
    let hex: Vec<String> = v.iter().map(|&x| hex_f32(x)).collect();
    let dec: Vec<String> = v.iter().map(|x| format!("{x:?}")).collect();
    format!("{}  # {}", hex.join(" "), dec.join(" "))
}

/// `x` as a C99 hexadecimal float (`0x1.8p+1`), exact; `inf`, `-inf`, `nan` as words.
pub fn hex_f32(x: f32) -> String {
    if x.is_nan() {
        return "nan".into();
    }
    if x.is_infinite() {
        return if x > 0.0 { "inf".into() } else { "-inf".into() };
    }
    let bits = x.to_bits();
    let sign = if bits >> 31 == 1 { "-" } else { "" };
    let exp = ((bits >> 23) & 0xff) as i32;
    let frac = bits & 0x7f_ffff;
    if exp == 0 && frac == 0 {
        return format!("{sign}0x0p+0");
    }
    // 23 fraction bits shifted to 24 = six hex digits.
    let (lead, e) = if exp == 0 { (0, -126) } else { (1, exp - 127) };
    let digits = format!("{:06x}", frac << 1);
    let digits = digits.trim_end_matches('0');
    if digits.is_empty() { format!("{sign}0x{lead}p{e:+}") } else { format!("{sign}0x{lead}.{digits}p{e:+}") }
}

/// Parse a hexadecimal (or decimal) float written by [`hex_f32`]; exact.
pub fn parse_f32(s: &str) -> Option<f32> {
    let s = s.trim();
    match s {
        "inf" | "+inf" => return Some(f32::INFINITY),
        "-inf" => return Some(f32::NEG_INFINITY),
        _ => {}
    }
    let (neg, body) = match s.strip_prefix('-') {
        Some(b) => (true, b),
        None => (false, s.strip_prefix('+').unwrap_or(s)),
    };
    let Some(hex) = body.strip_prefix("0x").or_else(|| body.strip_prefix("0X")) else {
        return s.parse().ok();
    };
    let (mant, exp) = hex.split_once(['p', 'P'])?;
    let exp: i32 = exp.parse().ok()?;
    let (int, frac) = mant.split_once('.').unwrap_or((mant, ""));
    let mut m: u64 = u64::from_str_radix(if int.is_empty() { "0" } else { int }, 16).ok()?;
    for ch in frac.chars() {
        m = m.checked_mul(16)? + ch.to_digit(16)? as u64;
    }
    // value = m * 2^(exp - 4 len(frac)); f64 holds it exactly (m < 2^53), then the f32 cast is exact for our output.
    let v = m as f64 * 2f64.powi(exp - 4 * frac.len() as i32);
    let v = v as f32;
    Some(if neg { -v } else { v })
}

/// Parse a line written by [`replay_line`] back into a ray.
pub fn parse_replay_line(line: &str) -> Option<Ray> {
    let body = line.split('#').next()?;
    let v: Vec<f32> = body.split_whitespace().map(parse_f32).collect::<Option<_>>()?;
    let [ox, oy, oz, dx, dy, dz, t0, t1] = v.try_into().ok()?;
    Some(Ray::with_range(glam::Vec3::new(ox, oy, oz), glam::Vec3::new(dx, dy, dz), t0, t1))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{Sphere, Triangle};
    use glam::Vec3;

    fn prims(tris: Vec<[Vec3; 3]>, spheres: Vec<Sphere>) -> Arc<Primitives> {
        Arc::new(Primitives { triangles: tris.into_iter().map(|v| Triangle { v }).collect(), spheres })
    }

    #[test]
    fn hex_floats_round_trip_exactly() {
        for x in [0.0f32, -0.0, 1.0, -1.5, 0.1, 3.4028235e38, f32::from_bits(1), 1e-40, f32::INFINITY, -7.25e-3] {
            let s = hex_f32(x);
            assert_eq!(parse_f32(&s).unwrap().to_bits(), x.to_bits(), "{x} -> {s}");
        }
        assert_eq!(hex_f32(1.0), "0x1p+0");
        assert_eq!(hex_f32(-1.5), "-0x1.8p+0");
        let r = Ray::with_range(Vec3::new(0.1, -2.0, 3.5), Vec3::new(1e-3, 0.5, -1.0), 0.0, f32::INFINITY);
        let back = parse_replay_line(&replay_line(&r)).unwrap();
        assert_eq!(format!("{back:?}"), format!("{r:?}"));
    }

    #[test]
    fn edge_hits_are_exact_ties_and_vertices_too() {
        // Two triangles sharing the diagonal of the unit square; a ray exactly through the diagonal.
        let p = prims(
            vec![
                [Vec3::ZERO, Vec3::X, Vec3::Y],
                [Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y],
                [Vec3::new(0.0, 0.0, -1.0), Vec3::new(1.0, 0.0, -1.0), Vec3::new(0.0, 1.0, -1.0)],
            ],
            vec![],
        );
        let arb = Arbiter::new(p);
        let r = Ray::new(Vec3::new(0.5, 0.5, 2.0), Vec3::new(0.0, 0.0, -1.0));
        let truth = arb.truth(&r);
        assert_eq!(truth.prims, vec![0, 1]);
        assert_eq!(truth.t_f64(), Some(2.0));
        assert!(truth.ill_conditioned(), "on an edge: margin {}", truth.margin);
        assert_eq!(arb.judge(&r, &truth, Some(1)), Verdict::Exact);
        // The triangle behind: each neighbour alone is missable at the edge (a
        // leak, which the per-primitive margins do not see; module docs).
        assert_eq!(arb.judge(&r, &truth, Some(2)), Verdict::WithinBound);
        // Well inside triangle 0: only it; the triangle behind is wrong, a miss is wrong.
        let r = Ray::new(Vec3::new(0.25, 0.25, 2.0), Vec3::new(0.0, 0.0, -1.0));
        let truth = arb.truth(&r);
        assert_eq!(truth.prims, vec![0]);
        assert!(!truth.ill_conditioned());
        assert_eq!(arb.judge(&r, &truth, Some(0)), Verdict::Exact);
        assert_eq!(arb.judge(&r, &truth, Some(2)), Verdict::Wrong);
        assert_eq!(arb.judge(&r, &truth, None), Verdict::Wrong);
        assert_eq!(arb.judge(&r, &truth, Some(1)), Verdict::Wrong);
    }

    #[test]
    fn a_hit_one_ulp_inside_an_edge_is_ill_conditioned_but_exact() {
        // Triangle with an edge on x = 1; rays at one ulp inside and outside it.
        let p = prims(vec![[Vec3::new(1.0, -1.0, 0.0), Vec3::new(1.0, 1.0, 0.0), Vec3::new(-1.0, 0.0, 0.0)]], vec![]);
        let arb = Arbiter::new(p);
        let inside = 1.0 - f32::EPSILON / 2.0; // the float below 1
        let r = Ray::new(Vec3::new(inside, 0.0, 1.0), Vec3::new(0.0, 0.0, -1.0));
        let truth = arb.truth(&r);
        assert_eq!(truth.prims, vec![0]);
        // One unit moves the origin and the edge's vertices by 2^-24 each: the
        // hit is 2^-24 inside, half of what they can move together.
        assert!(truth.ill_conditioned() && (truth.margin - 0.5).abs() < 1e-6, "{}", truth.margin);
        let r = Ray::new(Vec3::new(1.0 + f32::EPSILON, 0.0, 1.0), Vec3::new(0.0, 0.0, -1.0));
        let truth = arb.truth(&r);
        assert!(truth.prims.is_empty() && truth.ill_conditioned(), "{}", truth.margin);
        assert_eq!(arb.judge(&r, &truth, Some(0)), Verdict::WithinBound);
        // 64 ulps outside: beyond the tracer's bound of 32 units.
        let r = Ray::new(Vec3::new(1.0 + 64.0 * f32::EPSILON, 0.0, 1.0), Vec3::new(0.0, 0.0, -1.0));
        let truth = arb.truth(&r);
        assert!(truth.prims.is_empty() && !truth.ill_conditioned(), "{}", truth.margin);
        assert_eq!(arb.judge(&r, &truth, Some(0)), Verdict::Wrong);
        // Exact zeros are not rounded: a ray at the smallest subnormal off an
        // edge on x = 0, along an axis, keeps its side under any one-unit
        // perturbation (first order, underflow aside).
        let p = prims(vec![[Vec3::new(0.0, -1.0, 0.0), Vec3::new(1.0, 0.0, 0.0), Vec3::new(0.0, 1.0, 0.0)]], vec![]);
        let arb = Arbiter::new(p);
        let r = Ray::new(Vec3::new(f32::from_bits(1), 0.0, 1.0), Vec3::new(0.0, 0.0, -1.0));
        assert!(!arb.truth(&r).ill_conditioned());
    }

    #[test]
    fn the_line_index_finds_every_triangle_the_line_meets() {
        // A soup of 600 small random triangles and 3000 rays through it.
        let mut rng = crate::rays::Rng::new(5);
        let tris: Vec<[Vec3; 3]> = (0..600)
            .map(|_| {
                let c = rng.unit_vector() * rng.f32();
                [c, c + rng.unit_vector() * 0.1, c + rng.unit_vector() * 0.1]
            })
            .collect();
        let arb = Arbiter::new(prims(tris, vec![]));
        let mut found = 0;
        for _ in 0..3000 {
            let o = rng.unit_vector() * 2.0;
            let r = Ray::new(o, rng.unit_vector() * 0.3 - o);
            let brute: Vec<usize> = (0..600).filter(|&i| arb.near(&r, i)).collect();
            let truth = arb.truth(&r);
            let indexed: Vec<usize> = truth.candidates.iter().map(|e| e.prim as usize).filter(|&i| i < 600).collect();
            // Every triangle the line meets (any t) is found; nothing the
            // double-precision filter rejects is returned. (The filter alone
            // also keeps lines nearly parallel to a far triangle, whose
            // barycentric bound grows with the distance to the plane point;
            // the index measures the distance in space instead.)
            for &i in &brute {
                let e = arb.evaluate(&r, i as u32);
                if e.bary.iter().all(|&b| b >= 0.0) {
                    assert!(indexed.contains(&i), "{i} missing: {e:?}");
                }
            }
            assert!(indexed.iter().all(|i| brute.contains(i)));
            found += brute.len();
        }
        assert!(found > 3000, "{found}");
    }

    /// The candidate search keeps every triangle that can decide a margin up
    /// to the tracer bound: on rays through a soup of small triangles, some
    /// of them nearly coplanar layers (near ties in distance), the answer
    /// and the margin (up to `2 K_TRACER`) over the candidates equal those
    /// over every triangle.
    #[test]
    fn margins_over_the_candidates_equal_margins_over_every_triangle() {
        let mut rng = crate::rays::Rng::new(9);
        let mut tris: Vec<[Vec3; 3]> = Vec::new();
        for _ in 0..150 {
            let c = rng.unit_vector() * rng.f32() * 0.5;
            let t = [c, c + rng.unit_vector() * 0.2, c + rng.unit_vector() * 0.2];
            // A second layer a few float32 units behind, slightly tilted.
            let off = rng.unit_vector() * (rng.f32() * 64.0 * f32::EPSILON);
            tris.push(t);
            tris.push([t[0] + off, t[1] + off * 1.5, t[2] + off * 0.5]);
        }
        let n = tris.len();
        let arb = Arbiter::new(prims(tris, vec![]));
        let all: Vec<usize> = (0..n).collect();
        let (mut low, mut rays) = (0, 0);
        for _ in 0..400 {
            let o = rng.unit_vector() * 2.0;
            let r = Ray::new(o, rng.unit_vector() * 0.3 - o);
            let a = arb.truth(&r);
            let b = arb.truth_over(&r, &all);
            assert_eq!(a.prims, b.prims, "{}", replay_line(&r));
            let cap = 2.0 * K_TRACER;
            assert_eq!(a.margin.min(cap), b.margin.min(cap), "{}", replay_line(&r));
            low += (b.margin <= cap) as usize;
            rays += !b.prims.is_empty() as usize;
        }
        assert!(low > 20 && rays > 100, "{low} margins below the cap, {rays} hits");
    }

    #[test]
    fn spheres_are_decided_exactly() {
        let s = Sphere { center: Vec3::new(0.0, 0.0, 5.0), radius: 1.0 };
        let p = prims(vec![[Vec3::new(-9.0, -9.0, 4.0), Vec3::new(9.0, -9.0, 4.0), Vec3::new(0.0, 9.0, 4.0)]], vec![s]);
        let arb = Arbiter::new(p);
        // Through the centre: the sphere's front at t = 4 ties exactly with the plane z = 4 (prim 0).
        let r = Ray::new(Vec3::ZERO, Vec3::Z);
        let truth = arb.truth(&r);
        assert_eq!(truth.prims, vec![0, 1]);
        // From inside the sphere, beyond the triangle: the far root.
        let r = Ray::new(Vec3::new(0.0, 0.0, 4.5), Vec3::Z);
        let truth = arb.truth(&r);
        assert_eq!(truth.prims, vec![1]);
        assert_eq!(truth.t_f64(), Some(1.5));
        // Tangent: x = 1 exactly touches the sphere (one double root), a hit at t = 5 behind the plane.
        let r = Ray::new(Vec3::new(1.0, 0.0, 10.0), -Vec3::Z);
        let truth = arb.truth(&r);
        assert_eq!(truth.prims, vec![1]);
        assert_eq!(truth.t_f64(), Some(5.0));
        assert!(truth.ill_conditioned());
    }
}
