//! The reports' "SAH + binning" builder (section 4.2), kept to reproduce their
//! table: the node box's largest axis is cut into 5 equal bins, each
//! triangle's centroid (the mean of its vertices, as in the reports, not the
//! box centre the other builders use) goes to bin
//! `floor((c - low) * bins / length)` with `low`, `length` the node box's, and the split after bin `s`
//! (`s < bins - 1`) costs `N_l * V_l + N_r * V_r` with `V` the *volume* of
//! each side's box. The best cost starts at the no-split cost `N * V`, so a
//! node is a leaf unless some split is strictly cheaper; equal costs prefer
//! the more balanced split. Flat geometry (zero volume) therefore stays in
//! large leaves, as in the reports' Cornell box (10 triangles per leaf).

use super::config::Builder;
use crate::geometry::{Aabb, Primitives};

use super::build::{BinaryBvh, BoxA, BuildInput, PrimRef, Split, Splitter, build_with, partition};

/// The reports' bin count.
pub const VOLUME_BINS: usize = 5;

/// The reports' maximum tree level.
pub const VOLUME_MAX_DEPTH: u32 = 100;

/// Volume-cost binned split.
pub struct VolumeSplit;

impl Splitter for VolumeSplit {
    fn max_depth(&self) -> u32 {
        VOLUME_MAX_DEPTH
    }

    fn needs_vertex_means(&self) -> bool {
        true
    }

    fn split(
        &self,
        input: &BuildInput,
        idx: &mut [PrimRef],
        bounds: &Aabb,
        _centroids: Option<BoxA>,
        _depth: u32,
    ) -> Option<Split> {
        let axis = bounds.largest_axis();
        let low = bounds.min[axis];
        let length = bounds.extent()[axis];
        if length <= 0.0 {
            return None;
        }
        let bin = |r: &PrimRef| -> usize {
            let c = input.vertex_means[r.id() as usize][axis];
            (((c - low) * VOLUME_BINS as f32 / length) as usize).min(VOLUME_BINS - 1)
        };
        let mut count = [0usize; VOLUME_BINS];
        let mut boxes = [Aabb::EMPTY; VOLUME_BINS];
        for r in idx.iter() {
            let b = bin(r);
            count[b] += 1;
            boxes[b] = boxes[b].union(r.boxa().aabb());
        }
        let n = idx.len();
        let mut best_cost = n as f32 * bounds.volume();
        let mut best: Option<(usize, usize, Aabb, Aabb)> = None; // (split, imbalance, boxes)
        for s in 0..VOLUME_BINS - 1 {
            let nl: usize = count[..=s].iter().sum();
            let nr = n - nl;
            if nl == 0 || nr == 0 {
                continue;
            }
            let bl = boxes[..=s].iter().fold(Aabb::EMPTY, |a, &b| a.union(b));
            let br = boxes[s + 1..].iter().fold(Aabb::EMPTY, |a, &b| a.union(b));
            let cost = nl as f32 * bl.volume() + nr as f32 * br.volume();
            let imbalance = nl.abs_diff(nr);
            if cost < best_cost || (cost == best_cost && best.is_some_and(|(_, d, _, _)| imbalance < d)) {
                best_cost = cost;
                best = Some((s, imbalance, bl, br));
            }
        }
        let (s, _, bl, br) = best?;
        Some(Split { mid: partition(idx, |r| bin(r) <= s), bounds: Some((bl, br)) })
    }
}

/// Build with the reports' volume heuristic.
pub fn build(prims: &Primitives) -> BinaryBvh {
    build_with(prims, &VolumeSplit, Builder::SahVolume)
}
