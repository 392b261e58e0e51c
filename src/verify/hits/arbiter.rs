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
//! The interval is closed. Every primitive whose exact distance is minimal is
//! part of the answer (exact ties).
//!
//! # Classification
//!
//! A single-precision tracer cannot be asked for the exact answer when the
//! answer changes under perturbations of the size of its rounding. The unit of
//! that size is the module bound of the parity harness with `K = 1`: the hit
//! point may move by `u (|o|_inf + |p|_inf) / c` along the ray (`u = 2^-24`,
//! `c` the cosine between ray and surface normal), i.e. `t` by
//! `tb = u (|o| + |p|) / (c |d|)` and a barycentric by
//! `bb = u (|o| + |p|) L / (|N| c) + u` (`L` longest edge, `|N|` twice the
//! area). One unit is what rounding the ray's float32 inputs once does;
//! [`K_TRACER`] units (32, the parity harness's `K`) is what a correct float32
//! tracer may accumulate. The *conditioning margin* of a ray, in these units,
//! is the smallest perturbation that changes its exact answer:
//!
//! - the closest hit's smallest barycentric over `bb` (how far inside its
//!   triangle; for a sphere the half chord over `tb`),
//! - its distance to `t_min` and to `t_max` over `tb` (at `t_min`, over the
//!   larger of `tb` and twice the watertight test's own error bound on `t`,
//!   pbrt-v4 6.8.7, below which that test refuses a hit by design),
//! - for every other primitive, how far it is from being hit in front of the
//!   answer: the larger of `-min barycentric / bb` and `(t - t*) / tb` (with
//!   the larger of the two primitives' `tb`: two computed distances can come
//!   out in either order when they differ by less than either's error).
//!
//! A tracer's answer is [`Verdict::Exact`] when it is one of the exact
//! answer's primitives (or both miss); [`Verdict::WithinBound`] when it is
//! not, but the primitive it returned is reachable and everything it skipped
//! is missable within `K_TRACER` units; [`Verdict::Wrong`] otherwise. A ray is
//! **ill-conditioned** when its margin is at most one unit: its answer is
//! decided by the last bit of the inputs, and no single-precision tracer can
//! be held to it.

use std::sync::Arc;

use glam::DVec3;
use num_bigint::BigInt;
use num_traits::{Signed, Zero};
use serde::Serialize;

use super::exact::{self, BigVec, ExactT, fixed, fixed3};
use super::line_index::LineIndex;
use crate::geometry::{Prim, Primitives, Ray};

/// Units of rounding a correct float32 tracer may accumulate (the parity
/// harness's `K`, `hits::bounds` / module docs of the parity harness).
pub const K_TRACER: f64 = 32.0;
const U: f64 = f32::EPSILON as f64 * 0.5;

/// One primitive evaluated exactly against a ray's line.
#[derive(Clone, Debug)]
pub struct Exact {
    /// Global primitive id.
    pub prim: u32,
    /// Exact distance where the line meets the triangle's plane, or the
    /// sphere's root nearest the interval; `None` when the line is parallel to
    /// the plane or misses the sphere.
    pub t: Option<ExactT>,
    /// `t` rounded to `f64` (NaN when `t` is `None`).
    pub t_f64: f64,
    /// The ray hits the primitive exactly within `[t_min, t_max]`.
    pub hit: bool,
    /// Exact barycentrics of the line/plane point, rounded to `f64`
    /// (triangles); for spheres the signed half chord `sqrt(b^2 - a c) / a`
    /// in the first slot (negative: the line misses by that much).
    pub bary: [f64; 3],
    /// Unit `t` bound `tb` at this point (module docs).
    pub tb: f64,
    /// Unit barycentric bound `bb` (triangles; infinite for spheres).
    pub bb: f64,
}

impl Exact {
    /// How far inside the primitive the line passes, in units of its bound
    /// (negative outside): smallest barycentric over `bb`, or the half chord
    /// over `tb` for a sphere.
    pub fn inside_margin(&self, is_triangle: bool) -> f64 {
        if is_triangle {
            self.bary.iter().copied().fold(f64::INFINITY, f64::min) / self.bb
        } else {
            self.bary[0] / self.tb
        }
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
    /// Conditioning margin in units of the rounding bound (module docs).
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

    /// Unit bounds `(tb, bb)` (module docs) at parameter `t` on primitive `prim`.
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

    /// Exact evaluation of triangle `i` (or `None` when the line is parallel
    /// to its plane or the triangle has zero area).
    fn exact_triangle(&self, ray: &Ray, i: usize, o: &BigVec, d: &BigVec) -> Exact {
        let [v0, v1, v2] = self.prims.triangles[i].v;
        let a = exact::sub(&fixed3(v0), o);
        let b = exact::sub(&fixed3(v1), o);
        let c = exact::sub(&fixed3(v2), o);
        let bc = exact::cross(&b, &c);
        let w = [exact::dot(d, &bc), exact::dot(d, &exact::cross(&c, &a)), exact::dot(d, &exact::cross(&a, &b))];
        let sum: BigInt = &w[0] + &w[1] + &w[2];
        if sum.is_zero() {
            return Exact {
                prim: i as u32,
                t: None,
                t_f64: f64::NAN,
                hit: false,
                bary: [f64::NAN; 3],
                tb: f64::INFINITY,
                bb: f64::INFINITY,
            };
        }
        let t = ExactT::rational(exact::dot(&a, &bc), sum.clone());
        let inside = w.iter().all(|x| !x.is_negative()) || w.iter().all(|x| !x.is_positive());
        let in_range = t.cmp_f32(ray.t_min).is_ge() && t.cmp_f32(ray.t_max).is_le();
        let bary = [0, 1, 2].map(|k| exact::ratio_f64(&w[k], &sum));
        let t_f64 = t.to_f64();
        let (tb, bb) = self.unit_bounds(ray, i as u32, t_f64);
        Exact { prim: i as u32, t: Some(t), t_f64, hit: inside && in_range, bary, tb, bb }
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
        let half_chord = {
            let h = exact::ratio_f64(&disc.abs().sqrt(), &a);
            if disc.is_negative() { -h } else { h }
        };
        let miss = |t: Option<ExactT>| {
            let t_f64 = t.as_ref().map_or(f64::NAN, |t| t.to_f64());
            let (tb, _) = if t_f64.is_finite() { self.unit_bounds(ray, prim, t_f64) } else { (f64::INFINITY, 0.0) };
            Exact { prim, t, t_f64, hit: false, bary: [half_chord, f64::NAN, f64::NAN], tb, bb: f64::INFINITY }
        };
        if disc.is_negative() {
            // The line misses: report the closest approach's parameter b / a.
            return miss(Some(ExactT::rational(b, a)));
        }
        let root = |sgn: i64| ExactT { p: b.clone(), q: BigInt::from(sgn), d: disc.clone(), m: a.clone() };
        let in_range = |t: &ExactT| t.cmp_f32(ray.t_min).is_ge() && t.cmp_f32(ray.t_max).is_le();
        let (t0, t1) = (root(-1), root(1));
        let chosen = if in_range(&t0) {
            t0
        } else if in_range(&t1) {
            t1
        } else {
            // Neither root inside: the nearer root to the interval.
            let near = if t1.cmp_f32(ray.t_min).is_lt() { t1 } else { t0 };
            return miss(Some(near));
        };
        let t_f64 = chosen.to_f64();
        let (tb, bb) = self.unit_bounds(ray, prim, t_f64);
        Exact { prim, t: Some(chosen), t_f64, hit: true, bary: [half_chord, f64::NAN, f64::NAN], tb, bb }
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
        let o = fixed3(ray.origin);
        let d = fixed3(ray.dir);
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
        let mut candidates: Vec<Exact> = near.into_iter().map(|i| self.exact_triangle(ray, i, &o, &d)).collect();
        candidates.extend((0..self.prims.spheres.len()).map(|j| self.exact_sphere(ray, j, &o, &d)));
        let mut best: Option<ExactT> = None;
        let mut prims = Vec::new();
        for e in candidates.iter().filter(|e| e.hit) {
            let t = e.t.as_ref().expect("a hit has a distance");
            match best.as_ref().map(|b| t.cmp_exact(b)) {
                None | Some(std::cmp::Ordering::Less) => {
                    best = Some(t.clone());
                    prims = vec![e.prim];
                }
                Some(std::cmp::Ordering::Equal) => prims.push(e.prim),
                Some(std::cmp::Ordering::Greater) => {}
            }
        }
        prims.sort_unstable();
        let mut truth = Truth { t: best, prims, candidates, margin: f64::INFINITY };
        truth.margin = self.margin(ray, &truth);
        truth
    }

    fn is_triangle(&self, prim: u32) -> bool {
        self.prims.sphere_index(prim as usize).is_none()
    }

    /// The watertight test's own bound on `t` near the origin (twice its
    /// error bound; it refuses computed distances below one bound).
    fn t_min_bound(&self, ray: &Ray, e: &Exact) -> f64 {
        let tb = e.tb;
        if !self.is_triangle(e.prim) {
            return tb;
        }
        let [a, b, c] = self.prims.triangles[e.prim as usize].v;
        let wt = crate::geometry::triangle::watertight_t_error_for(ray, a, b, c).map_or(0.0, |x| 2.0 * x as f64);
        tb.max(wt / K_TRACER)
    }

    /// How many units it takes to miss hit `e` (through an edge or an end of the interval).
    fn missable(&self, ray: &Ray, e: &Exact) -> f64 {
        let inside = e.inside_margin(self.is_triangle(e.prim));
        let lo = (e.t_f64 - ray.t_min as f64) / self.t_min_bound(ray, e);
        let hi = (ray.t_max as f64 - e.t_f64) / e.tb;
        inside.min(lo).min(hi).max(0.0)
    }

    /// How many units it takes to hit `e` in front of `t_star` (or anywhere in
    /// the interval when `t_star` is the far end), whose own unit `t` bound
    /// is `tb_star`: two computed distances may come out in either order when
    /// they differ by less than the larger of their bounds.
    fn reachable(&self, ray: &Ray, e: &Exact, t_star: f64, tb_star: f64) -> f64 {
        if e.t.is_none() {
            return f64::INFINITY;
        }
        let outside = -e.inside_margin(self.is_triangle(e.prim));
        let behind = (e.t_f64 - t_star) / e.tb.max(tb_star);
        let before = (ray.t_min as f64 - e.t_f64) / self.t_min_bound(ray, e);
        outside.max(behind).max(before).max(0.0)
    }

    fn margin(&self, ray: &Ray, truth: &Truth) -> f64 {
        let t_star = truth.t_f64().unwrap_or(ray.t_max as f64);
        let tb_star =
            truth.candidates.iter().filter(|e| truth.prims.contains(&e.prim)).map(|e| e.tb).fold(0.0, f64::max);
        let mut m = f64::INFINITY;
        if truth.t.is_some() {
            // The answer survives if any of its tied primitives does.
            m = truth
                .candidates
                .iter()
                .filter(|e| truth.prims.contains(&e.prim))
                .map(|e| self.missable(ray, e))
                .fold(0.0, f64::max);
        }
        for e in truth.candidates.iter().filter(|e| !truth.prims.contains(&e.prim)) {
            m = m.min(self.reachable(ray, e, t_star, tb_star));
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
        // Units it takes to produce this answer: reach the returned primitive,
        // and skip every exact hit before it, by missing it or by misordering
        // two distances within the bound. Primitives exactly tied are skipped
        // only if each can be missed on its own: a ray through a shared edge
        // that misses both neighbours (a leak) is not judged wrong here, the
        // leak check of crossing rays catches it.
        let (mut need, t_answer, tb_answer) = match answer {
            None => (0.0, f64::INFINITY, 0.0),
            Some(p) => {
                let e = truth.candidates.iter().find(|e| e.prim == p).cloned().unwrap_or_else(|| self.evaluate(ray, p));
                let t = if e.t_f64.is_nan() { f64::INFINITY } else { e.t_f64 };
                (self.reachable(ray, &e, ray.t_max as f64, 0.0), t, e.tb)
            }
        };
        for e in truth.candidates.iter().filter(|e| e.hit && e.t_f64 <= t_answer && Some(e.prim) != answer) {
            let misorder =
                if t_answer.is_finite() { (t_answer - e.t_f64) / e.tb.max(tb_answer) } else { f64::INFINITY };
            need = f64::max(need, self.missable(ray, e).min(misorder));
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
        // Triangle with an edge on x = 0; rays at x = +-1 ulp of 0.25-scale numbers.
        let p = prims(vec![[Vec3::new(0.0, -1.0, 0.0), Vec3::new(1.0, 0.0, 0.0), Vec3::new(0.0, 1.0, 0.0)]], vec![]);
        let arb = Arbiter::new(p);
        let tiny = f32::from_bits(1); // smallest subnormal: exactly representable, exactly inside
        let r = Ray::new(Vec3::new(tiny, 0.0, 1.0), Vec3::new(0.0, 0.0, -1.0));
        let truth = arb.truth(&r);
        assert_eq!(truth.prims, vec![0]);
        assert!(truth.ill_conditioned());
        let r = Ray::new(Vec3::new(-tiny, 0.0, 1.0), Vec3::new(0.0, 0.0, -1.0));
        let truth = arb.truth(&r);
        assert!(truth.prims.is_empty() && truth.ill_conditioned());
        assert_eq!(arb.judge(&r, &truth, Some(0)), Verdict::WithinBound);
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
