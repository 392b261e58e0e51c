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

/// A reference for every primitive, in id order, with the box around all of
/// them and the box around their centroids, in one pass (in parallel chunks
/// for large meshes: boxes unite exactly in any order, so the bounds are
/// those of a sequential pass).
///
/// One pass rather than the references and then their bounds: a pass over
/// the 2.8 MB of dragon_87k's references fewer, and on a pool one parallel
/// phase fewer, each of which may have to wake the idle thread (docs/bvh.md,
/// issue 16, twenty-fourth pass).
pub fn prim_refs_and_bounds(prims: &Primitives) -> (Vec<PrimRef>, BoxA, BoxA) {
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
    // Write the references of ids `first..` into `dst`; their two boxes.
    let fill = |first: usize, dst: &mut [std::mem::MaybeUninit<PrimRef>]| {
        let (mut b, mut cb) = (BoxA::EMPTY, BoxA::EMPTY);
        for (k, d) in dst.iter_mut().enumerate() {
            let r = make(first + k);
            (b, cb) = (b.union(r.boxa()), cb.grow(r.centroid()));
            d.write(r);
        }
        (b, cb)
    };
    let n = prims.len();
    let mut refs = Vec::with_capacity(n);
    let room = &mut refs.spare_capacity_mut()[..n];
    let (b, cb) = if parallel_pass(n) {
        room.par_chunks_mut(PARALLEL_PASS)
            .enumerate()
            .map(|(c, dst)| fill(c * PARALLEL_PASS, dst))
            .reduce(|| (BoxA::EMPTY, BoxA::EMPTY), |(a, ca), (b, cb)| (a.union(b), ca.union(cb)))
    } else {
        fill(0, room)
    };
    // SAFETY: the `n` slots were reserved above and the chunks, which tile
    // them, wrote every one.
    unsafe { refs.set_len(n) };
    (refs, b, cb)
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
    let (mut refs, bounds, centroids) = prim_refs_and_bounds(prims);
    let mut root = Piece { nodes: Vec::with_capacity(2 * prims.len().max(1)), forks: Vec::new(), base: 0 };
    if !refs.is_empty() {
        build_node(splitter, &input, &mut refs, bounds.aabb(), Some(centroids), 0, 0, &mut root.nodes, &mut root.forks);
    }
    // The nodes' copy into place and the ids' gathering are independent: on
    // a pool they run as one parallel phase.
    let (nodes, order) = if parallel_pass(refs.len()) {
        rayon::join(|| root.flatten(), || refs.par_iter().with_min_len(PARALLEL_PASS).map(PrimRef::id).collect())
    } else {
        (root.flatten(), refs.iter().map(PrimRef::id).collect())
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

/// Build the subtree over `idx` (box `bounds`, primitives from `first` on,
/// at level `depth`) depth-first at the end of `out`. At a fork the right
/// subtree is built apart, on the pool, into a [`Piece`] pushed on `forks`
/// (the list of the piece that `out` belongs to).
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
    forks: &mut Vec<(u32, Piece)>,
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
        // as in the sequential order); the right one into a piece of its
        // own, put in place once the whole tree is built.
        let ((), right) = rayon::join(
            || build_node(s, input, l, lb, None, first, depth + 1, out, forks),
            || {
                let mut piece = Piece { nodes: Vec::with_capacity(r.len()), forks: Vec::new(), base: 0 };
                build_node(s, input, r, rb, None, right_first, depth + 1, &mut piece.nodes, &mut piece.forks);
                piece
            },
        );
        // The link is set when the pieces are laid out (`Piece::lay_out`).
        out[me] = Node::interior(bounds, u32::MAX);
        forks.push((me as u32, right));
    } else {
        build_node(s, input, l, lb, None, first, depth + 1, out, forks);
        let right = out.len() as u32;
        build_node(s, input, r, rb, None, right_first, depth + 1, out, forks);
        out[me] = Node::interior(bounds, right);
    }
}

/// Part of a tree built on its own: depth-first nodes whose links are
/// indices into `nodes`, except at the forks, whose right subtrees are
/// pieces of their own.
///
/// Below a node that does not fork nothing forks (a fork needs more
/// primitives), so a piece's forks lie on its leftmost path and the deepest
/// ends first: in depth-first order the piece's nodes come first, then the
/// forks' pieces in the order they were pushed. Each node is copied once,
/// into its place in the final array. (Until stop 36 each right subtree was
/// copied into its parent's array at its fork, and so again at every fork
/// above it whose right side it was in: dragon_full forks down ten levels.
/// Callgrind, instructions per build of dragon_87k through `build_tracer`,
/// `examples/call_path.rs` `build`: one thread 161.7M; two threads 166.7M
/// before, 164.0M with the pieces.)
struct Piece {
    /// The piece's nodes, depth-first.
    nodes: Vec<Node>,
    /// Each fork's index in `nodes` and the piece of its right subtree, deepest fork first.
    forks: Vec<(u32, Piece)>,
    /// Index of the piece's first node in the final array (set by [`Self::lay_out`]).
    base: u32,
}

impl Piece {
    /// The whole tree in one depth-first array (`self` is the root's piece).
    fn flatten(mut self) -> Vec<Node> {
        if self.forks.is_empty() {
            return self.nodes;
        }
        let total = self.lay_out(0);
        let mut rest: Vec<&Piece> = Vec::new();
        for (_, p) in &self.forks {
            p.preorder(&mut rest);
        }
        let mut out = self.nodes;
        let start = out.len();
        out.reserve(total as usize - start);
        // Cut the room after the root's nodes into one slot range per piece
        // (depth-first order is increasing `base`), in pieces of at most
        // `PARALLEL_PASS` nodes.
        let mut jobs = Vec::new();
        let mut room = &mut out.spare_capacity_mut()[..total as usize - start];
        for p in rest {
            let (dst, tail) = room.split_at_mut(p.nodes.len());
            room = tail;
            for (d, s) in dst.chunks_mut(PARALLEL_PASS).zip(p.nodes.chunks(PARALLEL_PASS)) {
                jobs.push((d, s, p.base));
            }
        }
        debug_assert!(room.is_empty());
        let copy = |(dst, src, base): (&mut [std::mem::MaybeUninit<Node>], &[Node], u32)| {
            for (d, n) in dst.iter_mut().zip(src) {
                d.write(if n.is_leaf() { *n } else { Node { offset: n.offset + base, ..*n } });
            }
        };
        if parallel_pass(total as usize - start) {
            jobs.into_par_iter().for_each(copy);
        } else {
            jobs.into_iter().for_each(copy);
        }
        // SAFETY: the `total - start` slots after `start` were reserved above,
        // and the jobs, cut alike from them and from the pieces' nodes (which
        // number exactly `total - start`, by `lay_out`), wrote every one.
        unsafe { out.set_len(total as usize) };
        out
    }

    /// Place this piece at `base` and its forks' pieces after it, and point
    /// each fork at its right subtree (relative to `base`, as the piece's
    /// other links are until the copy adds `base`). Returns the index after
    /// the last node placed.
    fn lay_out(&mut self, base: u32) -> u32 {
        self.base = base;
        let mut next = base + self.nodes.len() as u32;
        for (at, p) in &mut self.forks {
            self.nodes[*at as usize].offset = next - base;
            next = p.lay_out(next);
        }
        next
    }

    /// This piece and its forks' pieces in depth-first (increasing `base`) order.
    fn preorder<'a>(&'a self, out: &mut Vec<&'a Piece>) {
        out.push(self);
        for (_, p) in &self.forks {
            p.preorder(out);
        }
    }
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bvh::build_median::MedianSplit;
    use crate::bvh::build_sah::SahSplit;
    use crate::bvh::collapse::tests::scattered;

    /// Every interior link points past its node and at a node whose
    /// primitives follow its left sibling's, every leaf range lies inside
    /// the order, and every primitive is in exactly one leaf.
    fn check_links(tree: &BuiltTree) {
        let mut seen = vec![0u32; tree.order.len()];
        let mut stack = vec![(0usize, 0u32, tree.order.len() as u32)];
        while let Some((i, first, count)) = stack.pop() {
            let n = &tree.nodes[i];
            if n.is_leaf() {
                assert_eq!((n.offset, n.count), (first, count), "leaf {i}");
                for k in first..first + count {
                    seen[k as usize] += 1;
                }
                continue;
            }
            let (l, r) = (i + 1, n.offset as usize);
            assert!(r > l && r < tree.nodes.len(), "node {i} links to {r}");
            let lc = leaf_span(&tree.nodes, l);
            stack.push((l, first, lc));
            stack.push((r, first + lc, count - lc));
        }
        assert!(seen.iter().all(|&s| s == 1), "a primitive is in no leaf or in two");
    }

    /// Number of primitives under node `i`.
    fn leaf_span(nodes: &[Node], i: usize) -> u32 {
        let n = &nodes[i];
        if n.is_leaf() { n.count } else { leaf_span(nodes, i + 1) + leaf_span(nodes, n.offset as usize) }
    }

    /// The binary tree built on two threads (its right subtrees built apart
    /// in pieces, laid out once at the end) is node for node the one-thread
    /// tree, for the SAH builder and for the median builder's one-primitive
    /// leaves (the most nodes, the deepest forks).
    #[test]
    fn two_threads_lay_out_the_one_thread_tree() {
        let prims = scattered(60_000, 7);
        let sah = SahSplit { bins: 16, block: crate::bvh::packet::leaf_block(prims.len()) };
        let median = MedianSplit { leaf_size: 1 };
        for splitter in [&sah as &dyn Splitter, &median] {
            let build = |threads: usize| {
                let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
                pool.install(|| build_tree(&prims, splitter))
            };
            let (a, b) = (build(1), build(2));
            assert!(a.nodes.len() > 10_000);
            check_links(&a);
            assert!(a.nodes == b.nodes, "1 and 2 threads laid out different nodes");
            assert_eq!(a.order, b.order);
        }
    }
}
