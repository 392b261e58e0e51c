//! The JSON scene format (documented in docs/scene-format.md). Unknown fields
//! are rejected with their name, line and column.

use std::collections::BTreeMap;

use glam::Vec3;
use serde::{Deserialize, Serialize};

use crate::backends::{AccelConfig, Backend, Builder, EmbreeMode, EmbreeQuality, Traversal};
use crate::camera::Camera;
use crate::features::{Features, Params};
use crate::geometry::TriangleTest;
use crate::light::{Light, ParallelogramLight, PointLight, SegmentLight};
use crate::shading::ShadingModelKind;
use crate::texture::WrapMode;

/// A whole scene file.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SceneFile {
    /// Free text.
    pub description: Option<String>,
    /// Camera.
    pub camera: CameraSpec,
    /// Output image.
    pub image: ImageSpec,
    /// Default shading model of materials.
    pub shading_model: ShadingModelKind,
    /// Feature switches.
    pub features: Features,
    /// Feature parameters.
    pub params: Params,
    /// Acceleration structure.
    pub accel: AccelSpec,
    /// Named materials.
    pub materials: BTreeMap<String, MaterialSpec>,
    /// Triangle meshes.
    pub meshes: Vec<MeshSpec>,
    /// Analytic spheres.
    pub spheres: Vec<SphereSpec>,
    /// Lights.
    pub lights: Vec<LightSpec>,
}

/// Camera parameters.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct CameraSpec {
    /// Eye position.
    pub position: Vec3,
    /// Point looked at.
    pub look_at: Vec3,
    /// Up direction.
    pub up: Vec3,
    /// Vertical field of view in degrees.
    pub fov: f32,
    /// Lens radius for depth of field (0: pinhole).
    pub aperture: f32,
    /// Distance to the plane in focus along the view axis (default: distance to `look_at`).
    pub focus_distance: Option<f32>,
}

impl Default for CameraSpec {
    /// The course's default view: 3 units from the origin, rotated 20 degrees about x and y.
    fn default() -> Self {
        Self {
            position: crate::camera::DEFAULT_EYE,
            look_at: Vec3::ZERO,
            up: Vec3::Y,
            fov: crate::camera::DEFAULT_FOV,
            aperture: 0.0,
            focus_distance: None,
        }
    }
}

impl CameraSpec {
    /// The camera these parameters describe, sized to `width` x `height` pixels.
    pub fn camera(&self, width: u32, height: u32) -> Camera {
        let mut camera = Camera::look_at(self.position, self.look_at, self.up, self.fov, width, height);
        camera.aperture_radius = self.aperture;
        if let Some(d) = self.focus_distance {
            camera.focus_distance = d;
        }
        camera
    }
}

/// Output image parameters.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ImageSpec {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Camera samples per pixel (1: the pixel centre; n: jittered strata).
    pub spp: u32,
    /// Random seed.
    pub seed: u64,
    /// Colour of rays that hit nothing.
    pub background: Vec3,
}

impl Default for ImageSpec {
    fn default() -> Self {
        Self { width: 800, height: 800, spp: 1, seed: 0, background: Vec3::ZERO }
    }
}

/// Acceleration-structure overrides (absent fields follow the feature switches and defaults).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct AccelSpec {
    /// Backend (default: native, or brute when the `bvh` switch is off).
    pub backend: Option<Backend>,
    /// Builder (default: sah, or median when the `sah` switch is off).
    pub builder: Option<Builder>,
    /// Traversal.
    pub traversal: Option<Traversal>,
    /// Triangle test.
    pub triangle_test: Option<TriangleTest>,
    /// Leaf size of the median builder.
    pub leaf_size: Option<usize>,
    /// Bins of the SAH builder.
    pub bins: Option<usize>,
    /// Embree build quality.
    pub embree_quality: Option<EmbreeQuality>,
    /// Embree scene flags: `robust` (the default) or `default` (Embree's own default flags).
    pub embree_mode: Option<EmbreeMode>,
}

impl AccelSpec {
    /// The configuration to build: fields left out follow the feature
    /// switches (`bvh` off: brute force; `sah` off: the median builder) and
    /// [`AccelConfig::default`].
    pub fn resolve(&self, features: &Features) -> AccelConfig {
        let d = AccelConfig::default();
        AccelConfig {
            backend: self.backend.unwrap_or(if features.bvh { Backend::Native } else { Backend::Brute }),
            builder: self.builder.unwrap_or(if features.sah { Builder::Sah } else { Builder::Median }),
            traversal: self.traversal.unwrap_or(d.traversal),
            triangle_test: self.triangle_test.unwrap_or(d.triangle_test),
            leaf_size: self.leaf_size.unwrap_or(d.leaf_size).max(1),
            bins: self.bins.unwrap_or(d.bins).max(2),
            embree_quality: self.embree_quality.unwrap_or(d.embree_quality),
            embree_mode: self.embree_mode.unwrap_or(d.embree_mode),
        }
    }
}

/// A material.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MaterialSpec {
    /// Diffuse colour.
    pub kd: Option<Vec3>,
    /// Specular colour (mirror weight).
    pub ks: Option<Vec3>,
    /// Phong exponent.
    pub shininess: Option<f32>,
    /// Transparency in [0, 1] (0: opaque).
    pub transparency: Option<f32>,
    /// Diffuse texture, relative to the scene file.
    pub kd_texture: Option<String>,
    /// Read 8-bit textures as linear values instead of sRGB.
    pub texture_raw: bool,
    /// How the texture is addressed outside uv [0, 1]: `repeat` (default), `mirror` or `clamp`.
    pub texture_wrap: Option<WrapMode>,
    /// Shading model (default: the scene's).
    pub shading_model: Option<ShadingModelKind>,
}

/// Similarity transform applied after normalisation: scale, then rotate (degrees
/// about x, then y, then z), then translate.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TransformSpec {
    /// Per-axis scale.
    pub scale: Vec3,
    /// Rotation angles in degrees.
    pub rotate: Vec3,
    /// Translation.
    pub translate: Vec3,
}

impl Default for TransformSpec {
    fn default() -> Self {
        Self { scale: Vec3::ONE, rotate: Vec3::ZERO, translate: Vec3::ZERO }
    }
}

/// A triangle mesh from an OBJ file.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MeshSpec {
    /// OBJ path, relative to the scene file.
    pub file: String,
    /// Centre on the vertex mean and scale to the unit sphere (as the reference scenes do).
    pub normalize: bool,
    /// Transform applied after normalisation.
    pub transform: Option<TransformSpec>,
    /// Material replacing every MTL material of this mesh.
    pub material: Option<String>,
    /// Per-MTL-material replacements: MTL name -> scene material name.
    pub material_overrides: BTreeMap<String, String>,
}

/// An analytic sphere.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SphereSpec {
    /// Centre.
    pub center: Vec3,
    /// Radius (> 0).
    pub radius: f32,
    /// Material name (default material when absent).
    #[serde(default)]
    pub material: Option<String>,
}

/// A light source.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "kebab-case", deny_unknown_fields)]
pub enum LightSpec {
    /// Point light.
    Point {
        /// Position.
        position: Vec3,
        /// Colour / intensity.
        color: Vec3,
    },
    /// Segment light.
    Segment {
        /// End points.
        endpoints: [Vec3; 2],
        /// Colours at the end points.
        colors: [Vec3; 2],
    },
    /// Parallelogram light.
    Parallelogram {
        /// Corner.
        v0: Vec3,
        /// First edge.
        edge01: Vec3,
        /// Second edge.
        edge02: Vec3,
        /// Colours at v0, v0+edge01, v0+edge02, v0+edge01+edge02.
        colors: [Vec3; 4],
    },
}

impl LightSpec {
    /// The light this entry describes.
    pub fn light(&self) -> Box<dyn Light> {
        match *self {
            LightSpec::Point { position, color } => Box::new(PointLight { position, color }),
            LightSpec::Segment { endpoints, colors } => {
                Box::new(SegmentLight { p0: endpoints[0], p1: endpoints[1], c0: colors[0], c1: colors[1] })
            }
            LightSpec::Parallelogram { v0, edge01, edge02, colors } => {
                Box::new(ParallelogramLight { v0, edge01, edge02, colors })
            }
        }
    }
}
