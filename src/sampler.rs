//! Deterministic random numbers: one independent stream per pixel, so an image
//! is the same whatever the thread count or the order pixels are rendered in.

/// SplitMix64 finaliser: a bijective 64-bit mix with good avalanche.
#[inline]
pub fn mix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// PCG32 (O'Neill 2014, XSH-RR): small state, statistically strong, fast.
#[derive(Clone, Debug)]
pub struct Rng {
    state: u64,
    inc: u64,
}

impl Rng {
    /// A generator for `(seed, stream)`; different streams are independent.
    pub fn new(seed: u64, stream: u64) -> Self {
        let mut r = Self { state: 0, inc: (mix64(stream) << 1) | 1 };
        r.next_u32();
        r.state = r.state.wrapping_add(mix64(seed));
        r.next_u32();
        r
    }

    /// The stream for pixel `(x, y)` of an image rendered with `seed`.
    pub fn for_pixel(seed: u64, x: u32, y: u32) -> Self {
        Self::new(seed, ((y as u64) << 32) | x as u64)
    }

    /// Next 32 random bits.
    #[inline]
    pub fn next_u32(&mut self) -> u32 {
        let old = self.state;
        self.state = old.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(self.inc);
        let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
        let rot = (old >> 59) as u32;
        xorshifted.rotate_right(rot)
    }

    /// Uniform float in `[0, 1)` (24 random bits, so never exactly 1).
    #[inline]
    pub fn next_f32(&mut self) -> f32 {
        (self.next_u32() >> 8) as f32 * (1.0 / (1u32 << 24) as f32)
    }

    /// Uniform integer in `[0, n)` (n > 0), by Lemire's multiply-shift (bias < 2^-32 n).
    #[inline]
    pub fn below(&mut self, n: u32) -> u32 {
        ((self.next_u32() as u64 * n as u64) >> 32) as u32
    }
}

/// Map a unit-square sample to the unit disk, preserving stratification
/// (Shirley and Chiu's concentric mapping, as Mitsuba's thin lens uses).
pub fn concentric_disk(u: f32, v: f32) -> (f32, f32) {
    let a = 2.0 * u - 1.0;
    let b = 2.0 * v - 1.0;
    if a == 0.0 && b == 0.0 {
        return (0.0, 0.0);
    }
    let (r, phi) = if a.abs() > b.abs() {
        (a, std::f32::consts::FRAC_PI_4 * (b / a))
    } else {
        (b, std::f32::consts::FRAC_PI_2 - std::f32::consts::FRAC_PI_4 * (a / b))
    };
    (r * phi.cos(), r * phi.sin())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn streams_are_reproducible_and_distinct() {
        let a: Vec<u32> = (0..8)
            .map({
                let mut r = Rng::for_pixel(7, 3, 4);
                move |_| r.next_u32()
            })
            .collect();
        let b: Vec<u32> = (0..8)
            .map({
                let mut r = Rng::for_pixel(7, 3, 4);
                move |_| r.next_u32()
            })
            .collect();
        let c: Vec<u32> = (0..8)
            .map({
                let mut r = Rng::for_pixel(7, 4, 3);
                move |_| r.next_u32()
            })
            .collect();
        assert_eq!(a, b);
        assert_ne!(a, c);
    }

    #[test]
    fn floats_are_in_range_with_the_right_mean() {
        let mut r = Rng::new(1, 2);
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
    fn concentric_disk_stays_in_the_disk() {
        for i in 0..33 {
            for j in 0..33 {
                let (x, y) = concentric_disk(i as f32 / 32.0, j as f32 / 32.0);
                assert!(x * x + y * y <= 1.0 + 1e-6);
            }
        }
    }
}
