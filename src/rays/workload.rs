//! The benchmark's workloads: primary rays come from
//! [`crate::camera::Camera::pixel_centre_rays`]; here are the incoherent rays
//! (random origin and direction) and the shadow rays from primary hits towards
//! a point light, spawned through [`crate::geometry::SurfaceInteraction`].

use glam::Vec3;

use crate::geometry::offset::SpawnOffset;
use crate::geometry::{Aabb, Hit, Primitives, Ray};
use crate::rng::Pcg32;

/// `n` rays with uniform random origins in `bounds` and uniform random directions.
pub fn incoherent_rays(bounds: &Aabb, n: usize, seed: u64) -> Vec<Ray> {
    let mut rng = Pcg32::new(seed, 1);
    (0..n).map(|_| Ray::new(rng.in_box(bounds.min, bounds.max), rng.unit_vector())).collect()
}

/// Shadow rays from every hit of `rays` towards `light`, leaving the surface
/// under `policy`. Each ray spans `[0, 1]` with `dir = light - origin`.
pub fn shadow_rays(
    prims: &Primitives,
    rays: &[Ray],
    hits: &[Option<Hit>],
    light: Vec3,
    policy: SpawnOffset,
) -> Vec<Ray> {
    rays.iter()
        .zip(hits)
        .filter_map(|(r, h)| {
            let h = h.as_ref()?;
            Some(prims.interaction(r, h).spawn_ray_to(policy, light, 1.0))
        })
        .collect()
}
