//! The reports' priority-queue traversal (section 3.5.2): a binary heap
//! (`std::collections::BinaryHeap`) ordered by entry distance, always
//! expanding the nearest box, stopping when it lies beyond the closest hit.

use std::cmp::Ordering;
use std::collections::BinaryHeap;

use super::traverse_ordered::{Frontier, cmp_entry};

/// Heap entry ordered so that the *smallest* distance is the heap's maximum.
#[derive(Clone, Copy, Debug)]
struct Entry(f32, u32);

impl PartialEq for Entry {
    fn eq(&self, o: &Self) -> bool {
        self.cmp(o) == Ordering::Equal
    }
}
impl Eq for Entry {}
impl PartialOrd for Entry {
    fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
        Some(self.cmp(o))
    }
}
impl Ord for Entry {
    fn cmp(&self, o: &Self) -> Ordering {
        cmp_entry(&(o.0, o.1), &(self.0, self.1))
    }
}

/// Binary-heap frontier.
#[derive(Default)]
pub struct HeapFrontier(BinaryHeap<Entry>);

impl Frontier for HeapFrontier {
    #[inline]
    fn push(&mut self, t: f32, node: u32) {
        self.0.push(Entry(t, node));
    }
    #[inline]
    fn pop_nearest(&mut self) -> Option<(f32, u32)> {
        self.0.pop().map(|e| (e.0, e.1))
    }
}
