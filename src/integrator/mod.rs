//! Integrators: the radiance arriving along a camera ray. Each variant in its
//! own file behind [`Integrator`].

pub mod debug;
pub mod whitted;

pub use whitted::Whitted;

use glam::Vec3;

use crate::accel::Tracer;
pub use crate::features::IntegratorKind;
use crate::features::Plan;
use crate::geometry::{Hit, Ray};
use crate::rng::Pcg32;
use crate::scene::Scene;

/// Work counters: what a render actually did. Summed per row in a fixed
/// order, so they are identical for any thread count.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct Counters {
    /// Camera rays.
    pub primary_rays: u64,
    /// Reflection, glossy and transmission rays.
    pub secondary_rays: u64,
    /// Shadow (visibility) queries to the tracer: one per shadow ray, one
    /// more when transparency is on and the ray is blocked (its closest
    /// blocker is then traced), and one per transparent surface crossed.
    pub shadow_rays: u64,
    /// Texture lookups.
    pub texture_lookups: u64,
    /// Light samples shaded (points and area samples).
    pub light_samples: u64,
}

impl Counters {
    /// Element-wise sum.
    pub fn add(&mut self, o: &Counters) {
        self.primary_rays += o.primary_rays;
        self.secondary_rays += o.secondary_rays;
        self.shadow_rays += o.shadow_rays;
        self.texture_lookups += o.texture_lookups;
        self.light_samples += o.light_samples;
    }

    /// Rays of every kind traced.
    pub fn total_rays(&self) -> u64 {
        self.primary_rays + self.secondary_rays + self.shadow_rays
    }
}

/// Computes the colour seen along a ray.
pub trait Integrator: Send + Sync {
    /// Colour arriving at the ray origin along `ray` (a camera ray: depth 0).
    fn radiance(&self, ray: &Ray, rng: &mut Pcg32, counters: &mut Counters) -> Vec3;

    /// [`Integrator::radiance`] for a camera ray whose closest hit `hit` the
    /// caller has already traced (the renderer traces a row's camera rays as
    /// one batch): the same colour, random numbers and counters.
    fn radiance_with_hit(&self, ray: &Ray, hit: Option<Hit>, rng: &mut Pcg32, counters: &mut Counters) -> Vec3;
}

/// The integrator `scene` asks for, answering rays with `tracer` and doing
/// only what `plan` asks.
pub fn create<'a>(scene: &'a Scene, tracer: &'a dyn Tracer, plan: Plan) -> Box<dyn Integrator + 'a> {
    match scene.params.integrator {
        IntegratorKind::Whitted => Box::new(Whitted::new(scene, tracer, plan)),
    }
}
