//! Plain workloads: the benchmark's (primary rays come from
//! [`crate::camera::Camera::pixel_centre_rays`]; here are the incoherent rays,
//! random origin and direction, and the shadow rays from primary hits towards
//! a point light, spawned through [`crate::geometry::SurfaceInteraction`]),
//! and the BVH tests' mix of random and aimed rays with finite intervals.

use glam::Vec3;

use crate::geometry::offset::SpawnOffset;
use crate::geometry::{Aabb, Hit, Primitives, Ray};
use crate::rng::Pcg32;

use super::Rng;

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

/// `n` rays over `prims` for comparing tracers: a third with random origins
/// (in the scene's box grown by half its size on every side) and random
/// directions; a third aimed from such origins at random points on random
/// primitives (mostly hits, many grazing); a third aimed likewise but with a
/// finite interval `[t_min, t_max]` around the target (`t = 1`), so that the
/// closed ends of the interval are exercised.
pub fn mixed_rays(prims: &Primitives, n: usize, seed: u64) -> Vec<Ray> {
    let wb = prims.world_bounds();
    let e = wb.extent() * 0.5;
    let around = Aabb::new(wb.min - e, wb.max + e);
    let mut rng = Rng::stream(seed, 11);
    (0..n)
        .map(|k| {
            let o = rng.in_box(&around);
            if k % 3 == 0 || prims.is_empty() {
                return Ray::new(o, rng.unit_vector());
            }
            let target = rng.below(prims.len());
            let p = rng.point_on(prims, target);
            if k % 3 == 1 {
                Ray::new(o, p - o)
            } else {
                Ray::with_range(o, p - o, rng.range(0.0, 0.9), rng.range(0.9, 1.5))
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{Sphere, Triangle};

    #[test]
    fn mixed_rays_are_deterministic_and_aim_at_the_primitives() {
        let prims = Primitives {
            triangles: vec![Triangle { v: [Vec3::ZERO, Vec3::X, Vec3::Y] }],
            spheres: vec![Sphere { center: Vec3::new(3.0, 0.0, 0.0), radius: 0.5 }],
        };
        let a = mixed_rays(&prims, 300, 4);
        assert_eq!(a, mixed_rays(&prims, 300, 4));
        assert_ne!(a, mixed_rays(&prims, 300, 5));
        let tracer =
            crate::accel::BruteForce::new(std::sync::Arc::new(prims), crate::geometry::TriangleTest::Watertight);
        use crate::accel::Tracer;
        // Aimed rays (k % 3 == 1) reach their target at t = 1: all hit but for the rare one
        // whose target, rounded to f32, lies just off a triangle's edge or a sphere's silhouette.
        let hits = a.iter().skip(1).step_by(3).filter(|r| tracer.intersect(r).is_some()).count();
        assert!(hits >= 95, "{hits} of 100 aimed rays hit");
        // The last third has finite intervals around t = 1.
        assert!(a.iter().skip(2).step_by(3).all(|r| r.t_min < 0.9 && (0.9..1.5).contains(&r.t_max)));
    }
}
