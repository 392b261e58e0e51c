//! The physically based model that matches Mitsuba 3's units.

use glam::Vec3;

use super::{ShadingModel, SurfacePoint};
use crate::light::LightSample;

/// Lambert BRDF `Kd / pi`; point and segment samples fall off as `1 / r^2`;
/// parallelogram samples carry radiance and the cosine at the emitter
/// (front side only). Mirror reflection (weight `Ks`) is the integrator's job.
pub struct Physical;

impl ShadingModel for Physical {
    #[inline]
    fn direct(&self, sp: &SurfacePoint, s: &LightSample) -> Vec3 {
        let d = s.position - sp.p;
        let r2 = d.length_squared();
        if r2 == 0.0 {
            return Vec3::ZERO;
        }
        let l = d / r2.sqrt();
        let cos = sp.n.dot(l);
        if cos <= 0.0 {
            return Vec3::ZERO;
        }
        let cos_light = match s.normal {
            Some(n) => (-l).dot(n).max(0.0),
            None => 1.0,
        };
        sp.kd * std::f32::consts::FRAC_1_PI * s.color * (cos * cos_light * s.measure / r2)
    }
}
