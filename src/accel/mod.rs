//! Acceleration structures behind one interface.
//!
//! The renderer holds a `dyn Tracer` and never knows whether hits come from the
//! brute-force loop, one of the BVH variants, or Embree.

pub mod brute;

pub use brute::BruteForce;

use crate::geometry::{Hit, Ray};

/// Closest-hit and any-hit queries over a fixed set of [`crate::geometry::Primitives`].
pub trait Tracer: Send + Sync {
    /// Short name for summaries and reports (e.g. `brute`, `bvh-sah/fast`, `embree`).
    fn name(&self) -> String;

    /// The closest hit with `ray.t_min <= t <= ray.t_max`, if any.
    fn intersect(&self, ray: &Ray) -> Option<Hit>;

    /// True when any primitive is hit with `ray.t_min <= t <= ray.t_max`.
    fn occluded(&self, ray: &Ray) -> bool;
}
