//! Per-ray constants and the NaN-safe, conservative slab test that every
//! traversal uses (scalar here; the wide traversal has an AVX2 copy with the
//! same semantics).
//!
//! Semantics equal [`crate::geometry::Aabb::intersect`]: the far distance is
//! widened by `1 + 2 gamma(3)` (pbrt-v4, section 6.8.2) so rounding never
//! loses a box the ray touches, and a zero direction component (infinite
//! reciprocal) never produces a NaN that could accept or reject a box: each
//! slab's near and far distances are combined with `max`/`min` that ignore a
//! NaN, which arises only for an origin exactly on a slab plane with the ray
//! parallel to it, where the closed slab imposes no constraint.

use glam::Vec3;

use crate::geometry::Ray;
use crate::geometry::offset::gamma;

/// Widening factor of far slab distances, `1 + 2 gamma(3)`.
#[inline]
pub fn far_scale() -> f32 {
    1.0 + 2.0 * gamma(3)
}

/// Upper bound used to cull boxes against the current closest hit `t`.
///
/// The computed entry distance of a box can exceed its exact value by a
/// relative `gamma(3)`; widening `t` by `1 + 2 gamma(3)` keeps every box
/// whose exact entry is at most `t` (so an equal-distance hit with a lower
/// primitive id is still found). Infinity maps to `f32::MAX` so that a
/// slab entered at `+inf` (zero direction, origin outside) is rejected.
#[inline]
pub fn cull_bound(t: f32) -> f32 {
    let s = far_scale();
    let w = if t >= 0.0 { t * s } else { t / s };
    w.min(f32::MAX)
}

/// A ray prepared for box tests.
#[derive(Clone, Copy, Debug)]
pub struct RayPre {
    /// Origin.
    pub o: Vec3,
    /// Reciprocal direction (infinite for zero components).
    pub inv: Vec3,
    /// Per axis: 1 when the direction component is negative (the far plane is `min`).
    pub neg: [usize; 3],
}

impl RayPre {
    /// Precompute for `ray`.
    #[inline]
    pub fn new(ray: &Ray) -> Self {
        let inv = ray.dir.recip();
        Self { o: ray.origin, inv, neg: [inv.x < 0.0, inv.y < 0.0, inv.z < 0.0].map(usize::from) }
    }

    /// Entry distance of the box `[min, max]` clipped to `[t0, t1]`, or `None` when missed.
    #[inline(always)]
    pub fn hit(&self, min: Vec3, max: Vec3, t0: f32, t1: f32) -> Option<f32> {
        let b = [min, max];
        let s = far_scale();
        let tn_x = (b[self.neg[0]].x - self.o.x) * self.inv.x;
        let tn_y = (b[self.neg[1]].y - self.o.y) * self.inv.y;
        let tn_z = (b[self.neg[2]].z - self.o.z) * self.inv.z;
        let tf_x = (b[1 - self.neg[0]].x - self.o.x) * self.inv.x * s;
        let tf_y = (b[1 - self.neg[1]].y - self.o.y) * self.inv.y * s;
        let tf_z = (b[1 - self.neg[2]].z - self.o.z) * self.inv.z * s;
        // f32::max/min return the non-NaN operand.
        let near = tn_x.max(tn_y).max(tn_z).max(t0);
        let far = tf_x.min(tf_y).min(tf_z).min(t1);
        (near <= far).then_some(near)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Aabb;

    #[test]
    fn agrees_with_aabb_intersect_on_edge_cases() {
        let b = Aabb::new(Vec3::ZERO, Vec3::ONE);
        let cases = [
            (Vec3::new(0.5, 0.5, -1.0), Vec3::Z),
            (Vec3::new(1.0, 0.5, -1.0), Vec3::Z),  // on the x = 1 plane, parallel
            (Vec3::new(0.0, 0.0, -1.0), Vec3::Z),  // on an edge line
            (Vec3::new(1.5, 0.5, -1.0), Vec3::Z),  // outside, parallel
            (Vec3::new(0.5, 0.5, -1.0), -Vec3::Z), // pointing away
            (Vec3::new(0.5, 0.5, 0.5), Vec3::new(-0.0, 0.0, 1.0)),
            (Vec3::new(-1.0, -1.0, -1.0), Vec3::ONE),
        ];
        for (o, d) in cases {
            let r = Ray::new(o, d);
            let p = RayPre::new(&r);
            let a = b.intersect(&r, r.dir.recip()).is_some();
            let s = p.hit(b.min, b.max, r.t_min, cull_bound(r.t_max)).is_some();
            assert_eq!(a, s, "origin {o} dir {d}");
        }
    }

    #[test]
    fn cull_bound_is_finite_and_not_below_t() {
        assert_eq!(cull_bound(f32::INFINITY), f32::MAX);
        for t in [0.0, 1.0e-30, 0.3, 7.0, 1.0e20] {
            assert!(cull_bound(t) >= t);
        }
    }
}
