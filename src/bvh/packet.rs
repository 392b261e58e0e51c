//! Leaf triangles of the `fast` traversal in 4-wide structure-of-arrays
//! packets ([`Tri4`]), intersected four at a time with SSE (inside the AVX2
//! traversal) by the watertight test, lane for lane the same operations in the
//! same order as [`crate::geometry::triangle::intersect_watertight`] (separate
//! multiplies and subtractions, no fused multiply-add), so every lane's
//! `t, u, v` are bit-identical to the scalar routine's. Lanes with an edge
//! function whose single-precision sign is uncertain (within
//! `SIGN_MARGIN` error bounds of 0), or a distance not provably positive or
//! whose edge-function error may be too large (`T_SPREAD_MAX`), take the scalar
//! routine, with its double-precision fallback, instead.
//!
//! The vertices are stored, not edges or a normal: the watertight test works
//! on the vertices relative to the ray origin, and any precomputed quantity
//! would change its rounding.

use glam::Vec3;

use crate::geometry::offset::gamma;
use crate::geometry::triangle::{
    E_FLOOR, SIGN_MARGIN, T_ETA, T_SPREAD_MAX, TriangleKernel, WatertightRay, spread_scale,
};
use crate::geometry::{Hit, Ray};

use super::prims::{LeafPrims, watertight};

/// Triangles per packet.
pub const PW: usize = 4;

/// Four triangles in structure-of-arrays form, 160 bytes.
///
/// Unused lanes of a leaf's last packet repeat its last triangle (same id), so
/// they can never change the result and need no mask.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(32))]
pub struct Tri4 {
    /// Row `3 j + a`: coordinate `a` of vertex `j`, one lane per triangle.
    pub v: [[f32; PW]; 9],
    /// Original primitive ids.
    pub id: [u32; PW],
}

const _: () = assert!(std::mem::size_of::<Tri4>() == 160);

impl Tri4 {
    /// Vertex `j` of lane `l`.
    #[inline(always)]
    pub(super) fn vertex(&self, j: usize, l: usize) -> Vec3 {
        Vec3::new(self.v[3 * j][l], self.v[3 * j + 1][l], self.v[3 * j + 2][l])
    }
}

/// A ray's constants for the leaf tests of the `fast` traversal, made once
/// per ray ahead of its first leaf (`wide::shear`): the watertight test's shear and axis
/// permutation, kept as the packet test reads them (the origin on the
/// permuted axes, the shear constants, and the byte offsets of the permuted
/// axes' rows in a [`Tri4`]); the scalar routines' [`WatertightRay`] is
/// rebuilt from them ([`Self::wr`]) on the rare lanes and leaves that need
/// it. A leaf visit then broadcasts each constant from memory as it uses it
/// and stores nothing: made per leaf, the constants took about 55
/// instructions, as many as a third of a packet test, and kept in four lanes
/// each (with a copy of the [`WatertightRay`]) they took 77 per ray to make
/// (callgrind, suzanne incoherent rays).
#[derive(Clone, Copy, Debug)]
#[repr(C)]
pub struct LeafRay {
    /// `origin[kx], origin[ky], origin[kz], sx, sy, -sz` (the lane tests
    /// shear `o - v`, the negated coordinates, see `watertight_lanes!`), then
    /// the ray's [`spread_scale`].
    c: [f32; 7],
    /// Byte offsets of the rows of axes `kx, ky, kz` in a vertex's three
    /// rows of [`Tri4::v`]: `16 k`, each below 48 (made only by [`Self::new`]).
    rows: [usize; 3],
}

impl LeafRay {
    /// A stand-in for tests that take no shear (Moller-Trumbore).
    pub const UNUSED: Self = Self { c: [0.0; 7], rows: [0, 16, 32] };

    /// The leaf constants of `ray` (whose direction must not be the zero vector).
    #[inline]
    pub fn new(ray: &Ray) -> Self {
        let wr = WatertightRay::of(ray.dir.as_ref());
        let o: &[f32; 3] = ray.origin.as_ref();
        let ([kx, ky, kz], s) = (wr.k, wr.s);
        let ro = spread_scale(ray, &wr);
        Self { c: [o[kx], o[ky], o[kz], s.x, s.y, -s.z, ro], rows: wr.k.map(|a| 16 * a) }
    }

    /// The shear for the scalar routines: [`WatertightRay::new`]'s answer for
    /// the ray this was made from (the same permutation and constants, bit
    /// for bit).
    #[inline(always)]
    pub fn wr(&self) -> WatertightRay {
        WatertightRay { k: self.rows.map(|r| r / 16), s: Vec3::new(self.c[3], self.c[4], -self.c[5]) }
    }
}

/// All leaves' triangles packed in packets: a leaf of `n` triangles occupies
/// `ceil(n / 4)` consecutive packets.
#[derive(Clone, Debug, Default)]
pub struct TriPackets {
    /// The packets.
    pub packets: Vec<Tri4>,
}

/// Packet `c` of the leaf of triangles `first .. first + count`, where
/// `tri(k)` gives the vertices and id of leaf slot `k`; lanes past the leaf's
/// end repeat its last triangle.
#[inline]
pub fn leaf_packet(first: u32, count: u32, c: usize, tri: &impl Fn(usize) -> ([Vec3; 3], u32)) -> Tri4 {
    let mut p = std::mem::MaybeUninit::uninit();
    leaf_packet_into(&mut p, first, count, c, tri);
    // SAFETY: `leaf_packet_into` wrote the packet.
    unsafe { p.assume_init() }
}

/// [`leaf_packet`] written into `out`.
#[inline(always)]
fn leaf_packet_into(
    out: &mut std::mem::MaybeUninit<Tri4>,
    first: u32,
    count: u32,
    c: usize,
    tri: &impl Fn(usize) -> ([Vec3; 3], u32),
) {
    let (first, count) = (first as usize, count as usize);
    let p = out.write(Tri4 { v: [[0.0; PW]; 9], id: [0; PW] });
    for l in 0..PW {
        let (v, id) = tri(first + (PW * c + l).min(count - 1));
        for (j, vj) in v.iter().enumerate() {
            for a in 0..3 {
                p.v[3 * j + a][l] = vj[a];
            }
        }
        p.id[l] = id;
    }
}

/// Meshes of at least this many primitives get trees whose leaves are priced
/// as tests of eight triangles ([`leaf_block`]); smaller ones, of four.
///
/// A leaf of five to eight triangles takes one eight-lane test (`tri8_avx`)
/// in the single-ray walks, about what a four-lane one costs, so pricing
/// leaves by eight gives shallower trees with fuller leaves (dragon_87k:
/// 4,077 -> 2,437 wide nodes; incoherent rays 5.11 -> 4.87 node visits and
/// 1.26 -> 1.15 leaf tests). The batch walks test a leaf one triangle
/// against all their rays at a time, where fuller leaves cost more: measured
/// with `rtdiff bench --race 5 --threads 1`, old and new trees alternated,
/// ratios against Embree's default mode, batch shadow rays went 0.89-0.94 ->
/// 0.78-0.79 on suzanne (968 triangles), 1.22-1.23 -> 1.03-1.08 on bunny
/// (3,674), 1.06 -> 0.99 on dragon_res4 (11,102), 1.21 -> 1.20-1.22 on
/// dragon_res3 (47,794), 1.14-1.16 -> 1.14-1.18 on dragon_87k, and whole
/// renders of the Cornell boxes (a few dozen triangles, lit by area lights)
/// lost 10-25%, while single rays gained on every mesh (shadow rays 5-12%).
/// Above this size the batches no longer lose and single rays gain most
/// (dragon_full incoherent 0.963-0.968 -> 1.019-1.020).
pub const WIDE_LEAVES_FROM: usize = 1 << 15;

/// Triangles one leaf test covers in the cost model of a tree over `prims`
/// primitives (the block the SAH builder and the collapse round leaves up
/// to): eight from [`WIDE_LEAVES_FROM`] primitives, else four. Either way the
/// walks test a leaf's packets two at a time.
pub fn leaf_block(prims: usize) -> u32 {
    if prims >= WIDE_LEAVES_FROM { 2 * PW as u32 } else { PW as u32 }
}

/// Packets holding `count` triangles.
#[inline(always)]
pub fn packets_for(count: u32) -> usize {
    (count as usize).div_ceil(PW)
}

impl TriPackets {
    /// Append the triangles `first .. first + count` of `prims` (all
    /// triangles) as packets; returns the index of the first packet.
    pub fn push_leaf(&mut self, prims: &LeafPrims, first: u32, count: u32) -> u32 {
        self.push_leaf_with(first, count, |k| (prims.entries[k].v, prims.entries[k].id))
    }

    /// Append the leaf triangles `first .. first + count`, where `tri(k)`
    /// gives the vertices and id of leaf slot `k`, as packets; returns the
    /// index of the first packet.
    ///
    /// Each packet is made in its slot: pushed, a 160-byte packet was made
    /// on the stack and copied by a call to `memcpy` (2% of suzanne's build
    /// time, `perf record`).
    #[inline]
    pub fn push_leaf_with(&mut self, first: u32, count: u32, tri: impl Fn(usize) -> ([Vec3; 3], u32)) -> u32 {
        let start = self.packets.len();
        let np = packets_for(count);
        self.packets.reserve(np);
        for (c, slot) in self.packets.spare_capacity_mut()[..np].iter_mut().enumerate() {
            leaf_packet_into(slot, first, count, c, &tri);
        }
        // SAFETY: the `np` slots after `start` were reserved above and the loop wrote every one.
        unsafe { self.packets.set_len(start + np) };
        start as u32
    }

    /// Memory held, in bytes.
    pub fn bytes(&self) -> usize {
        self.packets.len() * std::mem::size_of::<Tri4>()
    }

    /// Triangle `k` of the leaf starting at packet `first`: `(vertices, id)`.
    #[inline(always)]
    fn tri(&self, first: u32, k: usize) -> ([Vec3; 3], u32) {
        let p = &self.packets[first as usize + k / PW];
        let l = k % PW;
        ([p.vertex(0, l), p.vertex(1, l), p.vertex(2, l)], p.id[l])
    }

    /// Scalar closest-hit test of a leaf (`count` triangles from packet
    /// `first`) with the triangle test `K`, with [`LeafPrims::intersect_leaf`]'s
    /// tie rule and `t_max` update. Returns true when `best` changed.
    #[inline(always)]
    pub fn intersect_leaf_scalar<K: TriangleKernel>(
        &self,
        first: u32,
        count: u32,
        ray: &mut Ray,
        wr: &WatertightRay,
        best: &mut Option<Hit>,
    ) -> bool {
        let mut changed = false;
        for k in 0..count as usize {
            let ([a, b, c], id) = self.tri(first, k);
            if let Some((t, u, v)) = K::intersect(ray, wr, a, b, c) {
                changed |= offer(best, ray, t, id, u, v);
            }
        }
        changed
    }

    /// Scalar any-hit test of a leaf with the triangle test `K`.
    #[inline(always)]
    pub fn occluded_leaf_scalar<K: TriangleKernel>(
        &self,
        first: u32,
        count: u32,
        ray: &Ray,
        wr: &WatertightRay,
    ) -> bool {
        (0..count as usize).any(|k| {
            let ([a, b, c], _) = self.tri(first, k);
            K::intersect(ray, wr, a, b, c).is_some()
        })
    }

    /// SIMD watertight closest-hit test of a leaf, whose packets are `pks`
    /// (the walk finds them, [`crate::bvh::WideBvh`]); same results as
    /// [`Self::intersect_leaf_scalar`] with the watertight test. Called from
    /// the AVX2 walks only (its packets go two at a time through `tri8_avx`).
    ///
    /// Leaves of at most two packets (every leaf of the SAH builder's trees:
    /// [`crate::bvh::build_sah::SAH_MAX_LEAF`] and the collapse's
    /// [`crate::bvh::collapse::MAX_LEAF`] are eight triangles) take one pair
    /// test without the loop over pairs (its set-up: the slice's chunk
    /// arithmetic and the registers saved around the loop; an empty leaf
    /// takes the loop, which tests nothing). Callgrind, 20,000
    /// rays through `examples/call_path.rs`, with the any-hit form alike:
    /// suzanne incoherent 14.02M -> 13.55M instructions, shadow 18.19M ->
    /// 17.56M; dragon_87k primary 21.20M -> 20.16M, shadow 26.99M -> 26.12M
    /// (`offer_lanes`, added after, moved these by under 1%).
    /// `rtdiff bench --race 5 --threads 1`, alternated binaries, against
    /// Embree's default mode: suzanne incoherent 0.943-0.944 -> 0.951-0.969,
    /// shadow 0.996-1.008 -> 1.013-1.016; dragon_87k primary 0.879-1.006 ->
    /// 1.023-1.033, incoherent 1.004-1.072 -> 1.071-1.098, shadow
    /// 1.116-1.148 -> 1.144-1.163.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    pub fn intersect_leaf_simd(pks: &[Tri4], ray: &mut Ray, lr: &LeafRay, best: &mut Option<Hit>) -> bool {
        if matches!(pks.len(), 1 | 2) {
            return closest_pair(&pks[0], pks.get(1), ray, lr, best);
        }
        let mut changed = false;
        for pq in pks.chunks(2) {
            changed |= closest_pair(&pq[0], pq.get(1), ray, lr, best);
        }
        changed
    }

    /// The any-hit test of two leaves of at most four triangles each, packets
    /// `a` and `b` (anywhere in the array), in one eight-lane test (from the
    /// AVX2 any-hit walk only: `WideBvh::two_leaves_any`).
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    pub fn occluded_two_leaves_simd(a: &Tri4, b: &Tri4, ray: &Ray, lr: &LeafRay) -> bool {
        occluded_pair(a, Some(b), ray, lr)
    }

    /// SIMD watertight any-hit test of a leaf of packets `pks` (from the AVX2
    /// walks only; one pair test for leaves of at most two packets, as in
    /// [`Self::intersect_leaf_simd`]).
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    pub fn occluded_leaf_simd(pks: &[Tri4], ray: &Ray, lr: &LeafRay) -> bool {
        if matches!(pks.len(), 1 | 2) {
            return occluded_pair(&pks[0], pks.get(1), ray, lr);
        }
        // (A loop, not `Iterator::any`: the closure of `any` was compiled
        // apart from the AVX2 walk, and the eight-lane test in it with calls
        // for its intrinsics.)
        for pq in pks.chunks(2) {
            if occluded_pair(&pq[0], pq.get(1), ray, lr) {
                return true;
            }
        }
        false
    }

    /// SIMD Moller-Trumbore closest-hit test of a leaf of packets `pks`; same results as
    /// [`Self::intersect_leaf_scalar`] with the Moller-Trumbore test (lane
    /// for lane the scalar routine's operations).
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    pub fn intersect_leaf_simd_mt(pks: &[Tri4], ray: &mut Ray, best: &mut Option<Hit>) -> bool {
        // (Unlike the watertight test's, this loop keeps no one-pair form:
        // written as in `intersect_leaf_simd` it took more instructions,
        // callgrind, 20,000 rays: suzanne incoherent 11.86M -> 13.61M.)
        let mut changed = false;
        for pq in pks.chunks(2) {
            let (ok, rows) = moller_trumbore_pair(pq, ray);
            changed |= offer_lanes(ok, |i| &pq[i], &rows, ray, best);
        }
        changed
    }

    /// SIMD Moller-Trumbore any-hit test of a leaf of packets `pks` (from the AVX2 walks only).
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    pub fn occluded_leaf_simd_mt(pks: &[Tri4], ray: &Ray) -> bool {
        if matches!(pks.len(), 1 | 2) {
            return moller_trumbore_pair(pks, ray).0 != 0;
        }
        pks.chunks(2).any(|pq| moller_trumbore_pair(pq, ray).0 != 0)
    }
}

/// Offer hit `(t, id, u, v)` (already within `ray`'s interval) under the
/// shared tie rule [`Hit::offer`].
#[inline(always)]
fn offer(best: &mut Option<Hit>, ray: &mut Ray, t: f32, id: u32, u: f32, v: f32) -> bool {
    Hit::offer(best, ray, Hit { t, prim: id, u, v })
}

/// The watertight test's arithmetic on a vector of lanes (four or eight), one
/// triangle per lane, written once for [`tri4_sse`] and [`tri8_avx`]: `$v`
/// is the vector type, `$ld(j, axis)` loads row `axis` of vertex `j` on the
/// permuted axes, `$lane(i)` broadcasts lane row `i` of the [`LeafRay`], and
/// the remaining arguments are the vector width's intrinsics. Evaluates to
/// `(hit mask, uncertain mask, t, u, v)` (see [`tri4_sse`]); returns early
/// from the enclosing function when no lane is a hit.
#[cfg(target_arch = "x86_64")]
macro_rules! watertight_lanes {
    ($v:ty, $ld:ident, $lane:ident, $ray:expr; $sub:path, $mul:path, $add:path, $max:path, $min:path,
     $andnot:path, $or:path, $xor:path, $and:path, $div:path, $set1:path, $zero:path, $ngt:path, $ge:path,
     $le:path, $gt:path, $movemask:path) => {{
        let (ox, oy, oz) = ($lane(0), $lane(1), $lane(2));
        // `nsz` is `-sz` ([`LeafRay`]).
        let (sx, sy, nsz) = ($lane(3), $lane(4), $lane(5));
        // The negated coordinates `o - v0, o - v1, o - v2` on the permuted
        // axes (the vertex row is then the subtraction's memory operand, not
        // a load of its own: nine instructions fewer per 4-lane test). Their
        // bits are those of the scalar routine's `v - o` with the sign
        // flipped (rounding to nearest is symmetric), and so are the sheared
        // `ax .. cy` below (`fl(-p - s (-q)) = -fl(p - s q)`): the edge
        // functions, products of two of them, come out bit for bit the
        // scalar routine's, and `nsz * (o - v)[z]` its `sz * (v - o)[z]`.
        // The error bounds take magnitudes only.
        let (a_x, a_y, a_z) = ($sub(ox, $ld(0, 0)), $sub(oy, $ld(0, 1)), $sub(oz, $ld(0, 2)));
        let (b_x, b_y, b_z) = ($sub(ox, $ld(1, 0)), $sub(oy, $ld(1, 1)), $sub(oz, $ld(1, 2)));
        let (c_x, c_y, c_z) = ($sub(ox, $ld(2, 0)), $sub(oy, $ld(2, 1)), $sub(oz, $ld(2, 2)));
        let ax = $sub(a_x, $mul(sx, a_z));
        let ay = $sub(a_y, $mul(sy, a_z));
        let bx = $sub(b_x, $mul(sx, b_z));
        let by = $sub(b_y, $mul(sy, b_z));
        let cx = $sub(c_x, $mul(sx, c_z));
        let cy = $sub(c_y, $mul(sy, c_z));
        let e0 = $sub($mul(cx, by), $mul(cy, bx));
        let e1 = $sub($mul(ax, cy), $mul(ay, cx));
        let e2 = $sub($mul(bx, ay), $mul(by, ax));
        let az = $mul(nsz, a_z);
        let bz = $mul(nsz, b_z);
        let cz = $mul(nsz, c_z);
        // The edge functions' error bound (`watertight_e_error`, same operation order).
        let sign = $set1(-0.0);
        let abs = |x: $v| $andnot(sign, x);
        // Operands are non-negative (no -0); a NaN lane fails every comparison below and is never a hit.
        let max3 = |x: $v, y: $v, w: $v| $max($max(abs(x), abs(y)), abs(w));
        let (max_xt, max_yt, max_zt) = (max3(ax, bx, cx), max3(ay, by, cy), max3(az, bz, cz));
        let (g2, g3, g5) = ($set1(gamma(2)), $set1(gamma(3)), $set1(gamma(5)));
        let delta_x = $mul(g5, $add(max_xt, max_zt));
        let delta_y = $mul(g5, $add(max_yt, max_zt));
        let delta_e =
            $mul($set1(2.0), $add($add($mul($mul(g2, max_xt), max_yt), $mul(delta_y, max_xt)), $mul(delta_x, max_yt)));
        // Lanes with an edge function within SIGN_MARGIN bounds of 0 (or a
        // NaN bound or minimum): uncertain sign, decided by the scalar routine.
        let min_e = $min($min(abs(e0), abs(e1)), abs(e2));
        // `E_FLOOR` first: `max` passes a NaN bound on (its second operand).
        let uncertain = $ngt(min_e, $max($set1(E_FLOOR), $mul($set1(SIGN_MARGIN), delta_e)));
        // In the other lanes, if no edge function is NaN, `min_e` is their
        // least magnitude and exceeds a bound >= 0, so all are nonzero and
        // "some negative and some positive" is "the sign bits differ"; a NaN
        // one (which `$min` may pass over) makes det and t NaN, which
        // no range admits, as in the scalar routine. Only the sign bit of
        // `mixed` is meaningful.
        let mixed = $or($xor(e0, e1), $xor(e0, e2));
        let det = $add($add(e0, e1), e2);
        let t_scaled = $add($add($mul(e0, az), $mul(e1, bz)), $mul(e2, cz));
        let inv_det = $div($set1(1.0), det);
        let t = $mul(t_scaled, inv_det);
        // Ordered comparisons: a NaN t fails both, as `!(t >= t_min)` and `!(t <= t_max)` reject it.
        // Sign bits only from here on (movemask reads nothing else).
        let past_min = $andnot($or(mixed, uncertain), $ge(t, $set1($ray.t_min)));
        let zero_mask = $movemask(uncertain) as u32;
        if $movemask(past_min) == 0 {
            // Most packets are missed: skip the t error bounds.
            let z = $zero();
            return (0, zero_mask, z, z, z);
        }
        // The edge functions' share of t's error against the parity bound
        // (`watertight_t_imprecise`, same operation order), before `t_max` as in the scalar
        // routine: lanes where it may be too large go to the scalar routine.
        let spread = $add($add(abs($sub(az, t)), abs($sub(bz, t))), abs($sub(cz, t)));
        let allowed = $mul($mul($set1(T_SPREAD_MAX), $max($lane(6), t)), abs(det));
        let imprecise = $and($gt($mul(delta_e, spread), allowed), past_min);
        let zero_mask = zero_mask | $movemask(imprecise) as u32;
        let ok = $andnot(imprecise, $and(past_min, $le(t, $set1($ray.t_max))));
        if $movemask(ok) == 0 {
            let z = $zero();
            return (0, zero_mask, z, z, z);
        }
        // The provably-positive-t check of `watertight_t_error` (pbrt-v4 6.8.7), same operation order.
        let delta_z = $mul(g3, max_zt);
        let max_e = max3(e0, e1, e2);
        let t_err = $mul(
            $mul(
                $set1(3.0),
                $add(
                    $add($add($mul($mul(g3, max_e), max_zt), $mul(delta_e, max_zt)), $mul(delta_z, max_e)),
                    $set1(T_ETA),
                ),
            ),
            abs(inv_det),
        );
        // Lanes whose distance is not provably positive go to the scalar routine too.
        let not_positive = $and($le(t, t_err), ok);
        let ok = $andnot(not_positive, ok);
        let zero_mask = zero_mask | $movemask(not_positive) as u32;
        ($movemask(ok) as u32, zero_mask, t, $mul(e1, inv_det), $mul(e2, inv_det))
    }};
}

/// The watertight test on four lanes: `(hit mask, uncertain mask, t, u, v)`.
/// Lanes in the uncertain mask (some edge function within `SIGN_MARGIN`
/// error bounds of 0 in single precision, or a distance in range that is not
/// provably positive or may be imprecise beyond `T_SPREAD_MAX`) are excluded from the hit mask and must be decided by
/// the scalar routine. `t, u, v` are meaningful only in hit lanes (zero when
/// there are none).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn tri4_sse(
    p: &Tri4,
    ray: &Ray,
    lr: &LeafRay,
) -> (u32, u32, std::arch::x86_64::__m128, std::arch::x86_64::__m128, std::arch::x86_64::__m128) {
    use std::arch::x86_64::*;
    // SAFETY: SSE and SSE2 are part of the x86_64 baseline, so these intrinsics are
    // available on every x86_64 CPU; the assembly is empty; the loads are justified
    // where they occur.
    unsafe {
        // An empty instruction (a comment) that may write `lr` as far as the
        // compiler knows, so it reads the ray's constants where they are used,
        // as memory operands, instead of copying them into spill slots at each
        // leaf (they cannot stay in registers beside the walk's): 13.82M ->
        // 13.20M instructions per 20,000 suzanne incoherent rays (callgrind).
        std::arch::asm!("/* {0} */", in(reg) lr, options(nostack, preserves_flags));
        // Row `axis` of vertex `j`: `lr.rows[axis]` is below 48 (`LeafRay::new`), so
        // the row is one of the packet's nine 16-byte rows, at a 16-byte multiple
        // inside the 32-byte aligned packet: an aligned load in bounds.
        let base = p.v.as_ptr().cast::<u8>();
        let ld = |j: usize, axis: usize| _mm_load_ps(base.add(48 * j + lr.rows[axis]).cast::<f32>());
        // Constant `i` in every lane (a broadcast from memory inside the AVX2 walks).
        let lane = |i: usize| _mm_set1_ps(lr.c[i]);
        watertight_lanes!(__m128, ld, lane, ray; _mm_sub_ps, _mm_mul_ps, _mm_add_ps, _mm_max_ps, _mm_min_ps,
            _mm_andnot_ps, _mm_or_ps, _mm_xor_ps, _mm_and_ps, _mm_div_ps, _mm_set1_ps, _mm_setzero_ps,
            _mm_cmpngt_ps, _mm_cmpge_ps, _mm_cmple_ps, _mm_cmpgt_ps, _mm_movemask_ps)
    }
}

/// [`tri4_sse`] on eight lanes: packet `p` in lanes 0-3 and packet `q` in
/// lanes 4-7, the same operations lane for lane (so, as there, every decided
/// lane is the scalar routine's answer bit for bit). A leaf of five to eight
/// triangles takes one such test instead of two four-lane ones.
///
/// Expanded into its callers, as [`tri4_sse`] (a function compiled for AVX2
/// of its own may not be, and the walks called it: the call, its arguments
/// and results through memory, and every per-ray constant reloaded after
/// it). `rtdiff bench --race 3 --threads 1 --rtdiff-isa avx2
/// --embree-max-isa avx2`, alternated binaries (two pairs), dragon_87k
/// (leaves of up to eight triangles) against Embree's default mode:
/// incoherent 0.918 / 0.915 -> 0.934 / 0.932, camera 1.020 / 1.040 -> 1.066
/// / 1.055; suzanne (`--race 5`) incoherent 0.918 / 0.920 -> 0.927 / 0.929.
///
/// # Safety
/// The CPU must have AVX2 (it runs inside the AVX2 walks only, whose
/// instruction set its intrinsics then take).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn tri8_avx(
    p: &Tri4,
    q: &Tri4,
    ray: &Ray,
    lr: &LeafRay,
) -> (u32, u32, std::arch::x86_64::__m256, std::arch::x86_64::__m256, std::arch::x86_64::__m256) {
    use std::arch::x86_64::*;
    // SAFETY: the caller guarantees AVX2; the assembly is empty; the loads are
    // justified where they occur.
    unsafe {
        // As in `tri4_sse`: the ray's constants are read where they are used.
        std::arch::asm!("/* {0} */", in(reg) lr, options(nostack, preserves_flags));
        let (bp, bq) = (p.v.as_ptr().cast::<u8>(), q.v.as_ptr().cast::<u8>());
        // The same row of both packets (aligned in-bounds loads, as in
        // `tri4_sse`), `p`'s in the low half and `q`'s in the high half.
        let ld = |j: usize, axis: usize| {
            let off = 48 * j + lr.rows[axis];
            _mm256_insertf128_ps::<1>(
                _mm256_castps128_ps256(_mm_load_ps(bp.add(off).cast::<f32>())),
                _mm_load_ps(bq.add(off).cast::<f32>()),
            )
        };
        // Constant `i` in every lane (a broadcast from memory).
        let lane = |i: usize| _mm256_set1_ps(lr.c[i]);
        watertight_lanes!(__m256, ld, lane, ray; _mm256_sub_ps, _mm256_mul_ps, _mm256_add_ps, _mm256_max_ps,
            _mm256_min_ps, _mm256_andnot_ps, _mm256_or_ps, _mm256_xor_ps, _mm256_and_ps, _mm256_div_ps,
            _mm256_set1_ps, _mm256_setzero_ps, _mm256_cmp_ps::<_CMP_NGT_UQ>, _mm256_cmp_ps::<_CMP_GE_OQ>,
            _mm256_cmp_ps::<_CMP_LE_OQ>, _mm256_cmp_ps::<_CMP_GT_OQ>, _mm256_movemask_ps)
    }
}

/// The closest-hit test of packet `p` and, when given, packet `q` (see
/// [`TriPackets::intersect_leaf_simd`]): hits offered to `best`, uncertain
/// lanes decided by the scalar routine. Returns true when `best` changed.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn closest_pair(p: &Tri4, q: Option<&Tri4>, ray: &mut Ray, lr: &LeafRay, best: &mut Option<Hit>) -> bool {
    let mut changed = false;
    let (ok, mut zero, rows) = watertight_pair(p, q, ray, lr);
    // Lanes 4-7 exist only with `q`.
    let pk = |i: usize| if i == 0 { p } else { q.unwrap_or(p) };
    while zero != 0 {
        let l = zero.trailing_zeros() as usize;
        zero &= zero - 1;
        let (p, k) = (pk(l / PW), l % PW);
        if let Some((t, u, v)) = watertight(ray, &lr.wr(), p.vertex(0, k), p.vertex(1, k), p.vertex(2, k)) {
            changed |= offer(best, ray, t, p.id[k], u, v);
        }
    }
    changed |= offer_lanes(ok, pk, &rows, ray, best);
    changed
}

/// Offer the hits of lanes `ok` (`rows`: their `t, u, v`; `pk(i)`: the packet of lanes `4 i .. 4 i + 4`)
/// under [`Hit::offer`]'s tie rule.
#[inline(always)]
fn offer_lanes<'a>(
    mut ok: u32,
    pk: impl Fn(usize) -> &'a Tri4,
    rows: &[[f32; 2 * PW]; 3],
    ray: &mut Ray,
    best: &mut Option<Hit>,
) -> bool {
    let mut changed = false;
    while ok != 0 {
        let l = ok.trailing_zeros() as usize;
        ok &= ok - 1;
        changed |= offer(best, ray, rows[0][l], pk(l / PW).id[l % PW], rows[1][l], rows[2][l]);
    }
    changed
}

/// The any-hit test of packet `p` and, when given, packet `q` (see
/// [`TriPackets::occluded_leaf_simd`]).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn occluded_pair(p: &Tri4, q: Option<&Tri4>, ray: &Ray, lr: &LeafRay) -> bool {
    let (ok, mut zero, _) = watertight_pair(p, q, ray, lr);
    if ok != 0 {
        return true;
    }
    let pk = |i: usize| if i == 0 { p } else { q.unwrap_or(p) };
    while zero != 0 {
        let l = zero.trailing_zeros() as usize;
        zero &= zero - 1;
        let (p, k) = (pk(l / PW), l % PW);
        if watertight(ray, &lr.wr(), p.vertex(0, k), p.vertex(1, k), p.vertex(2, k)).is_some() {
            return true;
        }
    }
    false
}

/// The watertight test of packet `p` and, when given, packet `q` (lanes 0-3:
/// `p`, lanes 4-7: `q`): `(hit mask, uncertain mask, [t, u, v])`,
/// the rows written only when some lane is a hit. Inside the AVX2 walks only.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn watertight_pair(p: &Tri4, q: Option<&Tri4>, ray: &Ray, lr: &LeafRay) -> (u32, u32, [[f32; 2 * PW]; 3]) {
    use std::arch::x86_64::*;
    let mut rows = [[0.0f32; 2 * PW]; 3];
    if let Some(q) = q {
        // SAFETY: the callers run inside the AVX2 walks, on CPUs with AVX2.
        let (ok, zero, t, u, v) = unsafe { tri8_avx(p, q, ray, lr) };
        if ok != 0 {
            for (row, x) in rows.iter_mut().zip([t, u, v]) {
                // SAFETY: each row holds 8 floats; storeu has no alignment requirement.
                unsafe { _mm256_storeu_ps(row.as_mut_ptr(), x) };
            }
        }
        return (ok, zero, rows);
    }
    let (ok, zero, t, u, v) = tri4_sse(p, ray, lr);
    if ok != 0 {
        for (row, x) in rows.iter_mut().zip([t, u, v]) {
            // SAFETY: SSE is part of the x86_64 baseline; each row holds at least 4 floats.
            unsafe { _mm_storeu_ps(row.as_mut_ptr(), x) };
        }
    }
    (ok, zero, rows)
}

/// The Moller-Trumbore test's arithmetic on a vector of `$n` lanes (four or
/// eight), written once for [`tri4_mt_sse`] and [`tri8_mt_avx`]: `$v` is the
/// vector type, `$ld(r)` loads row `r` of the packets' vertex rows, and the
/// remaining arguments are the vector width's intrinsics. Evaluates to
/// `(hit mask, t, u, v)` (see [`tri4_mt_sse`]); returns early from the
/// enclosing function when no lane can be a hit.
#[cfg(target_arch = "x86_64")]
macro_rules! moller_trumbore_lanes {
    ($v:ty, $n:expr, $ld:ident, $ray:expr; $sub:path, $mul:path, $add:path, $andnot:path, $or:path, $and:path,
     $div:path, $set1:path, $zero:path, $gt:path, $lt:path, $ge:path, $le:path, $movemask:path, $store:path) => {{
        let (o, d) = ($ray.origin.to_array(), $ray.dir.to_array());
        let (dx, dy, dz) = ($set1(d[0]), $set1(d[1]), $set1(d[2]));
        let (v0x, v0y, v0z) = ($ld(0), $ld(1), $ld(2));
        // e1 = v1 - v0, e2 = v2 - v0.
        let (e1x, e1y, e1z) = ($sub($ld(3), v0x), $sub($ld(4), v0y), $sub($ld(5), v0z));
        let (e2x, e2y, e2z) = ($sub($ld(6), v0x), $sub($ld(7), v0y), $sub($ld(8), v0z));
        let dot = |ax: $v, ay: $v, az: $v, bx: $v, by: $v, bz: $v| $add($add($mul(ax, bx), $mul(ay, by)), $mul(az, bz));
        // p = dir x e2 (glam: x = a.y b.z - b.y a.z, y = a.z b.x - b.z a.x, z = a.x b.y - b.x a.y).
        let px = $sub($mul(dy, e2z), $mul(e2y, dz));
        let py = $sub($mul(dz, e2x), $mul(e2z, dx));
        let pz = $sub($mul(dx, e2y), $mul(e2x, dy));
        let det = dot(e1x, e1y, e1z, px, py, pz);
        let (zero, one) = ($zero(), $set1(1.0));
        // `det == 0 || !det.is_finite()` rejects: keep 0 < |det| < inf (a NaN fails both).
        let abs_det = $andnot($set1(-0.0), det);
        let det_ok = $and($gt(abs_det, zero), $lt(abs_det, $set1(f32::INFINITY)));
        let inv_det = $div(one, det);
        // tv = origin - v0.
        let (tvx, tvy, tvz) = ($sub($set1(o[0]), v0x), $sub($set1(o[1]), v0y), $sub($set1(o[2]), v0z));
        let u = $mul(dot(tvx, tvy, tvz, px, py, pz), inv_det);
        // `(0.0..=1.0).contains(&u)`: ordered comparisons, a NaN fails.
        let ok = $and(det_ok, $and($ge(u, zero), $le(u, one)));
        if $movemask(ok) == 0 {
            // Most packets are missed here: skip the second cross product and the stores.
            return (0, [0.0; $n], [0.0; $n], [0.0; $n]);
        }
        // q = tv x e1.
        let qx = $sub($mul(tvy, e1z), $mul(e1y, tvz));
        let qy = $sub($mul(tvz, e1x), $mul(e1z, tvx));
        let qz = $sub($mul(tvx, e1y), $mul(e1x, tvy));
        let v = $mul(dot(dx, dy, dz, qx, qy, qz), inv_det);
        let v_out = $or($lt(v, zero), $gt($add(u, v), one));
        let t = $mul(dot(e2x, e2y, e2z, qx, qy, qz), inv_det);
        // `!(t >= t_min && t <= t_max)` rejects: ordered comparisons, a NaN t fails.
        let in_range = $and($ge(t, $set1($ray.t_min)), $le(t, $set1($ray.t_max)));
        let ok = $andnot(v_out, $and(ok, in_range));
        let (mut ts, mut us, mut vs) = ([0.0f32; $n], [0.0f32; $n], [0.0f32; $n]);
        // Each array has room for the vector's floats; storeu has no alignment requirement.
        $store(ts.as_mut_ptr(), t);
        $store(us.as_mut_ptr(), u);
        $store(vs.as_mut_ptr(), v);
        ($movemask(ok) as u32, ts, us, vs)
    }};
}

/// The Moller-Trumbore test on four lanes: `(hit mask, t, u, v)`, lane for
/// lane the operations of
/// [`crate::geometry::triangle::intersect_moller_trumbore`] in the same order
/// (glam's `cross` and `dot` written out: `dot` is `(x x' + y y') + z z'`,
/// no fused multiply-add), so every lane's answer is the scalar routine's bit
/// for bit; its rejections are the same comparisons, with NaN going the same
/// way (a NaN `v` passes `v < 0 || u + v > 1`, as there).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn tri4_mt_sse(p: &Tri4, ray: &Ray) -> (u32, [f32; PW], [f32; PW], [f32; PW]) {
    use std::arch::x86_64::*;
    // SAFETY: SSE and SSE2 are part of the x86_64 baseline, so these intrinsics are
    // available on every x86_64 CPU; the loads and stores are justified where they occur.
    unsafe {
        // Each row is 16 bytes at a 16-byte multiple inside a 32-byte aligned packet: aligned loads are valid.
        let ld = |r: usize| _mm_load_ps(p.v[r].as_ptr());
        moller_trumbore_lanes!(__m128, PW, ld, ray; _mm_sub_ps, _mm_mul_ps, _mm_add_ps, _mm_andnot_ps, _mm_or_ps,
            _mm_and_ps, _mm_div_ps, _mm_set1_ps, _mm_setzero_ps, _mm_cmpgt_ps, _mm_cmplt_ps, _mm_cmpge_ps,
            _mm_cmple_ps, _mm_movemask_ps, _mm_storeu_ps)
    }
}

/// [`tri4_mt_sse`] on eight lanes: packet `p` in lanes 0-3 and packet `q` in
/// lanes 4-7, the same operations lane for lane.
///
/// # Safety
/// The CPU must have AVX2 (it runs inside the AVX2 walks only).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
unsafe fn tri8_mt_avx(p: &Tri4, q: &Tri4, ray: &Ray) -> (u32, [f32; 2 * PW], [f32; 2 * PW], [f32; 2 * PW]) {
    use std::arch::x86_64::*;
    // SAFETY: the caller guarantees AVX2; the loads and stores are justified where they occur.
    unsafe {
        // Row `r` of both packets (16-byte rows at 16-byte multiples inside
        // 32-byte aligned packets: aligned loads), `p`'s in the low half.
        let ld = |r: usize| {
            _mm256_insertf128_ps::<1>(
                _mm256_castps128_ps256(_mm_load_ps(p.v[r].as_ptr())),
                _mm_load_ps(q.v[r].as_ptr()),
            )
        };
        moller_trumbore_lanes!(__m256, 2 * PW, ld, ray; _mm256_sub_ps, _mm256_mul_ps, _mm256_add_ps, _mm256_andnot_ps,
            _mm256_or_ps, _mm256_and_ps, _mm256_div_ps, _mm256_set1_ps, _mm256_setzero_ps,
            _mm256_cmp_ps::<_CMP_GT_OQ>, _mm256_cmp_ps::<_CMP_LT_OQ>, _mm256_cmp_ps::<_CMP_GE_OQ>,
            _mm256_cmp_ps::<_CMP_LE_OQ>, _mm256_movemask_ps, _mm256_storeu_ps)
    }
}

/// The Moller-Trumbore test of one or two consecutive packets `pq` (lanes
/// 0-3: `pq[0]`, lanes 4-7: `pq[1]`): `(hit mask, [t, u, v])`. Inside the
/// AVX2 walks only.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn moller_trumbore_pair(pq: &[Tri4], ray: &Ray) -> (u32, [[f32; 2 * PW]; 3]) {
    if let [p, q] = pq {
        // SAFETY: the callers run inside the AVX2 walks, on CPUs with AVX2.
        let (ok, t, u, v) = unsafe { tri8_mt_avx(p, q, ray) };
        return (ok, [t, u, v]);
    }
    let (ok, t, u, v) = tri4_mt_sse(&pq[0], ray);
    let wide = |x: [f32; PW]| std::array::from_fn(|l| if l < PW { x[l] } else { 0.0 });
    (ok, [wide(t), wide(u), wide(v)])
}

#[cfg(all(test, target_arch = "x86_64"))]
mod tests {
    use super::*;
    use crate::geometry::triangle::intersect_moller_trumbore;
    use crate::rng::Pcg32;

    /// A coordinate that is now and then special (0, -0, subnormal, huge,
    /// infinite, NaN or 1) and otherwise uniform in [-1, 1).
    fn coord(rng: &mut Pcg32) -> f32 {
        match rng.below(48) {
            0 => 0.0,
            1 => -0.0,
            2 => f32::MIN_POSITIVE * rng.next_f32(),
            3 => 1e30 * (rng.next_f32() - 0.5),
            4 => f32::INFINITY,
            5 => f32::NAN,
            6 => 1.0,
            _ => 2.0 * rng.next_f32() - 1.0,
        }
    }

    /// A packet of random triangles (lanes share vertices now and then, as a
    /// mesh's neighbours do) and a ray now and then aimed at (or just beside)
    /// one lane's triangle, with a finite interval now and then.
    fn packet_and_ray(rng: &mut Pcg32) -> (Tri4, Ray) {
        let mut p = Tri4 { v: [[0.0; PW]; 9], id: [0, 1, 2, 3] };
        for l in 0..PW {
            for r in 0..9 {
                p.v[r][l] = if l > 0 && rng.below(4) == 0 { p.v[r][l - 1] } else { coord(rng) };
            }
        }
        let v3 = |a: f32, b: f32, c: f32| glam::Vec3::new(a, b, c);
        let origin = v3(coord(rng), coord(rng), coord(rng));
        let mut dir = v3(coord(rng), coord(rng), coord(rng));
        if rng.below(2) == 0 {
            // Aim at (or just beside) one lane's triangle: hits, edges and vertices.
            let l = rng.below(PW as u32) as usize;
            let (a, b) = (1.2 * rng.next_f32() - 0.1, 1.2 * rng.next_f32() - 0.1);
            let (v0, v1, v2) = (p.vertex(0, l), p.vertex(1, l), p.vertex(2, l));
            dir = v0 + a * (v1 - v0) + b * (v2 - v0) - origin;
        }
        let mut ray = Ray::new(origin, dir);
        if rng.below(4) == 0 {
            ray.t_min = rng.next_f32();
            ray.t_max = ray.t_min + 4.0 * rng.next_f32();
        }
        (p, ray)
    }

    #[test]
    fn leaf_ray_keeps_the_scalar_shear() {
        // `LeafRay::wr` (what the uncertain lanes and the scalar leaves use)
        // is `WatertightRay::new` bit for bit, and the packet test's
        // constants are the origin on its axes and its shear (`sz` negated): directions with
        // ties between the largest components, signed zeros, every octant.
        let mut rng = Pcg32::new(0x4c52, 1);
        let picks = [0.0, -0.0, 1.0, -1.0, 0.5, -0.5, 1e-30, -3e20];
        let mut dirs: Vec<Vec3> = Vec::new();
        for &x in &picks {
            for &y in &picks {
                for &z in &picks {
                    dirs.push(Vec3::new(x, y, z));
                }
            }
        }
        dirs.extend((0..10_000).map(|_| Vec3::new(coord(&mut rng), coord(&mut rng), coord(&mut rng))));
        let mut checked = 0;
        for d in dirs {
            if d == Vec3::ZERO || !d.is_finite() {
                continue;
            }
            let origin = Vec3::new(coord(&mut rng), 2.0, -3.5);
            let ray = Ray::new(origin, d);
            let (lr, wr) = (LeafRay::new(&ray), WatertightRay::new(d));
            let got = lr.wr();
            assert_eq!(got.k, wr.k, "{d:?}");
            assert_eq!(got.s.to_array().map(f32::to_bits), wr.s.to_array().map(f32::to_bits), "{d:?}");
            let o = origin.to_array();
            let ro = origin.abs().max_element() * wr.s.z.abs();
            let expect = [o[wr.k[0]], o[wr.k[1]], o[wr.k[2]], wr.s.x, wr.s.y, -wr.s.z, ro];
            assert_eq!(lr.c.map(f32::to_bits), expect.map(f32::to_bits), "{d:?}");
            assert_eq!(lr.rows, wr.k.map(|a| 16 * a), "{d:?}");
            checked += 1;
        }
        assert!(checked > 9_000, "{checked} directions checked");
    }

    /// A leaf of no triangles tests nothing and reports nothing (the one-pair
    /// form of the SIMD leaf tests is for leaves of one or two packets only).
    #[test]
    fn an_empty_leaf_has_no_hit() {
        let mut pk = TriPackets { packets: Vec::new() };
        let tri = |_: usize| ([glam::Vec3::new(-1.0, -1.0, 1.0), glam::Vec3::new(1.0, -1.0, 1.0), glam::Vec3::Y], 0);
        pk.push_leaf_with(0, 1, tri);
        let mut ray = Ray::new(glam::Vec3::ZERO, glam::Vec3::Z);
        let lr = LeafRay::new(&ray);
        let mut best = None;
        // The triangle is in the way: the one-triangle leaf hits it (scalar, so any CPU runs this).
        assert!(pk.intersect_leaf_scalar::<crate::geometry::triangle::Watertight>(
            0,
            1,
            &mut ray.clone(),
            &lr.wr(),
            &mut best
        ));
        best = None;
        assert!(!TriPackets::intersect_leaf_simd(&pk.packets[..0], &mut ray, &lr, &mut best));
        assert!(best.is_none());
        assert!(!TriPackets::occluded_leaf_simd(&pk.packets[..0], &ray, &lr));
        assert!(!TriPackets::occluded_leaf_simd_mt(&pk.packets[..0], &ray));
    }

    #[test]
    fn watertight_lanes_are_the_scalar_routine() {
        // Every lane the SIMD test decides (hit or miss) is the scalar
        // routine's answer bit for bit, on every axis permutation of
        // `LeafRay`; the uncertain lanes are left to that routine. Both
        // widths the walks use: one packet (`tri4_sse`) and, on CPUs with
        // AVX2, two at once (`tri8_avx`), through `watertight_pair` as the
        // leaf tests call it.
        let widths: &[usize] = if is_x86_feature_detected!("avx2") { &[1, 2] } else { &[1] };
        for &n in widths {
            let mut rng = Pcg32::new(0x5754, 3 + n as u64);
            let (mut hits, mut cases, mut uncertain, mut decided_hits) = (0, 0, 0, 0);
            for _ in 0..50_000 {
                let (p, ray) = packet_and_ray(&mut rng);
                // The second packet's lanes: other random triangles, or the
                // first packet's lanes permuted (the ray aims at one of them).
                let (q, _) = packet_and_ray(&mut rng);
                let q = if rng.below(2) == 0 {
                    q
                } else {
                    let mut r = p;
                    for row in &mut r.v {
                        row.rotate_left(1 + rng.below(3) as usize);
                    }
                    r
                };
                if ray.dir == glam::Vec3::ZERO || !ray.dir.is_finite() {
                    continue;
                }
                let lr = LeafRay::new(&ray);
                let pq = [p, q];
                let (mask, unc, [ts, us, vs]) = watertight_pair(&pq[0], pq[..n].get(1), &ray, &lr);
                assert_eq!(mask & unc, 0, "a lane both hit and uncertain");
                assert_eq!((mask | unc) >> (PW * n), 0, "a lane past the packets");
                for l in 0..PW * n {
                    let t = &pq[l / PW];
                    let k = l % PW;
                    // The scalar routine with its own constants, not the LeafRay's.
                    let wr = WatertightRay::new(ray.dir);
                    let scalar = watertight(&ray, &wr, t.vertex(0, k), t.vertex(1, k), t.vertex(2, k));
                    cases += 1;
                    hits += usize::from(scalar.is_some());
                    if unc >> l & 1 != 0 {
                        uncertain += 1;
                        continue;
                    }
                    let simd = (mask >> l & 1 != 0).then(|| (ts[l], us[l], vs[l]));
                    let bits = |h: Option<(f32, f32, f32)>| h.map(|(a, b, c)| (a.to_bits(), b.to_bits(), c.to_bits()));
                    assert_eq!(bits(simd), bits(scalar), "lane {l} of {pq:?}, {ray:?}");
                    decided_hits += usize::from(simd.is_some());
                }
            }
            // The check means something only if the SIMD test itself decides
            // many lanes and many hits. (The special coordinates, zeros,
            // infinities and NaNs among them, leave many lanes uncertain.)
            assert!(hits > cases / 50 && hits < cases / 2, "{n} packets: {hits} hits of {cases}");
            assert!(uncertain < cases / 2, "{n} packets: {uncertain} uncertain lanes of {cases}");
            assert!(decided_hits > hits / 2, "{n} packets: {decided_hits} of {hits} hits decided by the SIMD test");
        }
    }

    #[test]
    fn moller_trumbore_lanes_are_the_scalar_routine() {
        // One packet (`tri4_mt_sse`) and, on CPUs with AVX2, two at once
        // (`tri8_mt_avx`), through `moller_trumbore_pair` as the leaf tests call it.
        let widths: &[usize] = if is_x86_feature_detected!("avx2") { &[1, 2] } else { &[1] };
        for &n in widths {
            let mut rng = Pcg32::new(0x4d54, 7 + n as u64);
            let (mut hits, mut cases) = (0, 0);
            for _ in 0..50_000 {
                let (p, ray) = packet_and_ray(&mut rng);
                let (q, _) = packet_and_ray(&mut rng);
                let pq = [p, q];
                let (mask, [t, u, v]) = moller_trumbore_pair(&pq[..n], &ray);
                assert_eq!(mask >> (PW * n), 0, "a lane past the packets");
                for l in 0..PW * n {
                    let (tri, k) = (&pq[l / PW], l % PW);
                    let scalar = intersect_moller_trumbore(&ray, tri.vertex(0, k), tri.vertex(1, k), tri.vertex(2, k));
                    let simd = (mask >> l & 1 != 0).then(|| (t[l], u[l], v[l]));
                    let bits = |h: Option<(f32, f32, f32)>| h.map(|(a, b, c)| (a.to_bits(), b.to_bits(), c.to_bits()));
                    assert_eq!(bits(simd), bits(scalar), "lane {l} of {pq:?}, {ray:?}");
                    hits += usize::from(scalar.is_some());
                    cases += 1;
                }
            }
            // The check means something only if both answers occur often.
            assert!(hits > cases / 50 && hits < cases / 2, "{n} packets: {hits} hits of {cases}");
        }
    }
}
