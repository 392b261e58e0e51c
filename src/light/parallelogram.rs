//! Parallelogram lights: `v0 + a edge01 + b edge02`, colour bilinear in the
//! four corner colours.

use glam::Vec3;

use super::{Light, LightSample, LightSampling};
use crate::rng::Pcg32;

/// A parallelogram light. Corner colours: `colors[0]` at `v0`, `[1]` at
/// `v0 + edge01`, `[2]` at `v0 + edge02`, `[3]` at `v0 + edge01 + edge02`.
/// It emits on the side of `edge01 x edge02` in the physical model.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ParallelogramLight {
    /// Corner.
    pub v0: Vec3,
    /// First edge.
    pub edge01: Vec3,
    /// Second edge.
    pub edge02: Vec3,
    /// Corner colours.
    pub colors: [Vec3; 4],
}

impl ParallelogramLight {
    /// Area of the parallelogram.
    pub fn area(&self) -> f32 {
        crate::geometry::scaled_length(self.edge01.cross(self.edge02))
    }

    /// Unit normal of the emitting side.
    pub fn normal(&self) -> Vec3 {
        crate::geometry::unit_or_zero(self.edge01.cross(self.edge02))
    }
}

impl Light for ParallelogramLight {
    fn is_point(&self) -> bool {
        false
    }

    /// Jittered sampling uses a `k x k` grid with `k = ceil(sqrt(n))` (so
    /// `k^2 >= n` samples, as report 001 does); random sampling takes `n`
    /// independent points.
    fn sample(&self, n: u32, sampling: LightSampling, rng: &mut Pcg32, f: &mut dyn FnMut(LightSample)) {
        let n = n.max(1);
        let normal = Some(self.normal());
        // The samples' count, weight and measure, made once per call (the
        // area's square root and the two divisions were made per sample).
        let k = (n as f32).sqrt().ceil() as u32;
        let count = if sampling == LightSampling::Jittered { k * k } else { n };
        let (average_weight, measure) = (1.0 / count as f32, self.area() / count as f32);
        let mut push = |a: f32, b: f32| {
            f(LightSample {
                position: self.position_at(a, b),
                color: self.color_at(a, b),
                average_weight,
                measure,
                normal,
            })
        };
        match sampling {
            LightSampling::Random => {
                for _ in 0..n {
                    let (a, b) = (rng.next_f32(), rng.next_f32());
                    push(a, b);
                }
            }
            LightSampling::Jittered => {
                for i in 0..k {
                    for j in 0..k {
                        let a = (i as f32 + rng.next_f32()) / k as f32;
                        let b = (j as f32 + rng.next_f32()) / k as f32;
                        push(a, b);
                    }
                }
            }
        }
    }

    fn position_at(&self, u: f32, v: f32) -> Vec3 {
        self.v0 + u * self.edge01 + v * self.edge02
    }

    fn color_at(&self, u: f32, v: f32) -> Vec3 {
        let [c0, c1, c2, c3] = self.colors;
        (1.0 - u) * ((1.0 - v) * c0 + v * c2) + u * ((1.0 - v) * c1 + v * c3)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn corner_colours_and_centre_mix() {
        let l = ParallelogramLight {
            v0: Vec3::ZERO,
            edge01: Vec3::X,
            edge02: Vec3::Z,
            colors: [Vec3::X, Vec3::Y, Vec3::Z, Vec3::ONE],
        };
        assert_eq!(l.color_at(0.0, 0.0), Vec3::X);
        assert_eq!(l.color_at(1.0, 0.0), Vec3::Y);
        assert_eq!(l.color_at(0.0, 1.0), Vec3::Z);
        assert_eq!(l.color_at(1.0, 1.0), Vec3::ONE);
        assert_eq!(l.color_at(0.5, 0.5), Vec3::new(0.5, 0.5, 0.5));
        let mut out = Vec::new();
        l.sample(10, LightSampling::Jittered, &mut Pcg32::new(1, 1), &mut |s| out.push(s));
        assert_eq!(out.len(), 16);
        let total: f32 = out.iter().map(|s| s.measure).sum();
        assert!((total - 1.0).abs() < 1e-6);
    }
}
