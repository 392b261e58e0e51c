//! The production path (`fast` traversal): the binary BVH collapsed into
//! 8-wide nodes whose eight child boxes are tested at once (AVX2 when the CPU
//! has it, detected at run time, with a portable scalar fallback of identical
//! semantics), nearest-first order, early termination against the closest hit
//! so far, a precomputed reciprocal direction, and an any-hit variant for
//! shadow rays.

use std::mem::MaybeUninit;

use glam::Vec3;

use crate::geometry::triangle::WatertightRay;
use crate::geometry::{Hit, Primitives, Ray, TriangleTest};

use super::build::BuiltTree;
use super::packet::TriPackets;
use super::slab::{cull_bound, far_scale};
use super::{BinaryBvh, LeafPrims, Node};

pub use super::count::{Count, TraversalCounts};

/// Children per wide node.
pub const WIDTH: usize = 8;

/// Traversal stack entries for any tree: at most `WIDTH` pending entries per
/// level and at most 100 levels (every builder caps the binary depth, and
/// collapsing never deepens the tree).
const STACK: usize = 1024;
/// Stack entries for trees of at most `SHALLOW_STACK / WIDTH` levels (every
/// mesh tested here): the closest-hit stack then stays under a 4 KiB page,
/// so a call needs no stack probes and touches fewer cache lines, which
/// matters for rays that miss everything.
const SHALLOW_STACK: usize = 288;

/// An 8-wide node: child boxes in structure-of-arrays form for SIMD tests.
///
/// 256 bytes (32 per child). Lane `i` is empty when `child[i] == u32::MAX`
/// (its box is inverted, `min = +inf`, `max = -inf`, so no ray hits it), an
/// inner node `child[i]` when `count[i] == 0`, or a leaf over the reordered
/// primitives `child[i] .. child[i] + count[i]`.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
pub struct WideNode {
    /// Rows 0..3: per-lane `min.x, min.y, min.z`; rows 3..6: `max.x, max.y, max.z`.
    pub b: [[f32; WIDTH]; 6],
    /// Child node index or first primitive.
    pub child: [u32; WIDTH],
    /// Primitive count of a leaf lane, 0 for inner-node and empty lanes.
    pub count: [u32; WIDTH],
}

const _: () = assert!(std::mem::size_of::<WideNode>() == 256);

impl WideNode {
    /// A node with every lane empty.
    pub(super) const EMPTY: WideNode = WideNode {
        b: [
            [f32::INFINITY; WIDTH],
            [f32::INFINITY; WIDTH],
            [f32::INFINITY; WIDTH],
            [f32::NEG_INFINITY; WIDTH],
            [f32::NEG_INFINITY; WIDTH],
            [f32::NEG_INFINITY; WIDTH],
        ],
        child: [u32::MAX; WIDTH],
        count: [0; WIDTH],
    };

    /// Set lane `lane` to binary node `n`'s box with the given child or leaf range.
    pub(super) fn set_lane(&mut self, lane: usize, n: &Node, child: u32, count: u32) {
        for a in 0..3 {
            self.b[a][lane] = n.min[a];
            self.b[3 + a][lane] = n.max[a];
        }
        self.child[lane] = child;
        self.count[lane] = count;
    }

    /// Number of used lanes.
    pub fn used(&self) -> usize {
        self.child.iter().filter(|&&c| c != u32::MAX).count()
    }
}

/// A ray prepared for 8-wide box tests.
#[derive(Clone, Copy)]
struct WidePre {
    o: Vec3,
    inv: Vec3,
    /// `inv * far_scale()`: the far distances `(b - o) * inv_far` take four
    /// roundings, as `((b - o) * inv) * far_scale()` does, so they keep the
    /// same conservative bound with one multiply fewer per slab.
    inv_far: Vec3,
    /// Row of `WideNode::b` holding the near plane of each axis.
    near_row: [usize; 3],
    /// Row holding the far plane.
    far_row: [usize; 3],
    t_min: f32,
}

impl WidePre {
    #[inline(always)]
    fn new(ray: &Ray) -> Self {
        let inv = ray.dir.recip();
        let neg = [inv.x < 0.0, inv.y < 0.0, inv.z < 0.0];
        Self {
            o: ray.origin,
            inv,
            inv_far: inv * far_scale(),
            near_row: [0, 1, 2].map(|a| a + 3 * neg[a] as usize),
            far_row: [0, 1, 2].map(|a| a + 3 * (!neg[a]) as usize),
            t_min: ray.t_min,
        }
    }
}

/// Scalar 8-lane box test: hit mask and entry distances (the arithmetic of
/// [`super::slab::RayPre::hit`], with the far scale folded into the
/// reciprocal; see [`WidePre::inv_far`]).
#[inline(always)]
fn box8_scalar(n: &WideNode, p: &WidePre, cull: f32) -> (u32, [f32; WIDTH]) {
    let mut mask = 0;
    let mut near = [0.0; WIDTH];
    for (l, near_l) in near.iter_mut().enumerate() {
        let tn_x = (n.b[p.near_row[0]][l] - p.o.x) * p.inv.x;
        let tn_y = (n.b[p.near_row[1]][l] - p.o.y) * p.inv.y;
        let tn_z = (n.b[p.near_row[2]][l] - p.o.z) * p.inv.z;
        let tf_x = (n.b[p.far_row[0]][l] - p.o.x) * p.inv_far.x;
        let tf_y = (n.b[p.far_row[1]][l] - p.o.y) * p.inv_far.y;
        let tf_z = (n.b[p.far_row[2]][l] - p.o.z) * p.inv_far.z;
        let tn = tn_x.max(tn_y).max(tn_z).max(p.t_min);
        let tf = tf_x.min(tf_y).min(tf_z).min(cull);
        *near_l = tn;
        mask |= u32::from(tn <= tf) << l;
    }
    (mask, near)
}

/// AVX2 8-lane box test, expanded inside the AVX2 traversal functions (a
/// macro rather than a function so it is always inlined into them).
/// `_mm256_max_ps`/`_mm256_min_ps` return their second operand when either is
/// NaN, so the possibly-NaN slab distance always goes first: a NaN slab
/// (origin on the plane, ray parallel) imposes nothing, exactly like
/// `f32::max`/`f32::min` in [`box8_scalar`].
#[cfg(target_arch = "x86_64")]
macro_rules! box8_avx2 {
    ($n:expr, $p:expr, $cull:expr) => {{
        use std::arch::x86_64::*;
        let (n, p): (&WideNode, &WidePre) = ($n, $p);
        let ox = _mm256_set1_ps(p.o.x);
        let oy = _mm256_set1_ps(p.o.y);
        let oz = _mm256_set1_ps(p.o.z);
        let ix = _mm256_set1_ps(p.inv.x);
        let iy = _mm256_set1_ps(p.inv.y);
        let iz = _mm256_set1_ps(p.inv.z);
        let (fx, fy, fz) = (_mm256_set1_ps(p.inv_far.x), _mm256_set1_ps(p.inv_far.y), _mm256_set1_ps(p.inv_far.z));
        // SAFETY: each row is 32 bytes inside a 64-byte aligned node, so aligned loads are valid.
        let ld = |row: usize| unsafe { _mm256_load_ps(n.b[row].as_ptr()) };
        let tn_x = _mm256_mul_ps(_mm256_sub_ps(ld(p.near_row[0]), ox), ix);
        let tn_y = _mm256_mul_ps(_mm256_sub_ps(ld(p.near_row[1]), oy), iy);
        let tn_z = _mm256_mul_ps(_mm256_sub_ps(ld(p.near_row[2]), oz), iz);
        let tf_x = _mm256_mul_ps(_mm256_sub_ps(ld(p.far_row[0]), ox), fx);
        let tf_y = _mm256_mul_ps(_mm256_sub_ps(ld(p.far_row[1]), oy), fy);
        let tf_z = _mm256_mul_ps(_mm256_sub_ps(ld(p.far_row[2]), oz), fz);
        let tn = _mm256_max_ps(tn_x, _mm256_max_ps(tn_y, _mm256_max_ps(tn_z, _mm256_set1_ps(p.t_min))));
        let tf = _mm256_min_ps(tf_x, _mm256_min_ps(tf_y, _mm256_min_ps(tf_z, _mm256_set1_ps($cull))));
        let mask = _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(tn, tf)) as u32;
        let mut near = [0.0f32; WIDTH];
        // SAFETY: near has room for 8 floats; storeu has no alignment requirement.
        unsafe { _mm256_storeu_ps(near.as_mut_ptr(), tn) };
        (mask, near)
    }};
}

/// [`box8_scalar`] in the calling convention of the box-test macros.
macro_rules! box8_portable {
    ($n:expr, $p:expr, $cull:expr) => {
        box8_scalar($n, $p, $cull)
    };
}

/// A pending child: entry distance, node or first primitive, primitive count (0 = inner node).
#[derive(Clone, Copy)]
struct Entry {
    t: f32,
    child: u32,
    count: u32,
}

/// Nearest-first closest-hit traversal, generic over the box test.
macro_rules! closest {
    ($self:ident, $ray:ident, $test:ident, $box8:ident, $leaf:ident, $counts:expr, $stack:expr) => {{
        let pre = WidePre::new($ray);
        // The shear of the triangle test is made at the first leaf: most
        // camera rays of a mesh that does not fill the view reach none.
        let mut wr: Option<WatertightRay> = None;
        let mut r = *$ray;
        let mut best: Option<Hit> = None;
        let mut cull = cull_bound(r.t_max);
        let mut stack = [MaybeUninit::<Entry>::uninit(); $stack];
        let mut sp = 0usize;
        let mut cur = Entry { t: r.t_min, child: 0, count: 0 };
        'outer: loop {
            if cur.count == 0 {
                let node = &$self.nodes[cur.child as usize];
                $counts.node(cur.child);
                let (mut mask, near) = $box8!(node, &pre, cull);
                if mask != 0 {
                    $self.prefetch_children(node, mask);
                    let first = mask.trailing_zeros() as usize;
                    mask &= mask - 1;
                    if mask == 0 {
                        cur = Entry { t: near[first], child: node.child[first], count: node.count[first] };
                        continue 'outer;
                    }
                    let second = mask.trailing_zeros() as usize;
                    if mask & (mask - 1) == 0 {
                        // Two hits (the common case): push the farther, visit the nearer.
                        // Ties go to the lower lane, as in the insertion sort below.
                        let (a, b) = if near[second] < near[first] { (second, first) } else { (first, second) };
                        stack[sp] = MaybeUninit::new(Entry { t: near[b], child: node.child[b], count: node.count[b] });
                        sp += 1;
                        cur = Entry { t: near[a], child: node.child[a], count: node.count[a] };
                        continue 'outer;
                    }
                    // Sort the hit lanes by entry distance (insertion sort, at most 8).
                    // Ties keep the lower lane first.
                    let mut lanes = [(0.0f32, 0u32); WIDTH];
                    lanes[0] = (near[first], first as u32);
                    let mut k = 1;
                    while mask != 0 {
                        let l = mask.trailing_zeros();
                        mask &= mask - 1;
                        let t = near[l as usize];
                        let mut j = k;
                        while j > 0 && lanes[j - 1].0 > t {
                            lanes[j] = lanes[j - 1];
                            j -= 1;
                        }
                        lanes[j] = (t, l);
                        k += 1;
                    }
                    for &(t, l) in lanes[1..k].iter().rev() {
                        let l = l as usize;
                        stack[sp] = MaybeUninit::new(Entry { t, child: node.child[l], count: node.count[l] });
                        sp += 1;
                    }
                    let (t, l) = (lanes[0].0, lanes[0].1 as usize);
                    cur = Entry { t, child: node.child[l], count: node.count[l] };
                    continue 'outer;
                }
            } else if {
                $counts.leaf(cur.child, cur.count);
                let wr = wr.get_or_insert_with(|| WatertightRay::new($ray.dir));
                $self.$leaf(cur.child, cur.count, &mut r, wr, $test, &mut best)
            } {
                $counts.closer();
                cull = cull_bound(r.t_max);
            }
            loop {
                if sp == 0 {
                    break 'outer;
                }
                sp -= 1;
                // SAFETY: entries below sp were written before.
                let e = unsafe { stack[sp].assume_init() };
                if e.t <= cull {
                    cur = e;
                    break;
                }
            }
        }
        best
    }};
}

/// Any-hit traversal, generic over the box test (no ordering needed).
macro_rules! any_hit {
    ($self:ident, $ray:ident, $test:ident, $box8:ident, $leaf:ident, $counts:expr, $stack:expr) => {{
        let pre = WidePre::new($ray);
        let mut wr: Option<WatertightRay> = None;
        let cull = cull_bound($ray.t_max);
        // Only inner nodes are stacked: hit leaves are tested at once, so an
        // occluder is found before descending further.
        let mut stack = [MaybeUninit::<u32>::uninit(); $stack];
        stack[0] = MaybeUninit::new(0);
        let mut sp = 1usize;
        while sp > 0 {
            sp -= 1;
            // SAFETY: entries below sp were written before.
            let index = unsafe { stack[sp].assume_init() };
            let node = &$self.nodes[index as usize];
            $counts.node(index);
            let (mut mask, _) = $box8!(node, &pre, cull);
            while mask != 0 {
                let l = mask.trailing_zeros() as usize;
                mask &= mask - 1;
                if node.count[l] > 0 {
                    $counts.leaf(node.child[l], node.count[l]);
                    let wr = wr.get_or_insert_with(|| WatertightRay::new($ray.dir));
                    if $self.$leaf(node.child[l], node.count[l], $ray, wr, $test) {
                        return true;
                    }
                } else {
                    stack[sp] = MaybeUninit::new(node.child[l]);
                    sp += 1;
                }
            }
        }
        false
    }};
}

/// Call the AVX2 traversal `$avx2` when the CPU has AVX2, else the portable
/// `$scalar`, with the one-page stack when the tree is shallow enough and the
/// large one otherwise (the stack size is a const generic after `$g`).
macro_rules! dispatch {
    ($self:ident, $avx2:ident, $scalar:ident, [$($g:ty),*], ($($arg:expr),*)) => {{
        let shallow = $self.levels * WIDTH <= SHALLOW_STACK;
        #[cfg(target_arch = "x86_64")]
        if $self.use_avx2 {
            // SAFETY: use_avx2 is only set when the CPU reports AVX2.
            return unsafe {
                if shallow {
                    $self.$avx2::<$($g,)* SHALLOW_STACK>($($arg),*)
                } else {
                    $self.$avx2::<$($g,)* STACK>($($arg),*)
                }
            };
        }
        if shallow { $self.$scalar::<$($g,)* SHALLOW_STACK>($($arg),*) } else { $self.$scalar::<$($g,)* STACK>($($arg),*) }
    }};
}

/// A wide BVH sharing the reordered primitives of the binary BVH it came from.
#[derive(Clone, Debug)]
pub struct WideBvh {
    /// Nodes; node 0 is the root. Empty when there are no primitives.
    pub nodes: Vec<WideNode>,
    /// Primitives in leaf order (moved from the binary BVH).
    pub prims: LeafPrims,
    /// When every primitive is a triangle: the leaves' triangles in 4-wide
    /// packets, and leaf lanes of [`Self::nodes`] point at packets instead of
    /// [`Self::prims`] entries (`count` is still the number of triangles).
    pub packets: Option<TriPackets>,
    use_avx2: bool,
    /// Wide nodes on the longest root-to-leaf path (sizes the traversal stack).
    levels: usize,
}

impl WideBvh {
    /// Collapse `bvh` into 8-wide nodes: each wide node takes a binary node's
    /// children and repeatedly opens the inner child of largest surface area
    /// until it has eight children or only leaves.
    pub fn from_binary(bvh: BinaryBvh) -> Self {
        let mut nodes = super::collapse::collapse(&bvh.nodes);
        let prims = bvh.prims;
        let packets = (prims.num_triangles as usize == prims.len())
            .then(|| pack(&mut nodes, |k| (prims.entries[k].v, prims.entries[k].id)));
        Self { levels: levels(&nodes), nodes, prims, packets, use_avx2: avx2_available() }
    }

    /// [`Self::from_binary`] for a tree whose primitives are not gathered yet:
    /// triangle meshes go straight from `prims` into packets (no intermediate
    /// [`LeafPrims`]); scenes with spheres gather [`LeafPrims`] instead.
    pub fn from_tree(prims: &Primitives, tree: &BuiltTree) -> Self {
        let mut nodes = super::collapse::collapse(&tree.nodes);
        let num_triangles = prims.triangles.len() as u32;
        if prims.spheres.is_empty() {
            let packets = pack(&mut nodes, |k| {
                let id = tree.order[k];
                (prims.triangles[id as usize].v, id)
            });
            let prims = LeafPrims { entries: Vec::new(), num_triangles };
            Self { levels: levels(&nodes), nodes, prims, packets: Some(packets), use_avx2: avx2_available() }
        } else {
            let prims = LeafPrims::new(prims, &tree.order);
            Self { levels: levels(&nodes), nodes, prims, packets: None, use_avx2: avx2_available() }
        }
    }

    /// Force the portable scalar box test (for testing it on AVX2 machines).
    pub fn set_scalar(&mut self) {
        self.use_avx2 = false;
    }

    /// True when the AVX2 path is used.
    pub fn uses_avx2(&self) -> bool {
        self.use_avx2
    }

    /// Memory held by nodes and primitives, in bytes.
    pub fn bytes(&self) -> usize {
        self.nodes.len() * std::mem::size_of::<WideNode>()
            + self.packets.as_ref().map_or_else(|| self.prims.bytes(), TriPackets::bytes)
    }

    /// Closest hit (ties: lowest primitive id).
    pub fn intersect(&self, ray: &Ray, test: TriangleTest) -> Option<Hit> {
        self.intersect_counting(ray, test, &mut ())
    }

    /// [`Self::intersect`] that also counts the work it does into `counts`
    /// (the same traversal; the counting is compiled out of `intersect`).
    pub fn intersect_counted(&self, ray: &Ray, test: TriangleTest, counts: &mut TraversalCounts) -> Option<Hit> {
        counts.ray();
        self.intersect_counting(ray, test, counts)
    }

    /// [`Self::intersect`] reporting its work to `counts` (any [`Count`];
    /// `()` is [`Self::intersect`] itself). Does not call [`Count::ray`].
    #[inline(always)]
    pub fn intersect_counting<C: Count>(&self, ray: &Ray, test: TriangleTest, counts: &mut C) -> Option<Hit> {
        if self.nodes.is_empty() {
            return None;
        }
        dispatch!(self, intersect_avx2, intersect_scalar, [C], (ray, test, counts))
    }

    /// True when anything is hit within the ray's interval.
    pub fn occluded(&self, ray: &Ray, test: TriangleTest) -> bool {
        self.occluded_counting(ray, test, &mut ())
    }

    /// [`Self::occluded`] reporting its work to `counts` (the same traversal).
    /// Does not call [`Count::ray`].
    #[inline(always)]
    pub fn occluded_counting<C: Count>(&self, ray: &Ray, test: TriangleTest, counts: &mut C) -> bool {
        if self.nodes.is_empty() {
            return false;
        }
        dispatch!(self, occluded_avx2, occluded_scalar, [C], (ray, test, counts))
    }

    /// Ask the cache for the nodes and leaf primitives of the children in
    /// `mask`: all but the nearest are visited later, and their memory latency
    /// (the traversal's main cost) then overlaps with the work in between.
    #[inline(always)]
    fn prefetch_children(&self, node: &WideNode, mut mask: u32) {
        #[cfg(target_arch = "x86_64")]
        while mask != 0 {
            use std::arch::x86_64::{_MM_HINT_T0, _mm_prefetch};
            let l = mask.trailing_zeros() as usize;
            mask &= mask - 1;
            let (c, n) = (node.child[l] as usize, node.count[l] as usize);
            let (p, bytes) = if n == 0 {
                (self.nodes.as_ptr().wrapping_add(c).cast::<i8>(), std::mem::size_of::<WideNode>())
            } else if let Some(pk) = &self.packets {
                (
                    pk.packets.as_ptr().wrapping_add(c).cast::<i8>(),
                    super::packet::packets_for(n as u32) * std::mem::size_of::<super::packet::Tri4>(),
                )
            } else {
                (
                    self.prims.entries.as_ptr().wrapping_add(c).cast::<i8>(),
                    n * std::mem::size_of::<super::prims::LeafEntry>(),
                )
            };
            // Every cache line the range touches (it need not start on a line).
            let mut off = 0;
            let end = (p as usize % 64) + bytes;
            while off < end {
                // SAFETY: prefetching is a hint and never faults, whatever the address.
                unsafe { _mm_prefetch::<_MM_HINT_T0>(p.wrapping_add(off)) };
                off += 64;
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        let _ = (node, mask);
    }

    /// Portable closest-hit leaf test (packets or entries).
    #[inline(always)]
    fn leaf_closest_scalar(
        &self,
        first: u32,
        count: u32,
        ray: &mut Ray,
        wr: &WatertightRay,
        test: TriangleTest,
        best: &mut Option<Hit>,
    ) -> bool {
        match &self.packets {
            Some(pk) => pk.intersect_leaf_scalar(first, count, ray, wr, test, best),
            None => self.prims.intersect_leaf(first, count, ray, wr, test, best),
        }
    }

    /// Portable any-hit leaf test (packets or entries).
    #[inline(always)]
    fn leaf_occluded_scalar(&self, first: u32, count: u32, ray: &Ray, wr: &WatertightRay, test: TriangleTest) -> bool {
        match &self.packets {
            Some(pk) => pk.occluded_leaf_scalar(first, count, ray, wr, test),
            None => self.prims.occluded_leaf(first, count, ray, wr, test),
        }
    }

    /// SIMD closest-hit leaf test: packets with the watertight test go four
    /// at a time, everything else through [`Self::leaf_closest_scalar`].
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    fn leaf_closest_simd(
        &self,
        first: u32,
        count: u32,
        ray: &mut Ray,
        wr: &WatertightRay,
        test: TriangleTest,
        best: &mut Option<Hit>,
    ) -> bool {
        match &self.packets {
            Some(pk) if test == TriangleTest::Watertight => pk.intersect_leaf_simd(first, count, ray, wr, best),
            _ => self.leaf_closest_scalar(first, count, ray, wr, test, best),
        }
    }

    /// SIMD any-hit leaf test (see [`Self::leaf_closest_simd`]).
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    fn leaf_occluded_simd(&self, first: u32, count: u32, ray: &Ray, wr: &WatertightRay, test: TriangleTest) -> bool {
        match &self.packets {
            Some(pk) if test == TriangleTest::Watertight => pk.occluded_leaf_simd(first, count, ray, wr),
            _ => self.leaf_occluded_scalar(first, count, ray, wr, test),
        }
    }

    fn intersect_scalar<C: Count, const S: usize>(&self, ray: &Ray, test: TriangleTest, counts: &mut C) -> Option<Hit> {
        closest!(self, ray, test, box8_portable, leaf_closest_scalar, counts, S)
    }

    fn occluded_scalar<C: Count, const S: usize>(&self, ray: &Ray, test: TriangleTest, counts: &mut C) -> bool {
        any_hit!(self, ray, test, box8_portable, leaf_occluded_scalar, counts, S)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn intersect_avx2<C: Count, const S: usize>(&self, ray: &Ray, test: TriangleTest, counts: &mut C) -> Option<Hit> {
        closest!(self, ray, test, box8_avx2, leaf_closest_simd, counts, S)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn occluded_avx2<C: Count, const S: usize>(&self, ray: &Ray, test: TriangleTest, counts: &mut C) -> bool {
        any_hit!(self, ray, test, box8_avx2, leaf_occluded_simd, counts, S)
    }
}

/// Wide nodes on the longest root-to-leaf path (0 for an empty tree).
fn levels(nodes: &[WideNode]) -> usize {
    if nodes.is_empty() {
        return 0;
    }
    let mut deepest = 0;
    let mut stack = vec![(0usize, 1usize)];
    while let Some((i, d)) = stack.pop() {
        deepest = deepest.max(d);
        let n = &nodes[i];
        for l in 0..WIDTH {
            if n.child[l] != u32::MAX && n.count[l] == 0 {
                stack.push((n.child[l] as usize, d + 1));
            }
        }
    }
    deepest
}

fn avx2_available() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::arch::is_x86_feature_detected!("avx2")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// Pack every leaf lane's triangles (`tri(k)` gives leaf slot `k`) into
/// packets and point the lanes at their first packet.
fn pack(nodes: &mut [WideNode], tri: impl Fn(usize) -> ([Vec3; 3], u32)) -> TriPackets {
    // Exact size up front: no reallocation copies of a many-megabyte array.
    let total: usize = nodes.iter().flat_map(|n| n.count.iter()).map(|&c| super::packet::packets_for(c)).sum();
    let mut packets = TriPackets { packets: Vec::with_capacity(total) };
    for node in nodes {
        for l in 0..WIDTH {
            if node.count[l] > 0 {
                node.child[l] = packets.push_leaf_with(node.child[l], node.count[l], &tri);
            }
        }
    }
    packets
}

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use super::*;
    use crate::accel::AccelConfig;
    use crate::geometry::Triangle;
    use crate::rng::Pcg32;

    /// The deep-tree stack (chosen for trees of more than 36 levels) gives
    /// the same answers as the one-page stack on the same tree and rays.
    #[test]
    fn deep_and_shallow_stacks_agree() {
        let mut rng = Pcg32::new(3, 0);
        let mut p = || Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
        let triangles = (0..4000)
            .map(|_| {
                let c = p();
                Triangle { v: [c, c + 0.05 * p(), c + 0.05 * p()] }
            })
            .collect();
        let prims = Primitives { triangles, spheres: Vec::new() };
        let shallow = super::super::build_wide(&prims, &AccelConfig::default());
        assert!(shallow.levels * WIDTH <= SHALLOW_STACK);
        let mut deep = shallow.clone();
        deep.levels = SHALLOW_STACK; // forces the 1024-entry stack
        let rays = crate::rays::incoherent_rays(&prims.world_bounds(), 20_000, 7);
        let mut hits = 0;
        for r in &rays {
            let a = shallow.intersect(r, TriangleTest::Watertight);
            assert_eq!(a, deep.intersect(r, TriangleTest::Watertight));
            assert_eq!(shallow.occluded(r, TriangleTest::Watertight), deep.occluded(r, TriangleTest::Watertight));
            hits += usize::from(a.is_some());
        }
        assert!(hits > 1000, "only {hits} hits: the rays do not exercise the traversal");
    }
}
