//! The reports' basic traversal (section 3.5.2): a depth-first walk that
//! enters every child whose box the ray hits, in fixed left-right order.
//! Boxes are tested against the ray's current interval, which shrinks as
//! closer hits are found.

use crate::geometry::triangle::WatertightRay;
use crate::geometry::{Hit, Ray, TriangleKernel, TriangleTest};

use super::BinaryBvh;
use super::count::Count;
use super::slab::{RayPre, cull_bound};

/// Stack size: one pending sibling per level, levels are capped at 100 by every builder.
pub(crate) const STACK: usize = 128;

/// Closest hit by depth-first traversal.
pub fn intersect(bvh: &BinaryBvh, ray: &Ray, test: TriangleTest) -> Option<Hit> {
    crate::with_triangle_kernel!(test, K => intersect_counting::<K, ()>(bvh, ray, &mut ()))
}

/// [`intersect`] reporting every box test, leaf test and closer hit to `counts`.
#[inline(always)]
pub fn intersect_counting<K: TriangleKernel, C: Count>(bvh: &BinaryBvh, ray: &Ray, counts: &mut C) -> Option<Hit> {
    if bvh.nodes.is_empty() {
        return None;
    }
    let pre = RayPre::new(ray);
    let wr = WatertightRay::new(ray.dir);
    let mut r = *ray;
    let mut best = None;
    let mut stack = [0u32; STACK];
    let mut sp = 1;
    while sp > 0 {
        sp -= 1;
        let i = stack[sp];
        let node = &bvh.nodes[i as usize];
        counts.node(i);
        if pre.hit(node.min, node.max, r.t_min, cull_bound(r.t_max)).is_none() {
            continue;
        }
        if node.is_leaf() {
            counts.leaf(i, node.count);
            if bvh.prims.intersect_leaf::<K>(node.offset, node.count, &mut r, &wr, &mut best) {
                counts.closer();
            }
        } else {
            // Right pushed first so the left child is visited first.
            stack[sp] = node.offset;
            stack[sp + 1] = i + 1;
            sp += 2;
        }
    }
    bvh.prims.finish(best, ray)
}

/// Any hit by depth-first traversal.
pub fn occluded(bvh: &BinaryBvh, ray: &Ray, test: TriangleTest) -> bool {
    crate::with_triangle_kernel!(test, K => occluded_counting::<K, ()>(bvh, ray, &mut ()))
}

/// [`occluded`] reporting every box test and leaf test to `counts`.
#[inline(always)]
pub fn occluded_counting<K: TriangleKernel, C: Count>(bvh: &BinaryBvh, ray: &Ray, counts: &mut C) -> bool {
    if bvh.nodes.is_empty() {
        return false;
    }
    let pre = RayPre::new(ray);
    let wr = WatertightRay::new(ray.dir);
    let t1 = cull_bound(ray.t_max);
    let mut stack = [0u32; STACK];
    let mut sp = 1;
    while sp > 0 {
        sp -= 1;
        let i = stack[sp];
        let node = &bvh.nodes[i as usize];
        counts.node(i);
        if pre.hit(node.min, node.max, ray.t_min, t1).is_none() {
            continue;
        }
        if node.is_leaf() {
            counts.leaf(i, node.count);
            if bvh.prims.occluded_leaf::<K>(node.offset, node.count, ray, &wr) {
                return true;
            }
        } else {
            stack[sp] = node.offset;
            stack[sp + 1] = i + 1;
            sp += 2;
        }
    }
    false
}
