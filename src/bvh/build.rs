//! The builder framework shared by every split strategy: per-primitive boxes
//! and centroids computed once, a recursive top-down build over an index array
//! partitioned in place, flattening into depth-first [`Node`]s, and a rayon
//! fork at large nodes. Split strategies only decide where to cut.

use std::mem::MaybeUninit;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::{Duration, Instant};

use glam::{Vec3A, Vec4};
use rayon::prelude::*;

use super::config::Builder;
use crate::geometry::{Aabb, Prim, Primitives};

use super::{LeafPrims, Node};

/// Nodes with at least this many primitives (and at least the share of the
/// tree's that [`FORKS_PER_THREAD`] sets) build their two subtrees in parallel
/// when the rayon pool has more than one thread. Small enough that
/// a mesh of a thousand triangles forks at its root: suzanne (968 triangles)
/// builds in 0.17-0.19 ms on two threads instead of 0.21 ms with 4096
/// (`rtdiff bench --race 7 --threads 2`, three runs each), and dragon_87k's
/// two-thread build is no slower.
const PARALLEL_THRESHOLD: usize = 512;

/// Nodes fork only if they hold at least one in `FORKS_PER_THREAD` times
/// the pool's threads of the tree's primitives: about twice that many forks
/// per tree, plenty for each thread to take work. A fork whose right subtree
/// another thread takes leaves a gap in the [`GappedTree`], whose edge pages
/// are written whole: when every fork left a gap, dragon_full forked some
/// 3,400 times with [`PARALLEL_THRESHOLD`] alone and took 6,000 page faults
/// more per 8 two-thread builds than with forks at one node in 128 of its
/// primitives. Gaps at the taken forks only, one in
/// 8, 32 and 128 measured alike (`RAYON_NUM_THREADS=2 call_path
/// dragon_full.obj build 15`, three alternated runs: 63.7-66.7, 63.1-65.9,
/// 63.5-69.0 ms).
const FORKS_PER_THREAD: usize = 16;

/// Passes over at least this many references (the root's boxes, the leaf
/// order) run in parallel chunks of this size.
const PARALLEL_PASS: usize = 1 << 14;

/// Blocks larger than this come from the system (`mmap`) at every
/// allocation with glibc, whose adaptive mmap threshold stops at 32 MiB.
const FRESH_BYTES: usize = 32 << 20;

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
        // SAFETY: both `w` lanes hold integers in `0..=0xffff` (`new`),
        // which convert exactly (one truncation each, without the
        // saturating conversion's checks).
        unsafe { self.lo.w.to_int_unchecked::<u32>() | (self.hi.w.to_int_unchecked::<u32>() << 16) }
    }

    /// Bounding box.
    #[inline(always)]
    pub fn boxa(&self) -> BoxA {
        BoxA { min: Vec3A::from_vec4(self.lo), max: Vec3A::from_vec4(self.hi) }
    }

    /// Centre of the bounding box (what the builders split on).
    #[inline(always)]
    pub fn centroid(&self) -> Vec3A {
        self.doubled_centroid() * 0.5
    }

    /// Twice the centre of the bounding box, `min + max`: the SAH builder
    /// bins and partitions on it, with its scale halved, which gives the
    /// same bins as the centre itself (a product by two commutes with
    /// rounding, short of the subnormal and overflowing ranges, 2^-125 and
    /// 2^127) without a multiplication per reference and per pass.
    #[inline(always)]
    pub fn doubled_centroid(&self) -> Vec3A {
        Vec3A::from_vec4(self.lo) + Vec3A::from_vec4(self.hi)
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
/// them and the box around their doubled centroids
/// ([`PrimRef::doubled_centroid`]), in one pass (in parallel chunks for
/// large meshes: boxes unite exactly in any order, so the bounds are those
/// of a sequential pass).
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
            (b, cb) = (b.union(r.boxa()), cb.grow(r.doubled_centroid()));
            d.write(r);
        }
        (b, cb)
    };
    let n = prims.len();
    let mut refs = super::scratch::refs(n);
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

/// Box around the doubled centroids of `refs` ([`PrimRef::doubled_centroid`]).
#[inline]
pub fn doubled_centroid_bounds_of(refs: &[PrimRef]) -> BoxA {
    refs.iter().fold(BoxA::EMPTY, |b, r| b.grow(r.doubled_centroid()))
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
    /// `centroids` is the box around the node's doubled centroids
    /// ([`PrimRef::doubled_centroid`]) when the caller has it (the root's).
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

/// A value computed for every node of a tree, bottom-up: a leaf's from the
/// leaf, an interior node's from the node and its two children's values
/// (the collapse's cost table, `collapse::CostTable`). A build that forks
/// computes each as it makes the node, without a pass of its own over the
/// finished tree ([`build_gapped`]).
pub trait Summary: Sync {
    /// One node's value.
    type Value: Copy + Send;
    /// The value of leaf `node`.
    fn leaf(&self, node: &Node) -> Self::Value;
    /// The value of interior `node` from its children's.
    fn interior(&self, node: &Node, left: &Self::Value, right: &Self::Value) -> Self::Value;
}

/// No value: the plain tree.
impl Summary for () {
    type Value = ();
    fn leaf(&self, _: &Node) {}
    fn interior(&self, _: &Node, _: &(), _: &()) {}
}

/// A tree built in place: every subtree over `m` primitives owns the `2m - 1`
/// slots from its node on (room for its largest possible tree, one
/// primitive per leaf), and at a fork whose right subtree another thread
/// took before the left one was finished, the right subtree starts right
/// after the left one's room, so that two threads write their subtrees
/// straight into one array; otherwise (the right subtree run after the left
/// one) right after the left one's last node. Below the forks the nodes
/// follow one another depth-first as in a sequential build; after the left
/// subtree of a fork of the first kind the slots it left unused stay
/// unwritten (gaps). Without forks (one thread, or a tree too small to
/// fork) there are no gaps and the layout is the sequential one.
///
/// A gap's first and last huge pages are written (and cleared by the
/// kernel) whole: with a gap at every fork, dragon_full's two-thread build
/// cleared 57 huge pages against one thread's 36 (`thp_fault_alloc` in
/// `/proc/vmstat`), with gaps at the taken forks only 48.
///
/// Each node's [`Summary`] value sits in `values` at the node's index.
///
/// Until stop 44 the right subtree at a fork was built into an array of its
/// own and every such piece was copied into place afterwards (0.1 ms of
/// dragon_87k's two-thread build, 4.5-5 ms of dragon_full's with the ids),
/// and the collapse's cost table was a parallel pass of its own over the
/// finished tree.
pub struct GappedTree<V> {
    /// Node slots; those reachable from slot 0 by the links are written.
    nodes: Vec<MaybeUninit<Node>>,
    /// Value slots, written where the node slots are.
    values: Vec<MaybeUninit<V>>,
    /// Nodes written.
    count: usize,
    /// One past the last slot written (0 for an empty tree).
    end: usize,
    /// Primitive ids in leaf order.
    pub order: Vec<u32>,
}

impl<V> GappedTree<V> {
    /// Number of nodes (gaps not counted).
    pub fn len(&self) -> usize {
        self.count
    }

    /// True for the tree over no primitives (no nodes).
    pub fn is_empty(&self) -> bool {
        self.count == 0
    }

    /// Node `i`.
    ///
    /// # Safety
    /// `i` must be the root (0, in a tree that is not empty) or reached
    /// from it by links: an interior node's left child `i + 1` and right
    /// child `offset`. Those slots are written; gaps are not.
    #[inline(always)]
    pub unsafe fn node(&self, i: usize) -> &Node {
        debug_assert!(i < self.end, "slot {i} past the tree's {}", self.end);
        // SAFETY: the caller's: a reachable slot, written by `build_gapped`.
        unsafe { self.nodes.get_unchecked(i).assume_init_ref() }
    }

    /// Node `i`'s value.
    ///
    /// # Safety
    /// As for [`Self::node`].
    #[inline(always)]
    pub unsafe fn value(&self, i: usize) -> &V {
        debug_assert!(i < self.end, "slot {i} past the tree's {}", self.end);
        // SAFETY: as in `node`: every written node's value was written with it.
        unsafe { self.values.get_unchecked(i).assume_init_ref() }
    }

    /// The gapless depth-first `nodes` (as a sequential build lays them
    /// out, [`BuiltTree::nodes`]) with `summary`'s values, made in one
    /// reverse sweep (children follow their parents), and leaf order `order`.
    pub fn from_nodes<S: Summary<Value = V>>(nodes: Vec<Node>, order: Vec<u32>, summary: &S) -> Self {
        let count = nodes.len();
        let mut values: Vec<MaybeUninit<V>> = Vec::with_capacity(count);
        // SAFETY: uninitialised `MaybeUninit`s are valid values.
        unsafe { values.set_len(count) };
        for k in (0..count).rev() {
            let n = &nodes[k];
            let v = if n.is_leaf() {
                summary.leaf(n)
            } else {
                let (l, r) = (k + 1, n.offset as usize);
                assert!(l < r && r < count, "node {k} links to {r} of {count} nodes");
                // SAFETY: both children lie after `k` (checked), so the sweep wrote them.
                unsafe { summary.interior(n, values[l].assume_init_ref(), values[r].assume_init_ref()) }
            };
            values[k].write(v);
        }
        let mut nodes = std::mem::ManuallyDrop::new(nodes);
        let (ptr, cap) = (nodes.as_mut_ptr(), nodes.capacity());
        // SAFETY: `Node` and `MaybeUninit<Node>` share a layout; the
        // allocation passes to the new vector whole.
        let nodes = unsafe { Vec::from_raw_parts(ptr.cast::<MaybeUninit<Node>>(), count, cap) };
        Self { nodes, values, count, end: count, order }
    }

    /// Give the node slots and the leaf order back to the thread's build
    /// scratch ([`super::scratch`]) once the tree has been read.
    pub fn recycle(self) {
        super::scratch::give_nodes(self.nodes);
        super::scratch::give_order(self.order);
    }

    /// The tree in the sequential depth-first layout, without the values.
    pub fn into_built(self) -> BuiltTree {
        let order = self.order;
        if self.count == self.end {
            // No gaps: the `count` distinct slots written all lie below
            // `end == count`, so slots `0..end` are all written.
            let mut nodes = std::mem::ManuallyDrop::new(self.nodes);
            let (ptr, cap) = (nodes.as_mut_ptr(), nodes.capacity());
            // SAFETY: `MaybeUninit<Node>` has `Node`'s layout, the first
            // `end <= cap` elements are initialised (above), and the
            // allocation passes to the new vector whole.
            let nodes = unsafe { Vec::from_raw_parts(ptr.cast::<Node>(), self.end, cap) };
            return BuiltTree { nodes, order };
        }
        // Walk the links depth-first, each node to the next place, the
        // right links set as the right children are placed.
        let mut nodes: Vec<Node> = Vec::with_capacity(self.count);
        let mut stack = vec![(0usize, usize::MAX)];
        while let Some((i, parent)) = stack.pop() {
            let at = nodes.len();
            if parent != usize::MAX {
                nodes[parent].offset = at as u32;
            }
            // SAFETY: slot 0 and the children of reached interior nodes.
            let node = unsafe { *self.nodes[i].assume_init_ref() };
            nodes.push(node);
            if !node.is_leaf() {
                stack.push((node.offset as usize, at));
                stack.push((i + 1, usize::MAX));
            }
        }
        BuiltTree { nodes, order }
    }
}

/// Run `splitter` over `prims` and flatten the result.
pub fn build_tree(prims: &Primitives, splitter: &dyn Splitter) -> BuiltTree {
    build_slots(prims, splitter, &(), fork_min(prims.len()), true).into_built()
}

/// The smallest node that forks in a build over `n` primitives on the
/// current pool (0: none does, on a one-thread pool, where a fork would only
/// leave gaps, or in a tree too small to fork).
fn fork_min(n: usize) -> usize {
    let threads = rayon::current_num_threads();
    if threads > 1 && n >= PARALLEL_THRESHOLD { PARALLEL_THRESHOLD.max(n / (FORKS_PER_THREAD * threads)) } else { 0 }
}

/// Run `splitter` over `prims` into a [`GappedTree`] with `summary`'s value
/// of every node, and gather the primitive ids in leaf order.
///
/// A build that forks computes the values as it makes the nodes, in the
/// slots beside them. One that does not fork sweeps the finished tree
/// instead, into an array of the exact size: the value slots of a build
/// have room for the largest possible tree (`2n - 1` nodes, three to four
/// times the usual count), and so allocated, suzanne's one-thread builds
/// (108 KiB of value slots beside 62 KiB of node slots) ran 3% slower in
/// `rtdiff bench --race` (four alternated pairs), the larger blocks
/// returned to the system and faulted back in at every build.
pub fn build_gapped<S: Summary>(prims: &Primitives, splitter: &dyn Splitter, summary: &S) -> GappedTree<S::Value> {
    let fork_min = fork_min(prims.len());
    if fork_min == 0 {
        let tree = build_slots(prims, splitter, &(), 0, true).into_built();
        return GappedTree::from_nodes(tree.nodes, tree.order, summary);
    }
    build_slots(prims, splitter, summary, fork_min, true)
}

/// [`build_gapped`] computing the values in the slots, forking at nodes of
/// at least `fork_min` primitives (0: nowhere), a fork's right subtree
/// packed after its left one when that is finished (`pack`, see
/// [`build_node`]).
fn build_slots<S: Summary>(
    prims: &Primitives,
    splitter: &dyn Splitter,
    summary: &S,
    fork_min: usize,
    pack: bool,
) -> GappedTree<S::Value> {
    let input = BuildInput::new(prims, splitter.needs_vertex_means());
    let (mut refs, bounds, centroids) = prim_refs_and_bounds(prims);
    let n = refs.len();
    let slots = (2 * n).saturating_sub(1);
    // A forking build's slots too large to keep between builds
    // (`scratch::KEEP_BYTES`) are asked for by [`gapped_slots`]; the value
    // slots of any build too.
    let mut nodes: Vec<MaybeUninit<Node>> =
        if fork_min > 0 && slots * std::mem::size_of::<Node>() > super::scratch::KEEP_BYTES {
            gapped_slots(slots)
        } else {
            super::scratch::nodes(slots)
        };
    let mut values: Vec<MaybeUninit<S::Value>> = gapped_slots(slots);
    // SAFETY: uninitialised `MaybeUninit`s are valid values.
    unsafe {
        nodes.set_len(slots);
        values.set_len(slots);
    }
    let (mut count, mut end) = (0, 0);
    if n > 0 {
        let out = Slots { nodes: nodes.as_mut_ptr(), values: values.as_mut_ptr(), len: slots };
        let c = Ctx { splitter, summary, input: &input, out, fork_min, pack };
        let root = build_node(&c, &mut refs, bounds.aabb(), Some(centroids), 0, 0, 0);
        (count, end) = (root.count, root.end);
    }
    let mut order = super::scratch::order(n);
    if parallel_pass(n) {
        refs.par_iter().with_min_len(PARALLEL_PASS).map(PrimRef::id).collect_into_vec(&mut order);
    } else {
        order.extend(refs.iter().map(PrimRef::id));
    }
    super::scratch::give_refs(refs);
    GappedTree { nodes, values, count, end, order }
}

/// Room for `n` slots of a [`GappedTree`]: beyond glibc's largest mmap
/// threshold ([`FRESH_BYTES`]) the block comes fresh from the system at every
/// build and is asked for on huge pages; a smaller one comes from the
/// allocator's heap, whose pages a later build reuses (the huge-page advice
/// would drop them, and the gaps at the forks other threads take would touch
/// huge pages of their own).
fn gapped_slots<T>(n: usize) -> Vec<MaybeUninit<T>> {
    if n * std::mem::size_of::<T>() > FRESH_BYTES { super::huge::vec_with_capacity(n) } else { Vec::with_capacity(n) }
}

/// Run `splitter` over `prims`, flatten the result and gather the primitives in leaf order.
pub fn build_with(prims: &Primitives, splitter: &dyn Splitter, builder: Builder) -> BinaryBvh {
    let start = Instant::now();
    let tree = build_tree(prims, splitter);
    let leaf_prims = LeafPrims::new(prims, &tree.order);
    BinaryBvh { nodes: tree.nodes, prims: leaf_prims, builder, build_time: start.elapsed() }
}

/// The node and value slots of a [`GappedTree`] under construction, shared
/// by the threads that build its subtrees (each writes the slots of its own
/// subtree only, see [`build_node`]).
struct Slots<V> {
    nodes: *mut MaybeUninit<Node>,
    values: *mut MaybeUninit<V>,
    len: usize,
}

// SAFETY: the slots are written through `put`, whose callers write disjoint
// slots from different threads (the ranges of different subtrees).
unsafe impl<V: Send> Sync for Slots<V> {}

impl<V> Slots<V> {
    /// Write `node` and `value` into slot `i`.
    ///
    /// # Safety
    /// No other thread may access slot `i` meanwhile.
    #[inline(always)]
    unsafe fn put(&self, i: usize, node: Node, value: V) {
        assert!(i < self.len, "node slot {i} of {}", self.len);
        // SAFETY: in bounds (above); exclusive by the caller.
        unsafe {
            (*self.nodes.add(i)).write(node);
            (*self.values.add(i)).write(value);
        }
    }

    /// The value in slot `i`.
    ///
    /// # Safety
    /// Slot `i` must have been written ([`Self::put`]) and no thread may
    /// write it meanwhile.
    #[inline(always)]
    unsafe fn value(&self, i: usize) -> &V {
        assert!(i < self.len, "value slot {i} of {}", self.len);
        // SAFETY: in bounds (above), written and not being written (the caller).
        unsafe { (*self.values.add(i)).assume_init_ref() }
    }
}

/// What every node's build shares: the split strategy, the summary, the
/// input, the slots and the smallest node that forks (0: none does).
struct Ctx<'a, S: Summary> {
    splitter: &'a dyn Splitter,
    summary: &'a S,
    input: &'a BuildInput,
    out: Slots<S::Value>,
    fork_min: usize,
    /// Place a fork's right subtree straight after its left one when that
    /// is finished (false: always after the left one's room, tests only).
    pack: bool,
}

/// What building a subtree reports: one past its last slot written and its
/// number of nodes. (Its root's value is read from the root's slot: moved
/// out through the returns of the recursion, the collapse's 56-byte entry
/// cost 50 instructions per node, callgrind on suzanne.)
struct Built {
    end: usize,
    count: usize,
}

/// Build the subtree over `idx` (box `bounds`, primitives from `first` on,
/// at level `depth`) with its root in slot `at`, writing only the slots
/// `at .. at + 2 * idx.len() - 1` (by induction: a leaf takes one; a node
/// over `n` whose sides hold `m` and `n - m` takes one, its left subtree at
/// most `2m - 1` from `at + 1`, its right one at most `2(n - m) - 1` from
/// `at + 2m` at a fork or from the left one's end otherwise, at most
/// `1 + (2m - 1) + 2(n - m) - 1` in all; the right one may also start at
/// the left one's end, which lies no later). At a fork the two subtrees are
/// built in parallel, each in its own disjoint slots: the right one starts
/// at the left one's end when the left one is finished by the time the
/// right one starts (`Ctx::pack`), after its room otherwise.
fn build_node<S: Summary>(
    c: &Ctx<S>,
    idx: &mut [PrimRef],
    bounds: Aabb,
    centroids: Option<BoxA>,
    first: u32,
    depth: u32,
    at: usize,
) -> Built {
    let (s, summary, out) = (c.splitter, c.summary, &c.out);
    let n = idx.len();
    let leaf = || {
        let node = Node::leaf(bounds, first, n as u32);
        let value = summary.leaf(&node);
        // SAFETY: slot `at` is this subtree's own (see above).
        unsafe { out.put(at, node, value) };
        Built { end: at + 1, count: 1 }
    };
    if n <= 1 || depth >= s.max_depth() {
        return leaf();
    }
    let Some(Split { mid, bounds: child_bounds }) = s.split(c.input, idx, &bounds, centroids, depth) else {
        return leaf();
    };
    // Children compute their own centroid boxes when they need them (see
    // `build_sah::partition_branchless`); only the root's comes from outside.
    // Both sides non-empty: the slot ranges above rest on it.
    assert!(mid > 0 && mid < n, "split strategy returned an empty side");
    let (l, r) = idx.split_at_mut(mid);
    let (lb, rb) = child_bounds.unwrap_or_else(|| (bounds_of(l), bounds_of(r)));
    let right_first = first + mid as u32;
    let (left, right, right_at) = if c.fork_min > 0 && n >= c.fork_min {
        // The right subtree starts straight after the left one when that is
        // finished (the right one was not taken by another thread, which is
        // the common case below the top forks, and rayon then runs it after
        // the left one): no gap. Otherwise after the left one's room.
        let left_end = AtomicUsize::new(usize::MAX);
        let (left, (right, right_at)) = rayon::join(
            || {
                let left = build_node(c, l, lb, None, first, depth + 1, at + 1);
                left_end.store(left.end, Ordering::Release);
                left
            },
            || {
                let end = left_end.load(Ordering::Acquire);
                let right_at = if end == usize::MAX || !c.pack { at + 2 * mid } else { end };
                (build_node(c, r, rb, None, right_first, depth + 1, right_at), right_at)
            },
        );
        (left, right, right_at)
    } else {
        let left = build_node(c, l, lb, None, first, depth + 1, at + 1);
        let right_at = left.end;
        let right = build_node(c, r, rb, None, right_first, depth + 1, right_at);
        (left, right, right_at)
    };
    let node = Node::interior(bounds, right_at as u32);
    // SAFETY: the children's builds, finished, wrote their roots' slots.
    let value = unsafe { summary.interior(&node, out.value(at + 1), out.value(right_at)) };
    // SAFETY: slot `at` is this subtree's own, and its children's slots follow it.
    unsafe { out.put(at, node, value) };
    Built { end: right.end, count: 1 + left.count + right.count }
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

    /// The binary tree built on two threads (its subtrees written in place,
    /// with gaps, then laid out without them) is node for node the
    /// one-thread tree, for the SAH builder and for the median builder's
    /// one-primitive leaves (the most nodes, the deepest forks).
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
            // The two-thread build forked, and with every right subtree
            // after its left one's room (not packed) left gaps (but for one
            // primitive per leaf, which fills every subtree's room): laid
            // out, those slots are the one-thread tree too.
            let gapped = rayon::ThreadPoolBuilder::new()
                .num_threads(2)
                .build()
                .unwrap()
                .install(|| build_slots(&prims, splitter, &(), fork_min(prims.len()), false));
            assert_eq!(gapped.count, a.nodes.len());
            assert!(gapped.end > gapped.count || std::ptr::addr_eq(splitter, &median), "no gaps");
            assert!(gapped.into_built().nodes == a.nodes, "the gapped slots laid out another tree");
            check_links(&a);
            assert!(a.nodes == b.nodes, "1 and 2 threads laid out different nodes");
            assert_eq!(a.order, b.order);
        }
    }
}
