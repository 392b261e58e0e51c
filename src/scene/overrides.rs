//! Command-line overrides, applied to a parsed scene file before it is checked and built.

use crate::backends::{Backend, Builder, Traversal};
use crate::error::{Error, Result};
use crate::geometry::TriangleTest;

use super::SceneFile;

/// Command-line overrides applied on top of a scene file.
#[derive(Clone, Debug, Default)]
pub struct Overrides {
    /// Image width.
    pub width: Option<u32>,
    /// Image height.
    pub height: Option<u32>,
    /// Samples per pixel.
    pub spp: Option<u32>,
    /// Seed.
    pub seed: Option<u64>,
    /// Feature switches `(name, on)`.
    pub features: Vec<(String, bool)>,
    /// Recursion depth (`params.max_depth`).
    pub max_depth: Option<u32>,
    /// Backend.
    pub backend: Option<Backend>,
    /// BVH builder.
    pub builder: Option<Builder>,
    /// BVH traversal.
    pub traversal: Option<Traversal>,
    /// Triangle test.
    pub triangle_test: Option<TriangleTest>,
}

impl Overrides {
    /// Write these overrides into `file` (an unknown feature name is an error).
    pub fn apply(&self, file: &mut SceneFile) -> Result<()> {
        let img = &mut file.image;
        img.width = self.width.unwrap_or(img.width);
        img.height = self.height.unwrap_or(img.height);
        img.spp = self.spp.unwrap_or(img.spp);
        img.seed = self.seed.unwrap_or(img.seed);
        file.params.max_depth = self.max_depth.unwrap_or(file.params.max_depth);
        for (name, on) in &self.features {
            *file.features.get_mut(name).ok_or_else(|| {
                Error::Invalid(format!(
                    "unknown feature '{name}' (known: {})",
                    crate::features::FEATURE_NAMES.join(", ")
                ))
            })? = *on;
        }
        let a = &mut file.accel;
        a.backend = self.backend.or(a.backend);
        a.builder = self.builder.or(a.builder);
        a.traversal = self.traversal.or(a.traversal);
        a.triangle_test = self.triangle_test.or(a.triangle_test);
        Ok(())
    }
}
