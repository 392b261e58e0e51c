//! Binned surface-area-heuristic builder (Wald 2007; pbrt-v4 section 7.3).
//!
//! Centroids are binned on all three axes; the split between bins costs
//! `C_trav + C_isect * (A_l N_l + A_r N_r) / A` with `A` the box *surface
//! area* (the probability that a ray through the parent also crosses the
//! child, for uniformly distributed rays). A node becomes a leaf when no split
//! beats its leaf cost `C_isect * N` and it holds at most [`SAH_MAX_LEAF`]
//! primitives. Large nodes build their subtrees in parallel (rayon).

use glam::Vec3A;

use crate::accel::Builder;
use crate::geometry::{Aabb, Primitives};

use super::build::{BinaryBvh, BoxA, BuildInput, Split, Splitter, build_with};

/// Cost of visiting one node, relative to [`INTERSECTION_COST`].
pub const TRAVERSAL_COST: f32 = 1.0;
/// Cost of one primitive intersection. Below the traversal cost because the
/// `fast` path tests a leaf's triangles four at a time (4-wide packets) while a
/// node visit costs a cache miss: on dragon_87k, 0.35 beat 1.0 by about 1.1x
/// (primary), 1.3x (incoherent) and 1.15x (shadow) with leaves of up to 8.
pub const INTERSECTION_COST: f32 = 0.35;
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

/// Bin of centroid `c` on every axis: `trunc(min((c - cmin) * scale, last))`,
/// the same per-lane arithmetic as the partition step uses on one axis.
/// The argument is in `[0, last]`, so truncation to an integer is exact.
#[inline(always)]
fn bins_of(c: Vec3A, cmin: Vec3A, scale: Vec3A, last: Vec3A) -> [usize; 3] {
    let f = ((c - cmin) * scale).min(last);
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{__m128i, _mm_cvttps_epi32, _mm_storeu_si128};
        let mut o = [0i32; 4];
        // SAFETY: SSE2 is part of the x86_64 baseline; o has room for 4 lanes.
        unsafe { _mm_storeu_si128(o.as_mut_ptr().cast::<__m128i>(), _mm_cvttps_epi32(f.into())) };
        [o[0] as usize, o[1] as usize, o[2] as usize]
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        [f.x as usize, f.y as usize, f.z as usize]
    }
}

impl Splitter for SahSplit {
    fn max_depth(&self) -> u32 {
        SAH_MAX_DEPTH
    }

    fn split(
        &self,
        input: &BuildInput,
        idx: &mut [u32],
        bounds: &Aabb,
        centroids: Option<BoxA>,
        _depth: u32,
    ) -> Option<Split> {
        let n = idx.len();
        let cb = centroids.unwrap_or_else(|| input.centroid_bounds_of(idx));
        let ext = cb.max - cb.min;
        // Small nodes need no more bins than primitives (saves clearing empty bins).
        let nb = self.bins.clamp(2, SAH_MAX_BINS).min(n.max(4));
        let scale = Vec3A::select(ext.cmpgt(Vec3A::ZERO), Vec3A::splat(nb as f32) / ext, Vec3A::ZERO);

        SCRATCH.with_borrow_mut(|scratch| self.split_with(scratch, input, idx, bounds, cb, nb, scale))
    }
}

thread_local! {
    /// Per-thread bin storage reused across nodes (no allocation per node).
    static SCRATCH: std::cell::RefCell<Scratch> = const { std::cell::RefCell::new(Scratch { count: Vec::new(), boxes: Vec::new(), right_cost: Vec::new(), order: Vec::new() }) };
}

struct Scratch {
    count: Vec<u32>,
    boxes: Vec<BoxA>,
    right_cost: Vec<f32>,
    order: Vec<u32>,
}

impl SahSplit {
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn split_with(
        &self,
        scratch: &mut Scratch,
        input: &BuildInput,
        idx: &mut [u32],
        bounds: &Aabb,
        cb: BoxA,
        nb: usize,
        scale: Vec3A,
    ) -> Option<Split> {
        let n = idx.len();
        let last = nb as u32 - 1;
        let Scratch { count, boxes, right_cost, order } = scratch;
        count.clear();
        count.resize(3 * nb, 0);
        boxes.clear();
        boxes.resize(3 * nb, BoxA::EMPTY);
        right_cost.clear();
        right_cost.resize(nb, 0.0);
        let (cent, bnds) = (&input.centroids[..], &input.bounds[..]);
        let lastf = Vec3A::splat(last as f32);
        let (count, boxes) = (&mut count[..], &mut boxes[..]);
        for &i in idx.iter() {
            let i = i as usize;
            let k = bins_of(cent[i], cb.min, scale, lastf);
            let b = bnds[i];
            for (a, &ka) in k.iter().enumerate() {
                let j = a * nb + ka;
                count[j] += 1;
                boxes[j] = boxes[j].union(b);
            }
        }

        // Best split: minimise A_l N_l + A_r N_r (the constant terms of the cost do not change the argmin).
        let mut best: Option<(f32, usize, usize)> = None; // (A_l N_l + A_r N_r, axis, last left bin)
        for a in 0..3 {
            if scale[a] == 0.0 {
                continue;
            }
            let (cnt, bx) = (&count[a * nb..(a + 1) * nb], &boxes[a * nb..(a + 1) * nb]);
            let (mut rb, mut rn) = (BoxA::EMPTY, 0u32);
            for s in (1..nb).rev() {
                rb = rb.union(bx[s]);
                rn += cnt[s];
                right_cost[s] = if rn == 0 { f32::NAN } else { rb.half_area() * rn as f32 };
            }
            let (mut lb, mut ln) = (BoxA::EMPTY, 0u32);
            for s in 0..nb - 1 {
                lb = lb.union(bx[s]);
                ln += cnt[s];
                let rc = right_cost[s + 1];
                if ln == 0 || rc.is_nan() {
                    continue;
                }
                let cost = lb.half_area() * ln as f32 + rc;
                if best.is_none_or(|(c, _, _)| cost < c) {
                    best = Some((cost, a, s));
                }
            }
        }

        let Some((cost, axis, s)) = best else {
            // Every centroid coincides: no bin separates them. Split by count only if too many.
            return (n > SAH_MAX_LEAF).then(|| (n / 2).into());
        };
        let area = bounds.surface_area() * 0.5;
        let split_cost = TRAVERSAL_COST * area + INTERSECTION_COST * cost;
        let leaf_cost = INTERSECTION_COST * n as f32 * area;
        if n <= SAH_MAX_LEAF && split_cost >= leaf_cost {
            return None;
        }
        let bx = &boxes[axis * nb..(axis + 1) * nb];
        let lb = bx[..=s].iter().fold(BoxA::EMPTY, |a, &b| a.union(b)).aabb();
        let rb = bx[s + 1..].iter().fold(BoxA::EMPTY, |a, &b| a.union(b)).aabb();
        // The same per-lane arithmetic as `bins_of`, on the chosen axis only.
        let (cmin, sc, lastf) = (cb.min[axis], scale[axis], last as f32);
        // Stable, branch-free partition through a scratch buffer (the side of
        // each primitive is unpredictable, so branches would mispredict often),
        // gathering each side's centroid box for the children on the way.
        let nl: u32 = count[axis * nb..=axis * nb + s].iter().sum();
        let nl = nl as usize;
        order.clear();
        order.resize(n, 0);
        let (mut lcb, mut rcb) = (BoxA::EMPTY, BoxA::EMPTY);
        let (mut li, mut ri) = (0usize, nl);
        for &id in idx.iter() {
            let c = cent[id as usize];
            let left = (((c[axis] - cmin) * sc).min(lastf) as usize) <= s;
            order[if left { li } else { ri }] = id;
            li += usize::from(left);
            ri += usize::from(!left);
            let m = glam::BVec3A::splat(left);
            lcb =
                BoxA { min: Vec3A::select(m, lcb.min.min(c), lcb.min), max: Vec3A::select(m, lcb.max.max(c), lcb.max) };
            rcb =
                BoxA { min: Vec3A::select(m, rcb.min, rcb.min.min(c)), max: Vec3A::select(m, rcb.max, rcb.max.max(c)) };
        }
        debug_assert_eq!(li, nl);
        idx.copy_from_slice(order);
        let i = nl;
        Some(Split { mid: i, bounds: Some((lb, rb)), centroids: Some((lcb, rcb)) })
    }
}

/// Build with the binned SAH.
pub fn build(prims: &Primitives, bins: usize) -> BinaryBvh {
    build_with(prims, &SahSplit { bins }, Builder::Sah)
}
