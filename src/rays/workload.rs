//! Reproducible ray sets for the benchmark and the tests: pinhole camera
//! (primary), random origin and direction (incoherent), and shadow rays from
//! primary hits towards a point light, spawned with a chosen offset policy.

use glam::Vec3;

use crate::geometry::offset::{SpawnOffset, spawn_origin, sphere_point_error, triangle_point_error};
use crate::geometry::{Aabb, Hit, Primitives, Ray};
use crate::mesh::Mesh;
use crate::rng::Pcg32;

/// Centre a mesh on its vertex mean and scale it into the unit sphere
/// (the scene default for the benchmark meshes).
pub fn normalize_mesh(mesh: &mut Mesh) {
    if mesh.positions.is_empty() {
        return;
    }
    let n = mesh.positions.len() as f64;
    let sum = mesh.positions.iter().fold(glam::DVec3::ZERO, |s, p| s + p.as_dvec3());
    let c = (sum / n).as_vec3();
    let r = mesh.positions.iter().map(|p| (*p - c).length()).fold(0.0f32, f32::max);
    let s = if r > 0.0 { 1.0 / r } else { 1.0 };
    mesh.map_positions(|p| (p - c) * s);
}

/// Translate and scale a mesh's vertices so that their mean is at the origin
/// and the farthest vertex at distance 1 (the default camera's framing).
pub fn normalise_to_unit_sphere(positions: &mut [Vec3]) {
    if positions.is_empty() {
        return;
    }
    let sum = positions.iter().fold(glam::DVec3::ZERO, |a, p| a + p.as_dvec3());
    let c = sum / positions.len() as f64;
    let r = positions.iter().map(|p| (p.as_dvec3() - c).length()).fold(0.0, f64::max);
    let s = if r > 0.0 { 1.0 / r } else { 1.0 };
    for p in positions {
        *p = ((p.as_dvec3() - c) * s).as_vec3();
    }
}

/// A pinhole camera.
#[derive(Clone, Copy, Debug)]
pub struct Camera {
    /// Eye position.
    pub eye: Vec3,
    /// Point looked at.
    pub target: Vec3,
    /// Up direction.
    pub up: Vec3,
    /// Vertical field of view in degrees.
    pub vfov_deg: f32,
}

impl Camera {
    /// The scene-default viewpoint of the normalised meshes.
    pub fn scene_default() -> Self {
        Self { eye: Vec3::new(-0.964, 1.026, -2.649), target: Vec3::ZERO, up: Vec3::Y, vfov_deg: 50.0 }
    }

    /// One ray through the centre of each pixel of a `width` x `height` image, row by row.
    pub fn rays(&self, width: u32, height: u32) -> Vec<Ray> {
        let fwd = (self.target - self.eye).normalize();
        let right = fwd.cross(self.up).normalize();
        let up = right.cross(fwd);
        let h = (self.vfov_deg.to_radians() * 0.5).tan();
        let aspect = width as f32 / height as f32;
        let mut out = Vec::with_capacity((width * height) as usize);
        for y in 0..height {
            for x in 0..width {
                let sx = (2.0 * (x as f32 + 0.5) / width as f32 - 1.0) * h * aspect;
                let sy = (1.0 - 2.0 * (y as f32 + 0.5) / height as f32) * h;
                out.push(Ray::new(self.eye, (fwd + sx * right + sy * up).normalize()));
            }
        }
        out
    }
}

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
