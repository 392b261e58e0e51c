//! The one module that names every tracer backend and builds it: brute force
//! ([`crate::accel::BruteForce`]), rtdiff's BVH ([`crate::bvh`], configured
//! by [`BvhConfig`]), Intel Embree ([`crate::embree`], configured by
//! [`EmbreeQuality`]) and tracers loaded from a plugin library
//! ([`crate::plugin`], `--tracer plugin:PATH`). [`crate::accel`] holds only the [`Tracer`] interface
//! and the brute-force oracle and imports no backend; each backend owns its
//! configuration; this factory imports them all.

use std::sync::Arc;

use clap::ValueEnum;
use serde::{Deserialize, Serialize};

pub use crate::plugin::PluginId;

pub use crate::bvh::config::{BinaryOrder, Builder, BvhConfig, NodeLayout, Traversal};
pub use crate::embree::quality::{EmbreeMode, EmbreeQuality, embree_label};

use crate::accel::{BruteForce, Tracer};
use crate::error::Result;
use crate::geometry::{Hit, Primitives, Ray, TriangleTest};

/// Where hits come from.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Backend {
    /// rtdiff's own BVH.
    #[default]
    Native,
    /// Every primitive against every ray (the oracle; also the reports' "BVH off").
    Brute,
    /// Intel Embree 4 (needs the `embree` cargo feature and scripts/setup-embree.sh).
    Embree,
    /// A tracer from a shared library implementing `include/rtdiff_tracer.h` ([`crate::plugin::load`]).
    Plugin(PluginId),
}

impl Backend {
    /// The tracer named on the command line: `native`, `brute`, `embree`, or
    /// `plugin:PATH` (the library is loaded and checked here; errors name it).
    pub fn parse(s: &str) -> Result<Self> {
        match s {
            "native" => Ok(Backend::Native),
            "brute" => Ok(Backend::Brute),
            "embree" => Ok(Backend::Embree),
            _ => match s.strip_prefix("plugin:") {
                Some(path) if !path.is_empty() => Ok(Backend::Plugin(crate::plugin::load(std::path::Path::new(path))?)),
                _ => Err(crate::error::Error::Invalid(format!(
                    "unknown tracer '{s}' (expected native, brute, embree or plugin:PATH to a shared library)"
                ))),
            },
        }
    }
}

/// `--tracer` as clap reads it: checked for its form only; [`TracerArg::backend`] loads a plugin.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct TracerArg(pub String);

impl TracerArg {
    /// The backend this names (loading a plugin; errors name the library).
    pub fn backend(&self) -> Result<Backend> {
        Backend::parse(&self.0)
    }
}

impl std::str::FromStr for TracerArg {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        if matches!(s, "native" | "brute" | "embree") || s.strip_prefix("plugin:").is_some_and(|p| !p.is_empty()) {
            Ok(TracerArg(s.to_string()))
        } else {
            Err(format!("unknown tracer '{s}' (expected native, brute, embree or plugin:PATH to a shared library)"))
        }
    }
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
            Backend::Plugin(id) => id.plugin().label(),
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
/// calling rayon pool (every backend). A plugin's hits are checked
/// ([`crate::plugin::Checked`]: an invalid hit is a miss), so that a render
/// never shades a primitive that does not exist; the harness judges the
/// unchecked answers ([`build_tracer_unchecked`]).
pub fn build_tracer(prims: Arc<Primitives>, cfg: &AccelConfig) -> Result<Box<dyn Tracer>> {
    match cfg.backend {
        Backend::Plugin(id) => {
            Ok(Box::new(crate::plugin::Checked::new(crate::plugin::PluginTracer::new(id, &prims)?, prims)))
        }
        _ => build_tracer_unchecked(prims, cfg),
    }
}

/// [`build_tracer`], with a plugin's answers as it gives them (ids that name
/// no primitive, distances outside the interval, NaN: [`Hit::fault`]), for
/// the harness that judges them. The same tracer for every other backend.
pub fn build_tracer_unchecked(prims: Arc<Primitives>, cfg: &AccelConfig) -> Result<Box<dyn Tracer>> {
    match cfg.backend {
        Backend::Plugin(id) => Ok(Box::new(crate::plugin::PluginTracer::new(id, &prims)?)),
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

/// Build the tracer `cfg` asks for over `prims` and find the closest hit of each of `rays`, in parallel
/// (a plugin's hits as it returns them: [`build_tracer_unchecked`]).
pub fn trace_rays(prims: Arc<Primitives>, cfg: &AccelConfig, rays: &[Ray]) -> Result<Vec<Option<Hit>>> {
    use rayon::prelude::*;
    let tracer = build_tracer_unchecked(prims, cfg)?;
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
