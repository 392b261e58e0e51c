//! Reproducible ray sets for the benchmark and the tests: primary rays come
//! from [`crate::camera::Camera::pixel_centre_rays`]; random origin and direction (incoherent), and shadow rays from
//! primary hits towards a point light, spawned with a chosen offset policy.

use glam::Vec3;

use crate::geometry::offset::{SpawnOffset, spawn_origin, sphere_point_error, triangle_point_error};
use crate::geometry::{Aabb, Hit, Primitives, Ray};
use crate::rng::Pcg32;

/// `n` rays with uniform random origins in `bounds` and uniform random directions.
pub fn incoherent_rays(bounds: &Aabb, n: usize, seed: u64) -> Vec<Ray> {
    let mut rng = Pcg32::new(seed, 1);
    (0..n).map(|_| Ray::new(rng.in_box(bounds.min, bounds.max), rng.unit_vector())).collect()
}

/// Hit point, its floating-point error bound and the geometric normal of `hit`
/// (triangle: barycentric interpolation as in pbrt-v4; sphere: the ray point).
pub fn surface_point(prims: &Primitives, ray: &Ray, hit: &Hit) -> (Vec3, Vec3, Vec3) {
    let i = hit.prim as usize;
    let nt = prims.triangles.len();
    if i < nt {
        let tri = &prims.triangles[i];
        let b = [1.0 - hit.u - hit.v, hit.u, hit.v];
        let p = b[0] * tri.v[0] + b[1] * tri.v[1] + b[2] * tri.v[2];
        (p, triangle_point_error(b, tri.v), tri.normal())
    } else {
        let s = &prims.spheres[i - nt];
        let p = ray.at(hit.t);
        (p, sphere_point_error(p) + sphere_point_error(s.center), p - s.center)
    }
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
            let (p, err, n) = surface_point(prims, r, h);
            let o = spawn_origin(policy, p, err, n, light - p);
            Some(Ray::with_range(o, light - o, 0.0, 1.0))
        })
        .collect()
}
