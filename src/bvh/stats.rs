//! BVH statistics: the figures the reports' performance table lists (levels,
//! primitives per leaf, build time) plus node counts, memory and SAH cost.

use serde::Serialize;

use super::BinaryBvh;
use super::build_sah::{INTERSECTION_COST, TRAVERSAL_COST, leaf_slots};
use super::packet::leaf_block;

/// Statistics of a binary BVH (and of its 8-wide collapse).
#[derive(Clone, Debug, Serialize)]
pub struct BvhStats {
    /// Builder name.
    pub builder: String,
    /// Number of primitives.
    pub primitives: usize,
    /// Binary nodes (inner + leaves).
    pub nodes: usize,
    /// Leaves.
    pub leaves: usize,
    /// Levels: the deepest leaf's depth + 1 (a lone root leaf is 1 level).
    pub levels: u32,
    /// Largest primitive count of a leaf.
    pub max_prims_per_leaf: u32,
    /// Mean primitive count of a leaf.
    pub mean_prims_per_leaf: f64,
    /// SAH cost with the `sah` builder's constants, leaf counts rounded up to
    /// whole tests of [`super::packet::leaf_block`] triangles, relative to the
    /// root's surface area.
    pub sah_cost: f64,
    /// Memory of binary nodes and reordered primitives, in bytes.
    pub bytes: usize,
    /// Nodes of the 8-wide BVH used by the `fast` traversal.
    pub wide_nodes: usize,
    /// Memory of the 8-wide BVH (nodes and primitives), in bytes.
    pub wide_bytes: usize,
    /// Build time of the binary BVH, in milliseconds.
    pub build_ms: f64,
}

impl BvhStats {
    /// Gather statistics of `bvh`; `wide` is its 8-wide collapse (nodes, bytes) if built.
    pub fn of(bvh: &BinaryBvh, wide: Option<(usize, usize)>) -> Self {
        let mut s = Self {
            builder: clap::ValueEnum::to_possible_value(&bvh.builder)
                .map_or_else(String::new, |v| v.get_name().to_string()),
            primitives: bvh.prims.len(),
            nodes: bvh.nodes.len(),
            leaves: 0,
            levels: 0,
            max_prims_per_leaf: 0,
            mean_prims_per_leaf: 0.0,
            sah_cost: 0.0,
            bytes: bvh.nodes.len() * std::mem::size_of::<super::Node>() + bvh.prims.bytes(),
            wide_nodes: wide.map_or(0, |w| w.0),
            wide_bytes: wide.map_or(0, |w| w.1),
            build_ms: bvh.build_time.as_secs_f64() * 1e3,
        };
        let Some(root) = bvh.nodes.first() else { return s };
        let root_area = f64::from(root.bounds().surface_area());
        let mut area_sum = 0.0f64;
        let block = leaf_block(bvh.prims.len());
        let mut stack = vec![(0usize, 1u32)];
        while let Some((i, level)) = stack.pop() {
            let n = &bvh.nodes[i];
            let a = f64::from(n.bounds().surface_area());
            if n.is_leaf() {
                s.leaves += 1;
                s.levels = s.levels.max(level);
                s.max_prims_per_leaf = s.max_prims_per_leaf.max(n.count);
                area_sum += a * f64::from(INTERSECTION_COST) * leaf_slots(n.count as usize, block) as f64;
            } else {
                area_sum += a * f64::from(TRAVERSAL_COST);
                stack.push((i + 1, level + 1));
                stack.push((n.offset as usize, level + 1));
            }
        }
        s.mean_prims_per_leaf = s.primitives as f64 / s.leaves as f64;
        // A zero-area root (all primitives degenerate to a point) has cost 0 by convention.
        s.sah_cost = if root_area > 0.0 { area_sum / root_area } else { 0.0 };
        s
    }
}
