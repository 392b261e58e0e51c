//! Zero-cost instrumentation of the traversals: every traversal is generic
//! over a [`Count`] that it tells what it does (node box tests, leaf tests,
//! closer hits). Production calls pass `()`, whose empty methods compile
//! away; [`TraversalCounts`] sums the work (heatmaps, `traversal_counts`),
//! and [`VisitLog`] records which nodes and leaves one ray visited (the
//! `traversal` overlay of `rtdiff debug --draw`).

use serde::Serialize;

/// What a traversal reports as it goes.
pub trait Count {
    /// A query starts (one closest-hit or any-hit ray).
    #[inline(always)]
    fn ray(&mut self) {}
    /// Node `index` is visited: a binary node's box is tested, or a wide
    /// node's eight child boxes are tested.
    fn node(&mut self, index: u32);
    /// A leaf's `count` primitives are tested. `leaf` names the leaf: the
    /// binary node index, or in a wide tree the leaf lane's `child` value
    /// (its first packet or entry).
    fn leaf(&mut self, leaf: u32, count: u32);
    /// The leaf just tested produced a closer hit (closest-hit queries only).
    #[inline(always)]
    fn closer(&mut self) {}
}

impl Count for () {
    #[inline(always)]
    fn node(&mut self, _: u32) {}
    #[inline(always)]
    fn leaf(&mut self, _: u32, _: u32) {}
}

/// Work done by traversals, summed over rays.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct TraversalCounts {
    /// Rays traced (closest-hit and any-hit queries).
    pub rays: u64,
    /// Node visits: binary node boxes tested, or 8-wide nodes whose eight boxes were tested.
    pub nodes: u64,
    /// Leaves whose primitives were tested.
    pub leaves: u64,
    /// Leaf packets of 4 triangles the `fast` path tests (for binary
    /// traversals: the packets the same leaves would fill).
    pub packets: u64,
    /// Primitives (triangles and spheres) tested.
    pub triangles: u64,
}

impl TraversalCounts {
    /// Element-wise sum.
    pub fn add(&mut self, o: &TraversalCounts) {
        self.rays += o.rays;
        self.nodes += o.nodes;
        self.leaves += o.leaves;
        self.packets += o.packets;
        self.triangles += o.triangles;
    }
}

impl Count for TraversalCounts {
    #[inline(always)]
    fn ray(&mut self) {
        self.rays += 1;
    }
    #[inline(always)]
    fn node(&mut self, _: u32) {
        self.nodes += 1;
    }
    #[inline(always)]
    fn leaf(&mut self, _: u32, count: u32) {
        self.leaves += 1;
        self.packets += super::packet::packets_for(count) as u64;
        self.triangles += u64::from(count);
    }
}

/// One event of a [`VisitLog`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum Visit {
    /// [`Count::node`].
    Node(u32),
    /// [`Count::leaf`]: the leaf's name and primitive count.
    Leaf(u32, u32),
    /// [`Count::closer`].
    Closer,
}

/// Every event of the traversals it was passed to, in order.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize)]
pub struct VisitLog {
    /// The events.
    pub events: Vec<Visit>,
}

impl VisitLog {
    /// The leaf that produced the final closest hit: the last leaf tested
    /// before the last [`Visit::Closer`] (None when nothing was hit).
    pub fn hit_leaf(&self) -> Option<u32> {
        let last = self.events.iter().rposition(|e| *e == Visit::Closer)?;
        self.events[..last].iter().rev().find_map(|e| match e {
            Visit::Leaf(l, _) => Some(*l),
            _ => None,
        })
    }
}

impl Count for VisitLog {
    fn node(&mut self, index: u32) {
        self.events.push(Visit::Node(index));
    }
    fn leaf(&mut self, leaf: u32, count: u32) {
        self.events.push(Visit::Leaf(leaf, count));
    }
    fn closer(&mut self) {
        self.events.push(Visit::Closer);
    }
}
