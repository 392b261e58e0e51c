//! Surface materials.

use std::sync::Arc;

use glam::Vec3;

use crate::shading::ShadingModelKind;
use crate::texture::{Texture, WrapMode};

/// A surface material (the reports' Kd / Ks / Ns, plus opacity and a Kd texture).
#[derive(Clone, Debug)]
pub struct Material {
    /// Name (from the scene file or the MTL library).
    pub name: String,
    /// Diffuse colour.
    pub kd: Vec3,
    /// Specular colour; also the weight of mirror reflections.
    pub ks: Vec3,
    /// Phong exponent.
    pub shininess: f32,
    /// Opacity in [0, 1] (1: opaque). Transparency is `1 - opacity`.
    pub opacity: f32,
    /// Diffuse texture replacing `kd` when texture mapping is on.
    pub kd_texture: Option<Arc<Texture>>,
    /// How `kd_texture` is addressed outside `[0, 1]`.
    pub wrap: WrapMode,
    /// Shading model used at hits on this material.
    pub model: ShadingModelKind,
}

impl Default for Material {
    /// The course's default for a mesh without material: kd 1, ks 0, shininess 1.
    fn default() -> Self {
        Self {
            name: "default".into(),
            kd: Vec3::ONE,
            ks: Vec3::ZERO,
            shininess: 1.0,
            opacity: 1.0,
            kd_texture: None,
            wrap: WrapMode::Repeat,
            model: ShadingModelKind::Phong,
        }
    }
}

impl Material {
    /// True when mirror reflection can contribute.
    pub fn is_reflective(&self) -> bool {
        self.ks != Vec3::ZERO
    }

    /// True when light passes through.
    pub fn is_transparent(&self) -> bool {
        self.opacity < 1.0
    }
}
