//! Packets of up to eight rays through the 8-wide tree: the batch entry
//! points ([`crate::accel::Tracer::intersect_batch`] /
//! [`crate::accel::Tracer::occluded_batch`]) for coherent rays (a tile of
//! camera rays, the shadow rays of one surface point).
//!
//! The packet walks the tree once: each node is loaded once for all its
//! rays; a frustum (`Frustum`) around the rays (when their directions share signs)
//! bounds all eight child boxes at once, and each child it keeps is tested
//! against the eight rays at once (AVX2, rays in the lanes). The box arithmetic is the single-ray path's, lane for
//! lane (each ray's near and far planes picked by its own direction signs,
//! the same subtractions and multiplications, and `max`/`min` that ignore a
//! NaN slab; the single-ray test's tree of them may also drop a slab beside
//! a NaN one, `wide::box8_avx2`), so a ray enters the boxes it would enter
//! alone (in that degenerate case possibly fewer, never one it passes
//! through), and
//! each stacked child keeps its rays' own entry distances, so a ray whose
//! closest hit moved nearer drops the children beyond it. A leaf that most
//! of the packet's rays reach is tested one triangle against the rays at
//! once, with the single-ray arithmetic lane for lane (each ray on its own
//! axis permutation of the watertight test, or Moller-Trumbore's
//! operations); other leaves are tested ray by ray with the single-ray leaf
//! code, and an inner node that at most `SINGLE_RAYS` (closest hit) or
//! `SINGLE_RAYS_ANY` (any hit) of the packet's rays reach is walked by each
//! of them alone with the single-ray traversal. Each ray's answer is therefore the
//! single-ray answer, bit for bit (the tests check it against brute force).

use std::mem::MaybeUninit;

use crate::geometry::offset::gamma;
use crate::geometry::triangle::{E_FLOOR, SIGN_MARGIN, T_ETA, T_SPREAD_MAX, TriangleKernel};
use crate::geometry::{Hit, Ray};

use super::packet::LeafRay;
use super::slab::{cull_bound, far_scale};
use super::wide::{ENTRY_LEAF, WIDTH, WideBvh};

/// Rays per packet.
pub const PACKET: usize = 8;

/// Fewer rays than this go one by one: a packet tests all eight lanes of
/// every node for all its rays, which costs about as much as five rays
/// walking the tree alone.
pub const MIN_PACKET: usize = 5;

/// A stacked child: its rays' entry distances (`+inf` for rays that missed it).
#[derive(Clone, Copy)]
#[repr(C, align(32))]
struct Entry {
    near: [f32; PACKET],
    child: u32,
    count: u32,
}

/// Per-packet ray data in structure-of-arrays form.
#[derive(Clone, Copy)]
#[repr(C, align(32))]
struct Soa {
    o: [[f32; PACKET]; 3],
    d: [[f32; PACKET]; 3],
    inv: [[f32; PACKET]; 3],
    inv_far: [[f32; PACKET]; 3],
    t_min: [f32; PACKET],
    cull: [f32; PACKET],
}

impl Soa {
    /// Rays `rays` (at most [`PACKET`]); missing lanes repeat the last ray and are never active.
    #[inline(always)]
    fn new(rays: &[Ray]) -> Self {
        let mut s = Soa {
            o: [[0.0; PACKET]; 3],
            d: [[0.0; PACKET]; 3],
            inv: [[0.0; PACKET]; 3],
            inv_far: [[0.0; PACKET]; 3],
            t_min: [0.0; PACKET],
            cull: [0.0; PACKET],
        };
        for i in 0..PACKET {
            let r = &rays[i.min(rays.len() - 1)];
            let (o, dir) = (r.origin.to_array(), r.dir.to_array());
            for (a, (o_row, d_row)) in s.o.iter_mut().zip(s.d.iter_mut()).enumerate() {
                o_row[i] = o[a];
                d_row[i] = dir[a];
            }
            s.t_min[i] = r.t_min;
            s.cull[i] = cull_bound(r.t_max);
        }
        // The single-ray path's per-ray constants (`WidePre`: `dir.recip()`
        // and `inv * far_scale()`), as whole rows: the same IEEE divisions
        // and products lane for lane, which the compiler makes eight-wide.
        for (inv_row, (far_row, d_row)) in s.inv.iter_mut().zip(s.inv_far.iter_mut().zip(&s.d)) {
            for ((inv, far), &x) in inv_row.iter_mut().zip(far_row.iter_mut()).zip(d_row) {
                *inv = 1.0 / x;
                *far = *inv * far_scale();
            }
        }
        s
    }
}

/// The box test of one child lane against the packet: `(hit mask, near)`.
#[cfg(target_arch = "x86_64")]
macro_rules! lane_box {
    ($node:expr, $l:expr, $v:expr, $cull:expr, $active:expr) => {{
        use std::arch::x86_64::*;
        let (node, l) = ($node, $l);
        let b = |row: usize| _mm256_set1_ps(node.b[row][l]);
        let (near_x, near_y, near_z, far_x, far_y, far_z) = if let Some([nx, ny, nz, fx, fy, fz]) = $v.rows {
            // Every ray's direction has the same signs: the same planes for all.
            (b(nx), b(ny), b(nz), b(fx), b(fy), b(fz))
        } else {
            // Each ray's near plane is the max plane where its direction is negative.
            let (lo_x, lo_y, lo_z, hi_x, hi_y, hi_z) = (b(0), b(1), b(2), b(3), b(4), b(5));
            (
                _mm256_blendv_ps(lo_x, hi_x, $v.neg[0]),
                _mm256_blendv_ps(lo_y, hi_y, $v.neg[1]),
                _mm256_blendv_ps(lo_z, hi_z, $v.neg[2]),
                _mm256_blendv_ps(hi_x, lo_x, $v.neg[0]),
                _mm256_blendv_ps(hi_y, lo_y, $v.neg[1]),
                _mm256_blendv_ps(hi_z, lo_z, $v.neg[2]),
            )
        };
        let tn_x = _mm256_mul_ps(_mm256_sub_ps(near_x, $v.o[0]), $v.inv[0]);
        let tn_y = _mm256_mul_ps(_mm256_sub_ps(near_y, $v.o[1]), $v.inv[1]);
        let tn_z = _mm256_mul_ps(_mm256_sub_ps(near_z, $v.o[2]), $v.inv[2]);
        let tf_x = _mm256_mul_ps(_mm256_sub_ps(far_x, $v.o[0]), $v.inv_far[0]);
        let tf_y = _mm256_mul_ps(_mm256_sub_ps(far_y, $v.o[1]), $v.inv_far[1]);
        let tf_z = _mm256_mul_ps(_mm256_sub_ps(far_z, $v.o[2]), $v.inv_far[2]);
        // A chain, each possibly-NaN slab first: a NaN slab is ignored. (The
        // single-ray test's depth-two tree measured slower here: dragon_87k
        // batch shadow rays 1.205-1.215 -> 1.167-1.181 against Embree's
        // default mode, `bench --race 5`, three alternated pairs.)
        let tn = _mm256_max_ps(tn_x, _mm256_max_ps(tn_y, _mm256_max_ps(tn_z, $v.t_min)));
        let tf = _mm256_min_ps(tf_x, _mm256_min_ps(tf_y, _mm256_min_ps(tf_z, $cull)));
        let hit = _mm256_and_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(tn, tf), $active);
        (hit, tn)
    }};
}

/// The packet's rays in AVX2 registers.
#[cfg(target_arch = "x86_64")]
struct Regs {
    o: [std::arch::x86_64::__m256; 3],
    inv: [std::arch::x86_64::__m256; 3],
    inv_far: [std::arch::x86_64::__m256; 3],
    neg: [std::arch::x86_64::__m256; 3],
    /// When every ray's direction has the same signs: the rows of the near
    /// and far planes of each axis (as the single-ray test picks them).
    rows: Option<[usize; 6]>,
    t_min: std::arch::x86_64::__m256,
}

#[cfg(target_arch = "x86_64")]
macro_rules! regs {
    ($s:expr) => {{
        use std::arch::x86_64::*;
        let s: &Soa = $s;
        // SAFETY: every row is 32 bytes at a 32-byte multiple of the aligned Soa.
        let ld = |p: &[f32; PACKET]| unsafe { _mm256_load_ps(p.as_ptr()) };
        let inv = [ld(&s.inv[0]), ld(&s.inv[1]), ld(&s.inv[2])];
        let z = _mm256_setzero_ps();
        let neg = inv.map(|i| _mm256_cmp_ps::<_CMP_LT_OQ>(i, z));
        let signs = neg.map(|n| _mm256_movemask_ps(n));
        let rows = signs.iter().all(|&m| m == 0 || m == 0xff).then(|| {
            let n = signs.map(|m| usize::from(m != 0));
            [3 * n[0], 1 + 3 * n[1], 2 + 3 * n[2], 3 - 3 * n[0], 4 - 3 * n[1], 5 - 3 * n[2]]
        });
        Regs {
            o: [ld(&s.o[0]), ld(&s.o[1]), ld(&s.o[2])],
            neg,
            rows,
            inv,
            inv_far: [ld(&s.inv_far[0]), ld(&s.inv_far[1]), ld(&s.inv_far[2])],
            t_min: ld(&s.t_min),
        }
    }};
}

/// `$op` (`_mm256_min_ps` or `_mm256_max_ps`) over the eight lanes of
/// `$v`, the result in every lane.
#[cfg(target_arch = "x86_64")]
macro_rules! horizontal {
    ($op:ident, $v:expr) => {{
        use std::arch::x86_64::*;
        let v = $v;
        let a = $op(v, _mm256_permute2f128_ps::<1>(v, v));
        let b = $op(a, _mm256_shuffle_ps::<0b01_00_11_10>(a, a));
        $op(b, _mm256_shuffle_ps::<0b10_11_00_01>(b, b))
    }};
}

/// A conservative bound of the packet's box tests, for all eight children
/// of a node at once: the rays' origins and reciprocals as intervals.
///
/// Each ray's entry distance on an axis is `fl(fl(b - o) inv)` (the exact
/// arithmetic of [`lane_box`]). Rounding is monotone, so over origins in
/// `[o_lo, o_hi]` and reciprocals in `[inv_lo, inv_hi]` (one sign for all the
/// rays, so each ray's near plane is the same row) that distance is at least
/// `min(fl(d inv_lo), fl(d inv_hi))` with `d = fl(b - o_hi)` where the
/// reciprocals are positive (`fl(b - o_lo)` where negative); the exit
/// distances are bounded above the same way. Every reciprocal is finite and
/// nonzero, so no product is NaN. A child whose lower entry bound exceeds
/// its upper exit bound is entered by none of the rays: the packet skips
/// its eight-ray test, which would find no ray. The bound uses all the
/// packet's rays and a stale (larger) cull distance, both of which only
/// widen it.
#[cfg(target_arch = "x86_64")]
#[derive(Clone, Copy)]
struct Frustum {
    /// Byte offsets in a node of each axis's near and far rows.
    near: [usize; 3],
    far: [usize; 3],
    /// The origin bound that gives the least entry (greatest exit) distance.
    o_near: [std::arch::x86_64::__m256; 3],
    o_far: [std::arch::x86_64::__m256; 3],
    /// Least and greatest reciprocal (and far reciprocal) of each axis.
    inv: [[std::arch::x86_64::__m256; 2]; 3],
    inv_far: [[std::arch::x86_64::__m256; 2]; 3],
    /// Least `t_min` of the rays.
    t_min: std::arch::x86_64::__m256,
}

/// The packet's [`Frustum`], when every ray's direction has the same signs
/// and every reciprocal (and far reciprocal) is finite.
///
/// # Safety
/// The CPU must have AVX2 (inlined into AVX2 functions only).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn frustum(s: &Soa, rows: Option<[usize; 6]>) -> Option<Frustum> {
    use std::arch::x86_64::*;
    let rows = rows?;
    // SAFETY: AVX2 is guaranteed by the caller; every Soa row is 32 bytes at a 32-byte multiple of the aligned Soa.
    unsafe {
        let ld = |r: &[f32; PACKET]| _mm256_load_ps(r.as_ptr());
        let inf = _mm256_set1_ps(f32::INFINITY);
        let abs = |x: __m256| _mm256_andnot_ps(_mm256_set1_ps(-0.0), x);
        // Ordered comparisons: a NaN reciprocal is not finite either.
        let finite = |x: __m256| _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LT_OQ>(abs(x), inf)) == 0xff;
        let inv = [ld(&s.inv[0]), ld(&s.inv[1]), ld(&s.inv[2])];
        if !inv.iter().all(|&x| finite(x)) {
            return None;
        }
        let fs = _mm256_set1_ps(far_scale());
        let row = std::mem::size_of::<[f32; WIDTH]>();
        let mut f = Frustum {
            near: [0; 3],
            far: [0; 3],
            o_near: [inf; 3],
            o_far: [inf; 3],
            inv: [[inf; 2]; 3],
            inv_far: [[inf; 2]; 3],
            t_min: horizontal!(_mm256_min_ps, ld(&s.t_min)),
        };
        for a in 0..3 {
            let o = ld(&s.o[a]);
            let (o_lo, o_hi) = (horizontal!(_mm256_min_ps, o), horizontal!(_mm256_max_ps, o));
            // The near plane is the min row (row a) where the reciprocals are positive.
            let positive = rows[a] == a;
            f.near[a] = rows[a] * row;
            f.far[a] = rows[3 + a] * row;
            (f.o_near[a], f.o_far[a]) = if positive { (o_hi, o_lo) } else { (o_lo, o_hi) };
            f.inv[a] = [horizontal!(_mm256_min_ps, inv[a]), horizontal!(_mm256_max_ps, inv[a])];
            // Each ray's far reciprocal is fl(inv far_scale), monotone in inv:
            // the least and greatest are those of the least and greatest inv.
            f.inv_far[a] = [_mm256_mul_ps(f.inv[a][0], fs), _mm256_mul_ps(f.inv[a][1], fs)];
            if !(finite(f.inv_far[a][0]) && finite(f.inv_far[a][1])) {
                return None;
            }
        }
        Some(f)
    }
}

/// The children of `node` that some ray of the packet may enter (bit `l`
/// for lane `l`): a superset of the lanes whose [`lane_box`] test finds a
/// ray, never missing one (see [`Frustum`]). Empty lanes (inverted boxes)
/// are never in it.
///
/// # Safety
/// The CPU must have AVX2 (inlined into AVX2 functions only).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn frustum_lanes(node: &super::wide::WideNode, f: &Frustum, cull_hi: std::arch::x86_64::__m256) -> u32 {
    use std::arch::x86_64::*;
    // SAFETY: AVX2 is guaranteed by the caller.
    unsafe {
        let base = node.b.as_ptr().cast::<u8>();
        // SAFETY: every offset is a row (32 bytes) of the 64-byte aligned node.
        let ld = |off: usize| _mm256_load_ps(base.add(off).cast::<f32>());
        let near = |a: usize| {
            let d = _mm256_sub_ps(ld(f.near[a]), f.o_near[a]);
            _mm256_min_ps(_mm256_mul_ps(d, f.inv[a][0]), _mm256_mul_ps(d, f.inv[a][1]))
        };
        let far = |a: usize| {
            let d = _mm256_sub_ps(ld(f.far[a]), f.o_far[a]);
            _mm256_max_ps(_mm256_mul_ps(d, f.inv_far[a][0]), _mm256_mul_ps(d, f.inv_far[a][1]))
        };
        let tn = _mm256_max_ps(near(0), _mm256_max_ps(near(1), _mm256_max_ps(near(2), f.t_min)));
        let tf = _mm256_min_ps(far(0), _mm256_min_ps(far(1), _mm256_min_ps(far(2), cull_hi)));
        _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(tn, tf)) as u32
    }
}

/// Horizontal minimum of the eight lanes.
#[cfg(target_arch = "x86_64")]
macro_rules! hmin {
    ($v:expr) => {
        std::arch::x86_64::_mm256_cvtss_f32(horizontal!(_mm256_min_ps, $v))
    };
}

/// The packet's rays as the watertight test sees them: per ray, the origin
/// on the ray's permuted axes and its shear. For the Moller-Trumbore test
/// ([`rays8`]), which takes no shear, the axes are not permuted and `s`
/// holds the directions.
#[cfg(target_arch = "x86_64")]
struct Sheared {
    /// The rays' common axis permutation (unused when `mixed` is set).
    k: [usize; 3],
    /// When the rays' permutations differ: per permuted axis `j`, the lanes
    /// whose axis `j` is `y` (`[j][0]`) and `z` (`[j][1]`), as blend masks.
    mixed: Option<[[std::arch::x86_64::__m256; 2]; 3]>,
    o: [std::arch::x86_64::__m256; 3],
    s: [std::arch::x86_64::__m256; 3],
    t_min: std::arch::x86_64::__m256,
    /// The rays' [`spread_scale`](crate::geometry::triangle::spread_scale)s (zero for the tests that take no shear).
    spread: std::arch::x86_64::__m256,
}

/// Vertex `j` of lane `l` of `p` on each ray's permuted axes, the rays'
/// permutations given as [`Sheared::mixed`] blend masks.
///
/// # Safety
/// The CPU must have AVX2 (inlined into AVX2 functions only).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn permuted(
    sel: &[[std::arch::x86_64::__m256; 2]; 3],
    p: &super::packet::Tri4,
    l: usize,
    j: usize,
) -> [std::arch::x86_64::__m256; 3] {
    use std::arch::x86_64::*;
    // SAFETY: AVX2 is guaranteed by the caller.
    unsafe {
        let x = _mm256_set1_ps(p.v[3 * j][l]);
        let y = _mm256_set1_ps(p.v[3 * j + 1][l]);
        let z = _mm256_set1_ps(p.v[3 * j + 2][l]);
        [
            _mm256_blendv_ps(_mm256_blendv_ps(x, y, sel[0][0]), z, sel[0][1]),
            _mm256_blendv_ps(_mm256_blendv_ps(x, y, sel[1][0]), z, sel[1][1]),
            _mm256_blendv_ps(_mm256_blendv_ps(x, y, sel[2][0]), z, sel[2][1]),
        ]
    }
}

/// Leaves whose triangles are tested against this many of the packet's rays
/// or more take one triangle against all eight rays at once ([`tri_x8`]), in
/// the closest-hit packet walk. 4 or 2 measured the same on batch primary rays
/// (stop 29, `--race 3`, one binary, against Embree's default mode: suzanne
/// 1.22-1.23 from 6 rays, 1.25-1.26 from 4, 1.22-1.27 from 2; dragon_87k
/// 0.99-1.00, 0.97-1.00, 1.00).
const SOA_LEAF_RAYS: u32 = 6;

/// [`SOA_LEAF_RAYS`] for the any-hit packet walk: a leaf that two of the
/// packet's rays reach already takes one triangle against all eight rays.
/// Measured on the four-light shadow set (stop 29, `rtdiff bench --race 3
/// --threads 1`, batch shadow rays against Embree's default mode, one binary,
/// the value read from an environment variable for the measurement only):
/// suzanne from 6 rays 0.783 / 0.797, from 4 0.832 / 0.845 / 0.782 / 0.840,
/// from 3 0.851 / 0.848, from 2 0.866 / 0.879, from 1 0.852 / 0.868, never
/// (9) 0.595 / 0.592; dragon_87k from 6 1.014 / 1.014, from 2 1.036 / 1.039;
/// dragon_full (`--race 2`) from 6 1.074 / 1.069 / 1.036 / 1.057, from 2
/// 1.048 / 1.028.
///
/// A leaf of `n` triangles asks for at least `n / 2` rays as well (the
/// one-triangle test runs `n` times, the rays' own tests once per ray): in
/// trees of eight-triangle leaves (`packet::WIDE_LEAVES_FROM`) dragon_87k's
/// batch shadow rays went 1.130 / 1.130 -> 1.153 / 1.149 against Embree's
/// default mode (`--race 5 --threads 1`, alternated binaries); leaves of up
/// to four triangles keep the threshold of two.
const SOA_LEAF_RAYS_ANY: u32 = 2;

/// The watertight test of triangle `(v0, v1, v2)` against the eight rays of
/// `sh` (rays in the lanes, `t_max` per ray): `(hit mask, uncertain mask, t,
/// u, v)`. Lane for lane the operations of
/// [`crate::geometry::triangle::intersect_watertight`] in the same order (as
/// `packet::tri4_sse` does with triangles in the lanes), so a hit lane's `t,
/// u, v` are the scalar routine's bits; uncertain lanes (an edge sign within
/// `SIGN_MARGIN` bounds of 0, or a distance not provably positive or
/// possibly too imprecise, `T_SPREAD_MAX`) must be decided by the scalar routine.
///
/// # Safety
/// The CPU must have AVX2 (the callers are AVX2 functions, into which this is inlined).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn tri_x8(
    sh: &Sheared,
    p: &super::packet::Tri4,
    l: usize,
    t_max: std::arch::x86_64::__m256,
) -> (u32, u32, [f32; PACKET], [f32; PACKET], [f32; PACKET]) {
    // SAFETY: AVX2 is guaranteed by the caller (see above); the stores are justified where they occur.
    unsafe {
        use std::arch::x86_64::*;
        let [kx, ky, kz] = sh.k;
        let [ox, oy, oz] = sh.o;
        let [sx, sy, sz] = sh.s;
        // Coordinate `a` of vertex `j` of the packet's lane `l`, in every lane.
        let b = |j: usize, a: usize| _mm256_set1_ps(p.v[3 * j + a][l]);
        // The vertices on each ray's permuted axes.
        let ([v0x, v0y, v0z], [v1x, v1y, v1z], [v2x, v2y, v2z]) = if let Some(sel) = &sh.mixed {
            (permuted(sel, p, l, 0), permuted(sel, p, l, 1), permuted(sel, p, l, 2))
        } else {
            ([b(0, kx), b(0, ky), b(0, kz)], [b(1, kx), b(1, ky), b(1, kz)], [b(2, kx), b(2, ky), b(2, kz)])
        };
        // a = v0 - o, b = v1 - o, c = v2 - o on the permuted axes.
        let (a_x, a_y, a_z) = (_mm256_sub_ps(v0x, ox), _mm256_sub_ps(v0y, oy), _mm256_sub_ps(v0z, oz));
        let (b_x, b_y, b_z) = (_mm256_sub_ps(v1x, ox), _mm256_sub_ps(v1y, oy), _mm256_sub_ps(v1z, oz));
        let (c_x, c_y, c_z) = (_mm256_sub_ps(v2x, ox), _mm256_sub_ps(v2y, oy), _mm256_sub_ps(v2z, oz));
        let ax = _mm256_sub_ps(a_x, _mm256_mul_ps(sx, a_z));
        let ay = _mm256_sub_ps(a_y, _mm256_mul_ps(sy, a_z));
        let bx = _mm256_sub_ps(b_x, _mm256_mul_ps(sx, b_z));
        let by = _mm256_sub_ps(b_y, _mm256_mul_ps(sy, b_z));
        let cx = _mm256_sub_ps(c_x, _mm256_mul_ps(sx, c_z));
        let cy = _mm256_sub_ps(c_y, _mm256_mul_ps(sy, c_z));
        let e0 = _mm256_sub_ps(_mm256_mul_ps(cx, by), _mm256_mul_ps(cy, bx));
        let e1 = _mm256_sub_ps(_mm256_mul_ps(ax, cy), _mm256_mul_ps(ay, cx));
        let e2 = _mm256_sub_ps(_mm256_mul_ps(bx, ay), _mm256_mul_ps(by, ax));
        let az = _mm256_mul_ps(sz, a_z);
        let bz = _mm256_mul_ps(sz, b_z);
        let cz = _mm256_mul_ps(sz, c_z);
        // The edge functions' error bound (`watertight_e_error`, same operation order).
        let sign = _mm256_set1_ps(-0.0);
        let abs = |x: __m256| _mm256_andnot_ps(sign, x);
        let max3 = |x: __m256, y: __m256, w: __m256| _mm256_max_ps(_mm256_max_ps(abs(x), abs(y)), abs(w));
        let (max_xt, max_yt, max_zt) = (max3(ax, bx, cx), max3(ay, by, cy), max3(az, bz, cz));
        let (g2, g3, g5) = (_mm256_set1_ps(gamma(2)), _mm256_set1_ps(gamma(3)), _mm256_set1_ps(gamma(5)));
        let delta_x = _mm256_mul_ps(g5, _mm256_add_ps(max_xt, max_zt));
        let delta_y = _mm256_mul_ps(g5, _mm256_add_ps(max_yt, max_zt));
        let delta_e = _mm256_mul_ps(
            _mm256_set1_ps(2.0),
            _mm256_add_ps(
                _mm256_add_ps(_mm256_mul_ps(_mm256_mul_ps(g2, max_xt), max_yt), _mm256_mul_ps(delta_y, max_xt)),
                _mm256_mul_ps(delta_x, max_yt),
            ),
        );
        let min_e = _mm256_min_ps(_mm256_min_ps(abs(e0), abs(e1)), abs(e2));
        // Uncertain: an edge function within SIGN_MARGIN bounds or `E_FLOOR`
        // of 0, or a NaN bound or minimum (unordered compares true; `max`
        // passes a NaN bound on, its second operand).
        let bound = _mm256_max_ps(_mm256_set1_ps(E_FLOOR), _mm256_mul_ps(_mm256_set1_ps(SIGN_MARGIN), delta_e));
        let uncertain = _mm256_cmp_ps::<_CMP_NGT_US>(min_e, bound);
        // Elsewhere, with no NaN edge function, all are nonzero: "some
        // negative and some positive" is "the sign bits differ"; a NaN one
        // makes t NaN, never in range (see `packet::tri4_sse`).
        let mixed = _mm256_or_ps(_mm256_xor_ps(e0, e1), _mm256_xor_ps(e0, e2));
        let det = _mm256_add_ps(_mm256_add_ps(e0, e1), e2);
        let t_scaled =
            _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(e0, az), _mm256_mul_ps(e1, bz)), _mm256_mul_ps(e2, cz));
        let inv_det = _mm256_div_ps(_mm256_set1_ps(1.0), det);
        let t = _mm256_mul_ps(t_scaled, inv_det);
        // Ordered comparisons: a NaN t fails both, as `!(t >= t_min && t <= t_max)` rejects it.
        // Sign bits only from here on (movemask reads nothing else).
        let past_min = _mm256_andnot_ps(_mm256_or_ps(mixed, uncertain), _mm256_cmp_ps::<_CMP_GE_OS>(t, sh.t_min));
        let zero_mask = _mm256_movemask_ps(uncertain) as u32;
        if _mm256_movemask_ps(past_min) == 0 {
            return (0, zero_mask, [0.0; PACKET], [0.0; PACKET], [0.0; PACKET]);
        }
        // The edge functions' share of t's error against the parity bound
        // (`watertight_t_imprecise`, same operation order), before `t_max` as
        // in the scalar routine: lanes where it may be too large go to the
        // scalar routine.
        let spread = _mm256_add_ps(
            _mm256_add_ps(abs(_mm256_sub_ps(az, t)), abs(_mm256_sub_ps(bz, t))),
            abs(_mm256_sub_ps(cz, t)),
        );
        let allowed = _mm256_mul_ps(_mm256_mul_ps(_mm256_set1_ps(T_SPREAD_MAX), _mm256_max_ps(sh.spread, t)), abs(det));
        let imprecise = _mm256_and_ps(_mm256_cmp_ps::<_CMP_GT_OS>(_mm256_mul_ps(delta_e, spread), allowed), past_min);
        let zero_mask = zero_mask | _mm256_movemask_ps(imprecise) as u32;
        let ok = _mm256_andnot_ps(imprecise, _mm256_and_ps(past_min, _mm256_cmp_ps::<_CMP_LE_OS>(t, t_max)));
        if _mm256_movemask_ps(ok) == 0 {
            return (0, zero_mask, [0.0; PACKET], [0.0; PACKET], [0.0; PACKET]);
        }
        // The provably-positive-t check of `watertight_t_error` (pbrt-v4 6.8.7), same operation order.
        let delta_z = _mm256_mul_ps(g3, max_zt);
        let max_e = max3(e0, e1, e2);
        let t_err = _mm256_mul_ps(
            _mm256_mul_ps(
                _mm256_set1_ps(3.0),
                _mm256_add_ps(
                    _mm256_add_ps(
                        _mm256_add_ps(_mm256_mul_ps(_mm256_mul_ps(g3, max_e), max_zt), _mm256_mul_ps(delta_e, max_zt)),
                        _mm256_mul_ps(delta_z, max_e),
                    ),
                    _mm256_set1_ps(T_ETA),
                ),
            ),
            abs(inv_det),
        );
        let not_positive = _mm256_and_ps(_mm256_cmp_ps::<_CMP_LE_OS>(t, t_err), ok);
        let ok = _mm256_andnot_ps(not_positive, ok);
        let zero_mask = zero_mask | _mm256_movemask_ps(not_positive) as u32;
        let (mut ts, mut us, mut vs) = ([0.0f32; PACKET], [0.0f32; PACKET], [0.0f32; PACKET]);
        // Each array has room for 8 floats; storeu has no alignment requirement.
        _mm256_storeu_ps(ts.as_mut_ptr(), t);
        _mm256_storeu_ps(us.as_mut_ptr(), _mm256_mul_ps(e1, inv_det));
        _mm256_storeu_ps(vs.as_mut_ptr(), _mm256_mul_ps(e2, inv_det));
        (_mm256_movemask_ps(ok) as u32, zero_mask, ts, us, vs)
    }
}

/// The Moller-Trumbore test of triangle `(v0, v1, v2)` (lane `l` of `p`)
/// against the eight rays of `rows` ([`rays8`]: origins in `o`, directions
/// in `s`), rays in the lanes: `(hit mask, t, u, v)`. Lane for lane the
/// operations of [`crate::geometry::triangle::intersect_moller_trumbore`] in
/// the same order (as `packet::tri4_mt_sse` does with triangles in the
/// lanes; the edges `v1 - v0` and `v2 - v0` are the same in every lane), so
/// a hit lane's `t, u, v` are the scalar routine's bits, and its rejections
/// are the same comparisons.
///
/// # Safety
/// The CPU must have AVX2 (the callers are AVX2 functions, into which this is inlined).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn tri_x8_mt(
    rows: &Sheared,
    p: &super::packet::Tri4,
    l: usize,
    t_max: std::arch::x86_64::__m256,
) -> (u32, [f32; PACKET], [f32; PACKET], [f32; PACKET]) {
    // SAFETY: AVX2 is guaranteed by the caller; the stores are justified where they occur.
    unsafe {
        use std::arch::x86_64::*;
        let b = |j: usize, a: usize| _mm256_set1_ps(p.v[3 * j + a][l]);
        let [ox, oy, oz] = rows.o;
        let [dx, dy, dz] = rows.s;
        let (v0x, v0y, v0z) = (b(0, 0), b(0, 1), b(0, 2));
        // e1 = v1 - v0, e2 = v2 - v0.
        let (e1x, e1y, e1z) = (_mm256_sub_ps(b(1, 0), v0x), _mm256_sub_ps(b(1, 1), v0y), _mm256_sub_ps(b(1, 2), v0z));
        let (e2x, e2y, e2z) = (_mm256_sub_ps(b(2, 0), v0x), _mm256_sub_ps(b(2, 1), v0y), _mm256_sub_ps(b(2, 2), v0z));
        let dot = |ax: __m256, ay: __m256, az: __m256, bx: __m256, by: __m256, bz: __m256| {
            _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(ax, bx), _mm256_mul_ps(ay, by)), _mm256_mul_ps(az, bz))
        };
        // p = dir x e2 (glam: x = a.y b.z - b.y a.z, y = a.z b.x - b.z a.x, z = a.x b.y - b.x a.y).
        let px = _mm256_sub_ps(_mm256_mul_ps(dy, e2z), _mm256_mul_ps(e2y, dz));
        let py = _mm256_sub_ps(_mm256_mul_ps(dz, e2x), _mm256_mul_ps(e2z, dx));
        let pz = _mm256_sub_ps(_mm256_mul_ps(dx, e2y), _mm256_mul_ps(e2x, dy));
        let det = dot(e1x, e1y, e1z, px, py, pz);
        let (zero, one) = (_mm256_setzero_ps(), _mm256_set1_ps(1.0));
        // `det == 0 || !det.is_finite()` rejects: keep 0 < |det| < inf (a NaN fails both).
        let abs_det = _mm256_andnot_ps(_mm256_set1_ps(-0.0), det);
        let det_ok = _mm256_and_ps(
            _mm256_cmp_ps::<_CMP_GT_OQ>(abs_det, zero),
            _mm256_cmp_ps::<_CMP_LT_OQ>(abs_det, _mm256_set1_ps(f32::INFINITY)),
        );
        let inv_det = _mm256_div_ps(one, det);
        // tv = origin - v0.
        let (tvx, tvy, tvz) = (_mm256_sub_ps(ox, v0x), _mm256_sub_ps(oy, v0y), _mm256_sub_ps(oz, v0z));
        let u = _mm256_mul_ps(dot(tvx, tvy, tvz, px, py, pz), inv_det);
        // `(0.0..=1.0).contains(&u)`: ordered comparisons, a NaN fails.
        let ok = _mm256_and_ps(
            det_ok,
            _mm256_and_ps(_mm256_cmp_ps::<_CMP_GE_OQ>(u, zero), _mm256_cmp_ps::<_CMP_LE_OQ>(u, one)),
        );
        if _mm256_movemask_ps(ok) == 0 {
            return (0, [0.0; PACKET], [0.0; PACKET], [0.0; PACKET]);
        }
        // q = tv x e1.
        let qx = _mm256_sub_ps(_mm256_mul_ps(tvy, e1z), _mm256_mul_ps(e1y, tvz));
        let qy = _mm256_sub_ps(_mm256_mul_ps(tvz, e1x), _mm256_mul_ps(e1z, tvx));
        let qz = _mm256_sub_ps(_mm256_mul_ps(tvx, e1y), _mm256_mul_ps(e1x, tvy));
        let v = _mm256_mul_ps(dot(dx, dy, dz, qx, qy, qz), inv_det);
        // `v < 0.0 || u + v > 1.0` rejects (a NaN v passes, as there).
        let v_out =
            _mm256_or_ps(_mm256_cmp_ps::<_CMP_LT_OQ>(v, zero), _mm256_cmp_ps::<_CMP_GT_OQ>(_mm256_add_ps(u, v), one));
        let t = _mm256_mul_ps(dot(e2x, e2y, e2z, qx, qy, qz), inv_det);
        // `!(t >= t_min && t <= t_max)` rejects: ordered comparisons, a NaN t fails.
        let in_range = _mm256_and_ps(_mm256_cmp_ps::<_CMP_GE_OQ>(t, rows.t_min), _mm256_cmp_ps::<_CMP_LE_OQ>(t, t_max));
        let ok = _mm256_andnot_ps(v_out, _mm256_and_ps(ok, in_range));
        let (mut ts, mut us, mut vs) = ([0.0f32; PACKET], [0.0f32; PACKET], [0.0f32; PACKET]);
        // Each array has room for 8 floats; storeu has no alignment requirement.
        _mm256_storeu_ps(ts.as_mut_ptr(), t);
        _mm256_storeu_ps(us.as_mut_ptr(), u);
        _mm256_storeu_ps(vs.as_mut_ptr(), v);
        (_mm256_movemask_ps(ok) as u32, ts, us, vs)
    }
}

/// One triangle (lane `l` of `p`) against the packet's eight rays with the
/// test `K`: `(hit mask, uncertain mask, t, u, v)` ([`tri_x8`] or
/// [`tri_x8_mt`], which leaves no lane uncertain); `rows` is [`rays8`]'s.
///
/// # Safety
/// The CPU must have AVX2 (the callers are AVX2 functions, into which this is inlined).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn tri_x8_k<K: TriangleKernel>(
    rows: &Sheared,
    p: &super::packet::Tri4,
    l: usize,
    t_max: std::arch::x86_64::__m256,
) -> (u32, u32, [f32; PACKET], [f32; PACKET], [f32; PACKET]) {
    // SAFETY: AVX2 is guaranteed by the caller.
    unsafe {
        if K::WATERTIGHT {
            tri_x8(rows, p, l, t_max)
        } else {
            let (ok, t, u, v) = tri_x8_mt(rows, p, l, t_max);
            (ok, 0, t, u, v)
        }
    }
}

/// Closest hits of up to [`PACKET`] rays, answers into `out` (same length);
/// `S` is the traversal stack's size, `P` whether hit children are
/// prefetched (`WideBvh::prefetch_all`, fixed per tree by `WideBvh::kernels`).
///
/// # Safety
/// The CPU must have AVX2; `bvh` must be non-empty; `rays` holds 1 to 8 rays.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
pub(super) unsafe fn closest8<K: TriangleKernel, const S: usize, const P: bool>(
    bvh: &WideBvh,
    rays: &[Ray],
    out: &mut [Option<Hit>],
) {
    use std::arch::x86_64::*;
    let n = rays.len();
    let mut soa = Soa::new(rays);
    let v = regs!(&soa);
    // SAFETY: closest8 runs on AVX2 CPUs only.
    let fr = unsafe { frustum(&soa, v.rows) };
    let mut r: [Ray; PACKET] = std::array::from_fn(|i| rays[i.min(n - 1)]);
    let mut best: [Option<Hit>; PACKET] = [None; PACKET];
    let mut wr: [Option<LeafRay>; PACKET] = [None; PACKET];
    // Made at the first leaf that enough rays reach.
    let mut sheared: Option<Sheared> = None;
    let lanes = if n == PACKET { u32::MAX } else { (1u32 << n) - 1 };
    // SAFETY: the Soa row is aligned.
    let mut cull = unsafe { _mm256_load_ps(soa.cull.as_ptr()) };
    let mut stack = [MaybeUninit::<Entry>::uninit(); S];
    let mut sp = 0usize;
    let mut cur = Entry { near: soa.t_min, child: 0, count: 0 };
    let mut cur_mask = lanes & 0xff;
    let inf = _mm256_set1_ps(f32::INFINITY);
    'outer: loop {
        if cur.count == 0 && cur_mask.count_ones() <= SINGLE_RAYS {
            // Too few rays left for eight-lane box tests to pay: each walks
            // this subtree alone (the same box and triangle tests), bounded
            // by its closest hit so far, and offers what it finds under the
            // same tie rule.
            let mut m = cur_mask;
            let mut changed = false;
            while m != 0 {
                let i = m.trailing_zeros() as usize;
                m &= m - 1;
                if let Some(h) = bvh.closest_avx2_from::<K, S, P>(&r[i], cur.child)
                    && Hit::offer(&mut best[i], &mut r[i], h)
                {
                    soa.cull[i] = cull_bound(r[i].t_max);
                    changed = true;
                }
            }
            if changed {
                // SAFETY: the Soa row is aligned.
                cull = unsafe { _mm256_load_ps(soa.cull.as_ptr()) };
            }
        } else if cur.count == 0 {
            let node = &bvh.nodes[cur.child as usize];
            let active = _mm256_castsi256_ps(_mm256_cmpgt_epi32(
                _mm256_and_si256(_mm256_set1_epi32(cur_mask as i32), _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128)),
                _mm256_setzero_si256(),
            ));
            // Hit children with their rays' entry distances, nearest first.
            let mut hit: [(f32, u32); WIDTH] = [(0.0, 0); WIDTH];
            let mut near = [[0.0f32; PACKET]; WIDTH];
            let mut k = 0;
            // SAFETY: closest8 runs on AVX2 CPUs only.
            let mut candidates =
                fr.as_ref().map_or(0xff, |f| unsafe { frustum_lanes(node, f, horizontal!(_mm256_max_ps, cull)) });
            while candidates != 0 {
                let l = candidates.trailing_zeros() as usize;
                candidates &= candidates - 1;
                if node.child[l] == u32::MAX {
                    continue;
                }
                let near_l = &mut near[l];
                let (m, tn) = lane_box!(node, l, v, cull, active);
                if _mm256_movemask_ps(m) == 0 {
                    continue;
                }
                let tn = _mm256_blendv_ps(inf, tn, m);
                // SAFETY: near_l has room for 8 floats.
                unsafe { _mm256_storeu_ps(near_l.as_mut_ptr(), tn) };
                let key = hmin!(tn);
                let mut j = k;
                while j > 0 && hit[j - 1].0 > key {
                    hit[j] = hit[j - 1];
                    j -= 1;
                }
                hit[j] = (key, l as u32);
                k += 1;
            }
            if k > 0 {
                if P {
                    let mut lanes = 0u32;
                    for &(_, l) in &hit[..k] {
                        lanes |= 1 << l;
                    }
                    bvh.prefetch_children(node, lanes);
                }
                for &(_, l) in hit[1..k].iter().rev() {
                    let l = l as usize;
                    stack[sp] = MaybeUninit::new(Entry { near: near[l], child: node.child[l], count: node.count[l] });
                    sp += 1;
                }
                let l = hit[0].1 as usize;
                cur = Entry { near: near[l], child: node.child[l], count: node.count[l] };
                // SAFETY: near[l] holds 8 floats.
                let tn = unsafe { _mm256_loadu_ps(cur.near.as_ptr()) };
                cur_mask = _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(tn, cull)) as u32;
                continue 'outer;
            }
        } else if cur.count & ENTRY_LEAF == 0
            && cur_mask.count_ones() >= SOA_LEAF_RAYS
            && let Some(pk) = &bvh.packets
        {
            // One triangle against all the rays at once.
            let sh = sheared.get_or_insert_with(|| rays8::<K>(&soa));
            let c = cur.count as usize;
            let mut changed = false;
            let mut t_max = _mm256_setr_ps(
                r[0].t_max, r[1].t_max, r[2].t_max, r[3].t_max, r[4].t_max, r[5].t_max, r[6].t_max, r[7].t_max,
            );
            for k in 0..c {
                let p = &pk.packets[cur.child as usize + k / super::packet::PW];
                let l = k % super::packet::PW;
                // SAFETY: closest8 runs on AVX2 CPUs only.
                let (ok, unc, t, u, vv) = unsafe { tri_x8_k::<K>(sh, p, l, t_max) };
                let (mut ok, mut unc) = (ok & cur_mask, unc & cur_mask);
                let mut closer = false;
                while unc != 0 {
                    let i = unc.trailing_zeros() as usize;
                    unc &= unc - 1;
                    let w = wr[i].get_or_insert_with(|| LeafRay::new(&r[i]));
                    let (v0, v1, v2) = (p.vertex(0, l), p.vertex(1, l), p.vertex(2, l));
                    if let Some((t, u, v2)) = K::intersect(&r[i], &w.wr(), v0, v1, v2) {
                        closer |= Hit::offer(&mut best[i], &mut r[i], Hit { t, prim: p.id[l], u, v: v2 });
                    }
                }
                while ok != 0 {
                    let i = ok.trailing_zeros() as usize;
                    ok &= ok - 1;
                    closer |= Hit::offer(&mut best[i], &mut r[i], Hit { t: t[i], prim: p.id[l], u: u[i], v: vv[i] });
                }
                if closer {
                    t_max = _mm256_setr_ps(
                        r[0].t_max, r[1].t_max, r[2].t_max, r[3].t_max, r[4].t_max, r[5].t_max, r[6].t_max, r[7].t_max,
                    );
                    changed = true;
                }
            }
            if changed {
                for (c, ri) in soa.cull.iter_mut().zip(&r) {
                    *c = cull_bound(ri.t_max);
                }
                // SAFETY: the Soa row is aligned.
                cull = unsafe { _mm256_load_ps(soa.cull.as_ptr()) };
            }
        } else {
            let c = cur.count & !ENTRY_LEAF;
            let mut m = cur_mask;
            let mut changed = false;
            while m != 0 {
                let i = m.trailing_zeros() as usize;
                m &= m - 1;
                let w = wr[i].get_or_insert_with(|| LeafRay::new(&r[i]));
                let closer = if cur.count & ENTRY_LEAF != 0 {
                    bvh.prims.intersect_leaf::<K>(cur.child, c, &mut r[i], &w.wr(), &mut best[i])
                } else {
                    // SAFETY: a packet leaf lane of one of the tree's nodes.
                    unsafe { bvh.packets_closest::<K>(cur.child, c, &mut r[i], w, &mut best[i], true) }
                };
                if closer {
                    soa.cull[i] = cull_bound(r[i].t_max);
                    changed = true;
                }
            }
            if changed {
                // SAFETY: the Soa row is aligned.
                cull = unsafe { _mm256_load_ps(soa.cull.as_ptr()) };
            }
        }
        loop {
            if sp == 0 {
                break 'outer;
            }
            sp -= 1;
            // SAFETY: entries below sp were written before.
            let e = unsafe { stack[sp].assume_init() };
            // SAFETY: e.near holds 8 floats.
            let tn = unsafe { _mm256_loadu_ps(e.near.as_ptr()) };
            let m = _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(tn, cull)) as u32;
            if m != 0 {
                cur = e;
                cur_mask = m;
                break;
            }
        }
    }
    for (i, o) in out.iter_mut().enumerate() {
        *o = bvh.prims.finish(best[i], &rays[i]);
    }
}

/// The packet's rows for the one-triangle-against-eight-rays tests of `K`:
/// [`shear8`] for the watertight test; for Moller-Trumbore the origins and
/// directions as they are (see [`Sheared`]).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn rays8<K: TriangleKernel>(soa: &Soa) -> Sheared {
    if K::WATERTIGHT {
        return shear8(soa);
    }
    let (d, o, t_min) = gather8(soa);
    let zero = std::arch::x86_64::_mm256_setzero_ps();
    Sheared { k: [0, 1, 2], mixed: None, o, s: d, t_min, spread: zero }
}

/// The packet's directions, origins and `t_min` as rows of eight lanes.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn gather8(s: &Soa) -> ([std::arch::x86_64::__m256; 3], [std::arch::x86_64::__m256; 3], std::arch::x86_64::__m256) {
    use std::arch::x86_64::*;
    // SAFETY: every row is 32 bytes at a 32-byte multiple of the aligned Soa.
    let ld = |row: &[f32; PACKET]| unsafe { _mm256_load_ps(row.as_ptr()) };
    (s.d.each_ref().map(ld), s.o.each_ref().map(ld), ld(&s.t_min))
}

/// The packet as [`Sheared`]: per ray the axis permutation of
/// [`crate::geometry::triangle::WatertightRay::new`] (the same axis choice) and its shear (the same
/// divisions, lane for lane, so the same bits).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn shear8(soa: &Soa) -> Sheared {
    use std::arch::x86_64::*;
    let (d, o, t_min) = gather8(soa);
    let sign = _mm256_set1_ps(-0.0);
    let [ax, ay, az] = d.map(|x| _mm256_andnot_ps(sign, x));
    // kz = 0 where |x| >= |y| and |x| >= |z|, else 1 where |y| >= |z|, else 2.
    let z0 = _mm256_and_ps(_mm256_cmp_ps::<_CMP_GE_OQ>(ax, ay), _mm256_cmp_ps::<_CMP_GE_OQ>(ax, az));
    let z1 = _mm256_andnot_ps(z0, _mm256_cmp_ps::<_CMP_GE_OQ>(ay, az));
    let z2 = _mm256_andnot_ps(_mm256_or_ps(z0, z1), _mm256_castsi256_ps(_mm256_set1_epi32(-1)));
    let dz = _mm256_blendv_ps(_mm256_blendv_ps(d[0], d[1], z1), d[2], z2);
    // kx = kz + 1 and ky = kz + 2 (mod 3), swapped where dir[kz] < 0.
    let neg = _mm256_cmp_ps::<_CMP_LT_OQ>(dz, _mm256_setzero_ps());
    // `sz`, and `spread_scale` with the same operations: `|o|_inf |sz|`.
    let sz = _mm256_div_ps(_mm256_set1_ps(1.0), dz);
    let abs_o = o.map(|x| _mm256_andnot_ps(sign, x));
    let o_inf = _mm256_max_ps(_mm256_max_ps(abs_o[0], abs_o[1]), abs_o[2]);
    let spread = _mm256_mul_ps(o_inf, _mm256_andnot_ps(sign, sz));
    let uniform = |m: __m256| matches!(_mm256_movemask_ps(m), 0 | 0xff);
    if uniform(z0) && uniform(z1) && uniform(neg) {
        let kz = if _mm256_movemask_ps(z0) != 0 {
            0
        } else if _mm256_movemask_ps(z1) != 0 {
            1
        } else {
            2
        };
        let (mut kx, mut ky) = ((kz + 1) % 3, (kz + 2) % 3);
        if _mm256_movemask_ps(neg) != 0 {
            std::mem::swap(&mut kx, &mut ky);
        }
        let s = [_mm256_div_ps(d[kx], dz), _mm256_div_ps(d[ky], dz), sz];
        return Sheared { k: [kx, ky, kz], mixed: None, o: [o[kx], o[ky], o[kz]], s, t_min, spread };
    }
    // Per lane: axis kx is y where kz = 0 (z where kz = 1), axis ky is z where
    // kz = 0 (y where kz = 2); the two trade places where dir[kz] < 0.
    let (x_is_y, x_is_z, y_is_y, y_is_z) = (z0, z1, z2, z0);
    let sel = [
        [_mm256_blendv_ps(x_is_y, y_is_y, neg), _mm256_blendv_ps(x_is_z, y_is_z, neg)],
        [_mm256_blendv_ps(y_is_y, x_is_y, neg), _mm256_blendv_ps(y_is_z, x_is_z, neg)],
        [z1, z2],
    ];
    let pick = |v: &[__m256; 3], m: &[__m256; 2]| _mm256_blendv_ps(_mm256_blendv_ps(v[0], v[1], m[0]), v[2], m[1]);
    let (dx, dy) = (pick(&d, &sel[0]), pick(&d, &sel[1]));
    let s = [_mm256_div_ps(dx, dz), _mm256_div_ps(dy, dz), sz];
    let o = [pick(&o, &sel[0]), pick(&o, &sel[1]), pick(&o, &sel[2])];
    Sheared { k: [0, 1, 2], mixed: Some(sel), o, s, t_min, spread }
}

/// A packet entry (an inner node) with at most this many of its rays still
/// in it continues ray by ray. Since the packet's [`Frustum`] spares it the
/// eight-ray box test of the children no ray can enter, a packet of two or
/// three rays walks a node about as cheaply as they would alone, so only a
/// lone ray leaves the packet (it was 4 before the frustum). Measured in one
/// binary (stop 30, the value read from an environment variable for the
/// measurement only, `rtdiff bench --race 3 --threads 1`, batch primary
/// rays against Embree's default MEDIUM): dragon_87k from 4 rays 1.095 /
/// 1.096, 3: 1.144, 2: 1.173 / 1.169, 1: 1.202, 0 (never): 1.210;
/// dragon_full (`--race 2`) 4: 0.966, 2: 1.003, 1: 1.036 / 1.026 / 1.023, 0:
/// 1.013 / 1.029; suzanne 4: 1.316, 1: 1.310, 0: 1.340.
const SINGLE_RAYS: u32 = 1;

/// [`SINGLE_RAYS`] for the any-hit packet: an inner node that at most this
/// many of its rays still reach is walked by each of them alone. Lower than
/// for closest hits: a shadow ray alone stops at its first occluder and
/// needs no ordering. Measured in one binary (the value read from an
/// environment variable for the measurement only), `rtdiff bench --race 5
/// --threads 1`, batch shadow rays, Mrays/s: from 4 rays suzanne 15.8-16.1,
/// dragon_87k 5.8, dragon_full 3.19 (race 3); from 2 rays 16.0-16.5, 6.0-6.2,
/// 3.29-3.34; from 1 or 0 rays the same as 2 on suzanne and dragon_87k, and
/// from 0 dragon_full 3.23-3.25; from 6 or 8 rays slower everywhere (8:
/// suzanne 9.5).
const SINGLE_RAYS_ANY: u32 = 2;

/// Occlusion of up to [`PACKET`] rays, answers into `out` (same length).
///
/// # Safety
/// As [`closest8`].
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
pub(super) unsafe fn any8<K: TriangleKernel, const S: usize, const P: bool>(
    bvh: &WideBvh,
    rays: &[Ray],
    out: &mut [bool],
) {
    use std::arch::x86_64::*;
    let n = rays.len();
    let soa = Soa::new(rays);
    let v = regs!(&soa);
    // SAFETY: the Soa row is aligned.
    let cull = unsafe { _mm256_load_ps(soa.cull.as_ptr()) };
    // SAFETY: any8 runs on AVX2 CPUs only.
    let fr = unsafe { frustum(&soa, v.rows) };
    let cull_hi = horizontal!(_mm256_max_ps, cull);
    let mut wr: [Option<LeafRay>; PACKET] = [None; PACKET];
    // The rows of the one-triangle tests, with the rays' t_max, made here:
    // shadow rays nearly all reach a leaf, and made at the first leaf their
    // test waited for the shear and a branch guessed wrong once per packet.
    // (`rtdiff bench --race 5 --threads 1 --rtdiff-isa avx2 --embree-max-isa
    // avx2`, alternated binaries, two pairs, against Embree's default mode:
    // suzanne batch shadow rays 0.956 / 0.956 -> 1.027 / 1.031; dragon_87k,
    // `--race 3`, 1.301 -> 1.330.)
    let t_max: [f32; PACKET] = std::array::from_fn(|i| rays[i.min(n - 1)].t_max);
    // SAFETY: t_max holds 8 floats; loadu has no alignment requirement.
    let (sh, t_max) = (rays8::<K>(&soa), unsafe { _mm256_loadu_ps(t_max.as_ptr()) });
    // Rays still looking for an occluder.
    let mut open = if n == PACKET { 0xff } else { (1u32 << n) - 1 };
    let all = open;
    // Only inner nodes are stacked, with the rays that entered them; the one
    // visited next is kept in `cur` instead of being stacked and popped at
    // once (that store and load lengthened the walk's chain of dependent
    // loads, as in the single-ray walk).
    let mut stack = [MaybeUninit::<(u32, u32)>::uninit(); S];
    let mut sp = 0usize;
    let mut cur = (0u32, open);
    let bits = _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128);
    let inf = _mm256_set1_ps(f32::INFINITY);
    loop {
        let (index, entered) = cur;
        let m0 = entered & open;
        if m0 == 0 {
            if sp == 0 {
                break;
            }
            sp -= 1;
            // SAFETY: entries below sp were written before.
            cur = unsafe { stack[sp].assume_init() };
            continue;
        }
        if m0.count_ones() <= SINGLE_RAYS_ANY {
            // Too few rays left for eight-lane box tests to pay: each walks
            // this subtree alone (the same box tests, lane for lane).
            let mut m = m0;
            while m != 0 {
                let i = m.trailing_zeros() as usize;
                m &= m - 1;
                if bvh.any_avx2_from::<K, S, P>(&rays[i], index) {
                    open &= !(1 << i);
                }
            }
            if open == 0 || sp == 0 {
                break;
            }
            sp -= 1;
            // SAFETY: entries below sp were written before.
            cur = unsafe { stack[sp].assume_init() };
            continue;
        }
        let node = &bvh.nodes[index as usize];
        let active = _mm256_castsi256_ps(_mm256_cmpgt_epi32(
            _mm256_and_si256(_mm256_set1_epi32(m0 as i32), bits),
            _mm256_setzero_si256(),
        ));
        // Entered inner nodes, stacked after the node's leaves are tested,
        // the nearest first so that it is searched last (as in the
        // single-ray any-hit walk: a shadow ray's own surface is nearest).
        let mut inner = [(0u32, 0u32, 0.0f32); WIDTH];
        let (mut ni, mut nearest) = (0usize, 0usize);
        // SAFETY: any8 runs on AVX2 CPUs only.
        let mut candidates = fr.as_ref().map_or(0xff, |f| unsafe { frustum_lanes(node, f, cull_hi) });
        while candidates != 0 {
            let l = candidates.trailing_zeros() as usize;
            candidates &= candidates - 1;
            if node.child[l] == u32::MAX {
                continue;
            }
            let (hm, tn) = lane_box!(node, l, v, cull, active);
            let mut m = _mm256_movemask_ps(hm) as u32 & open;
            if m == 0 {
                continue;
            }
            let count = node.count[l];
            if count == 0 {
                let t = hmin!(_mm256_blendv_ps(inf, tn, hm));
                if ni > 0 && t < inner[nearest].2 {
                    nearest = ni;
                }
                inner[ni] = (node.child[l], m, t);
                ni += 1;
                if P {
                    // Searched after this node's leaves.
                    bvh.prefetch_node(node.child[l]);
                }
                continue;
            }
            let c = count & !ENTRY_LEAF;
            if count & ENTRY_LEAF == 0
                && m.count_ones() >= SOA_LEAF_RAYS_ANY.max(c.div_ceil(2))
                && let Some(pk) = &bvh.packets
            {
                // One triangle against all the leaf's rays at once; a ray
                // leaves the leaf at its first occluder (any occluder will do:
                // the answer is a yes or no).
                for k in 0..c as usize {
                    let p = &pk.packets[node.child[l] as usize + k / super::packet::PW];
                    let pl = k % super::packet::PW;
                    // SAFETY: any8 runs on AVX2 CPUs only.
                    let (ok, unc, _, _, _) = unsafe { tri_x8_k::<K>(&sh, p, pl, t_max) };
                    let (mut hit, mut unc) = (ok & m, unc & m);
                    while unc != 0 {
                        let i = unc.trailing_zeros() as usize;
                        unc &= unc - 1;
                        let w = wr[i].get_or_insert_with(|| LeafRay::new(&rays[i]));
                        let (v0, v1, v2) = (p.vertex(0, pl), p.vertex(1, pl), p.vertex(2, pl));
                        if K::intersect(&rays[i], &w.wr(), v0, v1, v2).is_some() {
                            hit |= 1 << i;
                        }
                    }
                    m &= !hit;
                    open &= !hit;
                    if m == 0 {
                        break;
                    }
                }
                // The rays left have no occluder in this leaf.
                m = 0;
            }
            while m != 0 {
                let i = m.trailing_zeros() as usize;
                m &= m - 1;
                let r = &rays[i];
                let w = wr[i].get_or_insert_with(|| LeafRay::new(r));
                let hit = if count & ENTRY_LEAF != 0 {
                    bvh.prims.occluded_leaf::<K>(node.child[l], c, r, &w.wr())
                } else {
                    // SAFETY: a packet leaf lane of this node.
                    unsafe { bvh.packets_any::<K>(node.child[l], c, r, w, true) }
                };
                if hit {
                    open &= !(1 << i);
                }
            }
            if open == 0 {
                break;
            }
        }
        if open == 0 {
            break;
        }
        if ni > 0 {
            // Stacked in this order: the nearest, then the others in lane
            // order; the last of them is visited next instead.
            let next = if ni == 1 {
                0
            } else if nearest == ni - 1 {
                ni - 2
            } else {
                ni - 1
            };
            if next != nearest {
                let (c, m, _) = inner[nearest];
                stack[sp] = MaybeUninit::new((c, m));
                sp += 1;
            }
            for (j, &(c, m, _)) in inner[..ni].iter().enumerate() {
                if j != nearest && j != next {
                    stack[sp] = MaybeUninit::new((c, m));
                    sp += 1;
                }
            }
            let (c, m, _) = inner[next];
            cur = (c, m);
        } else if sp > 0 {
            sp -= 1;
            // SAFETY: entries below sp were written before.
            cur = unsafe { stack[sp].assume_init() };
        } else {
            break;
        }
    }
    for (i, o) in out.iter_mut().enumerate() {
        *o = (all & !open) & (1 << i) != 0;
    }
}

#[cfg(all(test, target_arch = "x86_64"))]
mod tests {
    use glam::Vec3;

    use super::super::wide::WideNode;
    use super::*;
    use crate::rng::Pcg32;

    /// The lanes of `node` that some ray of `soa` enters by the exact
    /// eight-ray test, and the lanes the packet's [`Frustum`] keeps (`None`
    /// when the packet has no frustum).
    #[target_feature(enable = "avx2")]
    fn entered_and_kept(node: &WideNode, soa: &Soa) -> Option<(u32, u32)> {
        use std::arch::x86_64::*;
        let v = regs!(soa);
        // SAFETY: this function runs on AVX2 CPUs only; the Soa row is aligned.
        let (f, cull) = unsafe { (frustum(soa, v.rows)?, _mm256_load_ps(soa.cull.as_ptr())) };
        let active = _mm256_castsi256_ps(_mm256_set1_epi32(-1));
        let mut entered = 0;
        for l in 0..WIDTH {
            let (m, _) = lane_box!(node, l, v, cull, active);
            if _mm256_movemask_ps(m) != 0 {
                entered |= 1 << l;
            }
        }
        // SAFETY: as above.
        Some((entered, unsafe { frustum_lanes(node, &f, horizontal!(_mm256_max_ps, cull)) }))
    }

    /// One triangle against eight rays with Moller-Trumbore gives, ray by
    /// ray, the scalar routine's answer bit for bit (hits, edges, vertices,
    /// finite intervals, degenerate triangles).
    #[test]
    fn moller_trumbore_rays_are_the_scalar_routine() {
        if !std::arch::is_x86_feature_detected!("avx2") {
            return;
        }
        #[target_feature(enable = "avx2")]
        fn check(rays: &[Ray], p: &super::super::packet::Tri4, l: usize) -> usize {
            use std::arch::x86_64::*;
            let rows = rays8::<crate::geometry::triangle::MollerTrumbore>(&Soa::new(rays));
            let t_max: [f32; PACKET] = std::array::from_fn(|i| rays[i].t_max);
            // SAFETY: this function runs on AVX2 CPUs only; t_max holds 8 floats.
            let (mask, t, u, v) = unsafe { tri_x8_mt(&rows, p, l, _mm256_loadu_ps(t_max.as_ptr())) };
            let mut hits = 0;
            for (i, r) in rays.iter().enumerate() {
                let scalar = crate::geometry::triangle::intersect_moller_trumbore(
                    r,
                    p.vertex(0, l),
                    p.vertex(1, l),
                    p.vertex(2, l),
                );
                let simd = (mask >> i & 1 != 0).then(|| (t[i], u[i], v[i]));
                let bits = |h: Option<(f32, f32, f32)>| h.map(|(a, b, c)| (a.to_bits(), b.to_bits(), c.to_bits()));
                assert_eq!(bits(simd), bits(scalar), "ray {i} of {rays:?}, lane {l} of {p:?}");
                hits += usize::from(scalar.is_some());
            }
            hits
        }
        let mut rng = Pcg32::new(0x3d, 9);
        let (mut hits, mut cases) = (0, 0);
        for _ in 0..20_000 {
            let mut p = super::super::packet::Tri4 { v: [[0.0; 4]; 9], id: [0, 1, 2, 3] };
            for row in p.v.iter_mut() {
                for x in row.iter_mut() {
                    *x = 2.0 * rng.next_f32() - 1.0;
                }
            }
            let l = rng.below(4) as usize;
            if rng.below(16) == 0 {
                // A degenerate triangle: two vertices alike.
                for a in 0..3 {
                    p.v[3 + a][l] = p.v[a][l];
                }
            }
            let rays: Vec<Ray> = (0..PACKET)
                .map(|_| {
                    let o = rng.in_box(Vec3::splat(-2.0), Vec3::splat(2.0));
                    let (a, b) = (1.2 * rng.next_f32() - 0.1, 1.2 * rng.next_f32() - 0.1);
                    let (v0, v1, v2) = (p.vertex(0, l), p.vertex(1, l), p.vertex(2, l));
                    let mut target = v0 + a * (v1 - v0) + b * (v2 - v0);
                    if rng.below(8) == 0 {
                        target = [v0, v1, v2][rng.below(3) as usize];
                    }
                    let mut r = Ray::new(o, target - o);
                    if rng.below(4) == 0 {
                        r.t_min = rng.next_f32();
                        r.t_max = r.t_min + 2.0 * rng.next_f32();
                    }
                    r
                })
                .collect();
            // SAFETY: AVX2 was detected above.
            hits += unsafe { check(&rays, &p, l) };
            cases += PACKET;
        }
        assert!(hits > cases / 10 && hits < cases * 9 / 10, "{hits} hits of {cases}");
    }

    /// A float of random sign-free magnitude over many binades (and now and then 0).
    fn magnitude(rng: &mut Pcg32) -> f32 {
        if rng.below(16) == 0 {
            return 0.0;
        }
        (1.0 + rng.next_f32()) * 2f32.powi(rng.below(60) as i32 - 40)
    }

    /// The frustum never drops a lane that a ray of the packet enters (the
    /// oracle is the exact eight-ray box test the walks run), and it does
    /// drop lanes, so the check is not vacuous. Packets of rays with shared
    /// direction signs, spread or shared origins, directions over many
    /// binades (some with reciprocals near overflow, which have no frustum),
    /// random intervals; boxes around, beside, behind and through the
    /// origins, thin, flat and empty.
    #[test]
    fn the_frustum_keeps_every_lane_a_ray_enters() {
        if !std::arch::is_x86_feature_detected!("avx2") {
            return;
        }
        let mut rng = Pcg32::new(0xf7, 3);
        let (mut packets, mut kept, mut entered, mut dropped) = (0, 0u32, 0u32, 0u32);
        for _ in 0..20_000 {
            let signs = Vec3::new(
                if rng.below(2) == 0 { 1.0 } else { -1.0 },
                if rng.below(2) == 0 { 1.0 } else { -1.0 },
                if rng.below(2) == 0 { 1.0 } else { -1.0 },
            );
            let scale = 2f32.powi(rng.below(20) as i32 - 10);
            let centre = rng.in_box(Vec3::splat(-4.0 * scale), Vec3::splat(4.0 * scale));
            let spread = if rng.below(3) == 0 { 0.0 } else { scale * rng.next_f32() };
            let base = Vec3::new(magnitude(&mut rng), magnitude(&mut rng), magnitude(&mut rng));
            let rays: Vec<Ray> = (0..PACKET)
                .map(|_| {
                    let o = centre + spread * rng.in_box(Vec3::splat(-1.0), Vec3::splat(1.0));
                    let jitter = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
                    let d = signs * (base + 0.3 * jitter * base.max(Vec3::splat(1e-3)));
                    let d = if d == Vec3::ZERO { signs } else { d };
                    let mut r = Ray::new(o, d);
                    if rng.below(3) == 0 {
                        r.t_min = scale * rng.next_f32();
                        r.t_max = r.t_min + 4.0 * scale * rng.next_f32();
                    }
                    r
                })
                .collect();
            let soa = Soa::new(&rays);
            let mut node = WideNode::EMPTY;
            for l in 0..WIDTH {
                if rng.below(8) == 0 {
                    continue;
                }
                // Half the boxes sit on a ray of the packet (ahead of or behind its origin).
                let c = if rng.below(2) == 0 {
                    let r = &rays[rng.below(PACKET as u32) as usize];
                    r.origin + (8.0 * rng.next_f32() - 1.0) * scale * r.dir / r.dir.length()
                } else {
                    centre + 6.0 * scale * rng.in_box(Vec3::splat(-1.0), Vec3::splat(1.0))
                };
                let mut h = scale * Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
                if rng.below(4) == 0 {
                    h[rng.below(3) as usize] = 0.0;
                }
                for a in 0..3 {
                    node.b[a][l] = c[a] - h[a];
                    node.b[3 + a][l] = c[a] + h[a];
                }
                node.child[l] = l as u32;
            }
            // SAFETY: AVX2 was detected above.
            let Some((e, k)) = (unsafe { entered_and_kept(&node, &soa) }) else { continue };
            assert_eq!(e & !k, 0, "lanes {:#010b} entered but dropped: {node:?}, {rays:?}", e & !k);
            packets += 1;
            kept += k.count_ones();
            entered += e.count_ones();
            dropped += (!k & 0xff).count_ones();
        }
        assert!(packets > 15_000 && entered > 20_000 && dropped > 20_000, "{packets} {entered} {kept} {dropped}");
    }
}
