//! The reports' Phong model.

use glam::Vec3;

use super::{ShadingModel, SurfacePoint};
use crate::light::LightSample;

/// `I Kd max(0, n.l) + I Ks max(0, r.v)^n`, averaged over a light's samples;
/// a light behind the surface (n.l <= 0) contributes nothing.
pub struct Phong;

impl ShadingModel for Phong {
    #[inline]
    fn direct(&self, sp: &SurfacePoint, s: &LightSample) -> Vec3 {
        let l = (s.position - sp.p).normalize_or_zero();
        let ndl = sp.n.dot(l);
        if ndl <= 0.0 {
            return Vec3::ZERO;
        }
        let diffuse = sp.kd * ndl;
        let specular = if sp.ks == Vec3::ZERO {
            Vec3::ZERO
        } else {
            let r = 2.0 * ndl * sp.n - l;
            let rdv = r.dot(sp.wo);
            if rdv > 0.0 { sp.ks * rdv.powf(sp.shininess) } else { Vec3::ZERO }
        };
        s.color * (diffuse + specular) * s.average_weight
    }
}
