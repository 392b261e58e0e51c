//! The BVH backend's own configuration: builder, node layout (binary nodes
//! walked in one of the reports' orders, or 8-wide SIMD nodes), triangle
//! test, leaf size and bins, the presets, and the one label.
//!
//! [`Traversal`] is the name users and scene files give the choice (`fast`,
//! `basic`, ...; `AccelConfig::traversal`, `--traversal`); [`NodeLayout`] is
//! what it means to the BVH: `fast` is the 8-wide layout, every other name a
//! walk order over the binary nodes.

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

/// The traversal as users name it (`--traversal`, scene files,
/// `AccelConfig::traversal`); [`Traversal::layout`] gives the node layout it
/// stands for.
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
    /// The production path: the 8-wide node layout ([`NodeLayout::Wide8`]).
    #[default]
    Fast,
}

/// The order in which a traversal over binary nodes visits them.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum BinaryOrder {
    /// Depth-first into every intersected child, left before right (the reports' basic walk).
    DepthFirst,
    /// Nearest entry first from a binary heap.
    PriorityQueue,
    /// Nearest entry first from a vector kept sorted.
    SortedVector,
    /// Nearest entry first by nth-element selection.
    NthElement,
}

/// How the tree is laid out in memory, and with it how it is traversed.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum NodeLayout {
    /// 32-byte binary nodes, walked in the given order (the reports' traversals).
    Binary(BinaryOrder),
    /// The binary tree collapsed into 256-byte 8-wide nodes (eight child boxes
    /// tested at once), leaf triangles in 4-wide packets: the production path.
    Wide8,
}

impl Traversal {
    /// The node layout this traversal name stands for.
    pub fn layout(self) -> NodeLayout {
        match self {
            Traversal::Basic => NodeLayout::Binary(BinaryOrder::DepthFirst),
            Traversal::PriorityQueue => NodeLayout::Binary(BinaryOrder::PriorityQueue),
            Traversal::SortedVector => NodeLayout::Binary(BinaryOrder::SortedVector),
            Traversal::NthElement => NodeLayout::Binary(BinaryOrder::NthElement),
            Traversal::Fast => NodeLayout::Wide8,
        }
    }
}

impl NodeLayout {
    /// The traversal name of this layout (inverse of [`Traversal::layout`]).
    pub fn traversal(self) -> Traversal {
        match self {
            NodeLayout::Binary(BinaryOrder::DepthFirst) => Traversal::Basic,
            NodeLayout::Binary(BinaryOrder::PriorityQueue) => Traversal::PriorityQueue,
            NodeLayout::Binary(BinaryOrder::SortedVector) => Traversal::SortedVector,
            NodeLayout::Binary(BinaryOrder::NthElement) => Traversal::NthElement,
            NodeLayout::Wide8 => Traversal::Fast,
        }
    }
}

/// Everything a BVH build and its traversal depend on.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize)]
pub struct BvhConfig {
    /// Builder.
    pub builder: Builder,
    /// Node layout (binary with a walk order, or 8-wide).
    pub layout: NodeLayout,
    /// Ray/triangle test.
    pub triangle_test: TriangleTest,
    /// Maximum primitives per leaf for the `median` builder.
    pub leaf_size: usize,
    /// Bin count for the `sah` builder.
    pub bins: usize,
}

impl Default for BvhConfig {
    fn default() -> Self {
        Self::FAST
    }
}

impl From<&BvhConfig> for BvhConfig {
    fn from(c: &BvhConfig) -> Self {
        *c
    }
}

impl BvhConfig {
    /// The production preset (`bvh-sah/fast`): binned SAH, 8-wide nodes, the watertight test.
    pub const FAST: BvhConfig = BvhConfig {
        builder: Builder::Sah,
        layout: NodeLayout::Wide8,
        triangle_test: TriangleTest::Watertight,
        leaf_size: 1,
        bins: 16,
    };

    /// The reports' preset (`bvh-median/basic`): median splits into one-primitive
    /// leaves, binary nodes walked depth first.
    pub const REPORTS: BvhConfig = BvhConfig {
        builder: Builder::Median,
        layout: NodeLayout::Binary(BinaryOrder::DepthFirst),
        triangle_test: TriangleTest::Watertight,
        leaf_size: 1,
        bins: 16,
    };

    /// The traversal name of [`Self::layout`].
    pub fn traversal(&self) -> Traversal {
        self.layout.traversal()
    }

    /// The one label of this configuration (`bvh-sah/fast`, `bvh-median/basic mt`, ...).
    pub fn label(&self) -> String {
        format!("bvh-{}/{}{}", kebab(&self.builder), kebab(&self.traversal()), self.triangle_test.label_suffix())
    }
}

/// The lower-case name clap gives `v`.
pub fn kebab<T: clap::ValueEnum>(v: &T) -> String {
    v.to_possible_value().map_or_else(String::new, |p| p.get_name().to_string())
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::ValueEnum;

    #[test]
    fn every_traversal_name_is_one_layout_and_back() {
        for &t in Traversal::value_variants() {
            assert_eq!(t.layout().traversal(), t);
        }
        assert_eq!(Traversal::Fast.layout(), NodeLayout::Wide8);
        assert_eq!(BvhConfig::FAST.label(), "bvh-sah/fast");
        assert_eq!(BvhConfig::REPORTS.label(), "bvh-median/basic");
    }
}
