//! How a scene's acceleration structure is chosen: backend, BVH builder,
//! traversal and triangle test. Selectable from the scene file and the CLI.

use serde::{Deserialize, Serialize};

use crate::geometry::TriangleTest;

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

/// BVH construction algorithm.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum Builder {
    /// The reports' split: axis cycles x, y, z with depth, median centroid.
    Median,
    /// The reports' "SAH + binning": 5 bins, cost N * box volume.
    SahVolume,
    /// Binned surface-area heuristic with traversal and intersection costs.
    #[default]
    Sah,
}

/// BVH traversal algorithm.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum Traversal {
    /// The reports' depth-first walk into every intersected child.
    Basic,
    /// Binary heap ordered by entry distance.
    PriorityQueue,
    /// The reports' vector kept sorted by entry distance.
    SortedVector,
    /// The reports' vector with nth-element selection of the nearest entry.
    NthElement,
    /// The production path: wide nodes, nearest-first, early termination.
    #[default]
    Fast,
}

/// Embree's build quality (`rtcSetSceneBuildQuality`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum EmbreeQuality {
    /// RTC_BUILD_QUALITY_LOW.
    Low,
    /// RTC_BUILD_QUALITY_MEDIUM.
    Medium,
    /// RTC_BUILD_QUALITY_HIGH.
    #[default]
    High,
}

/// Full acceleration-structure configuration.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct AccelConfig {
    /// Hit provider.
    pub backend: Backend,
    /// BVH builder (native backend).
    pub builder: Builder,
    /// BVH traversal (native backend).
    pub traversal: Traversal,
    /// Ray/triangle test (native and brute backends).
    pub triangle_test: TriangleTest,
    /// Maximum primitives per leaf for the `median` builder (the reports used 1).
    pub leaf_size: usize,
    /// Bin count for the `sah` builder.
    pub bins: usize,
    /// Build quality of the Embree backend (always built with the robust flag).
    pub embree_quality: EmbreeQuality,
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
        }
    }
}
