//! Binned surface-area-heuristic builder (Wald 2007; pbrt-v4 section 7.3).
//!
//! Centroids are binned on all three axes; the split between bins costs
//! `C_trav + C_isect * (A_l B(N_l) + A_r B(N_r)) / A` with `A` the box *surface
//! area* (the probability that a ray through the parent also crosses the
//! child, for uniformly distributed rays) and `B(N)` the primitive count
//! rounded up to whole leaf tests of [`SahSplit::block`] triangles. A node becomes a leaf when
//! no split beats its leaf cost `C_isect * B(N)` and it holds at most
//! [`SAH_MAX_LEAF`] primitives. The bins of a node are held bin-major with the
//! three axes side by side, so the sweep evaluates the three axes at once.
//! Large nodes bin and partition their references in parallel chunks, and
//! build their subtrees in parallel (rayon).

use glam::{UVec4, Vec3A};

use super::config::Builder;
use crate::geometry::{Aabb, Primitives};

use super::build::{BinaryBvh, BoxA, BuildInput, PrimRef, Split, Splitter, build_with, doubled_centroid_bounds_of};

/// Cost of visiting one node, relative to [`INTERSECTION_COST`].
pub const TRAVERSAL_COST: f32 = 1.0;
/// Cost of one primitive slot of a leaf. The `fast` path tests a leaf's
/// triangles in 4-wide packets, so a leaf of `n` primitives costs
/// `ceil(n / block) * block` slots (as Embree's builders count them; `block`
/// is 4, or 8 in large meshes, [`crate::bvh::packet::leaf_block`]): a
/// packet costs `4 * 0.5 = 2` binary-node visits, about two thirds of one
/// 8-wide node visit (which stands for three binary levels).
///
/// Measured on dragon_87k (`examples/trace_loop.rs` counts, deterministic):
/// against the former per-primitive cost of 0.35, wide-node visits plus
/// packet tests per ray fell from 3.15 to 3.04 (primary) and from 6.77 to
/// 6.50 (incoherent), with 1.04 instead of 1.5 packets per leaf visited.
pub const INTERSECTION_COST: f32 = 0.5;
/// Nodes with more primitives than this are always split.
pub const SAH_MAX_LEAF: usize = 8;
/// Deepest level; only reachable on pathological input (the node then stays a large leaf).
pub const SAH_MAX_DEPTH: u32 = 100;
/// Largest accepted bin count.
pub const SAH_MAX_BINS: usize = 256;

/// Binned SAH split with `bins` bins per axis.
pub struct SahSplit {
    /// Bins per axis (clamped to `2..=SAH_MAX_BINS`).
    pub bins: usize,
    /// Triangles per leaf test, a power of two ([`crate::bvh::packet::leaf_block`]):
    /// leaf counts are rounded up to it, and nodes of at most this many
    /// primitives are leaves outright.
    pub block: u32,
}

/// Bin of (doubled) centroid `c` on every axis: `trunc(min((c - cmin) * scale, last))`,
/// the same per-lane arithmetic as the partition step uses on one axis.
/// The argument is in `[0, last]`, so truncation to an integer is exact.
#[inline(always)]
fn bins_of(c: Vec3A, cmin: Vec3A, scale: Vec3A, last: Vec3A) -> [usize; 3] {
    let f = ((c - cmin) * scale).min(last);
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{__m128i, _mm_cvttps_epi32, _mm_storeu_si128};
        let mut o = [0i32; 4];
        // SAFETY: SSE2 is part of the x86_64 baseline; o has room for 4 lanes.
        unsafe { _mm_storeu_si128(o.as_mut_ptr().cast::<__m128i>(), _mm_cvttps_epi32(f.into())) };
        [o[0] as usize, o[1] as usize, o[2] as usize]
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        [f.x as usize, f.y as usize, f.z as usize]
    }
}

impl Splitter for SahSplit {
    fn max_depth(&self) -> u32 {
        SAH_MAX_DEPTH
    }

    fn split(
        &self,
        _input: &BuildInput,
        idx: &mut [PrimRef],
        bounds: &Aabb,
        centroids: Option<BoxA>,
        _depth: u32,
    ) -> Option<Split> {
        let n = idx.len();
        if n <= self.block as usize {
            // One leaf test either way: splitting cannot save one.
            // (On dragon_87k the traversal counts are unchanged by this
            // shortcut, and the build runs 10% fewer instructions.)
            return None;
        }
        let cb = centroids.unwrap_or_else(|| doubled_centroid_bounds_of(idx));
        let ext = cb.max - cb.min;
        // Small nodes need no more bins than primitives (saves clearing empty bins).
        let nb = self.bins.clamp(2, SAH_MAX_BINS).min(n.max(4));
        let scale = Vec3A::select(ext.cmpgt(Vec3A::ZERO), Vec3A::splat(nb as f32) / ext, Vec3A::ZERO);

        SCRATCH.with_borrow_mut(|scratch| self.split_with(scratch, idx, bounds, cb, nb, scale))
    }
}

thread_local! {
    /// Per-thread bin storage reused across nodes (no allocation per node).
    static SCRATCH: std::cell::RefCell<Scratch> = const {
        std::cell::RefCell::new(Scratch {
            bins: Vec::new(),
            soa: Vec::new(),
            right_cost: Vec::new(),
            bins2: Vec::new(),
        })
    };
}

/// Bin `k` of all three axes: lane `a` of `count` and box `b[a]` belong to
/// bin `k` of axis `a`. One record per bin (not a count array beside a box
/// array): a reference's three updates then index one slice, whose bounds
/// check one clamp removes; with two arrays of unrelated lengths each update
/// kept its own checks (about ten instructions of a reference's 75).
#[derive(Clone, Copy)]
struct Bin {
    /// Primitives in the bin, per axis.
    count: UVec4,
    /// Box of the bin's primitives, per axis.
    b: [BoxA; 3],
}

impl Bin {
    const EMPTY: Bin = Bin { count: UVec4::ZERO, b: [BoxA::EMPTY; 3] };

    /// Add `o`'s primitives (counts add and boxes unite exactly, in any order).
    #[inline(always)]
    fn merge(&mut self, o: &Bin) {
        self.count += o.count;
        for (x, y) in self.b.iter_mut().zip(&o.b) {
            *x = x.union(*y);
        }
    }
}

/// Per-thread scratch of a node's split.
struct Scratch {
    /// The node's bins.
    bins: Vec<Bin>,
    /// The bins transposed for the sweeps.
    soa: Vec<Transposed>,
    /// Per bin `s`, lane `a`: the right side's term of the cost of the
    /// split before bin `s` of axis `a`, the half area of the union of bins
    /// `s..` times their primitives in whole blocks.
    right_cost: Vec<Vec3A>,
    /// A second set of bins for the odd primitives of [`bin_into2`].
    bins2: Vec<Bin>,
}

/// Make `v` at least `n` long (new entries `value`; existing ones kept).
#[inline(always)]
fn grow<T: Copy>(v: &mut Vec<T>, n: usize, value: T) {
    if v.len() < n {
        v.resize(n, value);
    }
}

/// Primitive slots a leaf of `n` primitives costs: `n` rounded up to whole
/// tests of `block` triangles.
pub fn leaf_slots(n: usize, block: u32) -> usize {
    n.div_ceil(block as usize) * block as usize
}

/// `n` rounded up to whole blocks of `1 << shift`, per lane, as floats.
///
/// Converted as signed integers (one instruction; SSE2 has no unsigned
/// conversion, which took eight): a count is at most a node's references,
/// below 2^31 for any mesh that fits in memory (2^31 references take 64 GiB),
/// and a count beyond would only misprice a split, not change an answer.
#[inline(always)]
fn block_slots(n: UVec4, shift: u32) -> Vec3A {
    Vec3A::from_vec4((((n + UVec4::splat((1 << shift) - 1)) >> shift) << shift).as_ivec4().as_vec4())
}

/// Three boxes (one bin of each axis) transposed: `lo[c]` and `hi[c]` hold
/// coordinate `c` of the three boxes' corners, box `a` in lane `a`.
#[derive(Clone, Copy)]
struct Transposed {
    lo: [Vec3A; 3],
    hi: [Vec3A; 3],
}

impl Transposed {
    const EMPTY: Transposed = Transposed { lo: [Vec3A::INFINITY; 3], hi: [Vec3A::NEG_INFINITY; 3] };

    /// Transpose the three boxes `b`.
    #[inline(always)]
    fn of(b: &[BoxA; 3]) -> Self {
        let t = |f: fn(&BoxA) -> Vec3A, c: usize| Vec3A::new(f(&b[0])[c], f(&b[1])[c], f(&b[2])[c]);
        Self {
            lo: [t(|b| b.min, 0), t(|b| b.min, 1), t(|b| b.min, 2)],
            hi: [t(|b| b.max, 0), t(|b| b.max, 1), t(|b| b.max, 2)],
        }
    }

    /// Lane-wise union.
    #[inline(always)]
    fn union(&self, o: &Transposed) -> Self {
        Self { lo: [0, 1, 2].map(|c| self.lo[c].min(o.lo[c])), hi: [0, 1, 2].map(|c| self.hi[c].max(o.hi[c])) }
    }

    /// Half surface area of each lane's box: the same arithmetic as
    /// [`BoxA::half_area`], lane by lane, but +inf for an empty box (its
    /// extents are -inf; [`BoxA::half_area`] clamps them to 0). A split
    /// with an empty side (0 slots) then costs `inf * 0 + ...`, NaN, which
    /// never compares below the best cost: the sweep needs no test of the
    /// sides' counts (nor of the axis, whose coinciding centroids all fall in
    /// bin 0). A box that is not empty has extents of at least 0, so the
    /// areas the sweeps compare are those of the clamped form.
    #[inline(always)]
    fn half_area(&self) -> Vec3A {
        let [x, y, z] = [0, 1, 2].map(|c| self.hi[c] - self.lo[c]);
        x * y + y * z + z * x
    }
}

/// Nodes with at least this many primitives bin in parallel (when the pool has more than one thread).
const PARALLEL_BINNING: usize = 1 << 16;

/// Add the primitives of `refs` to `bins`.
#[inline(always)]
fn bin_into(refs: &[PrimRef], bins: &mut [Bin], cmin: Vec3A, scale: Vec3A, lastf: Vec3A) {
    for r in refs {
        bin_one(r.boxa(), bins, cmin, scale, lastf);
    }
}

/// Add the primitive with box `b` to the bins of every axis.
#[inline(always)]
fn bin_one(b: BoxA, bins: &mut [Bin], cmin: Vec3A, scale: Vec3A, lastf: Vec3A) {
    let last = bins.len() - 1;
    let k = bins_of(b.min + b.max, cmin, scale, lastf);
    for (a, &ka) in k.iter().enumerate() {
        // bins_of returns values in 0..bins.len(); the clamp only lets the
        // compiler drop the bounds check.
        let bin = &mut bins[ka.min(last)];
        bin.count[a] += 1;
        bin.b[a] = bin.b[a].union(b);
    }
}

/// Nodes with at least this many primitives bin into two sets of bins (see [`bin_into2`]).
const TWO_WAY_BINNING: usize = 64;

/// [`bin_into`] with the even primitives in `bins` and the odd ones in
/// `bins2` (both cleared by the caller, of one length), then the second set
/// merged into the first. After the first splits, neighbouring primitives of a
/// node usually fall in the same bins, and with one set each update of a bin
/// waits for the previous one's store; two sets halve that chain. Counts add
/// and boxes unite exactly, so the bins are those of one pass.
#[inline(always)]
fn bin_into2(refs: &[PrimRef], bins: &mut [Bin], bins2: &mut [Bin], cmin: Vec3A, scale: Vec3A, lastf: Vec3A) {
    let pairs = refs.chunks_exact(2);
    let rest = pairs.remainder();
    for p in pairs {
        bin_one(p[0].boxa(), bins, cmin, scale, lastf);
        bin_one(p[1].boxa(), bins2, cmin, scale, lastf);
    }
    bin_into(rest, bins, cmin, scale, lastf);
    bins.iter_mut().zip(bins2.iter()).for_each(|(x, y)| x.merge(y));
}

/// In-place partition of `idx` by `side(doubled centroid)` (1: left); returns the
/// left count. No branch per reference (Lomuto's scheme with the side as the
/// increment of the left end: each reference is swapped to the left end,
/// which advances when it belongs left): the side of a reference is
/// unpredictable near the top of a tree, and a branching scan pays a
/// misprediction for about every other one.
///
/// Nodes under 1024 references used to take Hoare's branching scan (both
/// ends inward, swapping misplaced pairs), chosen from a loop that built one
/// mesh thousands of times in a row: there the branch predictor learns the
/// mesh's partitions, which a user's single build never has. In `rtdiff
/// bench --race` (rtdiff's build between Embree's builds and ray tracing, as
/// in an application) the branchless scan for every node builds suzanne
/// 0.21 -> 0.20 ms and dragon_87k 23.6-24.0 -> 20.5 ms on one thread. The
/// sides hold the same references in either scheme; the order inside a side
/// changes no binned split (bins, counts and boxes do not depend on order;
/// only the split by count of a node whose centroids all coincide does) and
/// no answer (ties between primitives go by id).
///
/// The loop also gathered the two sides' centroid boxes, with selects (SSE2
/// has no blend: three instructions each), which made it twice as long; each
/// child now computes its own in a separate read-only pass. Same boxes (a
/// minimum and a maximum are exact in any order), hence the same tree;
/// `examples/call_path.rs MESH build-cold N`, one binary with the two forms
/// switched: suzanne 0.164-0.165 -> 0.151-0.156 ms, dragon_87k 19.9-20.0 ->
/// 18.1-18.5 ms.
#[inline(always)]
fn partition_branchless(idx: &mut [PrimRef], side: impl Fn(Vec3A) -> u32) -> usize {
    let mut j = 0usize;
    for i in 0..idx.len() {
        let x = idx[i];
        let left = side(x.doubled_centroid());
        idx[i] = idx[j];
        idx[j] = x;
        j += left as usize;
    }
    j
}

/// Nodes with at least this many references are partitioned by
/// [`partition_chunked`] (on any number of threads, so that the tree does
/// not depend on the thread count).
const CHUNKED_PARTITION: usize = 1 << 15;

/// References per chunk of [`partition_chunked`] (a fixed size: the order the
/// partition leaves, and so the tree, does not depend on the thread count).
const PARTITION_CHUNK: usize = 1 << 13;

/// [`partition_branchless`] of a large node, its chunks of
/// [`PARTITION_CHUNK`] references in parallel (rayon): each chunk is
/// partitioned in place, then the right-side references that lie in the
/// left side's final range swap places, in order, with the left-side ones
/// beyond it, in parallel pieces. The two sides hold the same references as
/// after [`partition_branchless`] (in another order, fixed by the chunk size
/// alone). Returns the left count.
fn partition_chunked(idx: &mut [PrimRef], side: impl Fn(Vec3A) -> u32 + Sync) -> usize {
    use rayon::prelude::*;
    let lefts: Vec<usize> = idx.par_chunks_mut(PARTITION_CHUNK).map(|c| partition_branchless(c, &side)).collect();
    let total: usize = lefts.iter().sum();
    // Chunk `i` holds its left references at `s .. s + l` and its right ones
    // at `s + l .. e`: those of the right below `total` and those of the
    // left at or above it are misplaced, equally many.
    let (mut wrong_right, mut wrong_left) = (Vec::new(), Vec::new());
    for (i, &l) in lefts.iter().enumerate() {
        let (s, e) = (i * PARTITION_CHUNK, ((i + 1) * PARTITION_CHUNK).min(idx.len()));
        if s + l < total.min(e) {
            wrong_right.push(s + l..total.min(e));
        }
        if s.max(total) < s + l {
            wrong_left.push(s.max(total) - total..s + l - total);
        }
    }
    // Pair them up in order into equal-length pieces, one from each side of
    // `total` (increasing and disjoint on each side, so carved off in turn).
    let (mut lo, mut hi) = idx.split_at_mut(total);
    let (mut lo_at, mut hi_at) = (0, 0);
    let (mut a, mut b) = (wrong_right.into_iter(), wrong_left.into_iter());
    let (mut ra, mut rb) = (a.next(), b.next());
    let mut pieces = Vec::new();
    while let (Some(x), Some(y)) = (ra.clone(), rb.clone()) {
        let len = x.len().min(y.len()).min(PARTITION_CHUNK);
        let (p, rest) = std::mem::take(&mut lo)[x.start - lo_at..].split_at_mut(len);
        (lo, lo_at) = (rest, x.start + len);
        let (q, rest) = std::mem::take(&mut hi)[y.start - hi_at..].split_at_mut(len);
        (hi, hi_at) = (rest, y.start + len);
        pieces.push((p, q));
        ra = if len < x.len() { Some(x.start + len..x.end) } else { a.next() };
        rb = if len < y.len() { Some(y.start + len..y.end) } else { b.next() };
    }
    debug_assert!(ra.is_none() && rb.is_none(), "as many misplaced references on each side");
    pieces.into_par_iter().for_each(|(p, q)| p.swap_with_slice(q));
    total
}

impl SahSplit {
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn split_with(
        &self,
        scratch: &mut Scratch,
        idx: &mut [PrimRef],
        bounds: &Aabb,
        cb: BoxA,
        nb: usize,
        scale: Vec3A,
    ) -> Option<Split> {
        let n = idx.len();
        let last = nb as u32 - 1;
        debug_assert!(self.block.is_power_of_two(), "leaf block {} is not a power of two", self.block);
        let shift = self.block.trailing_zeros();
        let Scratch { bins, soa, right_cost, bins2 } = scratch;
        // The bins are accumulated into, so they start empty; the sweep
        // arrays are written before they are read and only need the room.
        grow(bins, nb, Bin::EMPTY);
        bins[..nb].fill(Bin::EMPTY);
        grow(right_cost, nb, Vec3A::ZERO);
        grow(soa, nb, Transposed::EMPTY);
        let lastf = Vec3A::splat(last as f32);
        let bins = &mut bins[..nb];
        if n >= PARALLEL_BINNING && rayon::current_num_threads() > 1 {
            // Large nodes (the top of the tree, which no fork shares out) bin
            // in parallel chunks, two sets of bins each as below, whose bins
            // are then merged: counts add and boxes unite exactly, so the
            // bins are those of one sequential pass.
            use rayon::prelude::*;
            let chunk = (n / (2 * rayon::current_num_threads())).max(PARALLEL_BINNING / 4);
            let merged = idx
                .par_chunks(chunk)
                .map(|c| {
                    let (mut b, mut b2) = (vec![Bin::EMPTY; nb], vec![Bin::EMPTY; nb]);
                    bin_into2(c, &mut b, &mut b2, cb.min, scale, lastf);
                    b
                })
                .reduce_with(|mut b0, b1| {
                    b0.iter_mut().zip(&b1).for_each(|(x, y)| x.merge(y));
                    b0
                })
                .expect("a node has primitives");
            bins.copy_from_slice(&merged);
        } else if n >= TWO_WAY_BINNING {
            grow(bins2, nb, Bin::EMPTY);
            bins2[..nb].fill(Bin::EMPTY);
            bin_into2(idx, bins, &mut bins2[..nb], cb.min, scale, lastf);
        } else {
            bin_into(idx, bins, cb.min, scale, lastf);
        }

        // Best split: minimise A_l B(N_l) + A_r B(N_r) (the constant terms of
        // the cost do not change the argmin), the three axes at once, one per
        // lane: the bins are transposed so that each coordinate of the three
        // axes' boxes sits in one vector.
        // Every array cut to the node's `nb` bins up front and walked by
        // iterators: indexing four arrays of independent lengths kept six
        // bounds checks in each sweep step.
        let soa = &mut soa[..nb];
        let right_cost = &mut right_cost[..nb];
        // The bins are transposed as the right-to-left sweep reaches them
        // (bin 0, which it does not reach, apart).
        soa[0] = Transposed::of(&bins[0].b);
        let mut run = Transposed::EMPTY;
        let mut rn = UVec4::ZERO;
        for ((t, b), rc) in soa.iter_mut().zip(bins.iter()).zip(right_cost.iter_mut()).skip(1).rev() {
            *t = Transposed::of(&b.b);
            run = run.union(t);
            rn += b.count;
            // The right term of the cost below, as a product made here: the
            // same bits as inside the sum (Rust does not fuse multiply-adds).
            *rc = run.half_area() * block_slots(rn, shift);
        }
        let mut best_cost = Vec3A::INFINITY;
        let mut best_bin = Vec3A::ZERO;
        let mut run = Transposed::EMPTY;
        let mut ln = UVec4::ZERO;
        // Bin `s` as a float, counted alongside (an exact integer).
        let mut sf = Vec3A::ZERO;
        for ((t, b), &rc) in soa.iter().zip(bins.iter()).zip(right_cost.iter().skip(1)) {
            run = run.union(t);
            ln += b.count;
            let cost = run.half_area() * block_slots(ln, shift) + rc;
            // Strictly cheaper (a split with an empty side costs NaN, see
            // `Transposed::half_area`): the first minimum per axis wins.
            // (`min` keeps `best_cost` for NaN and for ties, as the select did.)
            let better = cost.cmplt(best_cost);
            best_cost = cost.min(best_cost);
            best_bin = Vec3A::select(better, sf, best_bin);
            sf += Vec3A::ONE;
        }
        // Lowest axis among the cheapest (the order of a sequential search).
        let (mut axis, mut cost) = (usize::MAX, f32::INFINITY);
        for a in 0..3 {
            if best_cost[a] < cost {
                (axis, cost) = (a, best_cost[a]);
            }
        }
        if axis == usize::MAX {
            // Every centroid coincides: no bin separates them. Split by count only if too many.
            return (n > SAH_MAX_LEAF).then(|| (n / 2).into());
        }
        let s = best_bin[axis] as usize;
        let area = bounds.surface_area() * 0.5;
        let split_cost = TRAVERSAL_COST * area + INTERSECTION_COST * cost;
        let leaf_cost = INTERSECTION_COST * leaf_slots(n, self.block) as f32 * area;
        if n <= SAH_MAX_LEAF && split_cost >= leaf_cost {
            return None;
        }
        let (left, right) = bins.split_at(s + 1);
        let lb = left.iter().fold(BoxA::EMPTY, |b, k| b.union(k.b[axis])).aabb();
        let rb = right.iter().fold(BoxA::EMPTY, |b, k| b.union(k.b[axis])).aabb();
        // `bins_of(c)[axis] <= s`, i.e. `trunc(min(x, last)) <= s` for the
        // non-negative `x = (c - cmin) * scale`, is `x < s + 1` (an exact
        // integer no greater than `last`), evaluated with the same per-lane
        // arithmetic on all three lanes and read at `axis`.
        let limit = Vec3A::splat((s + 1) as f32);
        let side = |c: Vec3A| ((c - cb.min) * scale).cmplt(limit).bitmask() >> axis & 1;
        let i = if n >= CHUNKED_PARTITION { partition_chunked(idx, side) } else { partition_branchless(idx, side) };
        debug_assert_eq!(i, left.iter().map(|k| k.count[axis] as usize).sum::<usize>(), "the bins' left count");
        // The children's centroid boxes are left to the children (one
        // read-only pass each, `doubled_centroid_bounds_of`, and none for a child of
        // at most `block` references, which becomes a leaf before needing it).
        Some(Split { mid: i, bounds: Some((lb, rb)) })
    }
}

/// Build with the binned SAH.
pub fn build(prims: &Primitives, bins: usize) -> BinaryBvh {
    build_with(prims, &SahSplit { bins, block: crate::bvh::packet::leaf_block(prims.len()) }, Builder::Sah)
}

#[cfg(test)]
mod tests {
    use glam::Vec3A;

    use super::*;
    use crate::rng::Pcg32;

    /// The chunked partition puts the same references on each side as the
    /// sequential one, whatever the sizes (a part chunk at the end, one
    /// side empty, sides of every balance), and the same order on one
    /// thread as on two.
    #[test]
    fn chunked_partition_keeps_the_sides_of_the_sequential_one() {
        let mut rng = Pcg32::new(7, 1);
        let sizes = [1, PARTITION_CHUNK - 1, PARTITION_CHUNK, 3 * PARTITION_CHUNK + 17, 11 * PARTITION_CHUNK + 5];
        for &n in &sizes {
            for share in [0.0, 0.01, 0.3, 0.5, 0.9, 1.0] {
                let refs: Vec<PrimRef> = (0..n as u32)
                    .map(|id| {
                        let c = Vec3A::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
                        PrimRef::new(id, BoxA { min: c, max: c })
                    })
                    .collect();
                let side = |c: Vec3A| u32::from(c.x < 2.0 * share);
                let mut seq = refs.clone();
                let ns = partition_branchless(&mut seq, side);
                let mut orders = Vec::new();
                for threads in [1, 2] {
                    let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
                    let mut ch = refs.clone();
                    let nc = pool.install(|| partition_chunked(&mut ch, side));
                    assert_eq!(nc, ns, "n {n}, share {share}: left count");
                    let ids = |r: &[PrimRef]| {
                        let mut v: Vec<u32> = r.iter().map(PrimRef::id).collect();
                        v.sort_unstable();
                        v
                    };
                    assert_eq!(ids(&ch[..nc]), ids(&seq[..ns]), "n {n}, share {share}: left side");
                    assert_eq!(ids(&ch[nc..]), ids(&seq[ns..]), "n {n}, share {share}: right side");
                    orders.push(ch.iter().map(PrimRef::id).collect::<Vec<_>>());
                }
                assert_eq!(orders[0], orders[1], "n {n}, share {share}: order depends on the thread count");
            }
        }
    }
}
