//! Analytic spheres with a numerically stable ray intersection.

use glam::Vec3;

use super::{Aabb, Ray};

/// A sphere given by centre and radius.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sphere {
    /// Centre.
    pub center: Vec3,
    /// Radius (> 0).
    pub radius: f32,
}

impl Sphere {
    /// Bounding box.
    pub fn bounds(&self) -> Aabb {
        Aabb::new(self.center - Vec3::splat(self.radius), self.center + Vec3::splat(self.radius))
    }

    /// Nearest hit within the ray's interval: `Some((t, u, v))` with `(u, v)`
    /// the normalised longitude and colatitude of the hit point.
    ///
    /// Uses the formulation of Haines et al. (Ray Tracing Gems, ch. 7): the
    /// discriminant is computed from the distance between the centre and the
    /// ray's closest approach, which avoids the catastrophic cancellation of
    /// `b^2 - 4ac` for small or distant spheres, and the two roots come from
    /// `q = b + sign(b) sqrt(disc)` so neither is a difference of near-equal terms.
    #[inline]
    pub fn intersect(&self, ray: &Ray) -> Option<(f32, f32, f32)> {
        let t = self.intersect_t(ray)?;
        let (u, v) = self.uv_at(ray, t);
        Some((t, u, v))
    }

    /// The distance of [`Self::intersect`] alone: traversals offer sphere
    /// hits by distance and compute `(u, v)` ([`Self::uv_at`]) for the one
    /// that wins, with the same bits.
    #[inline]
    pub fn intersect_t(&self, ray: &Ray) -> Option<f32> {
        let d = ray.dir;
        let a = d.dot(d);
        let f = ray.origin - self.center;
        let b = -f.dot(d); // half of the usual -b
        let l = f + (b / a) * d; // centre -> point of closest approach
        let r2 = self.radius * self.radius;
        let h = r2 - l.dot(l);
        if h.is_nan() || h < 0.0 {
            return None;
        }
        let c = f.dot(f) - r2;
        // sqrt(a (r^2 - |l|^2)) as a product of square roots: `a` is the
        // squared length of an unnormalised direction (a shadow ray's
        // `target - origin`, up to (2 sqrt(3) MAX_COORDINATE)^2 = 1.2e25)
        // and `r^2 - |l|^2` up to MAX_COORDINATE^2 = 1e24, so their product
        // overflows f32 and would give t = c / inf = 0 (a false hit at the
        // ray's origin).
        let sq = a.sqrt() * h.sqrt();
        let q = if b >= 0.0 { b + sq } else { b - sq };
        let (mut t0, mut t1) = if q == 0.0 { (0.0, 0.0) } else { (c / q, q / a) };
        if t0 > t1 {
            std::mem::swap(&mut t0, &mut t1);
        }
        if t0 >= ray.t_min && t0 <= ray.t_max {
            Some(t0)
        } else if t1 >= ray.t_min && t1 <= ray.t_max {
            Some(t1)
        } else {
            None
        }
    }

    /// The normalised longitude and colatitude `(u, v)` of the point at `t` along `ray`.
    #[inline]
    pub fn uv_at(&self, ray: &Ray, t: f32) -> (f32, f32) {
        let n = (ray.at(t) - self.center) / self.radius;
        let u = (n.z.atan2(n.x) / std::f32::consts::TAU).rem_euclid(1.0);
        let v = n.y.clamp(-1.0, 1.0).acos() / std::f32::consts::PI;
        (u, v)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hits_front_and_from_inside() {
        let s = Sphere { center: Vec3::new(0.0, 0.0, 5.0), radius: 1.0 };
        let r = Ray::new(Vec3::ZERO, Vec3::Z);
        assert_eq!(s.intersect(&r).unwrap().0, 4.0);
        let r = Ray::new(Vec3::new(0.0, 0.0, 5.0), Vec3::Z);
        assert_eq!(s.intersect(&r).unwrap().0, 1.0);
        let r = Ray::new(Vec3::ZERO, -Vec3::Z);
        assert!(s.intersect(&r).is_none());
    }

    #[test]
    fn long_unnormalised_direction_at_the_coordinate_limit() {
        // A shadow ray from -1e12 to +1e12 (direction 2e12 long, t in [0, 1])
        // through a sphere of radius 1e11: entry at t = 0.45 exactly.
        let m = crate::limits::MAX_COORDINATE;
        let s = Sphere { center: Vec3::ZERO, radius: 0.1 * m };
        for dir in [Vec3::new(2.0 * m, 0.0, 0.0), Vec3::new(2.0 * m, 2.0 * m, 2.0 * m)] {
            let r = Ray::with_range(-dir * 0.5, dir, 0.0, 1.0);
            let t = s.intersect(&r).expect("hit").0;
            // Entry at |origin| - r = |dir| / 2 - 0.1 m along the ray: t = 0.5 - 0.1 m / |dir|.
            let exact = 0.5 - 0.1 * m as f64 / dir.as_dvec3().length();
            // A few roundings of a quantity of size ~1 (eps = 1.2e-7).
            assert!((t as f64 - exact).abs() < 1e-6, "t = {t}, exact {exact}");
        }
    }

    #[test]
    fn small_far_sphere_is_stable() {
        // b^2 - 4ac in f32 loses every digit here; the stable form does not.
        let s = Sphere { center: Vec3::new(0.0, 0.0, 1.0e4), radius: 1.0e-2 };
        let r = Ray::new(Vec3::ZERO, Vec3::Z);
        let t = s.intersect(&r).unwrap().0;
        assert!((t - (1.0e4 - 1.0e-2)).abs() <= 1.0e4 * f32::EPSILON, "t = {t}");
    }
}
