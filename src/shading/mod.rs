//! Shading models: how one light sample is reflected at a surface point.
//! Each model lives in its own file behind [`ShadingModel`].

pub mod phong;
pub mod physical;

use glam::Vec3;

use crate::light::LightSample;

/// Which shading model a material uses.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ShadingModelKind {
    /// The reports' Phong model: `I Kd max(0, n.l) + I Ks max(0, r.v)^n`, no falloff.
    #[default]
    Phong,
    /// Mitsuba's units: Lambert `Kd / pi`, `I / r^2`, area radiance with both cosines.
    Physical,
}

/// The surface quantities a shading model needs.
#[derive(Clone, Copy, Debug)]
pub struct SurfacePoint {
    /// Hit position.
    pub p: Vec3,
    /// Unit shading normal, on the viewer's side.
    pub n: Vec3,
    /// Unit direction towards the viewer.
    pub wo: Vec3,
    /// Diffuse colour (texture already applied).
    pub kd: Vec3,
    /// Specular colour.
    pub ks: Vec3,
    /// Phong exponent.
    pub shininess: f32,
}

/// A shading model.
pub trait ShadingModel: Send + Sync {
    /// Light reflected towards `sp.wo` from light sample `s` (visibility not included).
    fn direct(&self, sp: &SurfacePoint, s: &LightSample) -> Vec3;
}

/// The model implementation for `kind`.
pub fn model(kind: ShadingModelKind) -> &'static dyn ShadingModel {
    match kind {
        ShadingModelKind::Phong => &phong::Phong,
        ShadingModelKind::Physical => &physical::Physical,
    }
}
