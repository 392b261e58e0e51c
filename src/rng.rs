//! The project's one pseudo-random number generator (PCG32, O'Neill 2014):
//! seeded, reproducible, one independent stream per pixel or per ray set.
//! Not for cryptography.

use glam::Vec3;

/// SplitMix64 finaliser: a bijective 64-bit mix with good avalanche, so that
/// neighbouring seeds and stream ids (pixel (x, y) and (x + 1, y)) start far apart.
#[inline]
pub fn mix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// PCG32 (XSH RR variant): 64-bit state, 32-bit output.
#[derive(Clone, Debug)]
pub struct Pcg32 {
    state: u64,
    inc: u64,
}

impl Pcg32 {
    /// A generator for `seed` on stream `stream` (different streams give independent sequences).
    pub fn new(seed: u64, stream: u64) -> Self {
        let mut g = Self { state: 0, inc: (mix64(stream) << 1) | 1 };
        g.next_u32();
        g.state = g.state.wrapping_add(mix64(seed));
        g.next_u32();
        g
    }

    /// The stream for pixel `(x, y)` of an image rendered with `seed`.
    pub fn for_pixel(seed: u64, x: u32, y: u32) -> Self {
        Self::new(seed, ((y as u64) << 32) | x as u64)
    }

    /// Next 32 random bits.
    #[inline]
    pub fn next_u32(&mut self) -> u32 {
        let old = self.state;
        self.state = old.wrapping_mul(6364136223846793005).wrapping_add(self.inc);
        let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
        let rot = (old >> 59) as u32;
        xorshifted.rotate_right(rot)
    }

    /// Uniform in `[0, 1)` with 24 random bits.
    #[inline]
    pub fn next_f32(&mut self) -> f32 {
        (self.next_u32() >> 8) as f32 * (1.0 / 16_777_216.0)
    }

    /// Uniform in `[lo, hi)`.
    #[inline]
    pub fn range(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.next_f32()
    }

    /// Uniform integer in `0..n` (`n > 0`), by Lemire's multiply-shift (bias < n / 2^32).
    #[inline]
    pub fn below(&mut self, n: u32) -> u32 {
        ((self.next_u32() as u64 * n as u64) >> 32) as u32
    }

    /// Uniform point in the box `[lo, hi]`.
    pub fn in_box(&mut self, lo: Vec3, hi: Vec3) -> Vec3 {
        Vec3::new(self.range(lo.x, hi.x), self.range(lo.y, hi.y), self.range(lo.z, hi.z))
    }

    /// Uniformly distributed unit vector.
    pub fn unit_vector(&mut self) -> Vec3 {
        let z = self.range(-1.0, 1.0);
        let phi = self.range(0.0, std::f32::consts::TAU);
        let r = (1.0 - z * z).max(0.0).sqrt();
        Vec3::new(r * phi.cos(), r * phi.sin(), z)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn streams_are_reproducible_and_distinct() {
        let a: Vec<u32> = (0..8)
            .map({
                let mut r = Pcg32::for_pixel(7, 3, 4);
                move |_| r.next_u32()
            })
            .collect();
        let b: Vec<u32> = (0..8)
            .map({
                let mut r = Pcg32::for_pixel(7, 3, 4);
                move |_| r.next_u32()
            })
            .collect();
        let c: Vec<u32> = (0..8)
            .map({
                let mut r = Pcg32::for_pixel(7, 4, 3);
                move |_| r.next_u32()
            })
            .collect();
        assert_eq!(a, b);
        assert_ne!(a, c);
    }

    #[test]
    fn floats_are_in_range_with_the_right_mean() {
        let mut r = Pcg32::new(1, 2);
        let n = 100_000;
        let mut sum = 0.0f64;
        for _ in 0..n {
            let x = r.next_f32();
            assert!((0.0..1.0).contains(&x));
            sum += x as f64;
        }
        // Mean of U(0,1) has standard deviation sqrt(1/12/n) = 9.1e-4: allow 5 sigma.
        assert!((sum / n as f64 - 0.5).abs() < 5.0 * 9.2e-4);
    }

    #[test]
    fn reproducible_and_in_range() {
        let mut a = Pcg32::new(42, 7);
        let mut b = Pcg32::new(42, 7);
        let mut c = Pcg32::new(43, 7);
        let xs: Vec<u32> = (0..8).map(|_| a.next_u32()).collect();
        let ys: Vec<u32> = (0..8).map(|_| b.next_u32()).collect();
        let zs: Vec<u32> = (0..8).map(|_| c.next_u32()).collect();
        assert_eq!(xs, ys);
        assert_ne!(xs, zs);
        let mut mean = 0.0;
        for _ in 0..10_000 {
            let f = a.next_f32();
            assert!((0.0..1.0).contains(&f));
            mean += f / 10_000.0;
        }
        // Standard error of the mean of 10k uniforms is 0.0029: 0.02 is ~7 sigma.
        assert!((mean - 0.5).abs() < 0.02, "mean {mean}");
        let v = a.unit_vector();
        assert!((v.length() - 1.0).abs() < 1e-6);
    }
}
