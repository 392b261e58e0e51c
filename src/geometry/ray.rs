//! Rays with an explicit parametric interval.

use glam::Vec3;

/// A ray `origin + t * dir`, valid for `t_min <= t <= t_max` (the same closed
/// interval Embree uses for `tnear`/`tfar`). `dir` need not be normalised.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    /// Start point.
    pub origin: Vec3,
    /// Direction (any length, not zero).
    pub dir: Vec3,
    /// Smallest accepted hit distance, in units of `dir`.
    pub t_min: f32,
    /// Largest accepted hit distance, in units of `dir`.
    pub t_max: f32,
}

impl Ray {
    /// A ray over `[0, inf)`.
    pub fn new(origin: Vec3, dir: Vec3) -> Self {
        Self { origin, dir, t_min: 0.0, t_max: f32::INFINITY }
    }

    /// A ray over `[t_min, t_max]`.
    pub fn with_range(origin: Vec3, dir: Vec3, t_min: f32, t_max: f32) -> Self {
        Self { origin, dir, t_min, t_max }
    }

    /// Whether the ray can be traced at all: a finite origin, a finite
    /// non-zero direction, and an interval whose ends are not NaN with
    /// `t_min <= t_max`. Every tracer answers "no hit" for a ray that is
    /// not (Embree's behaviour on such rays is undefined: a NaN direction
    /// crashes it, and the wide BVH's box test would accept every lane).
    ///
    /// ```
    /// use glam::Vec3;
    /// use rtdiff::geometry::Ray;
    /// assert!(Ray::new(Vec3::ZERO, Vec3::Z).is_traceable());
    /// assert!(!Ray::new(Vec3::ZERO, Vec3::new(0.0, f32::NAN, 1.0)).is_traceable());
    /// assert!(!Ray::new(Vec3::ZERO, Vec3::ZERO).is_traceable());
    /// assert!(!Ray::with_range(Vec3::ZERO, Vec3::Z, 1.0, 0.5).is_traceable());
    /// ```
    #[inline]
    pub fn is_traceable(&self) -> bool {
        // Without short-circuits: every ray of a render passes, and six
        // finiteness branches cost more than the bit tests they guard.
        let exp = |x: f32| x.to_bits() & 0x7f80_0000;
        let inf = 0x7f80_0000;
        let finite = (exp(self.origin.x) != inf)
            & (exp(self.origin.y) != inf)
            & (exp(self.origin.z) != inf)
            & (exp(self.dir.x) != inf)
            & (exp(self.dir.y) != inf)
            & (exp(self.dir.z) != inf);
        let nonzero = ((self.dir.x.to_bits() | self.dir.y.to_bits() | self.dir.z.to_bits()) << 1) != 0;
        finite & nonzero & (self.t_min <= self.t_max)
    }

    /// The point at parameter `t`.
    ///
    /// ```
    /// use glam::Vec3;
    /// use rtdiff::geometry::Ray;
    /// let r = Ray::new(Vec3::ZERO, Vec3::new(0.0, 0.0, 2.0));
    /// assert_eq!(r.at(1.5), Vec3::new(0.0, 0.0, 3.0));
    /// ```
    #[inline]
    pub fn at(&self, t: f32) -> Vec3 {
        self.origin + t * self.dir
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The bit tests of [`Ray::is_traceable`] against the definition
    /// (finite origin and direction, a nonzero direction, a non-empty
    /// interval) on every pattern of zeros of both signs, subnormals,
    /// infinities and NaNs.
    #[test]
    fn traceable_is_the_definition() {
        let v =
            [0.0f32, -0.0, 1.0, -2.5, f32::MIN_POSITIVE / 4.0, -f32::MAX, f32::INFINITY, f32::NEG_INFINITY, f32::NAN];
        let mut seen = [0usize; 2];
        for &a in &v {
            for &b in &v {
                for &c in &v {
                    for (o, d) in
                        [(Vec3::new(a, b, c), Vec3::new(c, 1.0, a)), (Vec3::new(1.0, a, 2.0), Vec3::new(a, b, c))]
                    {
                        for (t0, t1) in [(0.0, f32::INFINITY), (1.0, 0.5), (f32::NAN, 1.0), (-1.0, -1.0)] {
                            let r = Ray::with_range(o, d, t0, t1);
                            let want = o.is_finite() && d.is_finite() && d != Vec3::ZERO && t0 <= t1;
                            assert_eq!(r.is_traceable(), want, "{r:?}");
                            seen[usize::from(want)] += 1;
                        }
                    }
                }
            }
        }
        assert!(seen[0] > 100 && seen[1] > 100, "{seen:?}");
    }
}
