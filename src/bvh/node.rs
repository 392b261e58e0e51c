//! The flattened binary BVH node: 32 bytes, depth-first order.

use glam::Vec3;

use crate::geometry::Aabb;

/// One node of a flattened binary BVH, 32 bytes.
///
/// Nodes are stored depth-first: an interior node's left child immediately
/// follows it and `offset` is the index of its right child. A leaf
/// (`count > 0`) covers the primitives `offset .. offset + count` of the
/// reordered primitive array ([`super::LeafPrims`]).
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(32))]
pub struct Node {
    /// Lower corner of the node's box.
    pub min: Vec3,
    /// Right child (interior) or first primitive (leaf).
    pub offset: u32,
    /// Upper corner of the node's box.
    pub max: Vec3,
    /// Number of primitives; 0 for an interior node.
    pub count: u32,
}

const _: () = assert!(std::mem::size_of::<Node>() == 32);

impl Node {
    /// A leaf over `count` primitives starting at `first`.
    #[inline]
    pub fn leaf(bounds: Aabb, first: u32, count: u32) -> Self {
        Self { min: bounds.min, offset: first, max: bounds.max, count }
    }

    /// An interior node whose right child is node `right` (the left child is the next node).
    #[inline]
    pub fn interior(bounds: Aabb, right: u32) -> Self {
        Self { min: bounds.min, offset: right, max: bounds.max, count: 0 }
    }

    /// True for leaves.
    #[inline]
    pub fn is_leaf(&self) -> bool {
        self.count > 0
    }

    /// The node's box.
    #[inline]
    pub fn bounds(&self) -> Aabb {
        Aabb::new(self.min, self.max)
    }
}
