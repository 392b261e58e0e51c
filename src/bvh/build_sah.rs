//! Binned surface-area-heuristic builder (Wald 2007; pbrt-v4 section 7.3).
//!
//! Centroids are binned on all three axes; the split between bins costs
//! `C_trav + C_isect * (A_l N_l + A_r N_r) / A` with `A` the box *surface
//! area* (the probability that a ray through the parent also crosses the
//! child, for uniformly distributed rays). A node becomes a leaf when no split
//! beats its leaf cost `C_isect * N` and it holds at most [`SAH_MAX_LEAF`]
//! primitives. Large nodes build their subtrees in parallel (rayon).

use crate::accel::Builder;
use crate::geometry::{Aabb, Primitives};

use super::build::{BinaryBvh, BuildInput, Splitter, build_with, partition};

/// Cost of visiting one node, relative to [`INTERSECTION_COST`].
pub const TRAVERSAL_COST: f32 = 1.0;
/// Cost of one primitive intersection.
pub const INTERSECTION_COST: f32 = 1.0;
/// Nodes with more primitives than this are always split.
pub const SAH_MAX_LEAF: usize = 8;
/// Deepest level; only reachable on pathological input (the node then stays a large leaf).
pub const SAH_MAX_DEPTH: u32 = 100;
/// Largest accepted bin count.
pub const SAH_MAX_BINS: usize = 256;

/// Binned SAH split with `bins` bins per axis.
pub struct SahSplit {
    /// Bins per axis (clamped to `2..=SAH_MAX_BINS`).
    pub bins: usize,
}

impl Splitter for SahSplit {
    fn max_depth(&self) -> u32 {
        SAH_MAX_DEPTH
    }

    fn split(&self, input: &BuildInput, idx: &mut [u32], bounds: &Aabb, _depth: u32) -> Option<usize> {
        let n = idx.len();
        let cb = input.centroid_bounds_of(idx);
        let ext = cb.extent();
        // Small nodes need no more bins than primitives (saves clearing empty bins).
        let nb = self.bins.clamp(2, SAH_MAX_BINS).min(n.max(4));
        let scale = [0, 1, 2].map(|a| if ext[a] > 0.0 { nb as f32 / ext[a] } else { 0.0 });
        let bin = |c: f32, a: usize| -> usize { (((c - cb.min[a]) * scale[a]) as usize).min(nb - 1) };

        let mut count = vec![0u32; 3 * nb];
        let mut boxes = vec![Aabb::EMPTY; 3 * nb];
        for &i in idx.iter() {
            let c = input.centroids[i as usize];
            let b = input.bounds[i as usize];
            for a in 0..3 {
                if scale[a] > 0.0 {
                    let k = a * nb + bin(c[a], a);
                    count[k] += 1;
                    boxes[k] = boxes[k].union(b);
                }
            }
        }

        // Best split: minimise A_l N_l + A_r N_r (the constant terms of the cost do not change the argmin).
        let mut best: Option<(f32, usize, usize)> = None; // (A_l N_l + A_r N_r, axis, last left bin)
        let mut right_cost = vec![0.0f32; nb];
        for a in 0..3 {
            if scale[a] == 0.0 {
                continue;
            }
            let (cnt, bx) = (&count[a * nb..(a + 1) * nb], &boxes[a * nb..(a + 1) * nb]);
            let (mut rb, mut rn) = (Aabb::EMPTY, 0u32);
            for s in (1..nb).rev() {
                rb = rb.union(bx[s]);
                rn += cnt[s];
                right_cost[s] = if rn == 0 { f32::NAN } else { rb.surface_area() * rn as f32 };
            }
            let (mut lb, mut ln) = (Aabb::EMPTY, 0u32);
            for s in 0..nb - 1 {
                lb = lb.union(bx[s]);
                ln += cnt[s];
                let rc = right_cost[s + 1];
                if ln == 0 || rc.is_nan() {
                    continue;
                }
                let cost = lb.surface_area() * ln as f32 + rc;
                if best.is_none_or(|(c, _, _)| cost < c) {
                    best = Some((cost, a, s));
                }
            }
        }

        let Some((cost, axis, s)) = best else {
            // Every centroid coincides: no bin separates them. Split by count only if too many.
            return (n > SAH_MAX_LEAF).then_some(n / 2);
        };
        let area = bounds.surface_area();
        let split_cost = TRAVERSAL_COST * area + INTERSECTION_COST * cost;
        let leaf_cost = INTERSECTION_COST * n as f32 * area;
        if n <= SAH_MAX_LEAF && split_cost >= leaf_cost {
            return None;
        }
        Some(partition(idx, |i| bin(input.centroids[i as usize][axis], axis) <= s))
    }
}

/// Build with the binned SAH.
pub fn build(prims: &Primitives, bins: usize) -> BinaryBvh {
    build_with(prims, &SahSplit { bins }, Builder::Sah)
}
