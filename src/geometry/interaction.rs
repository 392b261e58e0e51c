//! The surface interaction (pbrt-v4's `SurfaceInteraction` / `SpawnRay`): the
//! hit point with its floating-point error bound and geometric normal,
//! computed once by the primitive that was hit, and the one function every
//! caller (the integrator, the ray sets, the benchmark, the tests) spawns
//! secondary rays with.

use glam::Vec3;

use super::offset::{SideOrigins, SpawnOffset, gamma, spawn_origin, triangle_point_error};
use super::{Hit, Ray, Sphere, Triangle};

/// A point on a surface with what is needed to leave it robustly.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfaceInteraction {
    /// The point (from barycentrics for triangles, re-projected onto the
    /// surface for spheres; never `o + t d`).
    pub p: Vec3,
    /// Bound on the absolute error of `p`, per axis.
    pub p_err: Vec3,
    /// Unit geometric normal (triangle winding, or outward for spheres; not
    /// flipped towards the ray).
    pub ng: Vec3,
    /// Barycentric weights `(1 - u - v, u, v)` (triangles; zero for spheres).
    pub b: [f32; 3],
    /// The primitive hit.
    pub prim: u32,
}

impl SurfaceInteraction {
    /// Origin of a ray leaving the surface in direction `w` under `policy`.
    #[inline]
    pub fn spawn_origin(&self, policy: SpawnOffset, w: Vec3) -> Vec3 {
        spawn_origin(policy, self.p, self.p_err, self.ng, w)
    }

    /// A ray leaving the surface in direction `d`, over `[0, t_max]` (units of `d`).
    #[inline]
    pub fn spawn_ray(&self, policy: SpawnOffset, d: Vec3, t_max: f32) -> Ray {
        Ray::with_range(self.spawn_origin(policy, d), d, 0.0, t_max)
    }

    /// A ray from the surface towards `target` with direction `target - origin`,
    /// over `[0, t_max]` (so `t_max = 1` reaches the target).
    #[inline]
    pub fn spawn_ray_to(&self, policy: SpawnOffset, target: Vec3, t_max: f32) -> Ray {
        let o = self.spawn_origin(policy, target - self.p);
        Ray::with_range(o, target - o, 0.0, t_max)
    }
}

/// Rays leaving one surface point towards many targets (the shadow rays of
/// an area light's samples): [`SurfaceInteraction::spawn_ray_to`] with the
/// robust origin's work done once per side ([`SideOrigins`]), the same rays
/// bit for bit.
#[derive(Clone, Copy, Debug)]
pub struct Spawner {
    /// The point.
    p: Vec3,
    /// Its geometric normal (read by the scaled-normal offset).
    ng: Vec3,
    /// The policy.
    policy: SpawnOffset,
    /// Both robust origins (`None` under the other offsets, made ray by ray).
    sides: Option<SideOrigins>,
}

impl Spawner {
    /// `si.spawn_ray_to(policy, target, t_max)`.
    #[inline]
    pub fn ray_to(&self, target: Vec3, t_max: f32) -> Ray {
        let w = target - self.p;
        let o = match &self.sides {
            Some(sides) => sides.origin(w),
            // The other offsets do not read the error bound.
            None => spawn_origin(self.policy, self.p, Vec3::ZERO, self.ng, w),
        };
        Ray::with_range(o, target - o, 0.0, t_max)
    }
}

impl SurfaceInteraction {
    /// A [`Spawner`] for rays leaving this point under `policy`.
    #[inline]
    pub fn spawner(&self, policy: SpawnOffset) -> Spawner {
        let sides = matches!(policy, SpawnOffset::Robust).then(|| SideOrigins::new(self.p, self.p_err, self.ng));
        Spawner { p: self.p, ng: self.ng, policy, sides }
    }
}

impl Triangle {
    /// The interaction at `hit` (barycentric interpolation, pbrt-v4 eq. 6.34
    /// for the error bound; see [`triangle_point_error`]).
    #[inline]
    pub fn interaction(&self, hit: &Hit) -> SurfaceInteraction {
        let b = [1.0 - hit.u - hit.v, hit.u, hit.v];
        let v = self.v;
        let p = b[0] * v[0] + b[1] * v[1] + b[2] * v[2];
        SurfaceInteraction {
            p,
            p_err: triangle_point_error(b, v),
            ng: super::unit_or_zero(self.normal()),
            b,
            prim: hit.prim,
        }
    }
}

impl Sphere {
    /// The interaction at `hit` along `ray`: the point re-projected onto the
    /// sphere (pbrt-v4, section 6.8.5) and its error bound
    /// [`sphere_point_error`].
    #[inline]
    pub fn interaction(&self, ray: &Ray, hit: &Hit) -> SurfaceInteraction {
        let q = ray.at(hit.t) - self.center;
        let len = q.length();
        let q = if len > 0.0 { q * (self.radius / len) } else { Vec3::new(0.0, self.radius, 0.0) };
        SurfaceInteraction {
            p: self.center + q,
            p_err: sphere_point_error(q, self.center),
            ng: q.normalize_or_zero(),
            b: [0.0; 3],
            prim: hit.prim,
        }
    }
}

/// Error bound of the point `c + q` of a world-space sphere with centre `c`,
/// `q` the offset re-projected onto the radius.
///
/// pbrt-v4 (eq. 6.29) bounds the re-projected object-space point by
/// `gamma(5) |q|`; the addition of the centre rounds by at most
/// `u (|c| + |q|)`, so `gamma(6) |q| + gamma(1) |c|` covers the point. The
/// centre term is taken as `gamma(5) |c|` instead: the sphere test computes
/// `o - c` and `|o - c|^2 - r^2`, whose rounding grows with `|c|`, and a
/// spawned origin must sit several `u |c|` off the surface for that test to
/// see it outside. Without the centre term the bound vanishes where a
/// coordinate of the point is near 0 while the centre's is large (the top of
/// a large ground sphere), and shadow rays start inside the sphere (issue 8:
/// 1,339 of 1,996 lit pixels black at R = 20).
#[inline]
pub fn sphere_point_error(q: Vec3, c: Vec3) -> Vec3 {
    gamma(6) * q.abs() + gamma(5) * c.abs()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The spawner's rays are `spawn_ray_to`'s, bit for bit, on both sides
    /// of triangles and spheres (far from the origin too), under every policy.
    #[test]
    fn spawner_rays_are_spawn_ray_to() {
        let tri = Triangle {
            v: [Vec3::new(1.0e3, 2.0, -3.0), Vec3::new(1.0e3 + 1.0, 2.5, -3.0), Vec3::new(1.0e3, 2.0, -2.0)],
        };
        let sphere = Sphere { center: Vec3::new(-4.0, 20.0, 1.0e2), radius: 20.0 };
        let si_tri = tri.interaction(&Hit { t: 47.8, prim: 0, u: 0.2, v: 0.3 });
        let rs = Ray::new(Vec3::new(-4.0, 60.0, 1.0e2 + 0.5), Vec3::new(0.0, -1.0, 0.0));
        let si_sphere = sphere.interaction(&rs, &Hit { t: 20.0, prim: 1, u: 0.0, v: 0.0 });
        let targets = [
            Vec3::new(0.0, 100.0, 0.0),
            Vec3::new(0.0, -100.0, 0.0),
            Vec3::new(1.0e3 + 5.0, 2.0, -3.0),
            Vec3::new(-1.0e4, 3.0, 7.0),
        ];
        for si in [si_tri, si_sphere] {
            for policy in [
                SpawnOffset::Robust,
                SpawnOffset::Fixed { epsilon: 1e-3 },
                SpawnOffset::ScaledNormal { epsilon: 8.9e-5 },
            ] {
                let sp = si.spawner(policy);
                for t in targets {
                    let (a, b) = (sp.ray_to(t, 0.999), si.spawn_ray_to(policy, t, 0.999));
                    let bits = |r: &Ray| {
                        (r.origin.to_array().map(f32::to_bits), r.dir.to_array().map(f32::to_bits), r.t_min, r.t_max)
                    };
                    assert_eq!(bits(&a), bits(&b), "{policy:?} towards {t}");
                }
            }
        }
    }
}
