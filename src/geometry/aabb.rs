//! Axis-aligned bounding boxes and the crate's one scalar ray/box slab test
//! ([`Slab::clip`]), safe for zero direction components and conservative
//! under floating-point rounding. The tracers use it in `f32` ([`RayPre`]:
//! the BVH traversals, [`Aabb::intersect`]); the exact arbiter's candidate
//! search and the tests' closed-form oracles in `f64`. Only the BVH's 8-wide
//! SIMD kernels (`bvh/wide.rs`) repeat its arithmetic, lane by lane.

use glam::Vec3;
use num_traits::Float;

use super::Ray;

/// An axis-aligned box; `min > max` on any axis means empty.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    /// Lower corner.
    pub min: Vec3,
    /// Upper corner.
    pub max: Vec3,
}

impl Default for Aabb {
    fn default() -> Self {
        Self::EMPTY
    }
}

/// `1 + 2 gamma(3)`: the factor by which pbrt-v4 widens the far slab distance so
/// that rounding in `(bound - origin) * inv_dir` can never make a ray miss a box
/// it touches (pbrt-v4, section 6.8.2; gamma(n) = n u / (1 - n u), u = 2^-24).
pub const SLAB_FAR_SCALE: f32 = 1.0 + 2.0 * (3.0 * f32::EPSILON * 0.5) / (1.0 - 3.0 * f32::EPSILON * 0.5);

/// Widening factor of far slab distances in `f32`, [`SLAB_FAR_SCALE`].
#[inline]
pub fn far_scale() -> f32 {
    SLAB_FAR_SCALE
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

/// A ray or line `o + t d` prepared for slab tests, in `f32` or `f64`.
///
/// [`Slab::clip`] is NaN-safe: a zero direction component has an infinite
/// reciprocal, and each slab's near and far distances are combined with
/// `max`/`min`, which ignore a NaN. A NaN arises only for an origin exactly on
/// a slab plane with the line parallel to it, where the closed slab imposes
/// no constraint; an origin outside a slab it is parallel to gives an entry
/// of `+inf` or an exit of `-inf`, so the box is missed as long as the
/// interval's ends are finite (see [`cull_bound`]).
#[derive(Clone, Copy, Debug)]
pub struct Slab<F> {
    /// Origin.
    pub o: [F; 3],
    /// Reciprocal direction (infinite for zero components).
    pub inv: [F; 3],
    /// Per axis: 1 when the reciprocal direction is negative (the near plane is the box's `max`).
    pub neg: [usize; 3],
}

/// A ray prepared for the tracers' box tests.
pub type RayPre = Slab<f32>;

impl<F: Float> Slab<F> {
    /// Prepare the line through `o` with direction `d`.
    #[inline]
    pub fn from_line(o: [F; 3], d: [F; 3]) -> Self {
        let inv = d.map(F::recip);
        Self { o, inv, neg: inv.map(|x| usize::from(x < F::zero())) }
    }

    /// Entry and exit parameters of the box `[lo, hi]` within `[t0, t1]`, or
    /// `None` when the line misses it there. Far distances are multiplied by
    /// `far_scale` (`>= 1`: [`SLAB_FAR_SCALE`] in `f32` so that rounding never
    /// loses a box the ray touches; 1 where the caller widens the box itself).
    #[inline(always)]
    pub fn clip(&self, lo: [F; 3], hi: [F; 3], t0: F, t1: F, far_scale: F) -> Option<(F, F)> {
        let b = [lo, hi];
        let near = |a: usize| (b[self.neg[a]][a] - self.o[a]) * self.inv[a];
        let far = |a: usize| (b[1 - self.neg[a]][a] - self.o[a]) * self.inv[a] * far_scale;
        // max/min return the non-NaN operand, so the possibly-NaN slab distances go first.
        let tn = near(0).max(near(1)).max(near(2)).max(t0);
        let tf = far(0).min(far(1)).min(far(2)).min(t1);
        (tn <= tf).then_some((tn, tf))
    }
}

impl Slab<f32> {
    /// Prepare `ray` for box tests.
    #[inline]
    pub fn new(ray: &Ray) -> Self {
        Self::from_line(ray.origin.to_array(), ray.dir.to_array())
    }

    /// Entry distance of the box `[min, max]` clipped to `[t0, t1]` (pass
    /// [`cull_bound`] of the ray's `t_max` as `t1`), or `None` when missed.
    #[inline(always)]
    pub fn hit(&self, min: Vec3, max: Vec3, t0: f32, t1: f32) -> Option<f32> {
        self.clip(min.to_array(), max.to_array(), t0, t1, SLAB_FAR_SCALE).map(|(tn, _)| tn)
    }
}

impl Aabb {
    /// The empty box (identity of [`Aabb::union`]).
    pub const EMPTY: Aabb = Aabb { min: Vec3::splat(f32::INFINITY), max: Vec3::splat(f32::NEG_INFINITY) };

    /// Box spanning two corners.
    pub fn new(min: Vec3, max: Vec3) -> Self {
        Self { min, max }
    }

    /// Box around a set of points.
    pub fn from_points(points: &[Vec3]) -> Self {
        points.iter().fold(Self::EMPTY, |b, &p| b.grow(p))
    }

    /// This box grown to contain `p`.
    #[inline]
    pub fn grow(self, p: Vec3) -> Self {
        Self { min: self.min.min(p), max: self.max.max(p) }
    }

    /// Smallest box containing both.
    #[inline]
    pub fn union(self, o: Aabb) -> Self {
        Self { min: self.min.min(o.min), max: self.max.max(o.max) }
    }

    /// True when the box contains no point.
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.min.x > self.max.x || self.min.y > self.max.y || self.min.z > self.max.z
    }

    /// Edge lengths (zero for an empty box).
    #[inline]
    pub fn extent(&self) -> Vec3 {
        if self.is_empty() { Vec3::ZERO } else { self.max - self.min }
    }

    /// Centre point.
    #[inline]
    pub fn center(&self) -> Vec3 {
        0.5 * (self.min + self.max)
    }

    /// Surface area (zero for an empty box).
    #[inline]
    pub fn surface_area(&self) -> f32 {
        let e = self.extent();
        2.0 * (e.x * e.y + e.y * e.z + e.z * e.x)
    }

    /// Volume (zero for an empty box).
    #[inline]
    pub fn volume(&self) -> f32 {
        let e = self.extent();
        e.x * e.y * e.z
    }

    /// Index (0, 1, 2) of the longest axis.
    #[inline]
    pub fn largest_axis(&self) -> usize {
        let e = self.extent();
        if e.x >= e.y && e.x >= e.z {
            0
        } else if e.y >= e.z {
            1
        } else {
            2
        }
    }

    /// Largest absolute coordinate of the box: the scale that relative
    /// tolerances are measured against.
    pub fn max_abs_coord(&self) -> f32 {
        if self.is_empty() { 0.0 } else { self.min.abs().max(self.max.abs()).max_element() }
    }

    /// Entry and exit distances of `ray` through the box, clipped to the ray's
    /// interval (an infinite `t_max` to `f32::MAX`), or `None` when it misses.
    /// Conservative: a ray that touches the box in exact arithmetic is never
    /// reported as a miss ([`Slab::clip`] with [`SLAB_FAR_SCALE`]).
    #[inline]
    pub fn intersect(&self, ray: &Ray) -> Option<(f32, f32)> {
        RayPre::new(ray).clip(
            self.min.to_array(),
            self.max.to_array(),
            ray.t_min,
            ray.t_max.min(f32::MAX),
            SLAB_FAR_SCALE,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn zero_direction_components_do_not_produce_nan() {
        let b = Aabb::new(Vec3::ZERO, Vec3::ONE);
        let r = Ray::new(Vec3::new(0.5, 0.5, -1.0), Vec3::new(0.0, 0.0, 1.0));
        let hit = b.intersect(&r).unwrap();
        assert_eq!(hit, (1.0, 2.0 * SLAB_FAR_SCALE));
        // On the boundary plane, parallel to it: still inside the closed slab.
        let r = Ray::new(Vec3::new(1.0, 0.5, -1.0), Vec3::new(0.0, 0.0, 1.0));
        assert!(b.intersect(&r).is_some());
        let r = Ray::new(Vec3::new(1.5, 0.5, -1.0), Vec3::new(0.0, 0.0, 1.0));
        assert!(b.intersect(&r).is_none());
    }

    #[test]
    fn flat_box_is_hit() {
        // A triangle lying in z = 0 has a box of zero thickness.
        let b = Aabb::new(Vec3::new(0.0, 0.0, 0.0), Vec3::new(1.0, 1.0, 0.0));
        let r = Ray::new(Vec3::new(0.3, 0.3, 2.0), Vec3::new(0.0, 0.0, -1.0));
        assert!(b.intersect(&r).is_some());
    }

    #[test]
    fn the_traversal_test_agrees_with_intersect_on_edge_cases() {
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
            let a = b.intersect(&r).is_some();
            let s = RayPre::new(&r).hit(b.min, b.max, r.t_min, cull_bound(r.t_max)).is_some();
            assert_eq!(a, s, "origin {o} dir {d}");
        }
    }

    #[test]
    fn cull_bound_is_finite_and_not_below_t() {
        assert_eq!(cull_bound(f32::INFINITY), f32::MAX);
        for t in [0.0, 1.0e-30, 0.3, 7.0, 1.0e20] {
            assert!(cull_bound(t) >= t);
        }
        assert_eq!(far_scale(), 1.0 + 2.0 * crate::geometry::offset::gamma(3));
    }

    #[test]
    fn lines_in_double_precision() {
        // The whole line (both directions) through a unit box, and a segment stopping short of it.
        let s = Slab::from_line([0.5f64, 0.5, 3.0], [0.0, 0.0, 1.0]);
        assert_eq!(s.clip([0.0; 3], [1.0; 3], -f64::MAX, f64::MAX, 1.0), Some((-3.0, -2.0)));
        assert_eq!(s.clip([0.0; 3], [1.0; 3], 0.0, 1.0, 1.0), None);
        // Parallel to a slab and outside it: missed even over the whole line.
        let s = Slab::from_line([1.5f64, 0.5, 3.0], [0.0, 0.0, -1.0]);
        assert_eq!(s.clip([0.0; 3], [1.0; 3], -f64::MAX, f64::MAX, 1.0), None);
    }
}
