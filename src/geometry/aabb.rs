//! Axis-aligned bounding boxes and a ray/box slab test that is safe for zero
//! direction components and conservative under floating-point rounding.

use glam::Vec3;

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
const SLAB_FAR_SCALE: f32 = 1.0 + 2.0 * (3.0 * f32::EPSILON * 0.5) / (1.0 - 3.0 * f32::EPSILON * 0.5);

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
    /// interval, or `None` when it misses. `inv_dir` is `1 / ray.dir`
    /// (infinite for zero components). Conservative: a ray that touches the
    /// box in exact arithmetic is never reported as a miss.
    #[inline]
    pub fn intersect(&self, ray: &Ray, inv_dir: Vec3) -> Option<(f32, f32)> {
        let mut t0 = ray.t_min;
        let mut t1 = ray.t_max;
        for a in 0..3 {
            let o = ray.origin[a];
            let inv = inv_dir[a];
            let (lo, hi) = (self.min[a], self.max[a]);
            if inv.is_infinite() {
                // Direction component is zero: the slab is either always or never entered.
                if o < lo || o > hi {
                    return None;
                }
                continue;
            }
            let mut tn = (lo - o) * inv;
            let mut tf = (hi - o) * inv;
            if tn > tf {
                std::mem::swap(&mut tn, &mut tf);
            }
            tf *= SLAB_FAR_SCALE;
            // Written so that a NaN (never produced here) could not widen the interval.
            t0 = if tn > t0 { tn } else { t0 };
            t1 = if tf < t1 { tf } else { t1 };
            if t0 > t1 {
                return None;
            }
        }
        Some((t0, t1))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn zero_direction_components_do_not_produce_nan() {
        let b = Aabb::new(Vec3::ZERO, Vec3::ONE);
        let r = Ray::new(Vec3::new(0.5, 0.5, -1.0), Vec3::new(0.0, 0.0, 1.0));
        let hit = b.intersect(&r, r.dir.recip()).unwrap();
        assert_eq!(hit, (1.0, 2.0 * SLAB_FAR_SCALE));
        // On the boundary plane, parallel to it: still inside the closed slab.
        let r = Ray::new(Vec3::new(1.0, 0.5, -1.0), Vec3::new(0.0, 0.0, 1.0));
        assert!(b.intersect(&r, r.dir.recip()).is_some());
        let r = Ray::new(Vec3::new(1.5, 0.5, -1.0), Vec3::new(0.0, 0.0, 1.0));
        assert!(b.intersect(&r, r.dir.recip()).is_none());
    }

    #[test]
    fn flat_box_is_hit() {
        // A triangle lying in z = 0 has a box of zero thickness.
        let b = Aabb::new(Vec3::new(0.0, 0.0, 0.0), Vec3::new(1.0, 1.0, 0.0));
        let r = Ray::new(Vec3::new(0.3, 0.3, 2.0), Vec3::new(0.0, 0.0, -1.0));
        assert!(b.intersect(&r, r.dir.recip()).is_some());
    }
}
