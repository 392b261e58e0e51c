//! The production layout ([`super::config::NodeLayout::Wide8`], the `fast`
//! traversal): the binary BVH collapsed into 8-wide nodes whose eight child
//! boxes are tested at once (AVX2 when the CPU has it, with a portable scalar
//! fallback that gives the same answers), nearest-first order, early termination
//! against the closest hit so far, and an any-hit variant for shadow rays.
//!
//! Leaf triangles sit in 4-wide packets ([`super::packet`]); leaves that hold
//! spheres keep [`LeafPrims`] entries instead (flag [`ENTRY_LEAF`]), so a
//! scene with one sphere still tests its triangles four at a time.
//!
//! Everything a query needs to choose (triangle test, instruction set, stack
//! size) is chosen once, when the tree is built: [`WideBvh::kernels`] returns
//! the monomorphised entry points, and the loops below contain no runtime
//! choice of triangle test.

use std::mem::MaybeUninit;

use glam::Vec3;

use crate::geometry::triangle::TriangleKernel;
use crate::geometry::{Hit, Primitives, Ray, TriangleTest};

use super::build::GappedTree;
use super::packet::{LeafRay, PW, Tri4, TriPackets, packets_for};
use super::slab::{cull_bound, far_scale};
use super::{BinaryBvh, LeafPrims, Node};

pub use super::count::{Count, TraversalCounts};

/// Children per wide node.
pub const WIDTH: usize = 8;

/// Flag of a leaf lane's `count` whose primitives are [`LeafPrims`] entries
/// `child .. child + (count & !ENTRY_LEAF)` (a leaf holding a sphere) rather
/// than triangle packets.
pub const ENTRY_LEAF: u32 = 1 << 31;

/// Traversal stack entries for any tree: at most `WIDTH - 1` pending entries
/// per level and at most 100 levels (every builder caps the binary depth, and
/// collapsing never deepens the tree).
const STACK: usize = 1024;
/// Stack entries for trees of at most `SHALLOW_STACK / (WIDTH - 1)` levels
/// (27 wide levels, about 80 binary ones: every mesh tested here): the
/// closest-hit frame then stays under a 4 KiB page, so a call needs no stack
/// probe and touches fewer cache lines, which matters for rays that miss.
const SHALLOW_STACK: usize = 189;

/// An 8-wide node: child boxes in structure-of-arrays form for SIMD tests.
///
/// 256 bytes (32 per child). Lane `i` is empty when `child[i] == u32::MAX`
/// (its box is inverted, `min = +inf`, `max = -inf`, so no ray hits it), an
/// inner node `child[i]` when `count[i] == 0`, or a leaf of `count[i]`
/// triangles whose packets start at `child[i]` (or, with [`ENTRY_LEAF`] set,
/// of [`LeafPrims`] entries starting at `child[i]`).
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
pub struct WideNode {
    /// Rows 0..3: per-lane `min.x, min.y, min.z`; rows 3..6: `max.x, max.y, max.z`.
    pub b: [[f32; WIDTH]; 6],
    /// Child node index, first packet or first entry.
    pub child: [u32; WIDTH],
    /// Primitive count of a leaf lane (with [`ENTRY_LEAF`] for entry leaves), 0 for inner-node and empty lanes.
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

    /// Lanes with a zero count, as a bit mask (bit `i` for lane `i`): the
    /// inner nodes and the empty lanes (which no ray enters).
    #[inline(always)]
    pub fn inner_lanes(&self) -> u32 {
        #[cfg(target_arch = "x86_64")]
        {
            use std::arch::x86_64::*;
            // SAFETY: SSE2 is part of the x86_64 baseline; `count` is 32 bytes,
            // read as two unaligned 16-byte halves.
            unsafe {
                let p = self.count.as_ptr().cast::<__m128i>();
                let z = _mm_setzero_si128();
                let lo = _mm_castsi128_ps(_mm_cmpeq_epi32(_mm_loadu_si128(p), z));
                let hi = _mm_castsi128_ps(_mm_cmpeq_epi32(_mm_loadu_si128(p.add(1)), z));
                (_mm_movemask_ps(lo) | (_mm_movemask_ps(hi) << 4)) as u32
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            let mut m = 0;
            for (i, &n) in self.count.iter().enumerate() {
                m |= u32::from(n == 0) << i;
            }
            m
        }
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
        let (nx, ny, nz) = (usize::from(inv.x < 0.0), usize::from(inv.y < 0.0), usize::from(inv.z < 0.0));
        Self {
            o: ray.origin,
            inv,
            inv_far: inv * far_scale(),
            near_row: [3 * nx, 1 + 3 * ny, 2 + 3 * nz],
            far_row: [3 - 3 * nx, 4 - 3 * ny, 5 - 3 * nz],
            t_min: ray.t_min,
        }
    }
}

/// The leaf constants of `ray` ([`LeafRay`]: the watertight test's shear).
///
/// The walks make them in line, ahead of the first leaf: the closest-hit
/// walk at the first node where the ray enters a leaf's box, the any-hit walk
/// (whose shadow rays nearly all reach a leaf) at the first node it enters.
/// Their divisions then run beside the box tests that lead to the leaf
/// instead of delaying its test, as they did when made out of line at the
/// first leaf. Rays that enter no leaf's box (most camera rays of a mesh that
/// does not fill the view) make none. `rtdiff bench --race 7 --threads 1`,
/// alternated binaries, against Embree's default mode: suzanne incoherent
/// 0.868-0.870 -> 0.902-0.909 (robust MEDIUM 1.037-1.048 -> 1.075-1.089),
/// shadow 0.93-1.00 -> 0.94-1.01; dragon_87k shadow 1.095-1.113 ->
/// 1.125-1.133, primary 1.031-1.042 -> 1.012-1.020 (the cost: rays that
/// enter a leaf's box but hit nothing there). Made at the closest-hit walk's
/// first entered node instead, suzanne gained as much and dragon_87k's camera
/// rays lost more (0.996-1.012).
///
/// A ray whose origin lies inside the tree's box (the closest-hit entry
/// tests it for the root box's early out) nearly always reaches a leaf: the
/// closest-hit walk makes its shear at its start instead, and the branch
/// that asks at each node whether the shear is made then always goes one
/// way. `rtdiff bench --race 5 --threads 1 --rtdiff-isa avx2 --embree-max-isa
/// avx2`, alternated binaries (two pairs), against Embree's default mode:
/// suzanne incoherent 0.875 / 0.880 -> 0.913 / 0.911, camera rays (which
/// start outside) 1.027 / 1.032 -> 1.157 / 1.140 (the same instructions per
/// ray in callgrind: the walk's code moved); dragon_87k (`--race 3`)
/// incoherent 0.904 / 0.909 -> 0.922 / 0.914, camera 0.996 / 0.987 -> 1.021 /
/// 1.039.
///
/// Tests other than the watertight one take no shear: for them this is
/// [`LeafRay::UNUSED`].
#[inline(always)]
fn shear<K: TriangleKernel>(ray: &Ray) -> LeafRay {
    if K::WATERTIGHT { LeafRay::new(ray) } else { LeafRay::UNUSED }
}

/// Scalar 8-lane box test: hit mask and entry distances (the arithmetic of
/// [`super::slab::RayPre::hit`], with the far scale folded into the
/// reciprocal; see [`WidePre::inv_far`]).
#[inline(always)]
fn box8_scalar(n: &WideNode, p: &WidePre, cull: f32, near: &mut [f32; WIDTH]) -> u32 {
    let mut mask = 0;
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
    mask
}

/// The per-ray registers of the AVX2 box test.
#[cfg(target_arch = "x86_64")]
#[derive(Clone, Copy)]
struct Avx2Pre {
    o: [std::arch::x86_64::__m256; 3],
    /// `-inv` and `-inv_far` ([`WidePre`]): the box test computes
    /// `(o - b) * -inv`, the same bits as `(b - o) * inv` (rounding to
    /// nearest is symmetric: `fl(o - b) = -fl(b - o)`) but for the sign of
    /// a zero, which orders nothing (`-0 == 0`) and reaches no answer, with
    /// the node's row as the subtraction's memory operand instead of a load
    /// of its own: six instructions fewer per node.
    neg_inv: [std::arch::x86_64::__m256; 3],
    neg_inv_far: [std::arch::x86_64::__m256; 3],
    t_min: std::arch::x86_64::__m256,
    /// Byte offsets of the near rows of each axis in a node; the far row of
    /// axis `a` is the other of rows `a` and `a + 3`, at [`far_offset`]
    /// (one register per axis instead of two).
    near: [usize; 3],
}

/// Bytes of one row of a [`WideNode`]'s boxes (one coordinate of the eight lanes).
#[cfg(target_arch = "x86_64")]
const ROW_BYTES: usize = std::mem::size_of::<[f32; WIDTH]>();

/// Byte offset of axis `a`'s far row, given its near row's: rows `a` and
/// `a + 3` hold the axis's two planes, so the two offsets add up to
/// `(2 a + 3)` rows ([`WidePre::new`] picks one as near, the other as far).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
const fn far_offset(a: usize, near: usize) -> usize {
    (2 * a + 3) * ROW_BYTES - near
}

/// Broadcast `p` into the AVX2 box test's registers (a macro so it expands
/// inside the AVX2 traversal functions).
#[cfg(target_arch = "x86_64")]
macro_rules! avx2_pre {
    ($p:expr) => {{
        use std::arch::x86_64::*;
        let p: &WidePre = $p;
        let b = |v: Vec3| [_mm256_set1_ps(v.x), _mm256_set1_ps(v.y), _mm256_set1_ps(v.z)];
        debug_assert!((0..3).all(|a| far_offset(a, p.near_row[a] * ROW_BYTES) == p.far_row[a] * ROW_BYTES));
        Avx2Pre {
            o: b(p.o),
            neg_inv: b(-p.inv),
            neg_inv_far: b(-p.inv_far),
            t_min: _mm256_set1_ps(p.t_min),
            near: p.near_row.map(|r| r * ROW_BYTES),
        }
    }};
}

/// AVX2 8-lane box test, expanded inside the AVX2 traversal functions (a
/// macro rather than a function so it is always inlined into them).
///
/// The three slabs and the ray's range combine in a tree of depth two,
/// `max(max(x, y), max(z, t_min))`, one operation shorter on the walk's chain
/// of dependent operations (node row -> box test -> child -> node row) than
/// the chain `max(x, max(y, max(z, t_min)))`. `_mm256_max_ps`/`_mm256_min_ps`
/// return their second operand when either is NaN (a slab of a zero
/// direction component whose origin lies on the plane): a NaN `x` or `z`
/// slab is ignored, as `f32::max`/`f32::min` ignore it in [`box8_scalar`],
/// and a NaN `y` slab drops the `x` one with it. Dropping a slab only widens
/// the interval, so the test never rejects a box the exact test accepts; in
/// that degenerate case it may accept more, a visit that changes no answer.
/// `rtdiff bench --race 9 --threads 1`, the chain and the tree alternated
/// (four pairs), against Embree's default mode: suzanne incoherent
/// 0.982-0.990 -> 0.992-0.996, shadow 1.011-1.021 -> 1.018-1.040; dragon_87k
/// (`--race 5`, two pairs) camera rays 1.061-1.066 -> 1.077-1.144, incoherent
/// 1.078-1.087 -> 1.098-1.103, shadow 1.136-1.137 -> 1.149-1.172.
#[cfg(target_arch = "x86_64")]
macro_rules! box8_avx2 {
    ($n:expr, $q:expr, $cull:expr, $near:expr) => {{
        use std::arch::x86_64::*;
        let (n, q, near): (&WideNode, &Avx2Pre, &mut [f32; WIDTH]) = ($n, $q, $near);
        let base = n.b.as_ptr().cast::<u8>();
        // SAFETY: every offset is a row (32 bytes) of the 64-byte aligned node, so aligned loads are valid.
        let ld = |off: usize| unsafe { _mm256_load_ps(base.add(off).cast::<f32>()) };
        let tn_x = _mm256_mul_ps(_mm256_sub_ps(q.o[0], ld(q.near[0])), q.neg_inv[0]);
        let tn_y = _mm256_mul_ps(_mm256_sub_ps(q.o[1], ld(q.near[1])), q.neg_inv[1]);
        let tn_z = _mm256_mul_ps(_mm256_sub_ps(q.o[2], ld(q.near[2])), q.neg_inv[2]);
        let tf_x = _mm256_mul_ps(_mm256_sub_ps(q.o[0], ld(far_offset(0, q.near[0]))), q.neg_inv_far[0]);
        let tf_y = _mm256_mul_ps(_mm256_sub_ps(q.o[1], ld(far_offset(1, q.near[1]))), q.neg_inv_far[1]);
        let tf_z = _mm256_mul_ps(_mm256_sub_ps(q.o[2], ld(far_offset(2, q.near[2]))), q.neg_inv_far[2]);
        let tn = _mm256_max_ps(_mm256_max_ps(tn_x, tn_y), _mm256_max_ps(tn_z, q.t_min));
        let tf = _mm256_min_ps(_mm256_min_ps(tf_x, tf_y), _mm256_min_ps(tf_z, _mm256_set1_ps($cull)));
        let mask = _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(tn, tf)) as u32;
        // SAFETY: near has room for 8 floats; storeu has no alignment requirement.
        unsafe { _mm256_storeu_ps(near.as_mut_ptr(), tn) };
        mask
    }};
}

/// [`box8_scalar`] in the calling convention of the box-test macros.
macro_rules! box8_portable {
    ($n:expr, $q:expr, $cull:expr, $near:expr) => {
        box8_scalar($n, $q, $cull, $near)
    };
}

/// The portable per-ray data is [`WidePre`] itself.
macro_rules! portable_pre {
    ($p:expr) => {
        *$p
    };
}

/// The box around everything in a tree (the union of the root node's lanes),
/// kept beside the nodes for the closest-hit entry's early out
/// (`misses_root!`): a ray that provably misses it returns at once, before
/// the walk's per-ray set-up (the eight-lane broadcasts, the stack frame)
/// and the root node's eight-lane test. Lane 3 is padding that never
/// restricts a ray (`-inf` below, `+inf` above).
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(16))]
struct RootBox {
    lo: [f32; 4],
    hi: [f32; 4],
}

impl RootBox {
    /// The box of an empty tree: inverted, so that no ray enters it.
    const EMPTY: RootBox = RootBox {
        lo: [f32::INFINITY, f32::INFINITY, f32::INFINITY, f32::NEG_INFINITY],
        hi: [f32::NEG_INFINITY, f32::NEG_INFINITY, f32::NEG_INFINITY, f32::INFINITY],
    };

    /// The union of `root`'s lanes (empty lanes hold inverted boxes and add nothing).
    fn of(root: &WideNode) -> RootBox {
        let mut b = Self::EMPTY;
        for l in 0..WIDTH {
            for a in 0..3 {
                b.lo[a] = b.lo[a].min(root.b[a][l]);
                b.hi[a] = b.hi[a].max(root.b[3 + a][l]);
            }
        }
        b
    }
}

/// Whether the ray of origin `$o`, reciprocal direction `$inv` (both from
/// `ray_sse!`) and interval start `$t_min` provably misses `$bvh`'s
/// [`RootBox`], by the slab arithmetic of the walk's box test on four SSE
/// lanes (a macro, so that it expands inside the AVX2 entry points with
/// their instruction set).
///
/// Exactness. Each axis's entry and exit distances are computed as the
/// walk computes them for a node's lanes (`(plane - o) * inv` for the near
/// plane, `(plane - o) * inv_far` for the far one, the same roundings, the
/// planes picked by the sign of `inv`), so each is a valid conservative bound
/// of the exact slab, and `t_min` bounds the entries as in the walk (the
/// ray's `t_max` is not used, which only keeps more rays). The ray is declared a miss only when the largest
/// entry exceeds the smallest exit in an ordered comparison: `maxps` and
/// `minps` either drop a NaN slab (a zero direction component with the
/// origin on the plane, which bounds nothing) or carry it to the comparison,
/// which is then false. So a miss is declared only when some valid entry
/// bound exceeds some valid exit bound, which no ray that meets the box (and
/// so no ray that meets a triangle of the tree in its interval) can show.
/// Every box of the tree lies inside the root box, so the walk would have
/// entered nothing either: the answer (none) is the walk's, bit for bit.
#[cfg(target_arch = "x86_64")]
macro_rules! misses_root {
    ($bvh:expr, $o:expr, $inv:expr, $t_min:expr) => {{
        use std::arch::x86_64::*;
        let (b, o, inv, t_min): (&RootBox, __m128, __m128, f32) = (&$bvh.root_box, $o, $inv, $t_min);
        let inv_far = _mm_mul_ps(inv, _mm_set1_ps(far_scale()));
        // SAFETY: `RootBox` is 16-byte aligned and its rows are four floats.
        let (lo, hi) = unsafe { (_mm_load_ps(b.lo.as_ptr()), _mm_load_ps(b.hi.as_ptr())) };
        let (a, c) = (_mm_sub_ps(lo, o), _mm_sub_ps(hi, o));
        // Near: the low plane where `inv` is positive, the high one where it
        // is negative (its sign bit picks, as `WidePre::new` picks rows).
        let near = _mm_blendv_ps(_mm_mul_ps(a, inv), _mm_mul_ps(c, inv), inv);
        let far = _mm_blendv_ps(_mm_mul_ps(c, inv_far), _mm_mul_ps(a, inv_far), inv);
        let near = _mm_max_ps(near, _mm_movehl_ps(near, near));
        let near = _mm_max_ss(_mm_max_ss(near, _mm_movehdup_ps(near)), _mm_set_ss(t_min));
        let far = _mm_min_ps(far, _mm_movehl_ps(far, far));
        let far = _mm_min_ss(far, _mm_movehdup_ps(far));
        // (The ray's `t_max` is left to the walk: a miss proven without it
        // is a miss all the same.)
        _mm_comigt_ss(near, far) != 0
    }};
}

/// A ray's origin and direction on four SSE lanes each, `[ox, oy, oz, dx]`
/// and `[dx, dy, dz, t_min]`, and its `t_max`, read field by field.
///
/// A caller that makes each ray just before the call (a camera, a shadow ray
/// spawned at a hit: what users and rtdiff's renderer do) has written it with
/// stores of a field or two each, which have not reached the cache when the
/// call begins. A load wider than those stores, or straddling two of them,
/// cannot take its value from them and waits until they have (a failed
/// store-to-load forward, some 15-20 cycles: as long as a whole ray that
/// misses the root box). The entry therefore reads each field with a load
/// of its own (volatile, so that the optimiser does not merge them into
/// wider ones); the walk's wider loads come much later.
#[cfg(target_arch = "x86_64")]
macro_rules! ray_sse {
    ($ray:expr) => {{
        use std::arch::x86_64::*;
        let p = std::ptr::from_ref::<Ray>($ray).cast::<f32>();
        // SAFETY: the ray is eight aligned `f32`s (checked below).
        let f = |k: usize| unsafe { std::ptr::read_volatile(p.add(k)) };
        let dx = f(3);
        (_mm_setr_ps(f(0), f(1), f(2), dx), _mm_setr_ps(dx, f(4), f(5), f(6)), f(7))
    }};
}

/// [`Ray::is_traceable`] of the ray `ray_sse!` read (`$o`, `$d`, `$t_max`),
/// the same answer for every ray: the six coordinates' exponents from two
/// four-lane compares, a zero direction from another (`-0` equals `0`; a
/// subnormal does not), the interval from a scalar one.
#[cfg(target_arch = "x86_64")]
macro_rules! traceable_sse {
    ($o:expr, $d:expr, $t_max:expr) => {{
        use std::arch::x86_64::*;
        let (o, d, t_max): (__m128, __m128, f32) = ($o, $d, $t_max);
        let e = _mm_set1_epi32(0x7f80_0000);
        let inf =
            |v: __m128| _mm_movemask_ps(_mm_castsi128_ps(_mm_cmpeq_epi32(_mm_and_si128(_mm_castps_si128(v), e), e)));
        let nonfinite = inf(o) | (inf(d) & 0b111);
        let zero = _mm_movemask_ps(_mm_cmpeq_ps(d, _mm_setzero_ps())) & 0b111;
        (nonfinite == 0) & (zero != 0b111) & (_mm_cvtss_f32(_mm_shuffle_ps::<0b11>(d, d)) <= t_max)
    }};
}

/// `ray_sse!` reads a ray as eight consecutive floats.
const _: () = assert!(
    std::mem::offset_of!(Ray, origin) == 0
        && std::mem::offset_of!(Ray, dir) == 12
        && std::mem::offset_of!(Ray, t_min) == 24
        && std::mem::offset_of!(Ray, t_max) == 28
        && std::mem::size_of::<Ray>() == 32
);

/// A pending child: entry distance, node or first primitive, primitive count (0 = inner node).
#[derive(Clone, Copy)]
struct Entry {
    t: f32,
    child: u32,
    count: u32,
}

/// Nearest-first closest-hit traversal of the subtree under node `$start`,
/// generic over the box test; the closest hit before
/// [`LeafPrims::finish`] (a sphere's `(u, v)` not yet made).
macro_rules! closest {
    ($self:ident, $ray:ident, $start:expr, $k:ty, $q:expr, $box8:ident, $simd:expr, $counts:expr, $stack:expr, $pf:expr, $eager:expr) => {{
        debug_assert!($ray.is_traceable(), "the walks take traceable rays only");
        // The ray's box-test data (`WidePre` or `Avx2Pre`), made by the caller.
        let q = $q;
        // The shear of the triangle test, made at the first node where the
        // ray enters a leaf's box (see `shear`): every leaf visited was
        // entered so before.
        // (Uninitialised until then: a copy of `LeafRay::UNUSED` cost every
        // ray four instructions.)
        let mut lr = MaybeUninit::<LeafRay>::uninit();
        let mut made = false;
        if $eager {
            // A ray that starts inside the tree's box (the entry knows)
            // nearly always reaches a leaf: its shear is made here, beside
            // the root's box test, and the walk's `!made` test is decided
            // the same way at every node.
            lr = MaybeUninit::new(shear::<$k>($ray));
            made = true;
        }
        let mut r = *$ray;
        let mut best: Option<Hit> = None;
        let mut cull = cull_bound(r.t_max);
        let mut stack = [MaybeUninit::<Entry>::uninit(); $stack];
        let mut sp = 0usize;
        let mut cur = Entry { t: r.t_min, child: $start, count: 0 };
        let nodes = &$self.nodes[..];
        // The entry distances of the node just tested, one buffer for the
        // whole walk (a fresh array per node was stored, then copied).
        let mut near = [0.0f32; WIDTH];
        'outer: loop {
            if cur.count == 0 {
                debug_assert!((cur.child as usize) < nodes.len(), "node {} of {}", cur.child, nodes.len());
                // SAFETY: `cur` is the start node (a node, by the caller) or
                // a lane the box test entered with count 0. Such a lane is an
                // inner node, whose index `check_node` bounded when the tree
                // was built, or an empty lane, which no ray with a finite
                // origin and direction enters (`check_node`), and the walks
                // take no other (`Kernels::closest`).
                let node = unsafe { nodes.get_unchecked(cur.child as usize) };
                $counts.node(cur.child);
                let mut mask = $box8!(node, q, cull, &mut near);
                if mask != 0 {
                    if !made && mask & !node.inner_lanes() != 0 {
                        made = true;
                        // The ray passes through `black_box`, so the
                        // compiler cannot hoist the shear's axis choice and
                        // permutation (about 25 instructions) out of the
                        // loop into the walk's prologue, where every ray ran
                        // them, also the many that enter no leaf's box.
                        // Callgrind, 50,000 rays through `Tracer::intersect`
                        // (the AVX2 walk): rays that leave the mesh's
                        // bounds 252 -> 225 instructions (suzanne) and 247
                        // -> 227 (dragon_87k), suzanne camera 688 -> 667 and
                        // incoherent 657 -> 638, dragon_87k 973 -> 962 and
                        // 989 -> 980. Both sides on AVX2 (`--race 5
                        // --threads 1 --rtdiff-isa avx2 --embree-max-isa
                        // avx2`, three alternated pairs) against default
                        // MEDIUM: suzanne incoherent 0.920 / 0.932 / 0.926
                        // -> 0.934 / 0.950 / 0.942, camera 1.149 / 1.196 /
                        // 1.196 -> 1.175 / 1.203 / 1.232; dragon_87k and
                        // the AVX-512 walk level. (The any-hit walk makes
                        // the shear at its first node, which nearly every
                        // shadow ray passes on to a leaf: there the hoisted
                        // form costs nothing and the barrier measured 1.5%
                        // more instructions on suzanne.)
                        lr = MaybeUninit::new(shear::<$k>(std::hint::black_box($ray)));
                    }
                    if $pf {
                        $self.prefetch_first_children(node, mask);
                    }
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
                        // Both entries are read first and the nearer one
                        // picked by value (conditional moves), so the next
                        // node's index does not wait for a load that the
                        // comparison chose.
                        let ef = Entry { t: near[first], child: node.child[first], count: node.count[first] };
                        let es = Entry { t: near[second], child: node.child[second], count: node.count[second] };
                        let swap = es.t < ef.t;
                        let pick = |x: u32, y: u32| if swap { y } else { x };
                        let nearer = Entry {
                            t: f32::from_bits(pick(ef.t.to_bits(), es.t.to_bits())),
                            child: pick(ef.child, es.child),
                            count: pick(ef.count, es.count),
                        };
                        let farther = Entry {
                            t: f32::from_bits(pick(es.t.to_bits(), ef.t.to_bits())),
                            child: pick(es.child, ef.child),
                            count: pick(es.count, ef.count),
                        };
                        stack[sp] = MaybeUninit::new(farther);
                        sp += 1;
                        cur = nearer;
                        continue 'outer;
                    }
                    let k = mask.count_ones() as usize + 1;
                    if k <= 4 {
                        // Three or four hits: a sorting network on keys that
                        // order by entry distance, then lane (ties keep the
                        // lower lane first, as the insertion sort below),
                        // compare-exchanges without data-dependent branches.
                        // The key: the distance's bits made to sort as unsigned
                        // integers (negatives flipped; -0 made +0), the lane below.
                        let key = |l: usize| -> u64 {
                            let b = (near[l] + 0.0).to_bits();
                            let u = b ^ ((((b as i32) >> 31) as u32) | 0x8000_0000);
                            (u64::from(u) << 32) | l as u64
                        };
                        let mut m = mask;
                        let l1 = m.trailing_zeros() as usize;
                        m &= m - 1;
                        let l2 = m.trailing_zeros() as usize;
                        m &= m - 1;
                        // A fourth key, or one that sorts last.
                        let k3 = if m != 0 { key((m.trailing_zeros() as usize) & (WIDTH - 1)) } else { u64::MAX };
                        let mut s = [key(first), key(l1), key(l2), k3];
                        for (i, j) in [(0, 1), (2, 3), (0, 2), (1, 3), (1, 2)] {
                            let (lo, hi) = (s[i].min(s[j]), s[i].max(s[j]));
                            (s[i], s[j]) = (lo, hi);
                        }
                        let entry = |key: u64| {
                            let l = (key as usize) & (WIDTH - 1);
                            Entry { t: near[l], child: node.child[l], count: node.count[l] }
                        };
                        // The farthest deepest: s[3] (with three hits the
                        // padding, overwritten by s[2]), s[2], s[1] on top.
                        stack[sp] = MaybeUninit::new(entry(s[3]));
                        stack[sp + k - 3] = MaybeUninit::new(entry(s[2]));
                        stack[sp + k - 2] = MaybeUninit::new(entry(s[1]));
                        sp += k - 1;
                        cur = entry(s[0]);
                        continue 'outer;
                    }
                    // Five or more: sort the hit lanes by entry distance
                    // (insertion sort). Ties keep the lower lane first.
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
                let n = cur.count & !ENTRY_LEAF;
                $counts.leaf(cur.child, n);
                debug_assert!(made, "a leaf before its shear");
                // SAFETY: `lr` was made at the node whose leaf lane led here
                // (every leaf is reached through an entered leaf lane).
                let lr = unsafe { lr.assume_init_ref() };
                if cur.count & ENTRY_LEAF != 0 {
                    $self.prims.intersect_leaf::<$k>(cur.child, n, &mut r, &lr.wr(), &mut best)
                } else {
                    // SAFETY: a packet leaf lane of one of this tree's nodes.
                    unsafe { $self.packets_closest::<$k>(cur.child, n, &mut r, lr, &mut best, $simd) }
                }
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

/// The SIMD closest-hit walk from the root as method `$name` of [`WideBvh`],
/// compiled for the target features `$features` (one definition for every
/// instruction set the walk is compiled for, [`WalkIsa`]). Its callers
/// guarantee the features and a traceable ray ([`ClosestFn`]). Never
/// inlined into the entry points, whose early outs (`misses_root!`) then
/// need none of its stack frame and per-ray set-up.
macro_rules! simd_closest_walk {
    ($(#[$doc:meta])* $name:ident, $features:literal) => {
        $(#[$doc])*
        #[cfg(target_arch = "x86_64")]
        #[target_feature(enable = $features)]
        #[inline(never)]
        fn $name<K: TriangleKernel, C: Count, const S: usize, const P: bool>(
            &self,
            ray: &Ray,
            counts: &mut C,
            inside: bool,
        ) -> Option<Hit> {
            self.prims.finish(
                closest!(self, ray, 0, K, &avx2_pre!(&WidePre::new(ray)), box8_avx2, true, counts, S, P, inside),
                ray,
            )
        }
    };
}

/// Any-hit traversal, generic over the box test (any order gives the same answer).
macro_rules! any_hit {
    ($self:ident, $ray:ident, $start:expr, $k:ty, $pre:ident, $box8:ident, $simd:expr, $counts:expr, $stack:expr, $pf:expr) => {{
        debug_assert!($ray.is_traceable(), "the walks take traceable rays only");
        let pre = WidePre::new($ray);
        let q = $pre!(&pre);
        // The shear, made at the first node the ray enters (see `shear`),
        // before any leaf is tested.
        let mut lr = LeafRay::UNUSED;
        let mut at_root = true;
        let cull = cull_bound($ray.t_max);
        // Only inner nodes are stacked: hit leaves are tested at once, so an
        // occluder is found before descending further.
        let mut stack = [MaybeUninit::<u32>::uninit(); $stack];
        let mut sp = 0usize;
        // The node visited next is held in `cur`, not popped from the slot
        // just written: that store and indexed load sat on the walk's chain
        // of dependent loads (child index -> node rows -> box test -> child
        // index). Shadow rays against Embree's default mode, alternated
        // binaries: dragon_87k 0.92-0.94 -> 0.94-0.95, dragon_full 0.90-0.91
        // -> 0.94 (docs/bvh.md, ninth pass).
        let mut cur = $start;
        let nodes = &$self.nodes[..];
        let mut near = [0.0f32; WIDTH];
        loop {
            debug_assert!((cur as usize) < nodes.len(), "node {cur} of {}", nodes.len());
            // SAFETY: as in `closest!`: `cur` is the start node or an entered
            // inner lane (the ray has a finite origin and direction).
            let node = unsafe { nodes.get_unchecked(cur as usize) };
            $counts.node(cur);
            let mut mask = $box8!(node, &q, cull, &mut near);
            if at_root && mask != 0 {
                at_root = false;
                lr = shear::<$k>($ray);
            }
            // The nearest of the entered inner nodes is stacked first, so it
            // is searched last: a shadow ray leaves a surface, whose own
            // subtree is the nearest and cannot occlude it. (Same answers in
            // any order; fewer nodes and leaves per shadow ray for lights on
            // every side, `examples/traversal_counts.rs`.)
            // (A node that one child or none is entered in needs no choice.)
            let mut inner = if mask & mask.wrapping_sub(1) != 0 { mask & node.inner_lanes() } else { 0 };
            if inner & inner.wrapping_sub(1) != 0 {
                let mut first = inner.trailing_zeros() as usize;
                inner &= inner - 1;
                while inner != 0 {
                    let l = inner.trailing_zeros() as usize;
                    inner &= inner - 1;
                    if near[l] < near[first] {
                        first = l;
                    }
                }
                stack[sp] = MaybeUninit::new(node.child[first]);
                sp += 1;
                if $pf {
                    $self.prefetch_node(node.child[first]);
                }
                mask &= !(1 << first);
            }
            // Every entered inner node is stacked; the last one, visited
            // next, is also kept in `next` and its slot dropped.
            let base = sp;
            let mut next = 0;
            // Leaves of one packet (at most four triangles) are tested two at
            // a time, in one eight-lane test (see `two_leaves_any`): one held
            // here until the next one comes, or to the end of the node.
            let mut held: Option<(u32, u32)> = None;
            while mask != 0 {
                let l = mask.trailing_zeros() as usize;
                mask &= mask - 1;
                let count = node.count[l];
                if $simd && <$k as TriangleKernel>::WATERTIGHT && count.wrapping_sub(1) < PW as u32 {
                    let b = node.child[l];
                    match held.take() {
                        None => held = Some((b, count)),
                        Some((a, ca)) => {
                            $counts.leaf(a, ca);
                            $counts.leaf(b, count);
                            // SAFETY: two packet leaf lanes of this tree's nodes, of one to four triangles each.
                            if unsafe { $self.two_leaves_any::<$k>((a, ca), (b, count), $ray, &lr, $simd) } {
                                return true;
                            }
                        }
                    }
                } else if count > 0 {
                    let n = count & !ENTRY_LEAF;
                    $counts.leaf(node.child[l], n);
                    let hit = if count & ENTRY_LEAF != 0 {
                        $self.prims.occluded_leaf::<$k>(node.child[l], n, $ray, &lr.wr())
                    } else {
                        // SAFETY: a packet leaf lane of this node.
                        unsafe { $self.packets_any::<$k>(node.child[l], n, $ray, &lr, $simd) }
                    };
                    if hit {
                        return true;
                    }
                } else {
                    next = node.child[l];
                    stack[sp] = MaybeUninit::new(next);
                    sp += 1;
                    if $pf {
                        $self.prefetch_node(node.child[l]);
                    }
                }
            }
            if let Some((a, ca)) = held {
                $counts.leaf(a, ca);
                // SAFETY: a packet leaf lane of this node.
                if unsafe { $self.packets_any::<$k>(a, ca, $ray, &lr, $simd) } {
                    return true;
                }
            }
            cur = if sp > base {
                sp -= 1;
                next
            } else if sp > 0 {
                sp -= 1;
                // SAFETY: entries below sp were written before.
                unsafe { stack[sp].assume_init() }
            } else {
                break;
            };
        }
        false
    }};
}

/// A closest-hit entry point of one configuration. Unsafe to call: the
/// CPU must run its instruction set ([`Kernels`] makes sure of it). It
/// takes any ray, and answers none for one that is not
/// [`Ray::is_traceable`] (the walks behind it take traceable rays only: they
/// follow the tree's links without bounds checks, see `check_node` in
/// `wide.rs`).
pub type ClosestFn = unsafe fn(&WideBvh, &Ray) -> Option<Hit>;
/// An any-hit entry point of one configuration (the contract of [`ClosestFn`]).
pub type AnyFn = unsafe fn(&WideBvh, &Ray) -> bool;

/// A closest-hit entry point for a packet of up to eight traceable rays
/// (the contract of [`ClosestFn`]).
pub type Closest8Fn = unsafe fn(&WideBvh, &[Ray], &mut [Option<Hit>]);
/// An any-hit entry point for a packet of up to eight traceable rays.
pub type Any8Fn = unsafe fn(&WideBvh, &[Ray], &mut [bool]);

/// The monomorphised traversal entry points of one configuration (triangle
/// test, instruction set, stack size), chosen once by [`WideBvh::kernels`].
#[derive(Clone, Copy)]
pub struct Kernels {
    closest: ClosestFn,
    any: AnyFn,
    closest8: Closest8Fn,
    any8: Any8Fn,
}

impl std::fmt::Debug for Kernels {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("Kernels")
    }
}

impl Kernels {
    /// Closest hit of `ray` in `bvh`, which must be the tree these kernels were chosen for;
    /// none for a ray that is not [`Ray::is_traceable`] (the walks take
    /// traceable rays only: see `check_node` in `wide.rs`).
    #[inline(always)]
    pub fn closest(&self, bvh: &WideBvh, ray: &Ray) -> Option<Hit> {
        // SAFETY: `WideBvh::kernels` only hands out AVX2 (AVX-512) entry points when the CPU has AVX2
        // (AVX2, AVX-512F and AVX-512VL); the entry points check the ray.
        unsafe { (self.closest)(bvh, ray) }
    }

    /// Whether anything is hit along `ray` in `bvh` (false for a ray that is
    /// not [`Ray::is_traceable`]).
    #[inline(always)]
    pub fn any(&self, bvh: &WideBvh, ray: &Ray) -> bool {
        // SAFETY: as in `closest`.
        ray.is_traceable() && unsafe { (self.any)(bvh, ray) }
    }

    /// Closest hits of `rays` into `out` (same length), eight rays at a time
    /// ([`super::wide_packet`]); the same answers as [`Self::closest`], and
    /// none for a ray that is not [`Ray::is_traceable`].
    pub fn closest_batch(&self, bvh: &WideBvh, rays: &[Ray], out: &mut [Option<Hit>]) {
        assert_eq!(rays.len(), out.len(), "closest_batch: one answer per ray");
        if bvh.nodes.is_empty() {
            out.fill(None);
            return;
        }
        for (r, o) in rays.chunks(super::wide_packet::PACKET).zip(out.chunks_mut(super::wide_packet::PACKET)) {
            if r.len() < super::wide_packet::MIN_PACKET || !r.iter().all(Ray::is_traceable) {
                for (r, o) in r.iter().zip(o) {
                    // (None for a ray that is not traceable.)
                    *o = self.closest(bvh, r);
                }
            } else {
                // SAFETY: as in `closest`; the tree is not empty and each chunk holds 1 to 8 rays.
                unsafe { (self.closest8)(bvh, r, o) };
            }
        }
    }

    /// Occlusion of `rays` into `out`, eight rays at a time; the same answers as [`Self::any`].
    pub fn any_batch(&self, bvh: &WideBvh, rays: &[Ray], out: &mut [bool]) {
        assert_eq!(rays.len(), out.len(), "any_batch: one answer per ray");
        if bvh.nodes.is_empty() {
            out.fill(false);
            return;
        }
        for (r, o) in rays.chunks(super::wide_packet::PACKET).zip(out.chunks_mut(super::wide_packet::PACKET)) {
            if r.len() < super::wide_packet::MIN_PACKET || !r.iter().all(Ray::is_traceable) {
                for (r, o) in r.iter().zip(o) {
                    *o = self.any(bvh, r);
                }
            } else {
                // SAFETY: as in `closest_batch`.
                unsafe { (self.any8)(bvh, r, o) };
            }
        }
    }
}

/// Which instruction set the walks are compiled for ([`WideBvh::isa`]).
///
/// Every set gives the same answers bit for bit: the walks are the same
/// source, and Rust neither contracts nor reassociates floating-point
/// operations under any target feature.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum WalkIsa {
    /// The AVX2 walks, except the single-ray closest-hit walk, which is the
    /// same code compiled for AVX-512F and AVX-512VL: 256-bit vectors still,
    /// but 32 vector registers, mask registers and broadcasts folded into
    /// arithmetic. On Zen 4, in one binary (`rtdiff bench --race 9 --threads
    /// 1`, with and without `--rtdiff-isa avx2` alternated, three pairs,
    /// against Embree's default MEDIUM): suzanne's incoherent rays
    /// 0.956-0.960 -> 0.984-0.990, camera rays level (1.150-1.162 against
    /// 1.150-1.164); dragon_87k (`--race 5`, two pairs) camera rays
    /// 1.037-1.047 -> 1.066-1.068, incoherent 1.066-1.067 -> 1.077-1.078.
    /// The any-hit and packet walks stay AVX2: compiled so too, dragon_87k's
    /// shadow rays lost 3-4% (1.142-1.146 -> 1.112-1.128).
    Avx512,
    /// AVX2 boxes, SSE or AVX2 packet tests.
    Avx2,
    /// Portable scalar code.
    Portable,
}

impl WalkIsa {
    /// The set's name in reports: `avx512`, `avx2` or `portable`.
    pub fn name(self) -> &'static str {
        match self {
            Self::Avx512 => "avx512",
            Self::Avx2 => "avx2",
            Self::Portable => "portable",
        }
    }

    /// What runs under this set, for reports: `avx512 closest-hit walk, avx2
    /// elsewhere`, `avx2` or `portable`.
    pub fn summary(self) -> &'static str {
        match self {
            Self::Avx512 => "avx512 closest-hit walk, avx2 elsewhere",
            other => other.name(),
        }
    }

    /// Whether this CPU runs the set's walks.
    pub fn is_supported(self) -> bool {
        match self {
            #[cfg(target_arch = "x86_64")]
            Self::Avx512 => {
                std::arch::is_x86_feature_detected!("avx2")
                    && std::arch::is_x86_feature_detected!("avx512f")
                    && std::arch::is_x86_feature_detected!("avx512vl")
            }
            #[cfg(target_arch = "x86_64")]
            Self::Avx2 => std::arch::is_x86_feature_detected!("avx2"),
            #[cfg(not(target_arch = "x86_64"))]
            Self::Avx512 | Self::Avx2 => false,
            Self::Portable => true,
        }
    }

    /// The sets this CPU runs, widest first (the first is the default).
    pub fn supported() -> Vec<Self> {
        [Self::Avx512, Self::Avx2, Self::Portable].into_iter().filter(|i| i.is_supported()).collect()
    }

    /// Whether the AVX2 walks run (both SIMD sets).
    fn simd(self) -> bool {
        self != Self::Portable
    }
}

/// A wide BVH sharing the reordered primitives of the binary BVH it came from.
#[derive(Clone, Debug)]
pub struct WideBvh {
    /// Nodes; node 0 is the root. Empty when there are no primitives.
    /// Private to the module tree: the walks follow its links without
    /// bounds checks, which [`check_node`] made safe when the tree was built.
    pub(super) nodes: Vec<WideNode>,
    /// Primitives of the [`ENTRY_LEAF`] leaves (those holding a sphere), in leaf order.
    pub(super) prims: LeafPrims,
    /// The triangles of every other leaf in 4-wide packets (None when there are no triangles).
    pub(super) packets: Option<TriPackets>,
    isa: WalkIsa,
    /// The union of the root's lanes: the closest-hit entry's early out
    /// ([`RootBox`]).
    root_box: RootBox,
    /// Wide nodes on the longest root-to-leaf path (sizes the traversal stack).
    levels: usize,
    /// The tree outgrows a core's L2 cache ([`PREFETCH_ALL_BYTES`]): every
    /// walk (closest and any hit, single rays and packets) prefetches its hit
    /// children (the any-hit walks only the inner ones, see
    /// [`WideBvh::prefetch_node`]). The AVX2 walks take it as a const
    /// parameter (`P`, chosen once in [`WideBvh::kernels`]), so a small
    /// tree's walks have no prefetch code at all.
    pub(super) prefetch_all: bool,
}

/// Trees larger than this (a core's L2 cache on current x86 CPUs is 0.5-2
/// MiB) fetch most nodes from L3 or memory, and every walk prefetches each hit
/// child (the any-hit walks each inner one: `WideBvh::prefetch_node`).
/// Measured with `rtdiff bench --race` (one binary, the choice read from an
/// environment variable for the measurement only): dragon_full (48
/// MB) shadow rays +7%, batch shadow +9%, batch primary +3%; dragon_87k (4.8
/// MB) no change; suzanne (51 KiB) shadow rays 3-4% slower with the
/// prefetches (more instructions, nothing to hide), and primary rays 3%
/// slower with the closest-hit walk's (which prefetched in every tree until
/// stop 25: 7% of the instructions of suzanne's incoherent rays).
pub const PREFETCH_ALL_BYTES: usize = 2 << 20;

impl WideBvh {
    /// Collapse `bvh` into 8-wide nodes (see [`super::collapse`]).
    pub fn from_binary(bvh: BinaryBvh) -> Self {
        let block = super::packet::leaf_block(bvh.prims.entries.len());
        let tree = GappedTree::from_nodes(bvh.nodes, Vec::new(), &super::collapse::CostTable { block });
        let e = &bvh.prims.entries;
        let num_triangles = bvh.prims.num_triangles;
        let spheres = bvh.prims.spheres.clone();
        let collapsed = super::collapse::collapse(&tree);
        Self::assemble(collapsed, num_triangles, spheres, e.len(), |k| e[k].id, |k| e[k].v, |_| {})
    }

    /// [`Self::from_binary`] for a tree built with the collapse's table
    /// ([`super::collapse::CostTable`]) whose primitives are not gathered
    /// yet: leaf triangles go straight from `prims` into packets.
    pub fn from_tree(prims: &Primitives, tree: &GappedTree<super::collapse::Entry>) -> Self {
        let collapsed = super::collapse::collapse(tree);
        let nt = prims.triangles.len() as u32;
        let vertices = |k: usize| {
            let id = tree.order[k] as usize;
            match prims.get(id) {
                crate::geometry::Prim::Triangle(t) => t.v,
                crate::geometry::Prim::Sphere(s) => [s.center, Vec3::new(s.radius, 0.0, 0.0), Vec3::ZERO],
            }
        };
        // The leaf order visits the triangles in no order the hardware
        // prefetcher can follow: each node's are requested before they are
        // packed (one or two cache lines each).
        let touch = |k: usize| {
            if let Some(t) = prims.triangles.get(tree.order[k] as usize) {
                prefetch_span(std::ptr::from_ref(t).cast(), std::mem::size_of_val(t));
            }
        };
        Self::assemble(collapsed, nt, prims.spheres.clone(), tree.order.len(), |k| tree.order[k], vertices, touch)
    }

    /// Point every leaf lane of the collapse's `(nodes, levels)` at its
    /// packets, or at its entries when it holds a sphere, and check every
    /// node's links as it is done ([`check_node`]: the only way to a
    /// [`WideBvh`], so every tree the walks see was checked).
    /// `id(k)` and `v(k)` give leaf slot `k`'s primitive id and data (a [`crate::bvh::prims::LeafEntry`]'s `v`);
    /// `touch(k)` may prefetch what `v(k)` reads (it is called for a node's slots before they are read).
    fn assemble(
        (mut nodes, levels): (Vec<WideNode>, usize),
        num_triangles: u32,
        spheres: Vec<crate::geometry::Sphere>,
        slots: usize,
        id: impl Fn(usize) -> u32 + Sync,
        v: impl Fn(usize) -> [Vec3; 3] + Sync,
        touch: impl Fn(usize) + Sync,
    ) -> Self {
        let all_triangles = num_triangles as usize == slots;
        let only_triangles =
            |first: u32, count: u32| all_triangles || (first..first + count).all(|k| id(k as usize) < num_triangles);
        // Exact sizes up front: no reallocation copies of a many-megabyte array.
        let (mut npk, mut nent) = (0, 0);
        for node in &nodes {
            for l in 0..WIDTH {
                let c = node.count[l];
                if c > 0 {
                    if only_triangles(node.child[l], c) {
                        npk += packets_for(c);
                    } else {
                        nent += c as usize;
                    }
                }
            }
        }
        let mut packets = TriPackets { packets: super::huge::vec_with_capacity(npk) };
        let mut entries = Vec::with_capacity(nent);
        let tri = |k: usize| (v(k), id(k));
        if all_triangles && rayon::current_num_threads() > 1 && npk >= 1 << 14 {
            pack_parallel(&mut nodes, &mut packets.packets, npk, &tri, &touch);
            let prims = LeafPrims { entries, num_triangles, spheres };
            return Self::finish(nodes, levels, prims, Some(packets));
        }
        if let Some(first) = nodes.first() {
            touch_leaves(first, &touch);
        }
        let n_nodes = nodes.len();
        for i in 0..n_nodes {
            // The next node's triangles are requested while this node's are
            // packed, so that their cache misses overlap the packing.
            if let Some(next) = nodes.get(i + 1) {
                touch_leaves(next, &touch);
            }
            let node = &mut nodes[i];
            for l in 0..WIDTH {
                let (first, count) = (node.child[l], node.count[l]);
                if count == 0 {
                    continue;
                }
                if only_triangles(first, count) {
                    node.child[l] = packets.push_leaf_with(first, count, tri);
                } else {
                    node.child[l] = entries.len() as u32;
                    node.count[l] = count | ENTRY_LEAF;
                    entries.extend(
                        (first..first + count)
                            .map(|k| super::prims::LeafEntry { v: v(k as usize), id: id(k as usize) }),
                    );
                }
            }
            check_node(i, node, n_nodes, npk);
        }
        // The checks above bounded the leaves' packets by the count made
        // before packing: it must be the number packed.
        assert_eq!(packets.packets.len(), npk, "packed other than the counted packets");
        let packets = (num_triangles > 0).then_some(packets);
        let prims = LeafPrims { entries, num_triangles, spheres };
        Self::finish(nodes, levels, prims, packets)
    }

    /// The tree of `nodes` (checked, [`Self::assemble`]) over `prims` and
    /// `packets`, with its depth `levels`, the CPU's instruction set and the
    /// prefetch choice.
    fn finish(nodes: Vec<WideNode>, levels: usize, prims: LeafPrims, packets: Option<TriPackets>) -> Self {
        debug_assert_eq!(levels, levels_of(&nodes), "the collapse counted the levels wrong");
        let root_box = nodes.first().map_or(RootBox::EMPTY, RootBox::of);
        let mut bvh = Self { levels, nodes, prims, packets, isa: detect_isa(), root_box, prefetch_all: false };
        bvh.prefetch_all = bvh.bytes() > PREFETCH_ALL_BYTES;
        bvh
    }

    /// The nodes; node 0 is the root (none when there are no primitives).
    pub fn nodes(&self) -> &[WideNode] {
        &self.nodes
    }

    /// The primitives of the [`ENTRY_LEAF`] leaves (those holding a sphere), in leaf order.
    pub fn prims(&self) -> &LeafPrims {
        &self.prims
    }

    /// The triangles of every other leaf in 4-wide packets (None when there are no triangles).
    pub fn packets(&self) -> Option<&TriPackets> {
        self.packets.as_ref()
    }

    /// Run the walks compiled for `isa` (the widest set this CPU runs is the
    /// default; a narrower one is for tests and measurements). Returns false,
    /// changing nothing, when this CPU does not run `isa`. Kernels chosen by
    /// [`Self::kernels`] before keep their set.
    pub fn set_isa(&mut self, isa: WalkIsa) -> bool {
        let ok = isa.is_supported();
        if ok {
            self.isa = isa;
        }
        ok
    }

    /// The instruction set the walks run ([`WalkIsa`]).
    pub fn isa(&self) -> WalkIsa {
        self.isa
    }

    /// Memory the nodes and primitives take, in bytes (the arrays' lengths:
    /// the collapse reserves room for more nodes than it makes, two to three
    /// times as many, but the unwritten tail is address space that no page
    /// backs; giving it back with `shrink_to_fit` cost 0.2-2 ms per build).
    pub fn bytes(&self) -> usize {
        self.nodes.len() * std::mem::size_of::<WideNode>()
            + self.prims.bytes()
            + self.packets.as_ref().map_or(0, TriPackets::bytes)
    }

    /// The traversal entry points for triangle test `test` on this tree and
    /// this CPU, chosen once (keep them beside the tree; they must not be
    /// used with another tree).
    pub fn kernels(&self, test: TriangleTest) -> Kernels {
        crate::with_triangle_kernel!(test, K => self.kernels_for::<K>())
    }

    fn kernels_for<K: TriangleKernel>(&self) -> Kernels {
        let shallow = self.levels * (WIDTH - 1) <= SHALLOW_STACK;
        #[cfg(target_arch = "x86_64")]
        if self.isa.simd() {
            /// The SIMD entry points with stack size `S` and the prefetch
            /// choice `P`: AVX2, but the single-ray closest hit's compiled
            /// for AVX-512 when `wide` ([`WalkIsa::Avx512`]).
            fn simd<K: TriangleKernel, const S: usize, const P: bool>(wide: bool) -> Kernels {
                use super::wide_packet::{any8, closest8};
                Kernels {
                    closest: if wide { closest_avx512::<K, S, P> } else { closest_avx2::<K, S, P> },
                    any: any_avx2::<K, S, P>,
                    closest8: closest8::<K, S, P>,
                    any8: any8::<K, S, P>,
                }
            }
            let wide = self.isa == WalkIsa::Avx512;
            return match (shallow, self.prefetch_all) {
                (true, false) => simd::<K, SHALLOW_STACK, false>(wide),
                (true, true) => simd::<K, SHALLOW_STACK, true>(wide),
                (false, false) => simd::<K, STACK, false>(wide),
                (false, true) => simd::<K, STACK, true>(wide),
            };
        }
        let (closest, any): (ClosestFn, AnyFn) = if shallow {
            (closest_portable::<K, SHALLOW_STACK>, any_portable::<K, SHALLOW_STACK>)
        } else {
            (closest_portable::<K, STACK>, any_portable::<K, STACK>)
        };
        Kernels { closest, any, closest8: one_by_one_closest::<K>, any8: one_by_one_any::<K> }
    }

    /// Closest hit (ties: lowest primitive id).
    pub fn intersect(&self, ray: &Ray, test: TriangleTest) -> Option<Hit> {
        self.kernels(test).closest(self, ray)
    }

    /// [`Self::intersect`] that also counts the work it does into `counts`
    /// (the same traversal; the counting is compiled out of `intersect`).
    pub fn intersect_counted(&self, ray: &Ray, test: TriangleTest, counts: &mut TraversalCounts) -> Option<Hit> {
        counts.ray();
        self.intersect_counting(ray, test, counts)
    }

    /// [`Self::intersect`] reporting its work to `counts` (any [`Count`];
    /// `()` is [`Self::intersect`] itself). Does not call [`Count::ray`].
    pub fn intersect_counting<C: Count>(&self, ray: &Ray, test: TriangleTest, counts: &mut C) -> Option<Hit> {
        crate::with_triangle_kernel!(test, K => self.closest_counting::<K, C>(ray, counts))
    }

    fn closest_counting<K: TriangleKernel, C: Count>(&self, ray: &Ray, counts: &mut C) -> Option<Hit> {
        if self.nodes.is_empty() || !ray.is_traceable() {
            return None;
        }
        // SAFETY: isa is Avx512 only when the CPU reports AVX2, AVX-512F and
        // AVX-512VL, and Avx2 only when it reports AVX2; the ray is traceable.
        #[cfg(target_arch = "x86_64")]
        unsafe {
            match (self.isa, self.prefetch_all) {
                (WalkIsa::Avx512, false) => return self.closest_avx512_impl::<K, C, STACK, false>(ray, counts, false),
                (WalkIsa::Avx512, true) => return self.closest_avx512_impl::<K, C, STACK, true>(ray, counts, false),
                (WalkIsa::Avx2, false) => return self.closest_avx2_impl::<K, C, STACK, false>(ray, counts, false),
                (WalkIsa::Avx2, true) => return self.closest_avx2_impl::<K, C, STACK, true>(ray, counts, false),
                (WalkIsa::Portable, _) => {}
            }
        }
        // SAFETY: the ray is traceable.
        unsafe { self.closest_portable_impl::<K, C, STACK>(ray, counts) }
    }

    /// True when anything is hit within the ray's interval.
    pub fn occluded(&self, ray: &Ray, test: TriangleTest) -> bool {
        self.kernels(test).any(self, ray)
    }

    /// [`Self::occluded`] that also counts the work it does into `counts`.
    pub fn occluded_counted(&self, ray: &Ray, test: TriangleTest, counts: &mut TraversalCounts) -> bool {
        counts.ray();
        self.occluded_counting(ray, test, counts)
    }

    /// [`Self::occluded`] reporting its work to `counts` (the same traversal).
    /// Does not call [`Count::ray`].
    pub fn occluded_counting<C: Count>(&self, ray: &Ray, test: TriangleTest, counts: &mut C) -> bool {
        crate::with_triangle_kernel!(test, K => self.any_counting::<K, C>(ray, counts))
    }

    fn any_counting<K: TriangleKernel, C: Count>(&self, ray: &Ray, counts: &mut C) -> bool {
        if self.nodes.is_empty() || !ray.is_traceable() {
            return false;
        }
        #[cfg(target_arch = "x86_64")]
        if self.isa.simd() {
            // SAFETY: isa is Avx2 or Avx512 only when the CPU reports AVX2; the ray is traceable.
            return unsafe {
                if self.prefetch_all {
                    self.any_avx2_impl::<K, C, STACK, true>(ray, counts)
                } else {
                    self.any_avx2_impl::<K, C, STACK, false>(ray, counts)
                }
            };
        }
        // SAFETY: the ray is traceable.
        unsafe { self.any_portable_impl::<K, C, STACK>(ray, counts) }
    }

    /// Ask the cache for the four lines of node `c`: the any-hit walks
    /// prefetch the inner nodes they stack, not their hit leaves, which they
    /// test at once (dragon_87k shadow rays against Embree's default mode:
    /// 0.88 -> 0.92, median of six alternated races each).
    #[inline(always)]
    pub(super) fn prefetch_node(&self, c: u32) {
        #[cfg(target_arch = "x86_64")]
        {
            use std::arch::x86_64::{_MM_HINT_T0, _mm_prefetch};
            // A node: 256 bytes at a 64-byte boundary, exactly four lines.
            let p = self.nodes.as_ptr().wrapping_add(c as usize).cast::<i8>();
            // SAFETY: prefetching is a hint and never faults, whatever the address.
            unsafe {
                _mm_prefetch::<_MM_HINT_T0>(p);
                _mm_prefetch::<_MM_HINT_T0>(p.wrapping_add(64));
                _mm_prefetch::<_MM_HINT_T0>(p.wrapping_add(128));
                _mm_prefetch::<_MM_HINT_T0>(p.wrapping_add(192));
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        let _ = c;
    }

    /// Ask the cache for the nodes and leaf primitives of the children in
    /// `mask`: all but the nearest are visited later, and their memory latency
    /// (the traversal's main cost) then overlaps with the work in between.
    #[inline(always)]
    pub(super) fn prefetch_children(&self, node: &WideNode, mut mask: u32) {
        #[cfg(target_arch = "x86_64")]
        while mask != 0 {
            use std::arch::x86_64::{_MM_HINT_T0, _mm_prefetch};
            let l = mask.trailing_zeros() as usize;
            mask &= mask - 1;
            let (c, n) = (node.child[l] as usize, node.count[l]);
            // SAFETY (all prefetches below): prefetching is a hint and never faults, whatever the address.
            let line = |p: *const i8| unsafe { _mm_prefetch::<_MM_HINT_T0>(p) };
            if n == 0 {
                self.prefetch_node(c as u32);
                continue;
            }
            let (p, bytes) = if n & ENTRY_LEAF == 0
                && let Some(pk) = &self.packets
            {
                let p = pk.packets.as_ptr().wrapping_add(c).cast::<i8>();
                // One packet (160 bytes at a 32-byte boundary) spans exactly three lines.
                line(p);
                line(p.wrapping_add(64));
                line(p.wrapping_add(128));
                if n as usize <= super::packet::PW {
                    continue;
                }
                if n as usize <= 2 * super::packet::PW {
                    // Two packets (every SAH leaf has at most eight
                    // triangles): 320 bytes, five or six lines, the last
                    // one holding byte 319. Without the loop below, which
                    // asked again for the three lines above and whose trip
                    // count (five or six) was a branch to predict.
                    line(p.wrapping_add(192));
                    line(p.wrapping_add(256));
                    line(p.wrapping_add(319));
                    continue;
                }
                (p, packets_for(n) * std::mem::size_of::<super::packet::Tri4>())
            } else {
                let n = (n & !ENTRY_LEAF) as usize;
                let p = self.prims.entries.as_ptr().wrapping_add(c).cast::<i8>();
                (p, n * std::mem::size_of::<super::prims::LeafEntry>())
            };
            // Every cache line the range touches (it need not start on a line).
            let mut off = 0;
            let end = (p as usize % 64) + bytes;
            while off < end {
                line(p.wrapping_add(off));
                off += 64;
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        let _ = (node, mask);
    }

    /// [`Self::prefetch_children`] for the single-ray closest-hit walk, its
    /// first two entered lanes without a branch to guess (most nodes enter one
    /// or two): each address picked by value, an entered inner node's or
    /// packet leaf's, or for a lane not entered the node itself (already in
    /// the cache), and six lines from each (a node's four and the first two of
    /// the node after it; a leaf's one or two packets; a sphere leaf's lane
    /// gets an address of no use, which a prefetch may take). Only a third entered
    /// lane takes the loop of [`Self::prefetch_children`], whose trip count
    /// and inner-or-leaf test were branches that callgrind's model of the
    /// predictor missed 3.7 times per dragon_87k incoherent ray (of 9.4).
    /// `rtdiff bench --race 3 --threads 1 --rtdiff-isa avx2 --embree-max-isa
    /// avx2`, alternated binaries, against Embree's default mode: dragon_87k
    /// incoherent 0.922 / 0.915 -> 0.958 / 0.980, camera 1.055 / 1.055 ->
    /// 1.062 / 1.071; dragon_full (`--race 2`, one pair) incoherent 1.031 ->
    /// 1.086, camera 1.081 -> 1.100. The first four lanes so and no loop:
    /// dragon_87k incoherent 0.929 / 0.934 -> 0.959 / 0.947 but camera 1.059 /
    /// 1.060 -> 1.017 / 1.021 (24 prefetches per node).
    #[inline(always)]
    pub(super) fn prefetch_first_children(&self, node: &WideNode, mask: u32) {
        #[cfg(target_arch = "x86_64")]
        {
            use std::arch::x86_64::{_MM_HINT_T0, _mm_prefetch};
            let nodes = self.nodes.as_ptr() as usize;
            let packets = self.packets.as_ref().map_or(nodes, |pk| pk.packets.as_ptr() as usize);
            let here = std::ptr::from_ref(node) as usize;
            let mut m = mask;
            for _ in 0..2 {
                let l = (m.trailing_zeros() as usize) & (WIDTH - 1);
                let entered = m != 0;
                m &= m.wrapping_sub(1);
                let (c, n) = (node.child[l] as usize, node.count[l]);
                let inner = nodes.wrapping_add(c.wrapping_mul(std::mem::size_of::<WideNode>()));
                let leaf = packets.wrapping_add(c.wrapping_mul(std::mem::size_of::<Tri4>()));
                let a = if n == 0 { inner } else { leaf };
                let p = (if entered { a } else { here }) as *const i8;
                // SAFETY: prefetching is a hint and never faults, whatever the address.
                unsafe {
                    _mm_prefetch::<_MM_HINT_T0>(p);
                    _mm_prefetch::<_MM_HINT_T0>(p.wrapping_add(64));
                    _mm_prefetch::<_MM_HINT_T0>(p.wrapping_add(128));
                    _mm_prefetch::<_MM_HINT_T0>(p.wrapping_add(192));
                    _mm_prefetch::<_MM_HINT_T0>(p.wrapping_add(256));
                    _mm_prefetch::<_MM_HINT_T0>(p.wrapping_add(319));
                }
            }
            if m != 0 {
                self.prefetch_children(node, m);
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        let _ = (node, mask);
    }

    /// Closest-hit test of the triangle leaf of `count` triangles from packet
    /// `first`: SSE packets (four triangles at once) when `simd`, the
    /// per-triangle loop otherwise (same results).
    ///
    /// # Safety
    /// `first` and `count` are a packet leaf lane (`child`, `count` without
    /// [`ENTRY_LEAF`]) of one of this tree's nodes (the SIMD form reads its
    /// packets without bounds checks, see `leaf_packets`).
    #[inline(always)]
    pub(super) unsafe fn packets_closest<K: TriangleKernel>(
        &self,
        first: u32,
        count: u32,
        ray: &mut Ray,
        lr: &LeafRay,
        best: &mut Option<Hit>,
        simd: bool,
    ) -> bool {
        // SAFETY of the unwrap's absence: triangle leaves exist only when packets were built.
        let Some(pk) = &self.packets else { return false };
        #[cfg(target_arch = "x86_64")]
        if simd {
            // SAFETY: the caller's contract.
            let pks = unsafe { leaf_packets(pk, first, count) };
            return match K::TEST {
                TriangleTest::Watertight => TriPackets::intersect_leaf_simd(pks, ray, lr, best),
                TriangleTest::MollerTrumbore => TriPackets::intersect_leaf_simd_mt(pks, ray, best),
            };
        }
        let _ = simd;
        pk.intersect_leaf_scalar::<K>(first, count, ray, &lr.wr(), best)
    }

    /// [`Self::packets_any`] of two leaves of one packet each (at most four
    /// triangles), at packets `a` and `b`, in one eight-lane test: the any-hit
    /// walk's leaves in pairs.
    ///
    /// The leaves a shadow ray enters at one node were tested one after the
    /// other, each a chain of dependent operations (the watertight test, its
    /// division, the masks) that the next one's could overlap only as far as
    /// the branch between them let it; two leaves in one test take one chain.
    /// Any order gives the same answer, so the pairs need no rule. `rtdiff
    /// bench --race 5 --threads 1`, alternated binaries (three pairs),
    /// against Embree's default mode: suzanne shadow rays 0.984-1.030 ->
    /// 1.066-1.117 (camera and incoherent rays, whose walk this is not,
    /// level); both sides on AVX2 (`--rtdiff-isa avx2 --embree-max-isa
    /// avx2`, two pairs) 1.011-1.015 -> 1.043-1.075; dragon_87k (mostly
    /// leaves of five to eight triangles, one packet pair each already) level. The same pairing in the closest-hit walk (the
    /// nearest two entered leaves tested together, the farther no longer
    /// culled by a hit in the nearer) did not pay: suzanne incoherent level,
    /// camera rays 1.18-1.20 -> 1.12-1.15 (docs/bvh.md, twenty-second pass).
    ///
    /// `a` and `b` are `(first packet, triangle count)`; without `simd` (or
    /// off x86-64) the two leaves go through [`Self::packets_any`] in turn.
    ///
    /// # Safety
    /// `a` and `b` are packet leaf lanes of this tree's nodes (as for
    /// [`Self::packets_closest`]), each of one to four triangles.
    #[inline(always)]
    pub(super) unsafe fn two_leaves_any<K: TriangleKernel>(
        &self,
        a: (u32, u32),
        b: (u32, u32),
        ray: &Ray,
        lr: &LeafRay,
        simd: bool,
    ) -> bool {
        #[cfg(target_arch = "x86_64")]
        if simd && K::WATERTIGHT {
            let Some(pk) = &self.packets else { return false };
            // SAFETY: the caller's contract: two leaf lanes of one packet each
            // (one to four triangles), so `pa` and `pb` are one long.
            let (pa, pb) = unsafe { (leaf_packets(pk, a.0, a.1), leaf_packets(pk, b.0, b.1)) };
            debug_assert!(pa.len() == 1 && pb.len() == 1, "two leaves of one packet each");
            // SAFETY: as above.
            let (pa, pb) = unsafe { (pa.get_unchecked(0), pb.get_unchecked(0)) };
            return TriPackets::occluded_two_leaves_simd(pa, pb, ray, lr);
        }
        // SAFETY: the caller's contract.
        unsafe { self.packets_any::<K>(a.0, a.1, ray, lr, simd) || self.packets_any::<K>(b.0, b.1, ray, lr, simd) }
    }

    /// Any-hit test of a triangle leaf (see [`Self::packets_closest`]).
    ///
    /// # Safety
    /// As for [`Self::packets_closest`].
    #[inline(always)]
    pub(super) unsafe fn packets_any<K: TriangleKernel>(
        &self,
        first: u32,
        count: u32,
        ray: &Ray,
        lr: &LeafRay,
        simd: bool,
    ) -> bool {
        let Some(pk) = &self.packets else { return false };
        #[cfg(target_arch = "x86_64")]
        if simd {
            // SAFETY: the caller's contract.
            let pks = unsafe { leaf_packets(pk, first, count) };
            return match K::TEST {
                TriangleTest::Watertight => TriPackets::occluded_leaf_simd(pks, ray, lr),
                TriangleTest::MollerTrumbore => TriPackets::occluded_leaf_simd_mt(pks, ray),
            };
        }
        let _ = simd;
        pk.occluded_leaf_scalar::<K>(first, count, ray, &lr.wr())
    }

    /// The portable closest-hit walk.
    ///
    /// # Safety
    /// `ray` must be [`Ray::is_traceable`] (see [`check_node`]), as for
    /// every walk below (the SIMD ones also need their instruction sets).
    #[inline(always)]
    unsafe fn closest_portable_impl<K: TriangleKernel, C: Count, const S: usize>(
        &self,
        ray: &Ray,
        counts: &mut C,
    ) -> Option<Hit> {
        self.prims.finish(
            closest!(self, ray, 0, K, &WidePre::new(ray), box8_portable, false, counts, S, self.prefetch_all, false),
            ray,
        )
    }

    /// The portable any-hit walk.
    ///
    /// # Safety
    /// `ray` must be [`Ray::is_traceable`].
    #[inline(always)]
    unsafe fn any_portable_impl<K: TriangleKernel, C: Count, const S: usize>(&self, ray: &Ray, counts: &mut C) -> bool {
        any_hit!(self, ray, 0, K, portable_pre, box8_portable, false, counts, S, self.prefetch_all)
    }

    simd_closest_walk!(
        /// The AVX2 closest-hit walk.
        closest_avx2_impl,
        "avx2"
    );
    simd_closest_walk!(
        /// [`Self::closest_avx2_impl`] compiled for AVX-512F and AVX-512VL
        /// ([`WalkIsa::Avx512`]): the same source, so the same answers bit for bit.
        closest_avx512_impl,
        "avx2,avx512f,avx512vl"
    );

    /// The AVX2 closest-hit walk of the subtree under node `start` alone,
    /// before [`LeafPrims::finish`] (the packet walk's switch to single rays
    /// when few of its rays are left). The caller guarantees AVX2, a node
    /// `start` of this tree and a traceable ray.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    pub(super) fn closest_avx2_from<K: TriangleKernel, const S: usize, const P: bool>(
        &self,
        ray: &Ray,
        start: u32,
    ) -> Option<Hit> {
        closest!(self, ray, start, K, &avx2_pre!(&WidePre::new(ray)), box8_avx2, true, &mut (), S, P, false)
    }

    /// The AVX2 any-hit walk from the root (its callers guarantee AVX2 and a traceable ray).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn any_avx2_impl<K: TriangleKernel, C: Count, const S: usize, const P: bool>(
        &self,
        ray: &Ray,
        counts: &mut C,
    ) -> bool {
        any_hit!(self, ray, 0, K, avx2_pre, box8_avx2, true, counts, S, P)
    }

    /// The AVX2 any-hit walk of the subtree under node `start` alone (the
    /// packet walk's switch to single rays when few of its rays are left;
    /// the contract of [`Self::closest_avx2_from`]).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    pub(super) fn any_avx2_from<K: TriangleKernel, const S: usize, const P: bool>(
        &self,
        ray: &Ray,
        start: u32,
    ) -> bool {
        any_hit!(self, ray, start, K, avx2_pre, box8_avx2, true, &mut (), S, P)
    }
}

/// The portable closest-hit entry point ([`ClosestFn`]).
unsafe fn closest_portable<K: TriangleKernel, const S: usize>(bvh: &WideBvh, ray: &Ray) -> Option<Hit> {
    if !ray.is_traceable() || bvh.nodes.is_empty() {
        return None;
    }
    // SAFETY: the caller guarantees a traceable ray.
    unsafe { bvh.closest_portable_impl::<K, (), S>(ray, &mut ()) }
}

/// The portable any-hit entry point (the ray is traceable: [`AnyFn`]).
unsafe fn any_portable<K: TriangleKernel, const S: usize>(bvh: &WideBvh, ray: &Ray) -> bool {
    if bvh.nodes.is_empty() {
        return false;
    }
    // SAFETY: the caller guarantees a traceable ray.
    unsafe { bvh.any_portable_impl::<K, (), S>(ray, &mut ()) }
}

/// The closest-hit entry points' work before the walk `$walk` (a macro, so
/// that it expands inside each entry point with its instruction set): the
/// ray read field by field (`ray_sse!`), none for a ray that is not
/// traceable (`traceable_sse!`) or an empty tree, and the root box's early
/// out (`misses_root!`) for a ray whose origin lies outside the box (one
/// that starts inside it cannot miss it: the test, its division included,
/// is skipped for the rays that start in the scene, which is most of them
/// but camera rays).
#[cfg(target_arch = "x86_64")]
macro_rules! closest_entry {
    ($bvh:ident, $ray:ident, $walk:ident) => {{
        use std::arch::x86_64::*;
        let (o, d, t_max) = ray_sse!($ray);
        if !traceable_sse!(o, d, t_max) || $bvh.nodes.is_empty() {
            return None;
        }
        let b = &$bvh.root_box;
        // SAFETY: `RootBox` is 16-byte aligned and its rows are four floats.
        let (lo, hi) = unsafe { (_mm_load_ps(b.lo.as_ptr()), _mm_load_ps(b.hi.as_ptr())) };
        // (Lane 3, `-inf <= dx <= +inf`, is inside for every traceable ray.)
        let inside = _mm_movemask_ps(_mm_and_ps(_mm_cmple_ps(lo, o), _mm_cmple_ps(o, hi))) == 0b1111;
        if !inside
            && misses_root!($bvh, o, _mm_div_ps(_mm_set1_ps(1.0), d), _mm_cvtss_f32(_mm_shuffle_ps::<0b11>(d, d)))
        {
            return None;
        }
        // (The walk's contract, a traceable ray, is checked above.)
        $bvh.$walk::<K, (), S, P>($ray, &mut (), inside)
    }};
}

/// The AVX2 closest-hit entry point (only called when the CPU has AVX2;
/// `closest_entry!`, then the walk).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn closest_avx2<K: TriangleKernel, const S: usize, const P: bool>(bvh: &WideBvh, ray: &Ray) -> Option<Hit> {
    closest_entry!(bvh, ray, closest_avx2_impl)
}

/// The AVX-512 closest-hit entry point (only called when the CPU has AVX2,
/// AVX-512F and AVX-512VL), as [`closest_avx2`].
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,avx512f,avx512vl")]
unsafe fn closest_avx512<K: TriangleKernel, const S: usize, const P: bool>(bvh: &WideBvh, ray: &Ray) -> Option<Hit> {
    closest_entry!(bvh, ray, closest_avx512_impl)
}

/// The AVX2 any-hit entry point (only called when the CPU has AVX2, with a traceable ray).
#[cfg(target_arch = "x86_64")]
unsafe fn any_avx2<K: TriangleKernel, const S: usize, const P: bool>(bvh: &WideBvh, ray: &Ray) -> bool {
    if bvh.nodes.is_empty() {
        return false;
    }
    // SAFETY: the caller guarantees AVX2 (`WideBvh::kernels`) and a traceable ray.
    unsafe { bvh.any_avx2_impl::<K, (), S, P>(ray, &mut ()) }
}

/// The portable packet entry point: each ray through the single-ray kernel.
unsafe fn one_by_one_closest<K: TriangleKernel>(bvh: &WideBvh, rays: &[Ray], out: &mut [Option<Hit>]) {
    for (r, o) in rays.iter().zip(out) {
        // SAFETY: the batch entries pass traceable rays only.
        *o = unsafe { bvh.closest_portable_impl::<K, (), STACK>(r, &mut ()) };
    }
}

/// The portable any-hit packet entry point.
unsafe fn one_by_one_any<K: TriangleKernel>(bvh: &WideBvh, rays: &[Ray], out: &mut [bool]) {
    for (r, o) in rays.iter().zip(out) {
        // SAFETY: as in `one_by_one_closest`.
        *o = unsafe { bvh.any_portable_impl::<K, (), STACK>(r, &mut ()) };
    }
}

/// The packets of the triangle leaf of `count` triangles from packet
/// `first` of `pk`, a lane of a node of the tree `pk` belongs to.
///
/// Without a bounds check: [`check_node`] bounded every leaf lane's packets
/// when the tree was built, and the tree's fields cannot change after.
///
/// # Safety
/// `first` and `count` are a packet leaf lane of a node of the tree whose
/// packets `pk` are.
#[inline(always)]
unsafe fn leaf_packets(pk: &TriPackets, first: u32, count: u32) -> &[Tri4] {
    let (a, b) = (first as usize, first as usize + packets_for(count));
    debug_assert!(a <= b && b <= pk.packets.len(), "packets {a}..{b} of {}", pk.packets.len());
    // SAFETY: the lane's range, which `check_node` bounded.
    unsafe { pk.packets.get_unchecked(a..b) }
}

/// Check the links of wide node `i` of `n_nodes` (over `npk` packets) that
/// the walks follow without bounds checks; panics (a builder's bug) when one
/// is out of range. [`WideBvh::assemble`] checks each node once it has
/// pointed its leaves at their packets (in the parallel packing, by the
/// thread that packed it; until stop 44 a serial pass over the finished
/// tree, which two threads could not share):
/// - every inner lane (count 0, child not `u32::MAX`) names a node of `nodes`;
/// - every packet leaf lane's packets `child .. child + packets_for(count)`
///   lie in `packets`;
/// - every empty lane (child `u32::MAX`) has the inverted box `min = +inf`,
///   `max = -inf`. A ray with a finite origin and direction then never enters
///   it: on each axis the slab of the near row (`+inf` or `-inf` by the sign
///   of the reciprocal direction, itself nonzero, finite or infinite, never
///   NaN) gives the entry distance `+inf` and the far row the exit `-inf`, so
///   no NaN arises and the entry never lies at or before the exit (in the
///   scalar and in the SIMD test alike). The walks take such rays only
///   ([`Kernels::closest`], [`Kernels::any`], the batch entries).
///
/// Entry leaves ([`ENTRY_LEAF`]) keep checked indexing.
#[inline]
fn check_node(i: usize, n: &WideNode, n_nodes: usize, npk: usize) {
    for l in 0..WIDTH {
        let (c, k) = (n.child[l], n.count[l]);
        if c == u32::MAX && k == 0 {
            let inverted = (0..3).all(|a| n.b[a][l] == f32::INFINITY && n.b[3 + a][l] == f32::NEG_INFINITY);
            assert!(inverted, "wide node {i} lane {l}: an empty lane without the inverted box");
        } else if k == 0 {
            assert!((c as usize) < n_nodes, "wide node {i} lane {l}: child {c} of {n_nodes} nodes");
        } else if k & ENTRY_LEAF == 0 {
            let end = c as usize + packets_for(k);
            assert!(end <= npk, "wide node {i} lane {l}: packets {c}..{end} of {npk}");
        }
    }
}

/// Ask the CPU to bring the cache lines of the `len` bytes at `p` into the
/// cache (a hint: no memory is read, so any address is allowed).
#[inline(always)]
fn prefetch_span(p: *const u8, len: usize) {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{_MM_HINT_T0, _mm_prefetch};
        // SAFETY: prefetching is a hint that never faults, whatever the address.
        unsafe {
            _mm_prefetch::<_MM_HINT_T0>(p.cast());
            _mm_prefetch::<_MM_HINT_T0>(p.wrapping_add(len.saturating_sub(1)).cast());
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = (p, len);
}

/// `touch(k)` for every leaf slot `k` of `node` (inner lanes have none).
#[inline(always)]
fn touch_leaves(node: &WideNode, touch: &impl Fn(usize)) {
    for l in 0..WIDTH {
        let (first, count) = (node.child[l], node.count[l]);
        for k in first..first + count {
            touch(k as usize);
        }
    }
}

/// The triangle packets of every leaf lane of `nodes`, written in parallel
/// into `packets` (empty, with room for `npk`) in the order of the sequential
/// pass (node by node, lane by lane), and each lane pointed at its first
/// packet; `touch(k)` is called for every leaf slot of a node before the
/// node's packets are made (a prefetch).
fn pack_parallel(
    nodes: &mut [WideNode],
    packets: &mut Vec<super::packet::Tri4>,
    npk: usize,
    tri: &(impl Fn(usize) -> ([Vec3; 3], u32) + Sync),
    touch: &(impl Fn(usize) + Sync),
) {
    use rayon::prelude::*;
    assert!(packets.is_empty() && packets.capacity() >= npk);
    // Each node's packets, consecutive and in node order.
    let mut chunks = Vec::with_capacity(nodes.len());
    let mut rest = &mut packets.spare_capacity_mut()[..npk];
    let mut start = 0u32;
    for node in nodes.iter() {
        let k: usize = node.count.iter().map(|&c| packets_for(c)).sum();
        let (head, tail) = rest.split_at_mut(k);
        chunks.push((start, head));
        start += k as u32;
        rest = tail;
    }
    // Groups of consecutive nodes; in each, the next node's triangles are
    // requested while this node's are packed (as in the serial loop).
    const GROUP: usize = 256;
    let n_nodes = nodes.len();
    nodes.par_chunks_mut(GROUP).zip(chunks.par_chunks_mut(GROUP)).enumerate().for_each(|(g, (group, dsts))| {
        if let Some(first) = group.first() {
            touch_leaves(first, touch);
        }
        for i in 0..group.len() {
            if let Some(next) = group.get(i + 1) {
                touch_leaves(next, touch);
            }
            let (mut at, dst) = (dsts[i].0, std::mem::take(&mut dsts[i].1));
            let node = &mut group[i];
            let mut w = 0;
            for l in 0..WIDTH {
                let (first, count) = (node.child[l], node.count[l]);
                if count == 0 {
                    continue;
                }
                node.child[l] = at;
                for c in 0..packets_for(count) {
                    dst[w].write(super::packet::leaf_packet(first, count, c, tri));
                    w += 1;
                }
                at += packets_for(count) as u32;
            }
            check_node(g * GROUP + i, node, n_nodes, npk);
        }
    });
    // SAFETY: the chunks cover the first `npk` slots exactly and every one of
    // them was written above (each node writes all the packets it counted).
    unsafe { packets.set_len(npk) };
}

/// Wide nodes on the longest root-to-leaf path (0 for an empty tree).
fn levels_of(nodes: &[WideNode]) -> usize {
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

/// The widest set this CPU runs.
fn detect_isa() -> WalkIsa {
    WalkIsa::supported()[0]
}

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use super::*;
    use crate::backends::AccelConfig;
    use crate::geometry::{Sphere, Triangle};
    use crate::rng::Pcg32;

    fn soup(n: usize, seed: u64) -> Primitives {
        let mut rng = Pcg32::new(seed, 0);
        let mut p = || Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
        let triangles = (0..n)
            .map(|_| {
                let c = p();
                Triangle { v: [c, c + 0.05 * p(), c + 0.05 * p()] }
            })
            .collect();
        Primitives { triangles, spheres: Vec::new() }
    }

    /// `check_node` accepts the trees the builders make and refuses a tree
    /// with an inner lane past the nodes, a leaf's packets past the packets
    /// or an empty lane without the inverted box (the walks follow those
    /// links without bounds checks).
    /// [`check_node`] on every node of `nodes`.
    fn check_links(nodes: &[WideNode], packets: Option<&TriPackets>) {
        let npk = packets.map_or(0, |p| p.packets.len());
        for (i, n) in nodes.iter().enumerate() {
            check_node(i, n, nodes.len(), npk);
        }
    }

    #[test]
    fn links_out_of_range_are_refused() {
        let prims = std::sync::Arc::new(soup(3000, 11));
        let w = super::super::build_wide(&prims, &AccelConfig::default());
        let (nodes, pk) = (w.nodes().to_vec(), w.packets().cloned());
        check_links(&nodes, pk.as_ref());
        let lanes = |f: fn(&WideNode, usize) -> bool| {
            nodes.iter().enumerate().find_map(|(i, n)| (0..WIDTH).find(|&l| f(n, l)).map(|l| (i, l))).unwrap()
        };
        let refused = |nodes: Vec<WideNode>| {
            let pk = pk.clone();
            std::panic::catch_unwind(move || check_links(&nodes, pk.as_ref())).is_err()
        };
        let (i, l) = lanes(|n, l| n.count[l] == 0 && n.child[l] != u32::MAX);
        let mut bad = nodes.clone();
        bad[i].child[l] = nodes.len() as u32;
        assert!(refused(bad), "an inner lane past the nodes");
        let (i, l) = lanes(|n, l| n.count[l] > 0);
        let mut bad = nodes.clone();
        bad[i].child[l] = pk.as_ref().unwrap().packets.len() as u32;
        assert!(refused(bad), "a leaf past the packets");
        let (i, l) = lanes(|n, l| n.child[l] == u32::MAX);
        let mut bad = nodes.clone();
        bad[i].b[3][l] = 1.0;
        assert!(refused(bad), "an empty lane with a box");
    }

    /// Rays that are not traceable (a NaN or infinite origin or direction, a
    /// zero direction, an empty interval) get no hit from every entry point,
    /// so the walks never see them; traceable rays along every axis in both
    /// directions (reciprocals of +0 and -0 included) give the brute-force
    /// answers.
    #[test]
    fn untraceable_rays_never_reach_the_walks() {
        let prims = std::sync::Arc::new(soup(2000, 12));
        let w = super::super::build_wide(&prims, &AccelConfig::default());
        let nan = f32::NAN;
        let bad = [
            Ray::new(Vec3::new(nan, nan, nan), Vec3::X),
            Ray::new(Vec3::splat(0.5), Vec3::new(nan, 0.0, 0.0)),
            Ray::new(Vec3::new(f32::INFINITY, 0.5, 0.5), -Vec3::X),
            Ray::new(Vec3::splat(0.5), Vec3::ZERO),
            Ray::new(Vec3::splat(0.5), Vec3::splat(-0.0)),
            Ray::new(Vec3::splat(0.5), Vec3::new(0.0, f32::NEG_INFINITY, 0.0)),
            Ray { t_min: 1.0, t_max: 0.5, ..Ray::new(Vec3::splat(-1.0), Vec3::ONE) },
            Ray { t_min: f32::NAN, ..Ray::new(Vec3::splat(-1.0), Vec3::ONE) },
        ];
        for isa in WalkIsa::supported() {
            let mut w = w.clone();
            w.set_isa(isa);
            for test in [TriangleTest::Watertight, TriangleTest::MollerTrumbore] {
                let k = w.kernels(test);
                for r in &bad {
                    assert!(k.closest(&w, r).is_none() && !k.any(&w, r), "{isa:?} {r:?}");
                    assert!(w.intersect(r, test).is_none() && !w.occluded(r, test), "{isa:?} {r:?}");
                    let mut c = TraversalCounts::default();
                    assert!(w.intersect_counted(r, test, &mut c).is_none(), "{isa:?} {r:?}");
                    assert!(!w.occluded_counted(r, test, &mut c), "{isa:?} {r:?}");
                    assert_eq!(c.nodes, 0, "{isa:?}: an untraceable ray visited a node");
                }
                // In batches (full packets and a short one) beside traceable rays.
                let good = Ray::new(Vec3::new(-1.0, 0.5, 0.5), Vec3::X);
                for n in [3, 8, 16] {
                    let rays: Vec<Ray> =
                        (0..n).map(|i| if i % 2 == 0 { bad[i / 2 % bad.len()] } else { good }).collect();
                    let (mut hits, mut occl) = (vec![None; n], vec![true; n]);
                    k.closest_batch(&w, &rays, &mut hits);
                    k.any_batch(&w, &rays, &mut occl);
                    for (i, r) in rays.iter().enumerate() {
                        let (h, o) = if i % 2 == 0 { (None, false) } else { (k.closest(&w, r), k.any(&w, r)) };
                        assert_eq!(hits[i], h, "{isa:?} batch of {n}, ray {i}");
                        assert_eq!(occl[i], o, "{isa:?} batch of {n}, ray {i}");
                    }
                }
            }
        }
        // Rays along each axis both ways (reciprocals of +0 and -0) through the
        // shared brute-force comparison of every walk.
        let axis_rays: Vec<Ray> = [Vec3::X, Vec3::Y, Vec3::Z]
            .into_iter()
            .flat_map(|a| [a, -a])
            .flat_map(|d| (0..50).map(move |k| Ray::new(Vec3::splat(0.02 * k as f32) - d, d)))
            .collect();
        assert_brute_force_answers(&prims, &w, &axis_rays, 30);
    }

    /// The closest-hit entry's early out at the root box (`misses_root!`)
    /// changes no answer: on a mesh with triangles in the planes of its own
    /// bounding box (a unit cube's faces around a soup), rays that start on
    /// the box's faces, edges and corners or in their planes outside the
    /// box, with direction components of `+0` and `-0` (slabs that are NaN
    /// where the origin lies on the plane), rays from outside towards and
    /// away from the box, and rays whose interval ends before the box or
    /// starts after it give the brute-force answers bit for bit on every
    /// walk. The root box is the union of the root's lanes.
    #[test]
    fn the_root_box_early_out_keeps_the_answers() {
        let mut prims = soup(600, 21);
        let c = |x: f32, y: f32, z: f32| Vec3::new(x, y, z);
        let quads = [
            [c(0., 0., 0.), c(1., 0., 0.), c(1., 1., 0.), c(0., 1., 0.)],
            [c(0., 0., 1.05), c(1., 0., 1.05), c(1., 1., 1.05), c(0., 1., 1.05)],
            [c(0., 0., 0.), c(0., 1., 0.), c(0., 1., 1.05), c(0., 0., 1.05)],
            [c(1., 0., 0.), c(1., 1., 0.), c(1., 1., 1.05), c(1., 0., 1.05)],
            [c(0., 0., 0.), c(1., 0., 0.), c(1., 0., 1.05), c(0., 0., 1.05)],
            [c(0., 1., 0.), c(1., 1., 0.), c(1., 1., 1.05), c(0., 1., 1.05)],
        ];
        for q in quads {
            prims.triangles.push(Triangle { v: [q[0], q[1], q[2]] });
            prims.triangles.push(Triangle { v: [q[0], q[2], q[3]] });
        }
        let prims = std::sync::Arc::new(prims);
        let w = super::super::build_wide(&prims, &AccelConfig::default());
        let b = w.root_box;
        let (lo, hi) = (Vec3::from_slice(&b.lo[..3]), Vec3::from_slice(&b.hi[..3]));
        assert_eq!((lo, hi), (prims.world_bounds().min, prims.world_bounds().max), "the root box is the scene's");
        assert_eq!((b.lo[3], b.hi[3]), (f32::NEG_INFINITY, f32::INFINITY));
        let mut rng = Pcg32::new(5, 5);
        let mut rays = Vec::new();
        // Coordinates on the box's planes, just inside and outside them, and beyond.
        let coord = |a: usize, k: u32| {
            let (l, h) = (lo[a], hi[a]);
            [l, h, l.next_down(), h.next_up(), l.next_up(), h.next_down(), 0.5 * (l + h), l - 0.5, h + 0.5][k as usize]
        };
        let comp = [0.0f32, -0.0, 1.0, -1.0, 0.37, -0.81];
        for _ in 0..6000 {
            let o = Vec3::new(coord(0, rng.below(9)), coord(1, rng.below(9)), coord(2, rng.below(9)));
            let d = Vec3::new(comp[rng.below(6) as usize], comp[rng.below(6) as usize], comp[rng.below(6) as usize]);
            if d.abs().max_element() == 0.0 {
                continue;
            }
            let r = match rng.below(3) {
                0 => Ray::new(o, d),
                // An interval that ends before the box or starts after it (or neither).
                1 => Ray::with_range(o, d, 0.0, rng.next_f32() * 0.6),
                _ => Ray::with_range(o, d, 0.4 + rng.next_f32(), f32::INFINITY),
            };
            rays.push(r);
        }
        // The watertight test's answers are the brute force's; the
        // Moller-Trumbore test's may lie outside every box by a rounding
        // (a ray one subnormal beside a cube face "hits" its corner), which
        // no culling walk finds: for both tests, the entry point (with its
        // early out) answers as the walk from the root without it.
        let bits = |h: Option<Hit>| h.map(|h| (h.t.to_bits(), h.prim, h.u.to_bits(), h.v.to_bits()));
        let brute = crate::accel::brute::BruteForce::new(prims.clone(), TriangleTest::Watertight);
        for isa in WalkIsa::supported() {
            let mut w = w.clone();
            assert!(w.set_isa(isa));
            for test in [TriangleTest::Watertight, TriangleTest::MollerTrumbore] {
                let k = w.kernels(test);
                let mut hits = 0;
                for (i, r) in rays.iter().enumerate() {
                    let got = k.closest(&w, r);
                    assert_eq!(bits(got), bits(w.intersect_counting(r, test, &mut ())), "{test:?} {isa:?} ray {i}");
                    if test == TriangleTest::Watertight {
                        assert_eq!(bits(got), bits(crate::accel::Tracer::intersect(&brute, r)), "{isa:?} ray {i}");
                    }
                    hits += usize::from(got.is_some());
                }
                assert!(hits > 300, "{test:?} {isa:?}: only {hits} of {} rays hit", rays.len());
            }
        }
    }

    /// The deep-tree stack (chosen for trees of more than 27 levels) gives
    /// the same answers as the one-page stack on the same tree and rays.
    #[test]
    fn deep_and_shallow_stacks_agree() {
        let prims = soup(4000, 3);
        let shallow = super::super::build_wide(&prims, &AccelConfig::default());
        assert!(shallow.levels * (WIDTH - 1) <= SHALLOW_STACK);
        let mut deep = shallow.clone();
        deep.levels = SHALLOW_STACK; // forces the 1024-entry stack
        let (ks, kd) = (shallow.kernels(TriangleTest::Watertight), deep.kernels(TriangleTest::Watertight));
        let rays = crate::rays::incoherent_rays(&prims.world_bounds(), 20_000, 7);
        let mut hits = 0;
        for r in &rays {
            let a = ks.closest(&shallow, r);
            assert_eq!(a, kd.closest(&deep, r));
            assert_eq!(ks.any(&shallow, r), kd.any(&deep, r));
            hits += usize::from(a.is_some());
        }
        assert!(hits > 1000, "only {hits} hits: the rays do not exercise the traversal");
    }

    /// With spheres among the triangles, triangle-only leaves still use
    /// packets and the leaves holding a sphere use entries.
    #[test]
    fn sphere_leaves_use_entries_and_the_rest_packets() {
        let mut prims = soup(2000, 5);
        prims.spheres = vec![Sphere { center: Vec3::splat(0.5), radius: 0.1 }];
        let w = super::super::build_wide(&prims, &AccelConfig::default());
        let lanes: Vec<u32> = w.nodes.iter().flat_map(|n| n.count).filter(|&c| c > 0).collect();
        let entry_leaves = lanes.iter().filter(|&&c| c & ENTRY_LEAF != 0).count();
        assert_eq!(entry_leaves, 1, "one sphere, one entry leaf");
        let packed: u32 = lanes.iter().filter(|&&c| c & ENTRY_LEAF == 0).sum();
        assert_eq!(packed as usize + (w.prims.len()), prims.len());
        assert!(w.prims.entries.iter().any(|e| e.id == 2000));
    }

    /// The closest and any-hit answers of `rays` through the batch entry points.
    fn batch_answers(w: &WideBvh, k: &Kernels, rays: &[Ray]) -> (Vec<Option<Hit>>, Vec<bool>) {
        let mut closest = vec![None; rays.len()];
        let mut any = vec![false; rays.len()];
        k.closest_batch(w, rays, &mut closest);
        k.any_batch(w, rays, &mut any);
        (closest, any)
    }

    /// Every walk of `w` (closest and any hit, single rays and packets, both
    /// triangle tests, every instruction set the CPU runs) gives the
    /// brute-force answers on `rays`, bit for bit; more than `min_hits` of
    /// them hit, so the comparison is not vacuous.
    fn assert_brute_force_answers(prims: &std::sync::Arc<Primitives>, w: &WideBvh, rays: &[Ray], min_hits: usize) {
        let bits = |h: Option<Hit>| h.map(|h| (h.t.to_bits(), h.prim, h.u.to_bits(), h.v.to_bits()));
        for (test, isa) in [TriangleTest::Watertight, TriangleTest::MollerTrumbore]
            .into_iter()
            .flat_map(|t| WalkIsa::supported().into_iter().map(move |i| (t, i)))
        {
            let brute = crate::accel::brute::BruteForce::new(prims.clone(), test);
            let mut w = w.clone();
            assert!(w.set_isa(isa));
            let k = w.kernels(test);
            let (closest, any) = batch_answers(&w, &k, rays);
            let mut hits = 0;
            for (i, r) in rays.iter().enumerate() {
                let want = crate::accel::Tracer::intersect(&brute, r);
                assert_eq!(bits(k.closest(&w, r)), bits(want), "{test:?} {isa:?} ray {i}");
                assert_eq!(bits(closest[i]), bits(want), "{test:?} {isa:?} ray {i} in a packet");
                assert_eq!(k.any(&w, r), want.is_some(), "{test:?} {isa:?} ray {i}");
                assert_eq!(any[i], want.is_some(), "{test:?} {isa:?} ray {i} in a packet");
                hits += usize::from(want.is_some());
            }
            assert!(hits > min_hits, "{test:?} {isa:?}: only {hits} of {} rays hit", rays.len());
        }
    }

    /// A mesh large enough for leaves priced as eight-triangle tests
    /// (`packet::WIDE_LEAVES_FROM`) gets leaves of five to eight triangles,
    /// whose two packets the AVX2 walks test at once, and every walk (single
    /// rays and packets of eight, closest and any hit, both triangle tests)
    /// gives the brute-force answer bit for bit.
    #[test]
    fn eight_triangle_leaves_give_the_brute_force_answers() {
        let prims = std::sync::Arc::new(soup(super::super::packet::WIDE_LEAVES_FROM + 1000, 21));
        let w = super::super::build_wide(&prims, &AccelConfig::default());
        let counts: Vec<u32> = w.nodes.iter().flat_map(|n| n.count).filter(|&c| c > 0).collect();
        let pairs = counts.iter().filter(|&&c| c > 4).count();
        assert!(
            counts.iter().all(|&c| c <= 8) && pairs * 2 > counts.len(),
            "{pairs} of {} leaves hold 5-8",
            counts.len()
        );
        let b = prims.world_bounds();
        let mut rays = crate::rays::incoherent_rays(&b, 1500, 23);
        let eye = Vec3::new(0.5, 0.5, -2.0);
        rays.extend((0..1500).map(|i| {
            let (x, y) = ((i % 40) as f32 / 40.0, (i / 40) as f32 / 40.0);
            Ray::new(eye, Vec3::new(x, y, 0.5) - eye)
        }));
        assert_brute_force_answers(&prims, &w, &rays, 1500);
    }

    /// Rays that run in the planes of boxes (zero direction components, the
    /// other coordinates of the origin on a vertex's, so a slab is `0 * inf`,
    /// NaN, in the boxes of that vertex's leaves and their ancestors) give the
    /// brute-force answers on every walk: the AVX2 box test's tree of
    /// `max`/`min`, which may drop a slab beside a NaN one, never rejects a
    /// box the ray passes through.
    #[test]
    fn rays_in_box_planes_give_the_brute_force_answers() {
        let prims = std::sync::Arc::new(soup(3000, 17));
        let w = super::super::build_wide(&prims, &AccelConfig::default());
        let b = prims.world_bounds();
        let verts: Vec<Vec3> = prims.triangles.iter().flat_map(|t| t.v).collect();
        let mut rng = Pcg32::new(29, 0);
        let rays: Vec<Ray> = (0..6000)
            .map(|i| {
                let a = i % 3;
                let sign = |r: &mut Pcg32| if r.next_f32() < 0.5 { 1.0 } else { -1.0 };
                let mut d = Vec3::ZERO;
                d[a] = sign(&mut rng);
                if i % 2 == 1 {
                    // One zero component (an in-plane diagonal), else two.
                    d[(a + 1) % 3] = sign(&mut rng);
                }
                let mut o = b.min + (b.max - b.min) * Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
                o[a] += 2.0 * (rng.next_f32() - 0.5);
                let v = verts[(rng.next_f32() * verts.len() as f32) as usize % verts.len()];
                for k in 0..3 {
                    if d[k] == 0.0 {
                        o[k] = v[k];
                    }
                }
                Ray::new(o, d)
            })
            .collect();
        // Not vacuous: a good share of these rays touch the triangle whose vertex they run through.
        assert_brute_force_answers(&prims, &w, &rays, 1000);
    }

    /// Shadow-ray segments between points of a soup's bounds give the
    /// brute-force answers on every walk: the any-hit walk tests the leaves of
    /// one packet two at a time (`two_leaves_any`), and this tree has many
    /// nodes with two or more such leaves for the pairs to form.
    #[test]
    fn leaves_tested_in_pairs_give_the_brute_force_answers() {
        let prims = std::sync::Arc::new(soup(3000, 23));
        let w = super::super::build_wide(&prims, &AccelConfig::default());
        let small = |n: &WideNode| (0..WIDTH).filter(|&l| n.count[l].wrapping_sub(1) < PW as u32).count();
        let paired = w.nodes.iter().filter(|n| small(n) >= 2).count();
        assert!(paired * 2 > w.nodes.len(), "only {paired} of {} nodes hold two one-packet leaves", w.nodes.len());
        let b = prims.world_bounds();
        let mut rng = Pcg32::new(31, 0);
        let mut point = || b.min + (b.max - b.min) * Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
        let rays: Vec<Ray> = (0..8000)
            .map(|_| {
                let (p, q) = (point(), point());
                Ray::with_range(p, q - p, 0.0, 1.0)
            })
            .collect();
        assert_brute_force_answers(&prims, &w, &rays, 1000);
    }

    /// Packets of eight rays give every ray its single-ray answer, bit for
    /// bit: coherent camera rays, incoherent rays (mixed direction signs in
    /// one packet), a partial last packet, spheres among the triangles, and
    /// a ray with an empty interval.
    #[test]
    fn packets_give_the_single_ray_answers() {
        let mut prims = soup(3000, 9);
        prims.spheres = vec![Sphere { center: Vec3::splat(0.5), radius: 0.1 }];
        let b = prims.world_bounds();
        let mut rays = crate::rays::incoherent_rays(&b, 4001, 11);
        let eye = Vec3::new(0.5, 0.5, -2.0);
        for i in 0..4000 {
            let (x, y) = ((i % 64) as f32 / 64.0, (i / 64) as f32 / 64.0);
            rays.push(Ray::new(eye, Vec3::new(x, y, 0.5) - eye));
        }
        rays[5].t_min = 2.0;
        rays[5].t_max = 1.0;
        for isa in WalkIsa::supported() {
            let mut w = super::super::build_wide(&prims, &AccelConfig::default());
            assert!(w.set_isa(isa));
            let k = w.kernels(TriangleTest::Watertight);
            let (closest, any) = batch_answers(&w, &k, &rays);
            let mut hits = 0;
            for (i, r) in rays.iter().enumerate() {
                let one = k.closest(&w, r);
                assert_eq!(
                    closest[i].map(|h| (h.t.to_bits(), h.prim, h.u.to_bits(), h.v.to_bits())),
                    one.map(|h| (h.t.to_bits(), h.prim, h.u.to_bits(), h.v.to_bits())),
                    "{isa:?} ray {i}"
                );
                assert_eq!(any[i], one.is_some(), "{isa:?} ray {i}");
                hits += usize::from(one.is_some());
            }
            assert!(hits > 2000, "only {hits} hits");
        }
    }
}
