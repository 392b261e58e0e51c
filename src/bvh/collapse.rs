//! Collapsing a binary BVH into 8-wide nodes by dynamic programming on the
//! surface-area cost (after Ylitie, Karras and Laine, "Efficient incoherent
//! ray traversal on GPUs through compressed wide BVHs", HPG 2017).
//!
//! Each binary subtree `n` can appear in a wide node as one lane (a wide child
//! node, or a leaf when it holds at most [`MAX_LEAF`] primitives, which the
//! binary build placed contiguously) or be opened into several lanes spread
//! over its children. `cost[n][i]` is the cheapest way to represent `n` in at
//! most `i` lanes, under the surface-area model: a wide node visit costs
//! [`NODE_COST`] times its area, a leaf [`PACKET_COST`] times its area per
//! packet of four triangles. The table is filled bottom-up and the wide tree is
//! read off top-down.
//!
//! Compared with a greedy collapse (open the child of largest area until eight
//! lanes are full), this fills nodes better near the bottom, where greedy
//! collapsing leaves many two-lane nodes, and merges small sibling leaves into
//! one leaf where a node visit costs more than the extra packet.
use super::Node;
use super::build::{GappedTree, Summary};
use super::wide::{WIDTH, WideNode};

/// Cost of visiting one wide node per unit of (half) surface area.
pub const NODE_COST: f32 = 1.0;
/// Cost of one leaf test (a block of four or eight triangles, see
/// [`super::packet::leaf_block`]), relative to [`NODE_COST`].
///
/// Measured with `rtdiff bench --race` on dragon_87k (ratios to Embree in
/// the same rounds, two runs each): 0.67, 1.0, 1.5 and 2.0 all gave primary
/// 1.00-1.14, incoherent 1.06-1.11 and shadow 1.19-1.24; 1.0 was the most
/// consistent (primary 1.131 and 1.136, incoherent 1.099 and 1.106). Lower
/// values merge more sibling leaves (fewer node visits, more packet tests).
pub const PACKET_COST: f32 = 1.0;
/// Largest leaf the collapse may form by merging a subtree (two packets).
pub const MAX_LEAF: u32 = 8;

/// Lanes a subtree may use, `1..=WIDTH`; index 0 is unused.
type Row = [f32; WIDTH + 1];

/// Subtrees of at least this many primitives emit their wide children in
/// parallel (when the rayon pool has more than one thread).
const PARALLEL_THRESHOLD: u32 = 1 << 14;

/// Wide nodes per piece when the parallel subtrees are copied into place (1 MiB).
const COPY_PIECE: usize = 4096;

/// One binary node's entry of the dynamic-programming tables.
#[derive(Clone, Copy)]
pub struct Entry {
    /// `cost[i]`: cheapest representation of the subtree in at most `i` lanes.
    cost: Row,
    /// `split[i]`: lanes given to the left child in the cheapest way to open
    /// the subtree into its children's representations with at most `i` lanes.
    split: [u8; WIDTH + 1],
    /// A one-lane subtree is a leaf (else a wide node).
    as_leaf: bool,
    /// First primitive and primitive count of the subtree.
    range: (u32, u32),
}

/// The dynamic-programming tables of one binary tree: its nodes and each
/// node's [`Entry`], as the build made them ([`CostTable`]).
struct Plan<'a> {
    tree: &'a GappedTree<Entry>,
}

/// The collapse's [`Entry`] of every binary node, the [`Summary`] that
/// [`super::build::build_gapped`] computes: as the binary tree is built
/// when the build forks, in a sweep over the finished tree otherwise.
/// `block`: triangles per leaf test in the cost model
/// ([`super::packet::leaf_block`]).
///
/// Until stop 44 the table was always filled after the build, on a pool in
/// a parallel pass of its own (0.40 ms of dragon_87k's two-thread build).
pub struct CostTable {
    /// Triangles per leaf test.
    pub block: u32,
}

impl Summary for CostTable {
    type Value = Entry;

    #[inline]
    fn leaf(&self, node: &Node) -> Entry {
        entry(node, None, self.block)
    }

    #[inline]
    fn interior(&self, node: &Node, left: &Entry, right: &Entry) -> Entry {
        entry(node, Some((left, right)), self.block)
    }
}

/// Half surface area of a binary node's box.
#[inline]
fn half_area(n: &Node) -> f32 {
    n.bounds().surface_area() * 0.5
}

/// The entry of binary node `node` from its children's entries (`None` for a leaf).
/// `block`: triangles per leaf test.
fn entry(node: &Node, children: Option<(&Entry, &Entry)>, block: u32) -> Entry {
    let area = half_area(node);
    let Some((l, r)) = children else {
        let c = PACKET_COST * node.count.div_ceil(block) as f32 * area;
        return Entry { cost: [c; WIDTH + 1], split: [0; WIDTH + 1], as_leaf: true, range: (node.offset, node.count) };
    };
    let range = (l.range.0, l.range.1 + r.range.1);
    let (dist, split) = both_children(&l.cost, &r.cost);
    let as_node = NODE_COST * area + dist[WIDTH];
    let count = range.1;
    let as_leaf = if count <= MAX_LEAF { PACKET_COST * count.div_ceil(block) as f32 * area } else { f32::INFINITY };
    let mut row = [0.0; WIDTH + 1];
    row[1] = as_leaf.min(as_node);
    for i in 2..=WIDTH {
        // Opening n only pays when its children together are cheaper;
        // otherwise the row keeps the cost of fewer lanes (see `emit`).
        row[i] = dist[i].min(row[i - 1]);
    }
    Entry { cost: row, split, as_leaf: as_leaf <= as_node, range }
}

/// `(dist, split)`: `dist[i]` is the cheapest way to give both children (each
/// at least one lane) at most `i` lanes together, `2 <= i <= WIDTH`, and
/// `split[i]` the left child's lanes in it: the smallest `j` among the
/// cheapest `cl[j] + cr[i - j]`, and `j = 1` when no sum compares below the
/// first (every cost infinite or NaN, from box areas that overflow `f32`), so
/// that `emit` always splits into `1..i` lanes (a 0 there made it ask for
/// lane count 0 and index `cost[n][0 - 1]`). Index 0 and 1 are not used
/// (and hold anything).
///
/// A min-plus convolution, lane-parallel over `i` (one pass per `j`,
/// compare and select, no branches), in two SSE2 halves of four lanes on
/// x86_64: rustc had left the lane loop scalar. Callgrind, the collapse's
/// table (`fill`) of 200 suzanne trees: 23.2M -> 20.8M instructions.
#[inline]
fn both_children(cl: &Row, cr: &Row) -> (Row, [u8; WIDTH + 1]) {
    // `shifted[WIDTH + m] = cr[m]` for `m >= 1` and infinity below, so that
    // lanes `i = 1..=WIDTH` read `cr[i - j]` from `shifted[WIDTH + 1 - j..]`,
    // infinite where `i - j < 1` (a sum the lane never takes).
    #[cfg(not(target_arch = "x86_64"))]
    let mut shifted = [f32::INFINITY; 2 * WIDTH + 1];
    #[cfg(not(target_arch = "x86_64"))]
    shifted[WIDTH + 1..].copy_from_slice(&cr[1..]);
    // Lane `i - 1` holds `i`. j = 1 is taken unconditionally (see above).
    #[cfg(target_arch = "x86_64")]
    // SAFETY: SSE2 is part of the x86_64 baseline. The two unaligned loads
    // read `cr[1..9]`; the stores write `d[1..9]` and `s[1..9]`.
    unsafe {
        // The loop below in two 4-lane halves (rustc left it scalar: about
        // 110 instructions per call on the additions alone). `min_ps(c, d)`
        // is `if c < d { c } else { d }` lane for lane (NaN and signed zeros
        // included), and the split takes `j` where `c < d`.
        //
        // The windows `shifted[k..k + 4]` are shifted together in registers
        // from `cr`'s two halves and infinities: loaded from `shifted` just
        // after it was written, each load spanned two stores, which the CPU
        // cannot forward (the first stalled; 15% of `entry`'s time, `perf
        // record` on suzanne). Windows of infinities only (the low lanes
        // for `j >= 5`) change nothing: `c` is infinite or NaN, never below
        // `d`, and `min_ps` then keeps `d`.
        use std::arch::x86_64::*;
        const { assert!(WIDTH == 8) };
        let inf = _mm_set1_ps(f32::INFINITY);
        let (r0, r1) = (_mm_loadu_ps(cr.as_ptr().add(1)), _mm_loadu_ps(cr.as_ptr().add(5)));
        // Lanes `r..4` of `a` then lanes `0..r` of `b` (`r` in 1..=3).
        macro_rules! window {
            ($a:expr, $b:expr, $r:literal) => {
                _mm_castsi128_ps(_mm_or_si128(
                    _mm_srli_si128::<{ 4 * $r }>(_mm_castps_si128($a)),
                    _mm_slli_si128::<{ 16 - 4 * $r }>(_mm_castps_si128($b)),
                ))
            };
        }
        // `shifted[k..k + 4]` is `window(inf, r0, k - 5)` for `k` in 6..=8,
        // `r0` at 9, `window(r0, r1, k - 9)` for `k` in 10..=12.
        let c1 = _mm_set1_ps(cl[1]);
        let (mut d_lo, mut d_hi) = (_mm_add_ps(c1, window!(inf, r0, 3)), _mm_add_ps(c1, window!(r0, r1, 3)));
        let (mut s_lo, mut s_hi) = (_mm_set1_epi32(1), _mm_set1_epi32(1));
        macro_rules! step {
            ($j:literal, $hi:expr) => {{
                let (a, jv) = (_mm_set1_ps(cl[$j]), _mm_set1_epi32($j));
                let c_hi = _mm_add_ps(a, $hi);
                let m_hi = _mm_castps_si128(_mm_cmplt_ps(c_hi, d_hi));
                d_hi = _mm_min_ps(c_hi, d_hi);
                s_hi = _mm_or_si128(_mm_and_si128(m_hi, jv), _mm_andnot_si128(m_hi, s_hi));
                a
            }};
            ($j:literal, $lo:expr, $hi:expr) => {{
                let a = step!($j, $hi);
                let c_lo = _mm_add_ps(a, $lo);
                let m_lo = _mm_castps_si128(_mm_cmplt_ps(c_lo, d_lo));
                d_lo = _mm_min_ps(c_lo, d_lo);
                s_lo = _mm_or_si128(_mm_and_si128(m_lo, _mm_set1_epi32($j)), _mm_andnot_si128(m_lo, s_lo));
            }};
        }
        step!(2, window!(inf, r0, 2), window!(r0, r1, 2));
        step!(3, window!(inf, r0, 1), window!(r0, r1, 1));
        step!(4, inf, r0);
        step!(5, window!(inf, r0, 3));
        step!(6, window!(inf, r0, 2));
        step!(7, window!(inf, r0, 1));
        // Lane `i - 1` to index `i`, straight into the rows (the splits
        // narrowed to bytes by two saturating packs, exact for 1..=7): a
        // loop copying them cost about 30 instructions per interior node.
        let mut d = [f32::INFINITY; WIDTH + 1];
        let mut s = [0u8; WIDTH + 1];
        _mm_storeu_ps(d.as_mut_ptr().add(1), d_lo);
        _mm_storeu_ps(d.as_mut_ptr().add(5), d_hi);
        let bytes = _mm_packus_epi16(_mm_packs_epi32(s_lo, s_hi), _mm_setzero_si128());
        _mm_storel_epi64(s.as_mut_ptr().add(1).cast(), bytes);
        (d, s)
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let mut dist = [0.0f32; WIDTH];
        let mut split = [1u32; WIDTH];
        for (i, d) in dist.iter_mut().enumerate() {
            *d = cl[1] + shifted[WIDTH + i];
        }
        for j in 2..WIDTH {
            let a = cl[j];
            let src = &shifted[WIDTH + 1 - j..2 * WIDTH + 1 - j];
            for i in 0..WIDTH {
                let c = a + src[i];
                let take = c < dist[i];
                dist[i] = if take { c } else { dist[i] };
                split[i] = if take { j as u32 } else { split[i] };
            }
        }
        let mut d = [f32::INFINITY; WIDTH + 1];
        let mut s = [0u8; WIDTH + 1];
        for i in 2..=WIDTH {
            d[i] = dist[i - 1];
            s[i] = split[i - 1] as u8;
        }
        (d, s)
    }
}

impl<'a> Plan<'a> {
    /// Binary node `n` (reached from the root by the links).
    #[inline(always)]
    fn node(&self, n: usize) -> &'a Node {
        // SAFETY: the plan is read from the root along the links only: `n`
        // is the root (`collapse`), a child `n + 1` or `offset` of an
        // interior node reached so (`emit`), or a node an emitted lane
        // names (one of those).
        unsafe { self.tree.node(n) }
    }

    /// Binary node `n`'s entry (as for [`Self::node`]).
    #[inline(always)]
    fn entry(&self, n: usize) -> &'a Entry {
        // SAFETY: as in `node`.
        unsafe { self.tree.value(n) }
    }

    /// Append the lanes representing subtree `n` in at most `i` lanes (wide
    /// children as [`Lane::PENDING`], built by [`Self::build_node`]).
    fn emit(&self, n: usize, i: usize, lanes: &mut Lanes) {
        let node = self.node(n);
        let e = self.entry(n);
        if i == 1 || node.is_leaf() {
            if e.as_leaf {
                let (first, count) = e.range;
                lanes.push(Lane { node: n, child: first, count });
            } else {
                lanes.push(Lane { node: n, child: Lane::PENDING, count: 0 });
            }
            return;
        }
        if e.cost[i] == e.cost[i - 1] {
            // Opening n into i lanes is no cheaper than using fewer.
            self.emit(n, i - 1, lanes);
        } else {
            let j = e.split[i] as usize;
            self.emit(n + 1, j, lanes);
            self.emit(node.offset as usize, i - j, lanes);
        }
    }

    /// Make binary node `n` a wide node at the end of `out`, followed by its
    /// wide descendants depth-first; returns its index and the wide levels of
    /// its subtree (1 for a node without inner lanes). Large subtrees build
    /// their wide children in parallel.
    fn build_node(&self, n: usize, out: &mut Vec<WideNode>) -> (u32, u32) {
        let me = out.len();
        out.push(WideNode::EMPTY);
        let mut lanes = Lanes::default();
        let node = self.node(n);
        if node.is_leaf() {
            lanes.push(Lane { node: n, child: node.offset, count: node.count });
        } else {
            let j = self.entry(n).split[WIDTH] as usize;
            self.emit(n + 1, j, &mut lanes);
            self.emit(node.offset as usize, WIDTH - j, &mut lanes);
        }
        let lanes = &mut lanes.lanes[..lanes.len];
        let mut pending = [0usize; WIDTH];
        let mut np = 0;
        for (k, lane) in lanes.iter().enumerate() {
            if lane.child == Lane::PENDING {
                pending[np] = k;
                np += 1;
            }
        }
        let pending = &pending[..np];
        let mut below = 0;
        if self.entry(n).range.1 >= PARALLEL_THRESHOLD && pending.len() > 1 && rayon::current_num_threads() > 1 {
            use rayon::prelude::*;
            let subs: Vec<(Vec<WideNode>, u32)> = pending
                .par_iter()
                .map(|&k| {
                    // Room for twice the usual count (about one wide node per
                    // eight primitives), so that the vector does not grow by
                    // copies; it grows past that if it must.
                    let mut v = Vec::with_capacity(self.entry(lanes[k].node).range.1 as usize / 4 + 1);
                    let (_, levels) = self.build_node(lanes[k].node, &mut v);
                    (v, levels)
                })
                .collect();
            below = subs.iter().map(|s| s.1).max().unwrap_or(0);
            let subs: Vec<Vec<WideNode>> = subs.into_iter().map(|s| s.0).collect();
            // The subtrees go into place in parallel pieces: copied by this
            // thread alone, dragon_full's 110,000 wide nodes (28 MB) made the
            // emission as slow on two threads as on one.
            let start = out.len();
            let total: usize = subs.iter().map(Vec::len).sum();
            out.reserve(total);
            let mut rest = &mut out.spare_capacity_mut()[..total];
            let mut pieces = Vec::new();
            let mut base = start;
            for (&k, sub) in pending.iter().zip(&subs) {
                lanes[k].child = base as u32;
                let (dst, tail) = rest.split_at_mut(sub.len());
                rest = tail;
                for (d, s) in dst.chunks_mut(COPY_PIECE).zip(sub.chunks(COPY_PIECE)) {
                    pieces.push((d, s, base as u32));
                }
                base += sub.len();
            }
            pieces.into_par_iter().for_each(|(dst, src, base)| {
                for (d, w) in dst.iter_mut().zip(src) {
                    let mut w = *w;
                    for l in 0..WIDTH {
                        if w.count[l] == 0 && w.child[l] != u32::MAX {
                            w.child[l] += base;
                        }
                    }
                    d.write(w);
                }
            });
            // SAFETY: the `total` slots after `start` were reserved above and
            // every one was written: the pieces tile them (each subtree's
            // slots are split into pieces of its own nodes, and the subtrees'
            // slots follow one another up to `total`).
            unsafe { out.set_len(start + total) };
        } else {
            for &k in pending {
                let levels;
                (lanes[k].child, levels) = self.build_node(lanes[k].node, out);
                below = below.max(levels);
            }
        }
        let mut w = WideNode::EMPTY;
        for (k, lane) in lanes.iter().enumerate() {
            w.set_lane(k, self.node(lane.node), lane.child, lane.count);
        }
        out[me] = w;
        (me as u32, below + 1)
    }
}

/// One lane of a wide node under construction: the binary node it stands
/// for (its box), and the child index or first primitive and count.
#[derive(Clone, Copy, Default)]
struct Lane {
    node: usize,
    child: u32,
    count: u32,
}

impl Lane {
    /// The child of a wide-node lane whose node is not built yet.
    const PENDING: u32 = u32::MAX;
}

/// The lanes of one wide node under construction (at most [`WIDTH`]; an
/// array, not a `Vec`: no allocation per wide node).
#[derive(Default)]
struct Lanes {
    lanes: [Lane; WIDTH],
    len: usize,
}

impl Lanes {
    /// Append `lane` (the plan never gives a node more than [`WIDTH`] lanes).
    fn push(&mut self, lane: Lane) {
        self.lanes[self.len] = lane;
        self.len += 1;
    }
}

/// Collapse the binary `tree` into wide nodes, depth-first; node 0 is the
/// root. Empty for an empty tree. The result does not depend on the number
/// of threads (nor on the gaps of the tree's layout: the collapse follows
/// its links).
///
/// Also returns the wide levels, the nodes on the longest root-to-leaf path
/// (0 for an empty tree), counted as the nodes are made, instead of a
/// serial walk over the finished tree (until stop 44; with the links'
/// check moved into the packing, 139,000 instructions fewer per dragon_87k
/// build, callgrind).
pub fn collapse(tree: &GappedTree<Entry>) -> (Vec<WideNode>, usize) {
    let mut out = super::huge::vec_with_capacity(tree.len() / 4 + 1);
    let mut levels = 0;
    if !tree.is_empty() {
        levels = Plan { tree }.build_node(0, &mut out).1 as usize;
    }
    (out, levels)
}

#[cfg(test)]
pub(crate) mod tests {
    use glam::Vec3;

    use super::*;
    use crate::backends::{AccelConfig, Builder};
    use crate::geometry::{Aabb, Primitives, Triangle};
    use crate::rng::Pcg32;

    /// Small random triangles scattered in a unit cube.
    pub(crate) fn scattered(n: usize, seed: u64) -> Primitives {
        let mut rng = Pcg32::new(seed, 0);
        let mut p = || Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
        let triangles = (0..n)
            .map(|_| {
                let c = p();
                Triangle { v: [c, c + 0.02 * p(), c + 0.02 * p()] }
            })
            .collect();
        Primitives { triangles, spheres: Vec::new() }
    }

    /// [`collapse`] of a gapless depth-first binary tree (a [`crate::bvh::BinaryBvh`]'s
    /// nodes), its table made in one sweep. `block`: as in [`CostTable`].
    fn collapse_nodes(bin: &[Node], block: u32) -> (Vec<WideNode>, usize) {
        collapse(&GappedTree::from_nodes(bin.to_vec(), Vec::new(), &CostTable { block }))
    }

    /// The double loop `both_children` replaced (the definition).
    fn both_children_reference(cl: &Row, cr: &Row) -> (Row, [u8; WIDTH + 1]) {
        let mut dist = [f32::INFINITY; WIDTH + 1];
        let mut split = [0u8; WIDTH + 1];
        for i in 2..=WIDTH {
            for j in 1..i {
                let c = cl[j] + cr[i - j];
                if c < dist[i] || split[i] == 0 {
                    dist[i] = c;
                    split[i] = j as u8;
                }
            }
        }
        (dist, split)
    }

    #[test]
    fn lane_parallel_convolution_is_the_double_loop() {
        // Rows as `entry` makes them (non-increasing from lane 1) and arbitrary
        // ones, with ties, zeros, infinities and NaNs.
        let mut rng = Pcg32::new(17, 3);
        let specials = [0.0, f32::INFINITY, f32::NAN, f32::MAX, 1.0, 0.5];
        for case in 0..20_000 {
            let mut row = |monotone: bool| {
                let mut r: Row = [0.0; WIDTH + 1];
                for i in 1..=WIDTH {
                    r[i] = match rng.next_u32() % 8 {
                        0 => specials[(rng.next_u32() % specials.len() as u32) as usize],
                        1 if i > 1 => r[i - 1],
                        _ => (rng.next_u32() % 16) as f32 * 0.25,
                    };
                    if monotone && i > 1 {
                        r[i] = r[i].min(r[i - 1]);
                    }
                }
                r
            };
            let monotone = case % 2 == 0;
            let (cl, cr) = (row(monotone), row(monotone));
            let (d, s) = both_children(&cl, &cr);
            let (d_ref, s_ref) = both_children_reference(&cl, &cr);
            for i in 2..=WIDTH {
                assert_eq!(d[i].to_bits(), d_ref[i].to_bits(), "dist[{i}] of {cl:?} and {cr:?}");
                assert_eq!(s[i], s_ref[i], "split[{i}] of {cl:?} and {cr:?}");
                assert!((1..i as u8).contains(&s[i]));
            }
        }
    }

    /// Walk the wide tree: every primitive slot is in exactly one leaf lane,
    /// every lane's box contains what it holds, and leaves stay small.
    fn check(wide: &[WideNode], bin: &[Node], n_prims: usize) {
        let mut seen = vec![0u32; n_prims];
        let mut stack = vec![(0usize, None::<Aabb>)];
        while let Some((i, parent)) = stack.pop() {
            let node = &wide[i];
            assert!(node.used() >= 1);
            for l in 0..WIDTH {
                if node.child[l] == u32::MAX {
                    continue;
                }
                let b = Aabb::new(
                    Vec3::new(node.b[0][l], node.b[1][l], node.b[2][l]),
                    Vec3::new(node.b[3][l], node.b[4][l], node.b[5][l]),
                );
                if let Some(p) = parent {
                    assert!(p.union(b) == p, "lane box outside its parent's");
                }
                if node.count[l] > 0 {
                    assert!(node.count[l] <= MAX_LEAF);
                    for k in node.child[l]..node.child[l] + node.count[l] {
                        seen[k as usize] += 1;
                    }
                } else {
                    stack.push((node.child[l] as usize, Some(b)));
                }
            }
        }
        assert!(seen.iter().all(|&c| c == 1), "a primitive slot is missing or repeated");
        let interior = bin.iter().filter(|n| !n.is_leaf()).count();
        assert!(wide.len() <= interior.max(1), "{} wide nodes for {interior} binary interior nodes", wide.len());
    }

    #[test]
    fn collapse_covers_every_primitive_once_inside_its_boxes() {
        for (n, builder) in [(1, Builder::Sah), (7, Builder::Sah), (5000, Builder::Sah), (3000, Builder::Median)] {
            let prims = scattered(n, n as u64);
            let cfg = AccelConfig { builder, ..Default::default() };
            let bin = crate::bvh::build_binary(&prims, &cfg);
            let (wide, _) = collapse_nodes(&bin.nodes, crate::bvh::packet::leaf_block(prims.len()));
            check(&wide, &bin.nodes, n);
        }
    }

    #[test]
    fn median_leaves_of_one_are_merged_and_nodes_fill_up() {
        // The median builder's leaves hold one triangle: the collapse merges
        // siblings into leaves of up to MAX_LEAF and fills nodes, so there
        // are far fewer wide nodes than a binary interior node per two leaves.
        let prims = scattered(4096, 9);
        let cfg = AccelConfig { builder: Builder::Median, ..Default::default() };
        let bin = crate::bvh::build_binary(&prims, &cfg);
        let (wide, _) = collapse_nodes(&bin.nodes, crate::bvh::packet::leaf_block(prims.len()));
        let lanes: usize = wide.iter().map(WideNode::used).sum();
        assert!(lanes as f64 / wide.len() as f64 > 4.0, "mean fill {}", lanes as f64 / wide.len() as f64);
        let max_leaf = wide.iter().flat_map(|w| w.count).max().unwrap_or(0);
        assert!(max_leaf > 1 && max_leaf <= MAX_LEAF);
    }

    /// The tree, its wide nodes and its leaf packets do not depend on the
    /// number of threads that built them (the parallel binning, planning,
    /// emitting and packing merge exactly).
    #[test]
    fn one_and_two_threads_build_the_same_tree() {
        let prims = scattered(150_000, 4);
        let build = |threads: usize| {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            pool.install(|| crate::bvh::build_wide(&prims, &AccelConfig::default()))
        };
        let (a, b) = (build(1), build(2));
        assert!(a.nodes.len() > 1000);
        assert!(bits(&a) == bits(&b), "1 and 2 threads built different trees");
    }

    /// Every float of a wide tree's nodes and packets as bits, and every link, id and count.
    fn bits(w: &crate::bvh::WideBvh) -> Vec<u32> {
        let nodes =
            w.nodes.iter().flat_map(|n| n.b.iter().flatten().map(|f| f.to_bits()).chain(n.child).chain(n.count));
        let packets = w
            .packets
            .iter()
            .flat_map(|p| &p.packets)
            .flat_map(|p| p.v.iter().flatten().map(|f| f.to_bits()).chain(p.id));
        nodes.chain(packets).collect()
    }

    /// The cost table computed while a two-thread build makes its nodes
    /// (in the slots beside them, a layout with gaps) is the table a sweep
    /// over the finished, gapless tree makes: the wide trees collapsed from
    /// the two are the same bit for bit, for every builder.
    #[test]
    fn table_made_during_the_build_is_the_swept_one() {
        let prims = scattered(100_000, 5);
        let pool = rayon::ThreadPoolBuilder::new().num_threads(2).build().unwrap();
        for builder in [Builder::Sah, Builder::Median, Builder::SahVolume] {
            let cfg = AccelConfig { builder, ..Default::default() };
            let (during, swept) = pool.install(|| {
                let during = crate::bvh::build_wide(&prims, &cfg);
                let swept = crate::bvh::WideBvh::from_binary(crate::bvh::build_binary(&prims, &cfg));
                (during, swept)
            });
            assert!(during.nodes.len() > 1000);
            assert!(bits(&during) == bits(&swept), "{builder:?}: the tables differ");
        }
    }
}
