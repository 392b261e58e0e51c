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
        self.origin.is_finite() && self.dir.is_finite() && self.dir != Vec3::ZERO && self.t_min <= self.t_max
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
