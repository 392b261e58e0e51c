//! `bvh-leaf=N`: the N-th leaf of the binary BVH (depth-first order, from 0)
//! with its box and its primitives, as the reports' "debug leaves".

use super::{Context, Overlay};
use crate::debug::lines::{Lines, color};
use crate::error::{Error, Result};
use crate::geometry::Prim;

/// One leaf and its primitives.
pub struct BvhLeaf {
    /// Leaf index in depth-first order.
    pub index: u32,
}

impl Overlay for BvhLeaf {
    fn name(&self) -> String {
        format!("bvh-leaf={}", self.index)
    }

    fn lines(&self, ctx: &Context) -> Result<Lines> {
        let bvh = ctx.binary_bvh();
        let leaves: Vec<usize> = (0..bvh.nodes.len()).filter(|&i| bvh.nodes[i].is_leaf()).collect();
        let Some(&i) = leaves.get(self.index as usize) else {
            return Err(Error::Invalid(format!(
                "bvh-leaf={}: the BVH has {} leaves (0 to {})",
                self.index,
                leaves.len(),
                leaves.len().saturating_sub(1)
            )));
        };
        let node = bvh.nodes[i];
        let mut lines = Lines::default();
        for e in &bvh.prims.entries[node.offset as usize..(node.offset + node.count) as usize] {
            match ctx.scene.prims.get(e.id as usize) {
                Prim::Triangle(t) => lines.triangle(t.v, color::CYAN),
                Prim::Sphere(s) => {
                    for axis in [glam::Vec3::X, glam::Vec3::Y, glam::Vec3::Z] {
                        lines.circle(s.center, axis, s.radius, 48, color::CYAN);
                    }
                }
            }
        }
        lines.aabb(&node.bounds(), color::YELLOW);
        Ok(lines)
    }
}
