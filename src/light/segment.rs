//! Segment lights: a line between two end points whose colour is linearly
//! interpolated between the two end colours.

use glam::Vec3;

use super::{Light, LightSample, LightSampling, samples_1d};
use crate::rng::Pcg32;

/// A segment light from `p0` (colour `c0`) to `p1` (colour `c1`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SegmentLight {
    /// First end point.
    pub p0: Vec3,
    /// Second end point.
    pub p1: Vec3,
    /// Colour at `p0`.
    pub c0: Vec3,
    /// Colour at `p1`.
    pub c1: Vec3,
}

impl Light for SegmentLight {
    fn is_point(&self) -> bool {
        false
    }

    fn sample(&self, n: u32, sampling: LightSampling, rng: &mut Pcg32, f: &mut dyn FnMut(LightSample)) {
        let n = n.max(1);
        let measure = (self.p1 - self.p0).length() / n as f32;
        samples_1d(n, sampling, rng, |u| {
            f(LightSample {
                position: self.position_at(u, 0.0),
                color: self.color_at(u, 0.0),
                average_weight: 1.0 / n as f32,
                measure,
                normal: None,
            })
        });
    }

    fn position_at(&self, u: f32, _v: f32) -> Vec3 {
        self.p0 + u * (self.p1 - self.p0)
    }

    fn color_at(&self, u: f32, _v: f32) -> Vec3 {
        (1.0 - u) * self.c0 + u * self.c1
    }
}
