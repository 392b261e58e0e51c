//! `bvh-level=N`: the boxes of every node at level N of the binary BVH
//! (the root is level 0), each in its own colour, as the reports' "debug level".

use super::{Context, Overlay, node_levels};
use crate::debug::lines::{Lines, color};
use crate::error::{Error, Result};

/// The boxes of one BVH level.
pub struct BvhLevel {
    /// The level (0: the root).
    pub level: u32,
}

impl Overlay for BvhLevel {
    fn name(&self) -> String {
        format!("bvh-level={}", self.level)
    }

    fn lines(&self, ctx: &Context) -> Result<Lines> {
        let bvh = ctx.binary_bvh();
        let levels = node_levels(&bvh);
        let at: Vec<usize> = (0..bvh.nodes.len()).filter(|&i| levels[i] == self.level).collect();
        if at.is_empty() {
            let deepest = levels.iter().max().copied().unwrap_or(0);
            return Err(Error::Invalid(format!(
                "bvh-level={}: the BVH has levels 0 to {deepest} ({} nodes)",
                self.level,
                bvh.nodes.len()
            )));
        }
        let mut lines = Lines::default();
        for (k, &i) in at.iter().enumerate() {
            lines.aabb(&bvh.nodes[i].bounds(), color::palette(k, at.len().min(12)));
        }
        Ok(lines)
    }
}
