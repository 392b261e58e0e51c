//! The one module that names every tracer backend and builds it: brute force
//! ([`crate::accel::BruteForce`]), rtdiff's BVH ([`crate::bvh`], configured
//! by [`BvhConfig`]) and Intel Embree ([`crate::embree`], configured by
//! [`EmbreeQuality`]). [`crate::accel`] holds only the [`Tracer`] interface
//! and the brute-force oracle and imports no backend; each backend owns its
//! configuration; this factory imports them all.

use std::sync::Arc;

use clap::ValueEnum;
use serde::{Deserialize, Serialize};

pub use crate::bvh::config::{BinaryOrder, Builder, BvhConfig, NodeLayout, Traversal};
pub use crate::embree::quality::{EmbreeMode, EmbreeQuality, embree_label};

use crate::accel::{BruteForce, Tracer};
use crate::error::Result;
use crate::geometry::{Hit, Primitives, Ray, TriangleTest};

/// Where hits come from.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum Backend {
    /// rtdiff's own BVH.
    #[default]
    Native,
    /// Every primitive against every ray (the oracle; also the reports' "BVH off").
    Brute,
    /// Intel Embree 4 (needs the `embree` cargo feature and scripts/setup-embree.sh).
    Embree,
}

/// Full acceleration-structure configuration.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct AccelConfig {
    /// Hit provider.
    pub backend: Backend,
    /// BVH builder (native backend).
    pub builder: Builder,
    /// BVH traversal (native backend): `fast` is the 8-wide node layout, the
    /// others walk binary nodes ([`Traversal::layout`]).
    pub traversal: Traversal,
    /// Ray/triangle test (native and brute backends).
    pub triangle_test: TriangleTest,
    /// Maximum primitives per leaf for the `median` builder (the reports used 1).
    pub leaf_size: usize,
    /// Bin count for the `sah` builder.
    pub bins: usize,
    /// Build quality of the Embree backend.
    pub embree_quality: EmbreeQuality,
    /// Scene flags of the Embree backend (robust unless asked otherwise).
    pub embree_mode: EmbreeMode,
}

impl From<&AccelConfig> for BvhConfig {
    fn from(c: &AccelConfig) -> Self {
        BvhConfig {
            builder: c.builder,
            layout: c.traversal.layout(),
            triangle_test: c.triangle_test,
            leaf_size: c.leaf_size,
            bins: c.bins,
        }
    }
}

impl AccelConfig {
    /// The BVH part of this configuration.
    pub fn bvh(&self) -> BvhConfig {
        self.into()
    }

    /// The one label of this configuration, used by every report and summary
    /// (and by each tracer's [`Tracer::name`]): `bvh-sah/fast`, `brute`,
    /// `embree-high`, with ` mt` for the Moller-Trumbore triangle test.
    pub fn label(&self) -> String {
        match self.backend {
            Backend::Native => self.bvh().label(),
            Backend::Brute => format!("brute{}", self.triangle_test.label_suffix()),
            Backend::Embree => embree_label(self.embree_quality, self.embree_mode),
        }
    }
}

impl Default for AccelConfig {
    fn default() -> Self {
        Self {
            backend: Backend::Native,
            builder: Builder::Sah,
            traversal: Traversal::Fast,
            triangle_test: TriangleTest::Watertight,
            leaf_size: 1,
            bins: 16,
            embree_quality: EmbreeQuality::High,
            embree_mode: EmbreeMode::Robust,
        }
    }
}

/// Build the tracer `cfg` asks for over `prims`, with the threads of the
/// calling rayon pool (every backend).
pub fn build_tracer(prims: Arc<Primitives>, cfg: &AccelConfig) -> Result<Box<dyn Tracer>> {
    match cfg.backend {
        Backend::Brute => Ok(Box::new(BruteForce::new(prims, cfg.triangle_test))),
        Backend::Native => Ok(Box::new(crate::bvh::BvhTracer::new(&prims, cfg))),
        #[cfg(feature = "embree")]
        // Embree builds with as many threads as the calling rayon pool has,
        // like rtdiff's own builders.
        Backend::Embree => Ok(Box::new(crate::embree::EmbreeTracer::with_mode(
            &crate::embree::Device::new(&format!("threads={}", rayon::current_num_threads()))?,
            prims,
            cfg.embree_quality,
            cfg.embree_mode,
        )?)),
        #[cfg(not(feature = "embree"))]
        Backend::Embree => Err(crate::error::Error::Invalid(
            "this build has no Embree backend: run scripts/setup-embree.sh and build with --features embree".into(),
        )),
    }
}

/// Build the tracer `cfg` asks for over `prims` and find the closest hit of each of `rays`, in parallel.
pub fn trace_rays(prims: Arc<Primitives>, cfg: &AccelConfig, rays: &[Ray]) -> Result<Vec<Option<Hit>>> {
    use rayon::prelude::*;
    let tracer = build_tracer(prims, cfg)?;
    Ok(rays.par_iter().map(|r| tracer.intersect(r)).collect())
}

/// Every BVH builder, in declaration order (median, sah-volume, sah).
pub fn builders() -> Vec<Builder> {
    Builder::value_variants().to_vec()
}

/// Every BVH traversal, in declaration order (basic, priority-queue, sorted-vector, nth-element, fast).
pub fn traversals() -> Vec<Traversal> {
    Traversal::value_variants().to_vec()
}

/// Every native builder x traversal with the watertight test, the default
/// configuration (`bvh-sah/fast`) first: the variant list of `parity`, `bench`
/// and the tests.
pub fn native_variants() -> Vec<AccelConfig> {
    let default = AccelConfig { backend: Backend::Native, ..Default::default() };
    let mut v = vec![default];
    for builder in builders() {
        for traversal in traversals() {
            let cfg = AccelConfig { backend: Backend::Native, builder, traversal, ..Default::default() };
            if cfg != default {
                v.push(cfg);
            }
        }
    }
    v
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_label_per_configuration() {
        let labels: Vec<String> = native_variants().iter().map(AccelConfig::label).collect();
        assert_eq!(labels[0], "bvh-sah/fast");
        let mut unique = labels.clone();
        unique.sort();
        unique.dedup();
        assert_eq!(unique.len(), labels.len());
        let prims = Arc::new(Primitives::default());
        for cfg in native_variants().into_iter().chain([
            AccelConfig { backend: Backend::Brute, ..Default::default() },
            AccelConfig { backend: Backend::Brute, triangle_test: TriangleTest::MollerTrumbore, ..Default::default() },
            AccelConfig { triangle_test: TriangleTest::MollerTrumbore, ..Default::default() },
        ]) {
            assert_eq!(build_tracer(prims.clone(), &cfg).unwrap().name(), cfg.label());
        }
    }
}
