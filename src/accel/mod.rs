//! The tracer interface and the brute-force oracle.
//!
//! The renderer holds a `dyn Tracer` and never knows whether hits come from the
//! brute-force loop, one of the BVH variants, or Embree. This module imports no
//! backend: [`crate::backends`] names and builds them all.

pub mod brute;

pub use brute::BruteForce;

use crate::geometry::{Hit, Ray};

/// Closest-hit and any-hit queries over a fixed set of [`crate::geometry::Primitives`].
///
/// A ray that is not [`Ray::is_traceable`] (a NaN or infinite component, a
/// zero direction, `t_min > t_max`) hits nothing, in every implementation.
pub trait Tracer: Send + Sync {
    /// The configuration's one label (`crate::backends::AccelConfig::label`: `brute`, `bvh-sah/fast`, `embree-high`).
    fn name(&self) -> String;

    /// The closest hit with `ray.t_min <= t <= ray.t_max`, if any.
    fn intersect(&self, ray: &Ray) -> Option<Hit>;

    /// True when any primitive is hit with `ray.t_min <= t <= ray.t_max`.
    fn occluded(&self, ray: &Ray) -> bool;

    /// [`Tracer::intersect`] of every ray of `rays` into `out` (same length):
    /// the same answers, ray for ray. Backends that trace coherent rays
    /// faster together (packets) override it; callers with many rays at
    /// once (a tile of camera rays, the shadow rays of a tile) use it.
    ///
    /// # Panics
    /// When `out` and `rays` differ in length.
    fn intersect_batch(&self, rays: &[Ray], out: &mut [Option<Hit>]) {
        assert_eq!(rays.len(), out.len(), "intersect_batch: one answer per ray");
        for (r, o) in rays.iter().zip(out) {
            *o = self.intersect(r);
        }
    }

    /// [`Tracer::occluded`] of every ray of `rays` into `out` (same length).
    ///
    /// # Panics
    /// When `out` and `rays` differ in length.
    fn occluded_batch(&self, rays: &[Ray], out: &mut [bool]) {
        assert_eq!(rays.len(), out.len(), "occluded_batch: one answer per ray");
        for (r, o) in rays.iter().zip(out) {
            *o = self.occluded(r);
        }
    }
}
