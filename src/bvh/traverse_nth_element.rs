//! The reports' nth-element traversal (section 3.5.2, "Nth element"): an
//! unsorted `Vec`; before each pick, `select_nth_unstable` (C++'s
//! `std::nth_element`) moves the nearest entry to the last position, from
//! where it is removed in O(1).

use super::traverse_ordered::{Frontier, cmp_entry};

/// Unsorted vector frontier with selection of the nearest entry.
#[derive(Default)]
pub struct NthFrontier(Vec<(f32, u32)>);

impl Frontier for NthFrontier {
    #[inline]
    fn push(&mut self, t: f32, node: u32) {
        self.0.push((t, node));
    }
    #[inline]
    fn pop_nearest(&mut self) -> Option<(f32, u32)> {
        let n = self.0.len();
        if n == 0 {
            return None;
        }
        // Descending order: position n - 1 receives the smallest distance.
        self.0.select_nth_unstable_by(n - 1, |a, b| cmp_entry(b, a));
        self.0.pop()
    }
}
