//! The reports' sorted-vector traversal (section 3.5.2, "Sorted"): a `Vec`
//! sorted after new entries are added so that the nearest box is last,
//! popped in O(1).

use super::traverse_ordered::{Frontier, cmp_entry};

/// Vector frontier kept sorted by decreasing distance.
#[derive(Default)]
pub struct SortedFrontier(Vec<(f32, u32)>);

impl Frontier for SortedFrontier {
    #[inline]
    fn push(&mut self, t: f32, node: u32) {
        self.0.push((t, node));
    }
    #[inline]
    fn settle(&mut self) {
        self.0.sort_unstable_by(|a, b| cmp_entry(b, a));
    }
    #[inline]
    fn pop_nearest(&mut self) -> Option<(f32, u32)> {
        self.0.pop()
    }
}
