//! The builder framework shared by every split strategy: per-primitive boxes
//! and centroids computed once, a recursive top-down build over an index array
//! partitioned in place, flattening into depth-first [`Node`]s, and a rayon
//! fork at large nodes. Split strategies only decide where to cut.

use std::time::{Duration, Instant};

use glam::{Vec3A, Vec4};
use rayon::prelude::*;

use super::config::Builder;
use crate::geometry::{Aabb, Prim, Primitives};

use super::{LeafPrims, Node};

/// Nodes with at least this many primitives build their two subtrees in
/// parallel (when the rayon pool has more than one thread). Small enough that
/// a mesh of a thousand triangles forks at its root: suzanne (968 triangles)
/// builds in 0.17-0.19 ms on two threads instead of 0.21 ms with 4096
/// (`rtdiff bench --race 7 --threads 2`, three runs each), and dragon_87k's
/// two-thread build is no slower.
const PARALLEL_THRESHOLD: usize = 512;

/// Passes over at least this many references (the root's boxes, the leaf
/// order) run in parallel chunks of this size.
const PARALLEL_PASS: usize = 1 << 14;

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

/// One primitive's bounding box and id, 32 bytes: the element the builders
/// partition. Keeping the box next to the id (instead of an index into a
/// box array) makes every binning and partition pass a sequential stream.
#[derive(Clone, Copy, Debug)]
#[repr(C)]
pub struct PrimRef {
    /// Lower corner in `x, y, z`; `w` holds the low 16 bits of the id as a float.
    lo: Vec4,
    /// Upper corner in `x, y, z`; `w` holds the high 16 bits of the id as a float.
    hi: Vec4,
}

impl PrimRef {
    /// The reference to primitive `id` with box `b`.
    ///
    /// The id is kept as two small integral floats rather than raw bits: the
    /// SIMD box arithmetic also runs on the `w` lanes, and raw bits of small
    /// ids are subnormal floats, which make that arithmetic many times slower.
    #[inline(always)]
    pub fn new(id: u32, b: BoxA) -> Self {
        Self { lo: b.min.extend((id & 0xffff) as f32), hi: b.max.extend((id >> 16) as f32) }
    }

    /// Original primitive id.
    #[inline(always)]
    pub fn id(&self) -> u32 {
        self.lo.w as u32 | ((self.hi.w as u32) << 16)
    }

    /// Bounding box.
    #[inline(always)]
    pub fn boxa(&self) -> BoxA {
        BoxA { min: Vec3A::from_vec4(self.lo), max: Vec3A::from_vec4(self.hi) }
    }

    /// Centre of the bounding box (what the builders split on).
    #[inline(always)]
    pub fn centroid(&self) -> Vec3A {
        (Vec3A::from_vec4(self.lo) + Vec3A::from_vec4(self.hi)) * 0.5
    }
}

/// Per-primitive data some split strategies read, indexed by primitive id.
pub struct BuildInput {
    /// Mean of each triangle's vertices (a sphere's centre): the reports'
    /// "centroid". Only gathered for splitters that ask for it (else empty).
    pub vertex_means: Vec<Vec3A>,
}

impl BuildInput {
    /// Vertex means when `vertex_means` is set (computed in parallel for large meshes).
    pub fn new(prims: &Primitives, vertex_means: bool) -> Self {
        let n = if vertex_means { prims.len() } else { 0 };
        let mean = |i: usize| match prims.get(i) {
            Prim::Triangle(t) => Vec3A::from((t.v[0] + t.v[1] + t.v[2]) / 3.0),
            Prim::Sphere(s) => Vec3A::from(s.center),
        };
        let vertex_means = if parallel_pass(n) {
            (0..n).into_par_iter().with_min_len(PARALLEL_PASS).map(mean).collect()
        } else {
            (0..n).map(mean).collect()
        };
        Self { vertex_means }
    }
}

/// Whether a pass over `n` items runs on the pool: large passes with more
/// than one thread. Otherwise it runs on the calling thread: a parallel
/// iterator called from outside the pool hands even an empty pass to a pool
/// thread and waits for it. (Measured: whole one-thread builds called from
/// the main thread took the same time either way on this machine, whose
/// pool threads were still spinning between builds; the handoff is left out
/// because it can only add a wake-up.)
#[inline]
pub fn parallel_pass(n: usize) -> bool {
    n >= PARALLEL_PASS && rayon::current_num_threads() > 1
}

/// A reference for every primitive, in id order (computed in parallel for large meshes).
pub fn prim_refs(prims: &Primitives) -> Vec<PrimRef> {
    let make = |i: usize| {
        // A triangle's box in SIMD registers (the same minima and maxima
        // as `Triangle::bounds`, two operations per vertex instead of six).
        let b = if let Some(t) = prims.triangles.get(i) {
            let [a, b, c] = t.v.map(Vec3A::from);
            BoxA { min: a.min(b).min(c), max: a.max(b).max(c) }
        } else {
            let b = prims.bounds(i);
            BoxA { min: b.min.into(), max: b.max.into() }
        };
        PrimRef::new(i as u32, b)
    };
    if parallel_pass(prims.len()) {
        (0..prims.len()).into_par_iter().with_min_len(PARALLEL_PASS).map(make).collect()
    } else {
        (0..prims.len()).map(make).collect()
    }
}

/// Union of the boxes of `refs`.
#[inline]
pub fn bounds_of(refs: &[PrimRef]) -> Aabb {
    refs.iter().fold(BoxA::EMPTY, |b, r| b.union(r.boxa())).aabb()
}

/// Box around the centroids of `refs`.
#[inline]
pub fn centroid_bounds_of(refs: &[PrimRef]) -> BoxA {
    refs.iter().fold(BoxA::EMPTY, |b, r| b.grow(r.centroid()))
}

/// The box around `refs` and the box around their centroids, in one pass
/// (in parallel chunks for large inputs: boxes unite exactly in any order,
/// so the result is that of a sequential pass).
pub fn root_bounds(refs: &[PrimRef]) -> (BoxA, BoxA) {
    let one = |c: &[PrimRef]| {
        c.iter().fold((BoxA::EMPTY, BoxA::EMPTY), |(b, cb), r| (b.union(r.boxa()), cb.grow(r.centroid())))
    };
    if parallel_pass(refs.len()) {
        refs.par_chunks(PARALLEL_PASS)
            .map(one)
            .reduce(|| (BoxA::EMPTY, BoxA::EMPTY), |(a, ca), (b, cb)| (a.union(b), ca.union(cb)))
    } else {
        one(refs)
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

    /// Reorder `refs` (the primitives of a node with box `bounds` at level
    /// `depth`) and return `m` with `0 < m < refs.len()` to split it into
    /// `refs[..m]` and `refs[m..]`, or `None` to make the node a leaf. May also
    /// return the exact boxes of the two sides when it has them.
    /// `centroids` is the box around the node's centroids when the caller has it (the root's).
    fn split(
        &self,
        input: &BuildInput,
        refs: &mut [PrimRef],
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
}

impl From<usize> for Split {
    fn from(mid: usize) -> Self {
        Split { mid, bounds: None }
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

/// A built tree before the primitives are gathered: the flattened nodes and
/// the primitive ids in leaf order (leaf ranges index into `order`).
pub struct BuiltTree {
    /// Depth-first nodes; node 0 is the root. Empty when there are no primitives.
    pub nodes: Vec<Node>,
    /// Primitive ids in leaf order.
    pub order: Vec<u32>,
}

/// Run `splitter` over `prims` and flatten the result.
pub fn build_tree(prims: &Primitives, splitter: &dyn Splitter) -> BuiltTree {
    let input = BuildInput::new(prims, splitter.needs_vertex_means());
    let mut refs = prim_refs(prims);
    let mut nodes = Vec::with_capacity(2 * prims.len().max(1));
    if !refs.is_empty() {
        let (root, centroids) = root_bounds(&refs);
        build_node(splitter, &input, &mut refs, root.aabb(), Some(centroids), 0, 0, &mut nodes);
    }
    let order = if parallel_pass(refs.len()) {
        refs.par_iter().with_min_len(PARALLEL_PASS).map(PrimRef::id).collect()
    } else {
        refs.iter().map(PrimRef::id).collect()
    };
    BuiltTree { nodes, order }
}

/// Run `splitter` over `prims`, flatten the result and gather the primitives in leaf order.
pub fn build_with(prims: &Primitives, splitter: &dyn Splitter, builder: Builder) -> BinaryBvh {
    let start = Instant::now();
    let tree = build_tree(prims, splitter);
    let leaf_prims = LeafPrims::new(prims, &tree.order);
    BinaryBvh { nodes: tree.nodes, prims: leaf_prims, builder, build_time: start.elapsed() }
}

#[allow(clippy::too_many_arguments)]
fn build_node(
    s: &dyn Splitter,
    input: &BuildInput,
    idx: &mut [PrimRef],
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
    let Some(Split { mid, bounds: child_bounds }) = s.split(input, idx, &bounds, centroids, depth) else {
        return;
    };
    // Children compute their own centroid boxes when they need them (see
    // `build_sah::partition_branchless`); only the root's comes from outside.
    assert!(mid > 0 && mid < n, "split strategy returned an empty side");
    let (l, r) = idx.split_at_mut(mid);
    let (lb, rb) = child_bounds.unwrap_or_else(|| (bounds_of(l), bounds_of(r)));
    let right_first = first + mid as u32;
    // On a one-thread pool the fork would only add copies of the subtrees.
    if n >= PARALLEL_THRESHOLD && rayon::current_num_threads() > 1 {
        // The left subtree goes straight into `out` (right after this node,
        // as in the sequential order); only the right one is built apart and
        // copied after it.
        let ((), rv) = rayon::join(
            || build_node(s, input, l, lb, None, first, depth + 1, out),
            || {
                let mut v = Vec::with_capacity(2 * r.len());
                build_node(s, input, r, rb, None, right_first, depth + 1, &mut v);
                v
            },
        );
        let right = out.len() as u32;
        append_shifted(out, &rv);
        out[me] = Node::interior(bounds, right);
    } else {
        build_node(s, input, l, lb, None, first, depth + 1, out);
        let right = out.len() as u32;
        build_node(s, input, r, rb, None, right_first, depth + 1, out);
        out[me] = Node::interior(bounds, right);
    }
}

/// Append a subtree built with local node indices, shifting its child links.
///
/// Large subtrees are copied in parallel pieces of [`PARALLEL_PASS`] nodes:
/// the copies at the top forks come last in the build, with the other thread
/// idle, and they write memory no one has touched yet (its page faults
/// included). dragon_full on two threads, a throwaway timer: the root's copy
/// (184,000 nodes) took 3.2-3.4 ms and those one level down up to 3.0 ms.
fn append_shifted(out: &mut Vec<Node>, sub: &[Node]) {
    let base = out.len() as u32;
    let shifted = |n: &Node| if n.is_leaf() { *n } else { Node { offset: n.offset + base, ..*n } };
    if !parallel_pass(sub.len()) {
        out.extend(sub.iter().map(shifted));
        return;
    }
    out.reserve(sub.len());
    let start = out.len();
    out.spare_capacity_mut()[..sub.len()].par_chunks_mut(PARALLEL_PASS).zip(sub.par_chunks(PARALLEL_PASS)).for_each(
        |(dst, src)| {
            for (d, n) in dst.iter_mut().zip(src) {
                d.write(shifted(n));
            }
        },
    );
    // (rayon's `par_extend` over `sub.par_iter().with_min_len(..).map(..)`
    // does the same without `unsafe`, but measured slower: dragon_full's
    // two-thread build-cold 117.0-131.6 -> 122.2-146.6 ms, four alternated pairs.)
    // SAFETY: the `sub.len()` slots after `start` were reserved above, and the
    // pieces, cut alike from them and from `sub`, wrote every one.
    unsafe { out.set_len(start + sub.len()) };
}

/// Move the entries of `idx` satisfying `left` to the front; returns how many there are.
#[inline]
pub fn partition<T>(idx: &mut [T], mut left: impl FnMut(&T) -> bool) -> usize {
    let mut i = 0;
    let mut j = idx.len();
    while i < j {
        if left(&idx[i]) {
            i += 1;
        } else {
            j -= 1;
            idx.swap(i, j);
        }
    }
    i
}
