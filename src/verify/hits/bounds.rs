//! Per-ray error bounds of hit parity: how far two correct single-precision
//! tracers may disagree.
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

use glam::DVec3;

use crate::geometry::{Hit, Prim, Primitives, Ray};

/// `K` of the module documentation: how many unit roundings the difference
/// of two correct tracers may accumulate.
pub const K_ROUNDING: f64 = 32.0;
pub(crate) const U: f64 = f32::EPSILON as f64 * 0.5;

/// Geometry of a hit needed by the bounds: unit normal, longest edge, |N|.
pub(crate) struct HitGeom {
    pub(crate) n: DVec3,
    pub(crate) longest: f64,
    pub(crate) double_area: f64,
    pub(crate) is_triangle: bool,
}

pub(crate) fn hit_geom(prims: &Primitives, ray: &Ray, h: &Hit) -> HitGeom {
    match prims.get(h.prim as usize) {
        Prim::Triangle(t) => {
            let [a, b, c] = t.v.map(|p| p.as_dvec3());
            let nn = (b - a).cross(c - a);
            let longest = (b - a).length().max((c - b).length()).max((a - c).length());
            HitGeom { n: nn.normalize_or_zero(), longest, double_area: nn.length(), is_triangle: true }
        }
        Prim::Sphere(s) => {
            let n = (ray.at(h.t).as_dvec3() - s.center.as_dvec3()).normalize_or_zero();
            HitGeom { n, longest: 0.0, double_area: 0.0, is_triangle: false }
        }
    }
}

/// Per-ray bounds `(t bound, barycentric bound)` of the module documentation.
pub(crate) fn bounds(ray: &Ray, h: &Hit, g: &HitGeom) -> (f64, f64) {
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

/// The bounds `(t, barycentrics)` of the module documentation for hit `h` of
/// `ray` on `prims`: how far a correct single-precision tracer's distance and
/// barycentrics may lie from the exact ones.
pub fn of_hit(prims: &Primitives, ray: &Ray, h: &Hit) -> (f64, f64) {
    bounds(ray, h, &hit_geom(prims, ray, h))
}

/// True when the watertight test may refuse reference hit `h` by design: it
/// rejects a computed distance below its own error bound `delta`
/// (pbrt-v4's test that keeps spawned rays off their surface), so a true
/// distance up to `2 delta` can be refused; the reference's own error adds
/// `t_bound`.
pub(crate) fn unprovable_t(prims: &Primitives, ray: &Ray, h: &Hit, t_bound: f64) -> bool {
    let Some(tri) = prims.triangles.get(h.prim as usize) else { return false };
    let [a, b, c] = tri.v;
    crate::geometry::triangle::watertight_t_error_for(ray, a, b, c)
        .is_some_and(|delta| (h.t as f64) <= 2.0 * delta as f64 + t_bound)
}

pub(crate) fn near_edge(h: &Hit, b_bound: f64) -> bool {
    let w = 1.0 - h.u as f64 - h.v as f64;
    (h.u as f64).min(h.v as f64).min(w) <= b_bound
}

#[cfg(test)]
mod tests {
    use std::sync::Arc;

    use glam::Vec3;

    use super::*;
    use crate::backends::{AccelConfig, build_tracer};
    use crate::geometry::Triangle;
    use crate::geometry::triangle::{WatertightRay, intersect_watertight};
    use crate::rng::Pcg32 as Rng;
    use crate::verify::hits::arbiter::Arbiter;

    /// Slivers (aspect ratios 100 to 10,000) in random orientations, hit by
    /// rays from random directions at points inside them: every distance and
    /// barycentric pair of the watertight test, scalar and through the BVH's
    /// leaf tests, is within this module's bound of the exact hit
    /// ([`Arbiter::evaluate`]). Before the test sent hits whose edge-function
    /// error may move `t` too far to double precision
    /// (`geometry::triangle::T_SPREAD_MAX`), it returned distances beyond the
    /// bound on such triangles (regr01.obj's thin triangles, edge rays).
    #[test]
    fn watertight_distances_on_thin_triangles_are_within_the_bound_of_the_exact_hit() {
        let mut rng = Rng::new(0x5117e5, 7);
        let mut tris = Vec::new();
        for _ in 0..256 {
            let c = rng.in_box(Vec3::splat(-1.0), Vec3::splat(1.0));
            let a = rng.unit_vector();
            let b = a.cross(rng.unit_vector()).normalize();
            let len = 0.2;
            let w = len * 10f32.powf(-rng.range(2.0, 4.0));
            let shift = rng.range(-0.5, 0.5) * len;
            tris.push(Triangle { v: [c - a * (len / 2.0), c + a * (len / 2.0), c + a * shift + b * w] });
        }
        let prims = Arc::new(Primitives { triangles: tris.clone(), spheres: Vec::new() });
        let tracer = build_tracer(prims.clone(), &AccelConfig::default()).expect("a BVH");
        let arbiter = Arbiter::new(prims.clone());
        let (mut hits, mut beyond) = (0, Vec::new());
        let mut check = |ray: &Ray, h: Hit, how: &str| {
            let exact = arbiter.evaluate(ray, h.prim);
            let (tb, bb) = of_hit(&prims, ray, &h);
            let dt = (h.t as f64 - exact.t_f64).abs();
            let db = (h.u as f64 - exact.bary[1]).abs().max((h.v as f64 - exact.bary[2]).abs());
            hits += 1;
            if !(dt <= tb && db <= bb) {
                beyond.push(format!(
                    "{how} prim {}: t {} exact {} ({:.2} bounds), bary {:.2} bounds",
                    h.prim,
                    h.t,
                    exact.t_f64,
                    dt / tb,
                    db / bb
                ));
            }
        };
        for (i, t) in tris.iter().enumerate() {
            for _ in 0..16 {
                let (s, r) = (rng.next_f32(), rng.next_f32());
                let (s, r) = if s + r > 1.0 { (1.0 - s, 1.0 - r) } else { (s, r) };
                let target = t.v[0] + s * (t.v[1] - t.v[0]) + r * (t.v[2] - t.v[0]);
                let d = rng.unit_vector();
                let ray = Ray::new(target - d * rng.range(1.0, 3.0), d);
                if let Some((t_, u, v)) = intersect_watertight(&ray, &WatertightRay::new(d), t.v[0], t.v[1], t.v[2]) {
                    check(&ray, Hit { t: t_, prim: i as u32, u, v }, "scalar");
                }
                if let Some(h) = tracer.intersect(&ray) {
                    check(&ray, h, "bvh");
                }
            }
        }
        assert!(hits > 6000, "only {hits} hits");
        assert!(
            beyond.is_empty(),
            "{} of {hits} hits beyond the bound: {:#?}",
            beyond.len(),
            &beyond[..beyond.len().min(5)]
        );
    }
}
