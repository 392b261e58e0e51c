//! The reports' median builder (section 3.5.1): the split axis cycles x, y, z
//! with the level, the node is cut at the median centroid found by
//! `select_nth_unstable` (the median element of an odd count goes right),
//! nodes stop splitting at `leaf_size` primitives or at level 100.

use super::config::Builder;
use crate::geometry::{Aabb, Primitives};

use super::build::{BinaryBvh, BoxA, BuildInput, PrimRef, Split, Splitter, build_with};

/// The reports' maximum tree level.
pub const MEDIAN_MAX_DEPTH: u32 = 100;

/// Median split on the axis `level % 3`.
pub struct MedianSplit {
    /// Nodes with at most this many primitives become leaves (the reports used 1).
    pub leaf_size: usize,
}

impl Splitter for MedianSplit {
    fn max_depth(&self) -> u32 {
        MEDIAN_MAX_DEPTH
    }

    fn split(
        &self,
        _input: &BuildInput,
        idx: &mut [PrimRef],
        _bounds: &Aabb,
        _centroids: Option<BoxA>,
        depth: u32,
    ) -> Option<Split> {
        if idx.len() <= self.leaf_size.max(1) {
            return None;
        }
        let axis = (depth % 3) as usize;
        let mid = idx.len() / 2;
        // Ties on the coordinate are broken by primitive id, as the reports kept
        // the indices "to differentiate between triangles with the same centroid".
        idx.select_nth_unstable_by(mid, |a, b| {
            a.centroid()[axis].total_cmp(&b.centroid()[axis]).then(a.id().cmp(&b.id()))
        });
        Some(mid.into())
    }
}

/// Build with the median split.
pub fn build(prims: &Primitives, leaf_size: usize) -> BinaryBvh {
    build_with(prims, &MedianSplit { leaf_size }, Builder::Median)
}
