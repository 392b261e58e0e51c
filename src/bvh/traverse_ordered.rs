//! The distance-ordered traversal loop shared by the reports' priority-queue
//! and vector variants: a frontier of `(entry distance, node)` pairs, always
//! expanding the nearest, stopping once the nearest entry lies beyond the
//! closest hit found so far. The variants differ only in the frontier.

use crate::geometry::triangle::WatertightRay;
use crate::geometry::{Hit, Ray, TriangleKernel, TriangleTest};

use super::BinaryBvh;
use super::count::Count;
use super::slab::{RayPre, cull_bound};

/// A set of boxes still to visit, keyed by entry distance.
pub trait Frontier: Default {
    /// Add a node with entry distance `t`.
    fn push(&mut self, t: f32, node: u32);
    /// Called after the children of a node have been pushed.
    fn settle(&mut self) {}
    /// Remove and return the entry with the smallest distance.
    fn pop_nearest(&mut self) -> Option<(f32, u32)>;
}

/// Closest hit, expanding boxes nearest-first from frontier `F`.
pub fn intersect<F: Frontier>(bvh: &BinaryBvh, ray: &Ray, test: TriangleTest) -> Option<Hit> {
    crate::with_triangle_kernel!(test, K => intersect_counting::<F, K, ()>(bvh, ray, &mut ()))
}

/// [`intersect`] reporting every box test, leaf test and closer hit to `counts`.
#[inline(always)]
pub fn intersect_counting<F: Frontier, K: TriangleKernel, C: Count>(
    bvh: &BinaryBvh,
    ray: &Ray,
    counts: &mut C,
) -> Option<Hit> {
    let root = bvh.nodes.first()?;
    let pre = RayPre::new(ray);
    let wr = WatertightRay::new(ray.dir);
    let mut r = *ray;
    let mut best = None;
    let mut f = F::default();
    counts.node(0);
    if let Some(t) = pre.hit(root.min, root.max, r.t_min, cull_bound(r.t_max)) {
        f.push(t, 0);
    }
    while let Some((t, i)) = f.pop_nearest() {
        let cull = cull_bound(r.t_max);
        if t > cull {
            break; // every remaining box starts beyond the closest hit
        }
        let node = &bvh.nodes[i as usize];
        if node.is_leaf() {
            counts.leaf(i, node.count);
            if bvh.prims.intersect_leaf::<K>(node.offset, node.count, &mut r, &wr, &mut best) {
                counts.closer();
            }
        } else {
            for c in [i + 1, node.offset] {
                let child = &bvh.nodes[c as usize];
                counts.node(c);
                if let Some(tc) = pre.hit(child.min, child.max, r.t_min, cull) {
                    f.push(tc, c);
                }
            }
            f.settle();
        }
    }
    bvh.prims.finish(best, ray)
}

/// Any hit, visiting boxes in the same order (stops at the first hit).
pub fn occluded<F: Frontier>(bvh: &BinaryBvh, ray: &Ray, test: TriangleTest) -> bool {
    crate::with_triangle_kernel!(test, K => occluded_counting::<F, K, ()>(bvh, ray, &mut ()))
}

/// [`occluded`] reporting every box test and leaf test to `counts`.
#[inline(always)]
pub fn occluded_counting<F: Frontier, K: TriangleKernel, C: Count>(bvh: &BinaryBvh, ray: &Ray, counts: &mut C) -> bool {
    let Some(root) = bvh.nodes.first() else { return false };
    let pre = RayPre::new(ray);
    let wr = WatertightRay::new(ray.dir);
    let t1 = cull_bound(ray.t_max);
    let mut f = F::default();
    counts.node(0);
    if let Some(t) = pre.hit(root.min, root.max, ray.t_min, t1) {
        f.push(t, 0);
    }
    while let Some((_, i)) = f.pop_nearest() {
        let node = &bvh.nodes[i as usize];
        if node.is_leaf() {
            counts.leaf(i, node.count);
            if bvh.prims.occluded_leaf::<K>(node.offset, node.count, ray, &wr) {
                return true;
            }
        } else {
            for c in [i + 1, node.offset] {
                let child = &bvh.nodes[c as usize];
                counts.node(c);
                if let Some(tc) = pre.hit(child.min, child.max, ray.t_min, t1) {
                    f.push(tc, c);
                }
            }
            f.settle();
        }
    }
    false
}

/// Order by distance, then node index (a total, deterministic order).
#[inline]
pub(crate) fn cmp_entry(a: &(f32, u32), b: &(f32, u32)) -> std::cmp::Ordering {
    a.0.total_cmp(&b.0).then(a.1.cmp(&b.1))
}
