//! The noisy features of the convergence sweep and the scene each is measured on.

use serde::Serialize;

use crate::light::LightSampling;
use crate::scene::file::{MaterialSpec, SceneFile};

/// Most random light samples Mitsuba's plugin renders in one pass (more are split into passes).
pub const MITSUBA_LIGHT_SAMPLES_PER_KERNEL: u32 = 16;

fn gcd(a: u32, b: u32) -> u32 {
    if b == 0 { a } else { gcd(b, a % b) }
}

/// A noisy feature and the scene it is measured on.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Feature {
    /// Area light, independent uniform samples (`light_samples`).
    AreaRandom,
    /// Area light, jittered samples (`light_samples`).
    AreaJittered,
    /// Glossy reflection (`glossy_samples`).
    Glossy,
    /// Depth of field (`dof_samples`).
    DepthOfField,
    /// Pixel anti-aliasing (`spp`, jittered strata).
    PixelAa,
}

impl Feature {
    /// Every feature, in report order.
    pub const ALL: [Feature; 5] =
        [Feature::AreaRandom, Feature::AreaJittered, Feature::Glossy, Feature::DepthOfField, Feature::PixelAa];

    /// Short name (file names, JSON).
    pub fn name(self) -> &'static str {
        match self {
            Feature::AreaRandom => "area-random",
            Feature::AreaJittered => "area-jittered",
            Feature::Glossy => "glossy",
            Feature::DepthOfField => "depth-of-field",
            Feature::PixelAa => "pixel-aa",
        }
    }

    /// The scene file (under `scenes/`) and what is changed in it.
    pub fn setup(self) -> (&'static str, &'static str) {
        match self {
            Feature::AreaRandom => ("cornell_box_parallelogram_light.json", "light_sampling random, light_samples = N"),
            Feature::AreaJittered => {
                ("cornell_box_parallelogram_light.json", "light_sampling jittered, light_samples = N")
            }
            Feature::Glossy => {
                ("cornell_box.json", "glossy on, tall box glossy (ks 0.9, shininess 40), glossy_samples = N")
            }
            Feature::DepthOfField => {
                ("spheres.json", "depth_of_field on, aperture 0.15, focus 6 (blue sphere), dof_samples = N")
            }
            Feature::PixelAa => {
                ("cornell_box.json", "spp = N (the pixel centre for 1, a sqrt(N) x sqrt(N) jittered grid for square N)")
            }
        }
    }

    /// True when the sweep only changes how the scene's own image is
    /// estimated (its expectation is the scene file's): then a reference of
    /// the unchanged scene (`reference/`) is a reference of every render of
    /// the sweep. The area-light features change the number and placement of
    /// light samples, not what they average; the others turn on a feature that
    /// changes the image (a glossy box, a lens, the pixel's area instead of its
    /// centre).
    pub fn keeps_the_scenes_image(self) -> bool {
        matches!(self, Feature::AreaRandom | Feature::AreaJittered)
    }

    /// How Mitsuba renders `n` samples: the count written into the exported
    /// scene and the passes over it (`None`: the scene's own), or why it
    /// does not. The plugin unrolls its light samples into one JIT kernel, whose
    /// compilation grows faster than the count (on this project's loaded
    /// machine, first time: 16 samples 5 s, 64: 20 s, 256: 85 s, 1024:
    /// unfinished after 10 minutes; Dr.Jit caches kernels on disk after that).
    /// Random light samples are independent, so `n` of them are `n / L` passes
    /// of `L`; jittered ones are stratified over all `n` and cannot be split:
    /// above `jittered_max` they are not rendered.
    pub fn mitsuba_plan(self, n: u32, jittered_max: u32) -> std::result::Result<(u32, Option<u32>), String> {
        match self {
            Feature::AreaRandom if n > MITSUBA_LIGHT_SAMPLES_PER_KERNEL => {
                let l = gcd(n, MITSUBA_LIGHT_SAMPLES_PER_KERNEL);
                Ok((l, Some(n / l)))
            }
            Feature::AreaJittered if n > jittered_max => Err(format!(
                "{n} jittered light samples are not rendered by Mitsuba: its plugin unrolls them into one JIT \
                 kernel, whose compilation beyond {jittered_max} samples takes too long for this report (1024: \
                 over 10 minutes), and jittered samples cannot be split across passes"
            )),
            _ => Ok((n, None)),
        }
    }

    /// Apply the feature with `n` samples to a scene file.
    pub fn configure(self, f: &mut SceneFile, n: u32) {
        match self {
            Feature::AreaRandom | Feature::AreaJittered => {
                f.features.soft_shadows = true;
                f.params.light_samples = n;
                f.params.light_sampling =
                    if self == Feature::AreaRandom { LightSampling::Random } else { LightSampling::Jittered };
            }
            Feature::Glossy => {
                f.features.glossy = true;
                f.params.glossy_samples = n;
                f.materials.insert(
                    "glossy_mirror".into(),
                    MaterialSpec {
                        kd: Some(glam::Vec3::splat(0.01)),
                        ks: Some(glam::Vec3::splat(0.9)),
                        shininess: Some(40.0),
                        ..Default::default()
                    },
                );
                for m in &mut f.meshes {
                    m.material_overrides.insert("tallbox".into(), "glossy_mirror".into());
                }
            }
            Feature::DepthOfField => {
                f.features.depth_of_field = true;
                f.camera.aperture = 0.15;
                f.camera.focus_distance = Some(6.0);
                f.params.dof_samples = n;
            }
            Feature::PixelAa => f.image.spp = n,
        }
    }
}
