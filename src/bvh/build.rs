//! The builder framework shared by every split strategy: per-primitive boxes
//! and centroids computed once, a recursive top-down build over an index array
//! partitioned in place, flattening into depth-first [`Node`]s, and a rayon
//! fork at large nodes. Split strategies only decide where to cut.

use std::time::{Duration, Instant};

use glam::Vec3A;
use rayon::prelude::*;

use crate::accel::Builder;
use crate::geometry::{Aabb, Primitives};

use super::{LeafPrims, Node};

/// Nodes with at least this many primitives build their two subtrees in parallel.
const PARALLEL_THRESHOLD: usize = 4096;

/// A box in SIMD-friendly form for the builders' inner loops.
#[derive(Clone, Copy, Debug)]
pub struct BoxA {
    /// Lower corner.
    pub min: Vec3A,
    /// Upper corner.
    pub max: Vec3A,
}

impl BoxA {
    /// The empty box.
    pub const EMPTY: BoxA = BoxA { min: Vec3A::INFINITY, max: Vec3A::NEG_INFINITY };

    /// Smallest box containing both.
    #[inline(always)]
    pub fn union(self, o: BoxA) -> BoxA {
        BoxA { min: self.min.min(o.min), max: self.max.max(o.max) }
    }

    /// This box grown to contain `p`.
    #[inline(always)]
    pub fn grow(self, p: Vec3A) -> BoxA {
        BoxA { min: self.min.min(p), max: self.max.max(p) }
    }

    /// As an [`Aabb`].
    #[inline]
    pub fn aabb(self) -> Aabb {
        Aabb::new(self.min.into(), self.max.into())
    }

    /// Surface area (0 for an empty box).
    #[inline(always)]
    pub fn half_area(self) -> f32 {
        let e = (self.max - self.min).max(Vec3A::ZERO);
        e.x * e.y + e.y * e.z + e.z * e.x
    }
}

/// Per-primitive data the split strategies read.
pub struct BuildInput {
    /// Bounding box of each primitive.
    pub bounds: Vec<BoxA>,
    /// Centre of each primitive's box.
    pub centroids: Vec<Vec3A>,
    /// Mean of each triangle's vertices (a sphere's centre): the reports'
    /// "centroid". Only gathered for splitters that ask for it (else empty).
    pub vertex_means: Vec<Vec3A>,
}

impl BuildInput {
    /// Boxes and centroids of every primitive (computed in parallel), and
    /// vertex means when `vertex_means` is set.
    pub fn new(prims: &Primitives, vertex_means: bool) -> Self {
        let bounds: Vec<BoxA> = (0..prims.len())
            .into_par_iter()
            .with_min_len(4096)
            .map(|i| {
                let b = prims.bounds(i);
                BoxA { min: b.min.into(), max: b.max.into() }
            })
            .collect();
        let centroids = bounds.par_iter().with_min_len(4096).map(|b| (b.min + b.max) * 0.5).collect();
        let nt = prims.triangles.len();
        let vertex_means = (0..if vertex_means { prims.len() } else { 0 })
            .into_par_iter()
            .with_min_len(4096)
            .map(|i| {
                if i < nt {
                    let v = prims.triangles[i].v;
                    Vec3A::from((v[0] + v[1] + v[2]) / 3.0)
                } else {
                    Vec3A::from(prims.spheres[i - nt].center)
                }
            })
            .collect();
        Self { bounds, centroids, vertex_means }
    }

    /// Union of the boxes of `idx`.
    #[inline]
    pub fn bounds_of(&self, idx: &[u32]) -> Aabb {
        idx.iter().fold(BoxA::EMPTY, |b, &i| b.union(self.bounds[i as usize])).aabb()
    }

    /// Box around the centroids of `idx`.
    #[inline]
    pub fn centroid_bounds_of(&self, idx: &[u32]) -> BoxA {
        idx.iter().fold(BoxA::EMPTY, |b, &i| b.grow(self.centroids[i as usize]))
    }
}

/// A split strategy: the only part that differs between builders.
pub trait Splitter: Sync {
    /// Deepest level a node may have (the root is level 0); nodes there become leaves.
    fn max_depth(&self) -> u32;

    /// True when [`BuildInput::vertex_means`] is needed.
    fn needs_vertex_means(&self) -> bool {
        false
    }

    /// Reorder `idx` (the primitives of a node with box `bounds` at level
    /// `depth`) and return `m` with `0 < m < idx.len()` to split it into
    /// `idx[..m]` and `idx[m..]`, or `None` to make the node a leaf. May also
    /// return the exact boxes of the two sides when it has them.
    /// `centroids` is the box around the node's centroids when the parent's split computed it.
    fn split(
        &self,
        input: &BuildInput,
        idx: &mut [u32],
        bounds: &Aabb,
        centroids: Option<BoxA>,
        depth: u32,
    ) -> Option<Split>;
}

/// Where a node is cut.
pub struct Split {
    /// Number of primitives going left.
    pub mid: usize,
    /// Boxes of the left and right sides, if the strategy computed them.
    pub bounds: Option<(Aabb, Aabb)>,
    /// Boxes around the centroids of the left and right sides, if computed.
    pub centroids: Option<(BoxA, BoxA)>,
}

impl From<usize> for Split {
    fn from(mid: usize) -> Self {
        Split { mid, bounds: None, centroids: None }
    }
}

/// A built binary BVH: flattened nodes plus the reordered primitives.
#[derive(Clone, Debug)]
pub struct BinaryBvh {
    /// Depth-first nodes; node 0 is the root. Empty when there are no primitives.
    pub nodes: Vec<Node>,
    /// Primitives in leaf order.
    pub prims: LeafPrims,
    /// Which builder made it.
    pub builder: Builder,
    /// Wall-clock build time (including the primitive reordering).
    pub build_time: Duration,
}

/// Run `splitter` over `prims` and flatten the result.
pub fn build_with(prims: &Primitives, splitter: &dyn Splitter, builder: Builder) -> BinaryBvh {
    let start = Instant::now();
    let input = BuildInput::new(prims, splitter.needs_vertex_means());
    let mut idx: Vec<u32> = (0..prims.len() as u32).collect();
    let mut nodes = Vec::with_capacity(2 * prims.len().max(1));
    if !idx.is_empty() {
        let root = input.bounds_of(&idx);
        build_node(splitter, &input, &mut idx, root, None, 0, 0, &mut nodes);
    }
    let leaf_prims = LeafPrims::new(prims, &idx);
    BinaryBvh { nodes, prims: leaf_prims, builder, build_time: start.elapsed() }
}

#[allow(clippy::too_many_arguments)]
fn build_node(
    s: &dyn Splitter,
    input: &BuildInput,
    idx: &mut [u32],
    bounds: Aabb,
    centroids: Option<BoxA>,
    first: u32,
    depth: u32,
    out: &mut Vec<Node>,
) {
    let n = idx.len();
    let me = out.len();
    out.push(Node::leaf(bounds, first, n as u32));
    if n <= 1 || depth >= s.max_depth() {
        return;
    }
    let Some(Split { mid, bounds: child_bounds, centroids: child_cb }) = s.split(input, idx, &bounds, centroids, depth)
    else {
        return;
    };
    let (lc, rc) = child_cb.map_or((None, None), |(l, r)| (Some(l), Some(r)));
    assert!(mid > 0 && mid < n, "split strategy returned an empty side");
    let (l, r) = idx.split_at_mut(mid);
    let (lb, rb) = child_bounds.unwrap_or_else(|| (input.bounds_of(l), input.bounds_of(r)));
    let right_first = first + mid as u32;
    if n >= PARALLEL_THRESHOLD {
        let (lv, rv) = rayon::join(
            || {
                let mut v = Vec::with_capacity(2 * l.len());
                build_node(s, input, l, lb, lc, first, depth + 1, &mut v);
                v
            },
            || {
                let mut v = Vec::with_capacity(2 * r.len());
                build_node(s, input, r, rb, rc, right_first, depth + 1, &mut v);
                v
            },
        );
        append_shifted(out, &lv);
        let right = out.len() as u32;
        append_shifted(out, &rv);
        out[me] = Node::interior(bounds, right);
    } else {
        build_node(s, input, l, lb, lc, first, depth + 1, out);
        let right = out.len() as u32;
        build_node(s, input, r, rb, rc, right_first, depth + 1, out);
        out[me] = Node::interior(bounds, right);
    }
}

/// Append a subtree built with local node indices, shifting its child links.
fn append_shifted(out: &mut Vec<Node>, sub: &[Node]) {
    let base = out.len() as u32;
    out.extend(sub.iter().map(|n| if n.is_leaf() { *n } else { Node { offset: n.offset + base, ..*n } }));
}

/// Move the entries of `idx` satisfying `left` to the front; returns how many there are.
#[inline]
pub fn partition(idx: &mut [u32], mut left: impl FnMut(u32) -> bool) -> usize {
    let mut i = 0;
    let mut j = idx.len();
    while i < j {
        if left(idx[i]) {
            i += 1;
        } else {
            j -= 1;
            idx.swap(i, j);
        }
    }
    i
}
