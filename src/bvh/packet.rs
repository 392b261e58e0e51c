//! Leaf triangles of the `fast` traversal in 4-wide structure-of-arrays
//! packets ([`Tri4`]), intersected four at a time with SSE (inside the AVX2
//! traversal) by the watertight test, lane for lane the same operations in the
//! same order as [`crate::geometry::triangle::intersect_watertight`] (separate
//! multiplies and subtractions, no fused multiply-add), so every lane's
//! `t, u, v` are bit-identical to the scalar routine's. Lanes with an edge
//! function whose single-precision sign is uncertain (within
//! `SIGN_MARGIN` error bounds of 0) take the scalar routine, with its
//! double-precision fallback, instead.
//!
//! The vertices are stored, not edges or a normal: the watertight test works
//! on the vertices relative to the ray origin, and any precomputed quantity
//! would change its rounding.

use glam::Vec3;

use crate::geometry::offset::gamma;
use crate::geometry::triangle::{SIGN_MARGIN, TriangleKernel, WatertightRay};
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
/// per ray at its first leaf: the watertight test's shear ([`Self::wr`]) and,
/// for the SSE packet test, the origin on the permuted axes and the shear
/// constants, four lanes each, with the byte offsets of the permuted axes'
/// rows in a [`Tri4`]. A leaf visit then broadcasts, stores and checks
/// nothing: made per leaf, those took about 55 instructions, as many as a
/// third of a packet test (callgrind, suzanne incoherent rays).
#[derive(Clone, Copy, Debug)]
#[repr(C, align(16))]
pub struct LeafRay {
    /// `origin[kx], origin[ky], origin[kz], sx, sy, sz`, each in four lanes.
    lanes: [[f32; PW]; 6],
    /// Byte offsets of the rows of axes `kx, ky, kz` in a vertex's three
    /// rows of [`Tri4::v`]: `16 k`, each below 48 (made only by [`Self::new`]).
    rows: [usize; 3],
    /// The shear, for the scalar routines.
    pub wr: WatertightRay,
}

impl LeafRay {
    /// A stand-in for tests that take no shear (Moller-Trumbore).
    pub const UNUSED: Self = Self { lanes: [[0.0; PW]; 6], rows: [0, 16, 32], wr: WatertightRay::UNUSED };

    /// The leaf constants of `ray` (whose direction must not be the zero vector).
    #[inline]
    pub fn new(ray: &Ray) -> Self {
        let wr = WatertightRay::new(ray.dir);
        let o = ray.origin.to_array();
        let ([kx, ky, kz], s) = (wr.k, wr.s);
        Self {
            lanes: [[o[kx]; PW], [o[ky]; PW], [o[kz]; PW], [s.x; PW], [s.y; PW], [s.z; PW]],
            rows: wr.k.map(|a| 16 * a),
            wr,
        }
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
    let (first, count) = (first as usize, count as usize);
    let mut p = Tri4 { v: [[0.0; PW]; 9], id: [0; PW] };
    for l in 0..PW {
        let (v, id) = tri(first + (PW * c + l).min(count - 1));
        for (j, vj) in v.iter().enumerate() {
            for a in 0..3 {
                p.v[3 * j + a][l] = vj[a];
            }
        }
        p.id[l] = id;
    }
    p
}

/// Packets holding `count` triangles.
#[inline(always)]
pub fn packets_for(count: u32) -> usize {
    (count as usize).div_ceil(PW)
}

/// Offer the hits of packet `$p`'s lanes in `$mask`, in lane (slot) order,
/// setting `$changed` when `$best` changes. `offer` compares each hit with the best so
/// far, which gives the scalar loop's answer (that loop tests later slots
/// against the interval the earlier hits shortened, a comparison `offer`
/// repeats). A macro that sets the caller's flag: a form that returned the
/// flag (function or macro) changed the walks' code generation and cost 0.7%
/// (watertight) to 4% (Moller-Trumbore) more instructions per suzanne
/// incoherent ray (callgrind).
macro_rules! offer_lanes {
    ($changed:ident, $best:expr, $ray:expr, $p:expr, $mask:expr, $t:expr, $u:expr, $v:expr) => {{
        let mut mask = $mask;
        while mask != 0 {
            let l = mask.trailing_zeros() as usize;
            mask &= mask - 1;
            $changed |= offer($best, $ray, $t[l], $p.id[l], $u[l], $v[l]);
        }
    }};
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
    #[inline]
    pub fn push_leaf_with(&mut self, first: u32, count: u32, tri: impl Fn(usize) -> ([Vec3; 3], u32)) -> u32 {
        let start = self.packets.len() as u32;
        for c in 0..packets_for(count) {
            self.packets.push(leaf_packet(first, count, c, &tri));
        }
        start
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

    /// SIMD watertight closest-hit test of a leaf; same results as
    /// [`Self::intersect_leaf_scalar`] with the watertight test.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    pub fn intersect_leaf_simd(
        &self,
        first: u32,
        count: u32,
        ray: &mut Ray,
        lr: &LeafRay,
        best: &mut Option<Hit>,
    ) -> bool {
        use std::arch::x86_64::*;
        let mut changed = false;
        for p in &self.packets[first as usize..first as usize + packets_for(count)] {
            let (ok, zero, t, u, v) = tri4_sse(p, ray, lr);
            let mut zero = zero;
            while zero != 0 {
                let l = zero.trailing_zeros() as usize;
                zero &= zero - 1;
                if let Some((t, u, v)) = watertight(ray, &lr.wr, p.vertex(0, l), p.vertex(1, l), p.vertex(2, l)) {
                    changed |= offer(best, ray, t, p.id[l], u, v);
                }
            }
            if ok != 0 {
                let (mut ts, mut us, mut vs) = ([0.0f32; PW], [0.0f32; PW], [0.0f32; PW]);
                // SAFETY: SSE is part of the x86_64 baseline; each array has
                // room for 4 floats and storeu has no alignment requirement.
                unsafe {
                    _mm_storeu_ps(ts.as_mut_ptr(), t);
                    _mm_storeu_ps(us.as_mut_ptr(), u);
                    _mm_storeu_ps(vs.as_mut_ptr(), v);
                }
                offer_lanes!(changed, best, ray, p, ok, ts, us, vs);
            }
        }
        changed
    }

    /// SIMD watertight any-hit test of a leaf.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    pub fn occluded_leaf_simd(&self, first: u32, count: u32, ray: &Ray, lr: &LeafRay) -> bool {
        for p in &self.packets[first as usize..first as usize + packets_for(count)] {
            let (ok, mut zero, _, _, _) = tri4_sse(p, ray, lr);
            if ok != 0 {
                return true;
            }
            while zero != 0 {
                let l = zero.trailing_zeros() as usize;
                zero &= zero - 1;
                if watertight(ray, &lr.wr, p.vertex(0, l), p.vertex(1, l), p.vertex(2, l)).is_some() {
                    return true;
                }
            }
        }
        false
    }

    /// SIMD Moller-Trumbore closest-hit test of a leaf; same results as
    /// [`Self::intersect_leaf_scalar`] with the Moller-Trumbore test (lane
    /// for lane the scalar routine's operations).
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    pub fn intersect_leaf_simd_mt(&self, first: u32, count: u32, ray: &mut Ray, best: &mut Option<Hit>) -> bool {
        let mut changed = false;
        for p in &self.packets[first as usize..first as usize + packets_for(count)] {
            let (ok, t, u, v) = tri4_mt_sse(p, ray);
            offer_lanes!(changed, best, ray, p, ok, t, u, v);
        }
        changed
    }

    /// SIMD Moller-Trumbore any-hit test of a leaf.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    pub fn occluded_leaf_simd_mt(&self, first: u32, count: u32, ray: &Ray) -> bool {
        self.packets[first as usize..first as usize + packets_for(count)].iter().any(|p| tri4_mt_sse(p, ray).0 != 0)
    }
}

/// Offer hit `(t, id, u, v)` (already within `ray`'s interval) under the
/// shared tie rule [`Hit::offer`].
#[inline(always)]
fn offer(best: &mut Option<Hit>, ray: &mut Ray, t: f32, id: u32, u: f32, v: f32) -> bool {
    Hit::offer(best, ray, Hit { t, prim: id, u, v })
}

/// The watertight test on four lanes: `(hit mask, uncertain mask, t, u, v)`.
/// Lanes in the uncertain mask (some edge function within `SIGN_MARGIN`
/// error bounds of 0 in single precision, or a distance in range that is not
/// provably positive) are excluded from the hit mask and must be decided by
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
        // The lanes are 16-byte rows of the 16-byte aligned `LeafRay`.
        let lane = |i: usize| _mm_load_ps(lr.lanes[i].as_ptr());
        let (ox, oy, oz) = (lane(0), lane(1), lane(2));
        let (sx, sy, sz) = (lane(3), lane(4), lane(5));
        // a = v0 - o, b = v1 - o, c = v2 - o on the permuted axes.
        let (a_x, a_y, a_z) = (_mm_sub_ps(ld(0, 0), ox), _mm_sub_ps(ld(0, 1), oy), _mm_sub_ps(ld(0, 2), oz));
        let (b_x, b_y, b_z) = (_mm_sub_ps(ld(1, 0), ox), _mm_sub_ps(ld(1, 1), oy), _mm_sub_ps(ld(1, 2), oz));
        let (c_x, c_y, c_z) = (_mm_sub_ps(ld(2, 0), ox), _mm_sub_ps(ld(2, 1), oy), _mm_sub_ps(ld(2, 2), oz));
        let ax = _mm_sub_ps(a_x, _mm_mul_ps(sx, a_z));
        let ay = _mm_sub_ps(a_y, _mm_mul_ps(sy, a_z));
        let bx = _mm_sub_ps(b_x, _mm_mul_ps(sx, b_z));
        let by = _mm_sub_ps(b_y, _mm_mul_ps(sy, b_z));
        let cx = _mm_sub_ps(c_x, _mm_mul_ps(sx, c_z));
        let cy = _mm_sub_ps(c_y, _mm_mul_ps(sy, c_z));
        let e0 = _mm_sub_ps(_mm_mul_ps(cx, by), _mm_mul_ps(cy, bx));
        let e1 = _mm_sub_ps(_mm_mul_ps(ax, cy), _mm_mul_ps(ay, cx));
        let e2 = _mm_sub_ps(_mm_mul_ps(bx, ay), _mm_mul_ps(by, ax));
        let az = _mm_mul_ps(sz, a_z);
        let bz = _mm_mul_ps(sz, b_z);
        let cz = _mm_mul_ps(sz, c_z);
        // The edge functions' error bound (`watertight_e_error`, same operation order).
        let sign = _mm_set1_ps(-0.0);
        let abs = |x: __m128| _mm_andnot_ps(sign, x);
        // Operands are non-negative (no -0); a NaN lane fails every comparison below and is never a hit.
        let max3 = |x: __m128, y: __m128, w: __m128| _mm_max_ps(_mm_max_ps(abs(x), abs(y)), abs(w));
        let (max_xt, max_yt, max_zt) = (max3(ax, bx, cx), max3(ay, by, cy), max3(az, bz, cz));
        let (g2, g3, g5) = (_mm_set1_ps(gamma(2)), _mm_set1_ps(gamma(3)), _mm_set1_ps(gamma(5)));
        let delta_x = _mm_mul_ps(g5, _mm_add_ps(max_xt, max_zt));
        let delta_y = _mm_mul_ps(g5, _mm_add_ps(max_yt, max_zt));
        let delta_e = _mm_mul_ps(
            _mm_set1_ps(2.0),
            _mm_add_ps(
                _mm_add_ps(_mm_mul_ps(_mm_mul_ps(g2, max_xt), max_yt), _mm_mul_ps(delta_y, max_xt)),
                _mm_mul_ps(delta_x, max_yt),
            ),
        );
        // Lanes with an edge function within SIGN_MARGIN bounds of 0 (or a
        // NaN bound or minimum): uncertain sign, decided by the scalar routine.
        let min_e = _mm_min_ps(_mm_min_ps(abs(e0), abs(e1)), abs(e2));
        let uncertain = _mm_cmpngt_ps(min_e, _mm_mul_ps(_mm_set1_ps(SIGN_MARGIN), delta_e));
        // In the other lanes, if no edge function is NaN, `min_e` is their
        // least magnitude and exceeds a bound >= 0, so all are nonzero and
        // "some negative and some positive" is "the sign bits differ"; a NaN
        // one (which `_mm_min_ps` may pass over) makes det and t NaN, which
        // no range admits, as in the scalar routine. Only the sign bit of
        // `mixed` is meaningful.
        let mixed = _mm_or_ps(_mm_xor_ps(e0, e1), _mm_xor_ps(e0, e2));
        let det = _mm_add_ps(_mm_add_ps(e0, e1), e2);
        let t_scaled = _mm_add_ps(_mm_add_ps(_mm_mul_ps(e0, az), _mm_mul_ps(e1, bz)), _mm_mul_ps(e2, cz));
        let inv_det = _mm_div_ps(_mm_set1_ps(1.0), det);
        let t = _mm_mul_ps(t_scaled, inv_det);
        // Ordered comparisons: a NaN t fails both, as `!(t >= t_min && t <= t_max)` rejects it.
        let in_range = _mm_and_ps(_mm_cmpge_ps(t, _mm_set1_ps(ray.t_min)), _mm_cmple_ps(t, _mm_set1_ps(ray.t_max)));
        // Sign bits only from here on (movemask reads nothing else).
        let ok = _mm_andnot_ps(_mm_or_ps(mixed, uncertain), in_range);
        let zero_mask = _mm_movemask_ps(uncertain) as u32;
        if _mm_movemask_ps(ok) == 0 {
            // Most packets are missed: skip the t error bound.
            let z = _mm_setzero_ps();
            return (0, zero_mask, z, z, z);
        }
        // The provably-positive-t check of `watertight_t_error` (pbrt-v4 6.8.7), same operation order.
        let delta_z = _mm_mul_ps(g3, max_zt);
        let max_e = max3(e0, e1, e2);
        let t_err = _mm_mul_ps(
            _mm_mul_ps(
                _mm_set1_ps(3.0),
                _mm_add_ps(
                    _mm_add_ps(_mm_mul_ps(_mm_mul_ps(g3, max_e), max_zt), _mm_mul_ps(delta_e, max_zt)),
                    _mm_mul_ps(delta_z, max_e),
                ),
            ),
            abs(inv_det),
        );
        // Lanes whose distance is not provably positive go to the scalar routine too.
        let not_positive = _mm_and_ps(_mm_cmple_ps(t, t_err), ok);
        let ok = _mm_andnot_ps(not_positive, ok);
        let zero_mask = zero_mask | _mm_movemask_ps(not_positive) as u32;
        (_mm_movemask_ps(ok) as u32, zero_mask, t, _mm_mul_ps(e1, inv_det), _mm_mul_ps(e2, inv_det))
    }
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
        let (o, d) = (ray.origin.to_array(), ray.dir.to_array());
        let (dx, dy, dz) = (_mm_set1_ps(d[0]), _mm_set1_ps(d[1]), _mm_set1_ps(d[2]));
        let (v0x, v0y, v0z) = (ld(0), ld(1), ld(2));
        // e1 = v1 - v0, e2 = v2 - v0.
        let (e1x, e1y, e1z) = (_mm_sub_ps(ld(3), v0x), _mm_sub_ps(ld(4), v0y), _mm_sub_ps(ld(5), v0z));
        let (e2x, e2y, e2z) = (_mm_sub_ps(ld(6), v0x), _mm_sub_ps(ld(7), v0y), _mm_sub_ps(ld(8), v0z));
        let dot = |ax: __m128, ay: __m128, az: __m128, bx: __m128, by: __m128, bz: __m128| {
            _mm_add_ps(_mm_add_ps(_mm_mul_ps(ax, bx), _mm_mul_ps(ay, by)), _mm_mul_ps(az, bz))
        };
        // p = dir x e2 (glam: x = a.y b.z - b.y a.z, y = a.z b.x - b.z a.x, z = a.x b.y - b.x a.y).
        let px = _mm_sub_ps(_mm_mul_ps(dy, e2z), _mm_mul_ps(e2y, dz));
        let py = _mm_sub_ps(_mm_mul_ps(dz, e2x), _mm_mul_ps(e2z, dx));
        let pz = _mm_sub_ps(_mm_mul_ps(dx, e2y), _mm_mul_ps(e2x, dy));
        let det = dot(e1x, e1y, e1z, px, py, pz);
        let (zero, one) = (_mm_setzero_ps(), _mm_set1_ps(1.0));
        // `det == 0 || !det.is_finite()` rejects: keep 0 < |det| < inf (a NaN fails both).
        let abs_det = _mm_andnot_ps(_mm_set1_ps(-0.0), det);
        let det_ok = _mm_and_ps(_mm_cmpgt_ps(abs_det, zero), _mm_cmplt_ps(abs_det, _mm_set1_ps(f32::INFINITY)));
        let inv_det = _mm_div_ps(one, det);
        // tv = origin - v0.
        let (tvx, tvy, tvz) = (
            _mm_sub_ps(_mm_set1_ps(o[0]), v0x),
            _mm_sub_ps(_mm_set1_ps(o[1]), v0y),
            _mm_sub_ps(_mm_set1_ps(o[2]), v0z),
        );
        let u = _mm_mul_ps(dot(tvx, tvy, tvz, px, py, pz), inv_det);
        // `(0.0..=1.0).contains(&u)`: ordered comparisons, a NaN fails.
        let ok = _mm_and_ps(det_ok, _mm_and_ps(_mm_cmpge_ps(u, zero), _mm_cmple_ps(u, one)));
        if _mm_movemask_ps(ok) == 0 {
            // Most packets are missed here: skip the second cross product and the stores.
            return (0, [0.0; PW], [0.0; PW], [0.0; PW]);
        }
        // q = tv x e1.
        let qx = _mm_sub_ps(_mm_mul_ps(tvy, e1z), _mm_mul_ps(e1y, tvz));
        let qy = _mm_sub_ps(_mm_mul_ps(tvz, e1x), _mm_mul_ps(e1z, tvx));
        let qz = _mm_sub_ps(_mm_mul_ps(tvx, e1y), _mm_mul_ps(e1x, tvy));
        let v = _mm_mul_ps(dot(dx, dy, dz, qx, qy, qz), inv_det);
        let v_out = _mm_or_ps(_mm_cmplt_ps(v, zero), _mm_cmpgt_ps(_mm_add_ps(u, v), one));
        let t = _mm_mul_ps(dot(e2x, e2y, e2z, qx, qy, qz), inv_det);
        // `!(t >= t_min && t <= t_max)` rejects: ordered comparisons, a NaN t fails.
        let in_range = _mm_and_ps(_mm_cmpge_ps(t, _mm_set1_ps(ray.t_min)), _mm_cmple_ps(t, _mm_set1_ps(ray.t_max)));
        let ok = _mm_andnot_ps(v_out, _mm_and_ps(ok, in_range));
        let (mut ts, mut us, mut vs) = ([0.0f32; PW], [0.0f32; PW], [0.0f32; PW]);
        // Each array has room for 4 floats; storeu has no alignment requirement.
        _mm_storeu_ps(ts.as_mut_ptr(), t);
        _mm_storeu_ps(us.as_mut_ptr(), u);
        _mm_storeu_ps(vs.as_mut_ptr(), v);
        (_mm_movemask_ps(ok) as u32, ts, us, vs)
    }
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
    fn watertight_lanes_are_the_scalar_routine() {
        // Every lane the SSE test decides (hit or miss) is the scalar
        // routine's answer bit for bit, on every axis permutation of
        // `LeafRay`; the uncertain lanes are left to that routine.
        let mut rng = Pcg32::new(0x5754, 3);
        let (mut hits, mut cases, mut uncertain, mut decided_hits) = (0, 0, 0, 0);
        for _ in 0..50_000 {
            let (p, ray) = packet_and_ray(&mut rng);
            if ray.dir == glam::Vec3::ZERO || !ray.dir.is_finite() {
                continue;
            }
            let lr = LeafRay::new(&ray);
            let (mask, unc, t, u, v) = tri4_sse(&p, &ray, &lr);
            let (mut ts, mut us, mut vs) = ([0.0f32; PW], [0.0f32; PW], [0.0f32; PW]);
            // SAFETY: SSE is part of the x86_64 baseline; the arrays hold 4 floats.
            unsafe {
                use std::arch::x86_64::_mm_storeu_ps;
                _mm_storeu_ps(ts.as_mut_ptr(), t);
                _mm_storeu_ps(us.as_mut_ptr(), u);
                _mm_storeu_ps(vs.as_mut_ptr(), v);
            }
            assert_eq!(mask & unc, 0, "a lane both hit and uncertain");
            for l in 0..PW {
                let scalar = watertight(&ray, &lr.wr, p.vertex(0, l), p.vertex(1, l), p.vertex(2, l));
                cases += 1;
                hits += usize::from(scalar.is_some());
                if unc >> l & 1 != 0 {
                    uncertain += 1;
                    continue;
                }
                let simd = (mask >> l & 1 != 0).then(|| (ts[l], us[l], vs[l]));
                let bits = |h: Option<(f32, f32, f32)>| h.map(|(a, b, c)| (a.to_bits(), b.to_bits(), c.to_bits()));
                assert_eq!(bits(simd), bits(scalar), "lane {l} of {p:?}, {ray:?}");
                decided_hits += usize::from(simd.is_some());
            }
        }
        // The check means something only if the SSE test itself decides many
        // lanes and many hits. (The special coordinates, zeros, infinities and
        // NaNs among them, leave many lanes uncertain.)
        assert!(hits > cases / 50 && hits < cases / 2, "{hits} hits of {cases}");
        assert!(uncertain < cases / 2, "{uncertain} uncertain lanes of {cases}");
        assert!(decided_hits > hits / 2, "{decided_hits} of {hits} hits decided by the SSE test");
    }

    #[test]
    fn moller_trumbore_lanes_are_the_scalar_routine() {
        let mut rng = Pcg32::new(0x4d54, 7);
        let (mut hits, mut cases) = (0, 0);
        for _ in 0..50_000 {
            let (p, ray) = packet_and_ray(&mut rng);
            let (mask, t, u, v) = tri4_mt_sse(&p, &ray);
            for l in 0..PW {
                let scalar = intersect_moller_trumbore(&ray, p.vertex(0, l), p.vertex(1, l), p.vertex(2, l));
                let simd = (mask >> l & 1 != 0).then(|| (t[l], u[l], v[l]));
                let bits = |h: Option<(f32, f32, f32)>| h.map(|(a, b, c)| (a.to_bits(), b.to_bits(), c.to_bits()));
                assert_eq!(bits(simd), bits(scalar), "lane {l} of {p:?}, {ray:?}");
                hits += usize::from(scalar.is_some());
                cases += 1;
            }
        }
        // The check means something only if both answers occur often.
        assert!(hits > cases / 50 && hits < cases / 2, "{hits} hits of {cases}");
    }
}
