//! The reports' feature switches, their parameters, and the per-render plan
//! that decides which of them a scene actually needs.

use serde::{Deserialize, Serialize};

use crate::geometry::offset::SpawnOffset;
use crate::light::LightSampling;

/// The reports' feature switches.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Features {
    /// Phong/physical shading (off: the diffuse colour).
    pub shading: bool,
    /// Recursive mirror reflections.
    pub recursive: bool,
    /// Shadow rays towards point lights.
    pub hard_shadows: bool,
    /// Shadow rays towards area-light samples.
    pub soft_shadows: bool,
    /// Use an acceleration structure (off: brute force).
    pub bvh: bool,
    /// Interpolate vertex normals with barycentric weights.
    pub normal_interpolation: bool,
    /// Diffuse textures.
    pub texture_mapping: bool,
    /// Bilinear texture filtering (off: nearest).
    pub bilinear_filtering: bool,
    /// Build the BVH with the SAH (off: median split) unless `accel.builder` says otherwise.
    pub sah: bool,
    /// Bloom post-process.
    pub bloom: bool,
    /// Glossy reflections.
    pub glossy: bool,
    /// Alpha-blended transparency.
    pub transparency: bool,
    /// Thin-lens depth of field.
    pub depth_of_field: bool,
}

impl Default for Features {
    fn default() -> Self {
        Self {
            shading: true,
            recursive: true,
            hard_shadows: true,
            soft_shadows: true,
            bvh: true,
            normal_interpolation: false,
            texture_mapping: true,
            bilinear_filtering: false,
            sah: true,
            bloom: false,
            glossy: false,
            transparency: false,
            depth_of_field: false,
        }
    }
}

/// Names accepted by `--feature NAME=on|off`.
pub const FEATURE_NAMES: [&str; 13] = [
    "shading",
    "recursive",
    "hard_shadows",
    "soft_shadows",
    "bvh",
    "normal_interpolation",
    "texture_mapping",
    "bilinear_filtering",
    "sah",
    "bloom",
    "glossy",
    "transparency",
    "depth_of_field",
];

impl Features {
    /// Mutable access to a switch by name.
    pub fn get_mut(&mut self, name: &str) -> Option<&mut bool> {
        Some(match name {
            "shading" => &mut self.shading,
            "recursive" => &mut self.recursive,
            "hard_shadows" => &mut self.hard_shadows,
            "soft_shadows" => &mut self.soft_shadows,
            "bvh" => &mut self.bvh,
            "normal_interpolation" => &mut self.normal_interpolation,
            "texture_mapping" => &mut self.texture_mapping,
            "bilinear_filtering" => &mut self.bilinear_filtering,
            "sah" => &mut self.sah,
            "bloom" => &mut self.bloom,
            "glossy" => &mut self.glossy,
            "transparency" => &mut self.transparency,
            "depth_of_field" => &mut self.depth_of_field,
            _ => return None,
        })
    }

    /// Every switch on.
    pub fn all_on() -> Self {
        let mut f = Self::default();
        for n in FEATURE_NAMES {
            *f.get_mut(n).expect("known name") = true;
        }
        f
    }
}

/// Bloom parameters.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct BloomParams {
    /// Luminance threshold: pixels with `Y >= threshold` bloom.
    pub threshold: f32,
    /// Gaussian kernel width in pixels (OIIO `make_kernel("gaussian", w, w)`: sigma = w / 4).
    pub kernel_size: f32,
    /// Scale of the blurred bright pass added back.
    pub scale: f32,
}

impl Default for BloomParams {
    fn default() -> Self {
        Self { threshold: 0.8, kernel_size: 21.0, scale: 1.0 }
    }
}

/// The integrators a scene can ask for (`params.integrator`); a new variant
/// goes here, in its own file under `integrator/`, and in
/// [`crate::integrator::create`], and no caller changes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum IntegratorKind {
    /// The reports' recursive tracer ([`crate::integrator::Whitted`]).
    #[default]
    Whitted,
}

/// Parameters of the features.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Params {
    /// Maximum recursion depth of reflection/transmission rays.
    pub max_depth: u32,
    /// Samples per area light.
    pub light_samples: u32,
    /// Area-light sampling pattern.
    pub light_sampling: LightSampling,
    /// Rays per glossy reflection.
    pub glossy_samples: u32,
    /// Lens samples per camera sample for depth of field.
    pub dof_samples: u32,
    /// Bloom settings.
    pub bloom: BloomParams,
    /// How secondary rays leave surfaces.
    pub ray_offset: SpawnOffset,
    /// Which integrator renders the scene (see [`crate::integrator::create`]).
    pub integrator: IntegratorKind,
}

impl Default for Params {
    fn default() -> Self {
        Self {
            max_depth: 5,
            light_samples: 16,
            light_sampling: LightSampling::Jittered,
            glossy_samples: 16,
            dof_samples: 16,
            bloom: BloomParams::default(),
            ray_offset: SpawnOffset::Robust,
            integrator: IntegratorKind::Whitted,
        }
    }
}

/// What a render actually does, decided once from the switches *and* the
/// scene's content, so an unused feature costs nothing per ray.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct Plan {
    /// Shade (else return kd).
    pub shading: bool,
    /// Some material has a texture and texture mapping is on.
    pub textures: bool,
    /// Bilinear rather than nearest lookups.
    pub bilinear: bool,
    /// Interpolated normals.
    pub normal_interpolation: bool,
    /// Some material reflects, recursion is on and depth > 0.
    pub reflections: bool,
    /// Glossy (perturbed) reflections instead of perfect mirrors.
    pub glossy: bool,
    /// Some material is transparent and transparency is on.
    pub transparency: bool,
    /// Shadow rays to point lights.
    pub hard_shadows: bool,
    /// Shadow rays to area-light samples.
    pub soft_shadows: bool,
    /// The scene has area lights (sampled when shading).
    pub area_lights: bool,
    /// Lens sampling (aperture > 0 and the feature on).
    pub depth_of_field: bool,
    /// Bloom post-process.
    pub bloom: bool,
}
