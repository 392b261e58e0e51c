//! Point lights.

use glam::Vec3;

use super::{Light, LightSample, LightSampling};
use crate::rng::Pcg32;

/// An isotropic point light.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PointLight {
    /// Position.
    pub position: Vec3,
    /// Colour (Phong) or radiant intensity (physical).
    pub color: Vec3,
}

impl Light for PointLight {
    fn is_point(&self) -> bool {
        true
    }

    fn sample(&self, _n: u32, _sampling: LightSampling, _rng: &mut Pcg32, f: &mut dyn FnMut(LightSample)) {
        f(LightSample { position: self.position, color: self.color, average_weight: 1.0, measure: 1.0, normal: None });
    }

    fn position_at(&self, _u: f32, _v: f32) -> Vec3 {
        self.position
    }

    fn color_at(&self, _u: f32, _v: f32) -> Vec3 {
        self.color
    }
}
