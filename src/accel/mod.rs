//! Acceleration structures behind one interface.
//!
//! The renderer holds a `dyn Tracer` and never knows whether hits come from the
//! brute-force loop, one of the BVH variants, or Embree.

pub mod brute;
pub mod config;

pub use brute::BruteForce;
pub use config::{AccelConfig, Backend, Builder, EmbreeQuality, Traversal};

use std::sync::Arc;

use crate::error::Result;
use crate::geometry::Primitives;

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

/// Build the tracer `cfg` asks for over `prims`.
pub fn build_tracer(prims: Arc<Primitives>, cfg: &AccelConfig) -> Result<Box<dyn Tracer>> {
    match cfg.backend {
        Backend::Brute => Ok(Box::new(BruteForce::new(prims, cfg.triangle_test))),
        Backend::Native => Ok(Box::new(crate::bvh::BvhTracer::new(&prims, cfg))),
        #[cfg(feature = "embree")]
        Backend::Embree => Ok(Box::new(crate::embree::EmbreeTracer::new(prims, cfg.embree_quality)?)),
        #[cfg(not(feature = "embree"))]
        Backend::Embree => Err(crate::error::Error::Invalid(
            "this build has no Embree backend: run scripts/setup-embree.sh and build with --features embree".into(),
        )),
    }
}
