//! The ray sets' random numbers: one PCG32 stream per set.

use glam::Vec3;

use crate::geometry::{Aabb, Prim, Primitives, Triangle};

/// The harness's random numbers: the project's PCG32 ([`crate::rng::Pcg32`],
/// one stream per ray set) with the few extra draws ray generation needs.
#[derive(Clone, Debug)]
pub struct Rng(crate::rng::Pcg32);

impl Rng {
    /// A generator with the given seed (stream 0).
    pub fn new(seed: u64) -> Self {
        Self(crate::rng::Pcg32::new(seed, 0))
    }

    /// A generator for stream `stream` of `seed` (independent sub-sequences per set).
    pub fn stream(seed: u64, stream: u64) -> Self {
        Self(crate::rng::Pcg32::new(seed, stream))
    }

    /// Next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        ((self.0.next_u32() as u64) << 32) | self.0.next_u32() as u64
    }

    /// Uniform in `[0, 1)` with 24 random bits.
    pub fn f32(&mut self) -> f32 {
        self.0.next_f32()
    }

    /// Uniform in `[0, 1)` with 53 random bits.
    pub fn f64(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }

    /// Uniform in `[lo, hi)`.
    pub fn range(&mut self, lo: f32, hi: f32) -> f32 {
        self.0.range(lo, hi)
    }

    /// Uniform integer in `0..n` (`0 < n < 2^32`).
    pub fn below(&mut self, n: usize) -> usize {
        self.0.below(n as u32) as usize
    }

    /// Uniform direction on the unit sphere.
    pub fn unit_vector(&mut self) -> Vec3 {
        let z = 1.0 - 2.0 * self.f64();
        let phi = std::f64::consts::TAU * self.f64();
        let r = (1.0 - z * z).max(0.0).sqrt();
        Vec3::new((r * phi.cos()) as f32, (r * phi.sin()) as f32, z as f32)
    }

    /// Uniform point in `b`.
    pub fn in_box(&mut self, b: &Aabb) -> Vec3 {
        let e = b.extent();
        b.min + Vec3::new(self.f32() * e.x, self.f32() * e.y, self.f32() * e.z)
    }

    /// Uniform point on triangle `t` (barycentrics folded into the triangle).
    pub fn point_on_triangle(&mut self, t: &Triangle) -> Vec3 {
        let (mut b1, mut b2) = (self.f32(), self.f32());
        if b1 + b2 > 1.0 {
            (b1, b2) = (1.0 - b1, 1.0 - b2);
        }
        (1.0 - b1 - b2) * t.v[0] + b1 * t.v[1] + b2 * t.v[2]
    }

    /// Uniform point on primitive `i` of `prims` (on a sphere's surface).
    pub fn point_on(&mut self, prims: &Primitives, i: usize) -> Vec3 {
        match prims.get(i) {
            Prim::Triangle(t) => self.point_on_triangle(t),
            Prim::Sphere(s) => s.center + s.radius * self.unit_vector(),
        }
    }
}
