//! The BVH backend's own configuration: builder, traversal (the `fast`
//! traversal is the 8-wide node layout; the others walk the binary nodes in
//! the reports' orders), triangle test, leaf size and bins, and its label.

use serde::{Deserialize, Serialize};

use crate::geometry::TriangleTest;

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

/// Everything a BVH build and its traversal depend on.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize)]
pub struct BvhConfig {
    /// Builder.
    pub builder: Builder,
    /// Traversal (and with it the node layout: `fast` is 8-wide).
    pub traversal: Traversal,
    /// Ray/triangle test.
    pub triangle_test: TriangleTest,
    /// Maximum primitives per leaf for the `median` builder.
    pub leaf_size: usize,
    /// Bin count for the `sah` builder.
    pub bins: usize,
}

impl Default for BvhConfig {
    fn default() -> Self {
        Self {
            builder: Builder::Sah,
            traversal: Traversal::Fast,
            triangle_test: TriangleTest::Watertight,
            leaf_size: 1,
            bins: 16,
        }
    }
}

impl From<&BvhConfig> for BvhConfig {
    fn from(c: &BvhConfig) -> Self {
        *c
    }
}

impl BvhConfig {
    /// The one label of this configuration (`bvh-sah/fast`, `bvh-median/basic mt`, ...).
    pub fn label(&self) -> String {
        format!("bvh-{}/{}{}", kebab(&self.builder), kebab(&self.traversal), self.triangle_test.label_suffix())
    }
}

/// The lower-case name clap gives `v`.
pub fn kebab<T: clap::ValueEnum>(v: &T) -> String {
    v.to_possible_value().map_or_else(String::new, |p| p.get_name().to_string())
}
