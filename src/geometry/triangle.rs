//! Ray/triangle intersection: the watertight test of Woop, Benthin and Wald
//! (JCGT 2013) by default, Moller-Trumbore for comparison.
//!
//! Both report `t` and the barycentric weights `(u, v)` of vertices 1 and 2,
//! the convention Embree uses. Neither uses an absolute epsilon. The
//! watertight test trusts a single-precision edge function's sign only when it
//! exceeds twice its error bound ([`watertight_e_error`]) and the underflow
//! floor [`E_FLOOR`]; otherwise the whole
//! triangle is decided in double precision from the float32 inputs
//! ([`intersect_watertight_f64`]), so its hit/miss decisions are those of the
//! exact arithmetic of `verify::hits::arbiter` except within about `2^-29` of
//! the single-precision error, and a ray through a shared edge or vertex hits
//! at least one of the triangles that share it.

use glam::Vec3;

use super::Ray;

/// Which ray/triangle test a tracer uses.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum TriangleTest {
    /// Woop, Benthin, Wald 2013: no cracks along shared edges.
    #[default]
    Watertight,
    /// Moller and Trumbore 1997: fast, but rays can slip through shared edges.
    MollerTrumbore,
}

impl TriangleTest {
    /// Suffix of a tracer label: `""` for the watertight test, `" mt"` for Moller-Trumbore.
    pub fn label_suffix(self) -> &'static str {
        match self {
            TriangleTest::Watertight => "",
            TriangleTest::MollerTrumbore => " mt",
        }
    }
}

impl std::str::FromStr for TriangleTest {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "watertight" => Ok(Self::Watertight),
            "moller-trumbore" | "mt" => Ok(Self::MollerTrumbore),
            _ => Err(format!("unknown triangle test '{s}' (expected watertight or moller-trumbore)")),
        }
    }
}

/// A ray/triangle test chosen by type: the traversals and leaf loops are
/// generic over it, so each configuration compiles to its own kernel with no
/// runtime choice of test inside the hot loops ([`crate::with_triangle_kernel`]
/// turns a [`TriangleTest`] value into the type once per query or per tracer).
pub trait TriangleKernel: Copy + Default + Send + Sync + 'static {
    /// The test as a value (labels, reports).
    const TEST: TriangleTest;
    /// True for the watertight test, which the BVH's SIMD packet code implements.
    const WATERTIGHT: bool;
    /// `Some((t, u, v))` when `ray` meets triangle `(v0, v1, v2)` within its
    /// interval (`wr`: the per-ray constants of the watertight test).
    fn intersect(ray: &Ray, wr: &WatertightRay, v0: Vec3, v1: Vec3, v2: Vec3) -> Option<(f32, f32, f32)>;
}

/// [`TriangleTest::Watertight`] as a type ([`intersect_watertight`]).
#[derive(Clone, Copy, Debug, Default)]
pub struct Watertight;

/// [`TriangleTest::MollerTrumbore`] as a type ([`intersect_moller_trumbore`]).
#[derive(Clone, Copy, Debug, Default)]
pub struct MollerTrumbore;

impl TriangleKernel for Watertight {
    const TEST: TriangleTest = TriangleTest::Watertight;
    const WATERTIGHT: bool = true;
    #[inline(always)]
    fn intersect(ray: &Ray, wr: &WatertightRay, v0: Vec3, v1: Vec3, v2: Vec3) -> Option<(f32, f32, f32)> {
        intersect_watertight(ray, wr, v0, v1, v2)
    }
}

impl TriangleKernel for MollerTrumbore {
    const TEST: TriangleTest = TriangleTest::MollerTrumbore;
    const WATERTIGHT: bool = false;
    #[inline(always)]
    fn intersect(ray: &Ray, _: &WatertightRay, v0: Vec3, v1: Vec3, v2: Vec3) -> Option<(f32, f32, f32)> {
        intersect_moller_trumbore(ray, v0, v1, v2)
    }
}

/// Evaluate `$body` with the type `$k` bound to the [`TriangleKernel`] of the
/// [`TriangleTest`] value `$test`: the one place a test value becomes a type.
#[macro_export]
macro_rules! with_triangle_kernel {
    ($test:expr, $k:ident => $body:expr) => {
        match $test {
            $crate::geometry::TriangleTest::Watertight => {
                type $k = $crate::geometry::triangle::Watertight;
                $body
            }
            $crate::geometry::TriangleTest::MollerTrumbore => {
                type $k = $crate::geometry::triangle::MollerTrumbore;
                $body
            }
        }
    };
}

/// Per-ray constants of the watertight test: the axis permutation that makes
/// the ray direction's largest component `z`, and the shear that maps the ray
/// onto the `+z` axis.
#[derive(Clone, Copy, Debug)]
pub struct WatertightRay {
    /// Permuted axes (x, y, z).
    pub k: [usize; 3],
    /// Shear constants `(Sx, Sy, Sz)`.
    pub s: Vec3,
}

impl WatertightRay {
    /// A stand-in for tests that take no shear (Moller-Trumbore ignores it).
    pub const UNUSED: Self = Self { k: [0, 1, 2], s: Vec3::ZERO };

    /// Precompute the shear for `dir` (must not be the zero vector).
    #[inline]
    pub fn new(dir: Vec3) -> Self {
        Self::of(dir.as_ref())
    }

    /// [`Self::new`] of the direction `d`, read in place: given a ray's
    /// direction in memory, each component is one load from it, with no copy
    /// of the direction (a copy made as two stores and read back as one
    /// overlapping load stalls on store forwarding).
    #[inline(always)]
    pub fn of(d: &[f32; 3]) -> Self {
        let a = Vec3::from_array(*d).abs();
        let kz = if a.x >= a.y && a.x >= a.z {
            0
        } else if a.y >= a.z {
            1
        } else {
            2
        };
        // The next two axes in cyclic order, swapped when `dir[kz] < 0` to keep
        // the winding of the edge functions independent of its sign: one
        // table row per (kz, sign), instead of `% 3` arithmetic and a swap.
        const XY: [[usize; 2]; 6] = [[1, 2], [2, 1], [2, 0], [0, 2], [0, 1], [1, 0]];
        // Indexing the direction (one load each) rather than glam's `Index`, a
        // three-way match.
        let dz = d[kz];
        let [kx, ky] = XY[2 * kz + usize::from(dz < 0.0)];
        Self { k: [kx, ky, kz], s: Vec3::new(d[kx] / dz, d[ky] / dz, 1.0 / dz) }
    }
}

/// Watertight intersection of `ray` (with precomputed `wr`) and triangle
/// `(v0, v1, v2)`: `Some((t, u, v))` when `ray.t_min <= t <= ray.t_max`.
///
/// ```
/// use glam::Vec3;
/// use rtdiff::geometry::Ray;
/// use rtdiff::geometry::triangle::{WatertightRay, intersect_watertight};
/// let r = Ray::new(Vec3::new(0.25, 0.25, 1.0), Vec3::new(0.0, 0.0, -1.0));
/// let hit = intersect_watertight(&r, &WatertightRay::new(r.dir), Vec3::ZERO, Vec3::X, Vec3::Y);
/// assert_eq!(hit, Some((1.0, 0.25, 0.25)));
/// ```
#[inline(always)]
pub fn intersect_watertight(ray: &Ray, wr: &WatertightRay, v0: Vec3, v1: Vec3, v2: Vec3) -> Option<(f32, f32, f32)> {
    let [kx, ky, kz] = wr.k;
    let s = wr.s;
    let a = v0 - ray.origin;
    let b = v1 - ray.origin;
    let c = v2 - ray.origin;
    let ax = a[kx] - s.x * a[kz];
    let ay = a[ky] - s.y * a[kz];
    let bx = b[kx] - s.x * b[kz];
    let by = b[ky] - s.y * b[kz];
    let cx = c[kx] - s.x * c[kz];
    let cy = c[ky] - s.y * c[kz];
    let e0 = cx * by - cy * bx; // weight of v0
    let e1 = ax * cy - ay * cx; // weight of v1
    let e2 = bx * ay - by * ax; // weight of v2
    let az = s.z * a[kz];
    let bz = s.z * b[kz];
    let cz = s.z * c[kz];
    let max_xt = ax.abs().max(bx.abs()).max(cx.abs());
    let max_yt = ay.abs().max(by.abs()).max(cy.abs());
    let max_zt = az.abs().max(bz.abs()).max(cz.abs());
    let min_e = e0.abs().min(e1.abs()).min(e2.abs());
    if min_e <= SIGN_MARGIN * watertight_e_error(max_xt, max_yt, max_zt) || min_e <= E_FLOOR {
        // Some edge function's single-precision sign is not certain (it is
        // within its rounding error of 0, or so small that products underflow):
        // decide the triangle in double precision from the original vertices
        // (module docs).
        return intersect_watertight_f64(ray, wr, v0, v1, v2);
    }
    if (e0 < 0.0 || e1 < 0.0 || e2 < 0.0) && (e0 > 0.0 || e1 > 0.0 || e2 > 0.0) {
        return None;
    }
    let det = e0 + e1 + e2;
    let t_scaled = e0 * az + e1 * bz + e2 * cz;
    let inv_det = 1.0 / det;
    let t = t_scaled * inv_det;
    // Ordered comparisons: a NaN t is neither past `t_min` nor within `t_max`.
    let past_min = t >= ray.t_min;
    if !past_min {
        return None;
    }
    // A distance whose edge-function error may move it too far
    // ([`T_SPREAD_MAX`]: thin triangles seen at an angle) is decided in
    // double precision, before `t_max`: that bound shrinks as a traversal
    // finds hits, and the answer must not depend on their order.
    let ro = spread_scale(ray, wr);
    if watertight_t_imprecise(watertight_e_error(max_xt, max_yt, max_zt), [az, bz, cz], t, det, ro) {
        return intersect_watertight_f64(ray, wr, v0, v1, v2);
    }
    let within_max = t <= ray.t_max;
    if !within_max {
        return None;
    }
    // A distance that is not provably positive in single precision (pbrt-v4,
    // section 6.8.7: a ray spawned just off a surface must not hit that
    // surface again because rounding turned a tiny negative t into a positive
    // one) is decided in double precision, which accepts it only if it is
    // provably positive there: the refusal used to lose true hits up to twice
    // this bound away (the arbiter found them on shadow rays, issue 12).
    if t <= watertight_t_error([ax, ay, az], [bx, by, bz], [cx, cy, cz], [e0, e1, e2], inv_det) {
        return intersect_watertight_f64(ray, wr, v0, v1, v2);
    }
    Some((t, e1 * inv_det, e2 * inv_det))
}

/// How many edge-function error bounds ([`watertight_e_error`]) an edge
/// function must exceed for its single-precision sign to be trusted: 2, so
/// that a trusted sign belongs to an exact value at least one bound away from
/// 0, far beyond the double-precision fallback's own error (about `2^-29`
/// bounds), and a neighbour deciding the shared edge in double precision
/// finds the same sign (watertightness).
pub const SIGN_MARGIN: f32 = 2.0;

/// The least edge-function magnitude whose single-precision sign the
/// watertight test trusts, whatever its error bound: `2^-100`. The bounds of
/// [`watertight_e_error`] and [`watertight_t_error`] are relative to the
/// magnitudes of the operands and assume no product underflows; below
/// `2^-126` a product rounds to a multiple of `2^-149` (and the bounds
/// themselves to 0), so for a mesh scaled to 1e-17 .. 1e-22 (ray origins as
/// near) the edge functions and `det` fell into the subnormals, `1 / det`
/// overflowed to infinity and `t` came out NaN or 0: true hits were lost far
/// from any tie (`tests/tiny_scale.rs`). An edge function above this floor keeps an underflowed
/// operand's absolute error (`2^-150`, times coordinates up to `2^48`) below
/// half of it, and `1 / det` finite; smaller ones go to the double-precision
/// fallback, whose range reaches `2^-1074`.
pub const E_FLOOR: f32 = 1.0 / (1u128 << 100) as f32;

/// Absolute term of the watertight test's `t` error bound
/// ([`watertight_t_error`]): `2^-126`, covering the rounding of the products
/// `e_i z_i` should they underflow (at most `2^-150` each), which the bound's
/// relative terms (underflowing with them) do not.
pub const T_ETA: f32 = f32::MIN_POSITIVE;

/// How large the edge functions' share of the watertight test's distance
/// error may be, in units of a lower bound of the parity bound's scale,
/// before the hit is decided in double precision instead: `2^7 u = 2^-17`
/// (`u = 2^-24`), see [`watertight_t_imprecise`].
///
/// The single-precision distance is the barycentric blend `sum e_i z_i / det`
/// of the vertices' sheared distances `z_i` along the ray. Edge-function
/// errors `eps_i` (each at most `delta_e`, [`watertight_e_error`]) cancel from
/// it except through `sum eps_i (z_i - t) / det`, so they move `t` by at most
/// `delta_e sum |z_i - t| / |det|` (the *spread term*); the other roundings
/// (of the `z_i`, the products, sums and `1 / det`) move it by about `10 u t`.
/// On thin triangles `|det|` is small beside `delta_e`: the spread term is
/// what carried regr01.obj's 48 distances beyond the parity bound
/// (`verify::hits::bounds`), every one with the term above `3e4 u t`.
///
/// The parity bound on `t` is `32 u (|o|_inf + |p|_inf) / (c |d|_2)` (`p` the
/// hit point, `c <= 1` the cosine of the ray and the plane's normal), and
/// `|o|_inf + |p|_inf >= max(|o|_inf, t |d|_inf)`, `|d|_2 <= sqrt 3 |d|_inf`:
/// it is at least `32 u / sqrt 3 max(|o|_inf / |d|_inf, t) = 18.5 u max(ro,
/// t)`. The test falls back when the spread term exceeds `128 u max(ro, t)`.
///
/// Not a proof: `delta_e` is a worst case far above the errors that occur.
/// Measured instead (`examples/t_error_survey.rs`: the race's camera,
/// incoherent and shadow rays and every parity set, scaled ones included, on
/// suzanne, dragon_87k, teapot, bunny and regr01, 20,000 rays a set, against
/// the exact hit): wherever the spread term exceeds `64 u t`, the error is at
/// most 0.121 of it, so below `15.5 u max(ro, t)`, 0.84 of the bound's lower
/// bound, at this threshold (the hits kept in single precision came to at
/// most 0.15 of the bound); with no fallback at all, regr01's edge, vertex,
/// grazing and scaled rays go up to 23 times beyond it. Double precision
/// decides 0.3% to 3% of the hits of the race's camera, incoherent and
/// shadow rays on suzanne, dragon_87k, teapot and bunny (the rule before,
/// `2^8 u t` against `t` alone: suzanne 0.4%, 6.4%, 10%), 15% to 34% of
/// grazing hits, and on regr01 (large thin triangles seen from close by)
/// 7% to 26%. The cosine `c` is left out: bounding it from the plane's slope in
/// the sheared frame cut suzanne's fallbacks to 0.15% but cost 4% to 7% more
/// instructions per ray.
pub const T_SPREAD_MAX: f32 = 128.0 * (f32::EPSILON * 0.5);

/// `|o|_inf / |d|_inf` of a ray with shear `wr`, computed as `|o|_inf |s_z|`
/// (one rounding), the same way by the scalar test and the SIMD leaf tests
/// in `bvh` (see [`T_SPREAD_MAX`]).
#[inline(always)]
pub fn spread_scale(ray: &Ray, wr: &WatertightRay) -> f32 {
    let o = ray.origin.abs();
    o.x.max(o.y).max(o.z) * wr.s.z.abs()
}

/// `a > b ? a : b`, SSE's `max` (its second operand when either is NaN), so
/// that the scalar test and the SIMD lanes agree bit for bit.
#[inline(always)]
fn max_ps(a: f32, b: f32) -> f32 {
    if a > b { a } else { b }
}

/// Whether the watertight test's distance `t` may be too imprecise for the
/// parity bound ([`T_SPREAD_MAX`], which derives the rule): `delta_e (|z_0 -
/// t| + |z_1 - t| + |z_2 - t|) > T_SPREAD_MAX max(ro, t) |det|`, from the
/// edge-function bound `delta_e`, the sheared distances `z` of the vertices,
/// the distance, `det` and the ray's [`spread_scale`] `ro`. The SIMD leaf
/// tests in `bvh` compute it with the same operations in the same order.
#[inline(always)]
pub fn watertight_t_imprecise(delta_e: f32, z: [f32; 3], t: f32, det: f32, ro: f32) -> bool {
    let spread = (z[0] - t).abs() + (z[1] - t).abs() + (z[2] - t).abs();
    delta_e * spread > T_SPREAD_MAX * max_ps(ro, t) * det.abs()
}

/// Bound on the absolute error of the watertight test's single-precision
/// edge functions (pbrt-v4, section 6.8.7: `delta_e`), from the largest
/// magnitudes of the sheared vertex coordinates. It covers the rounding of
/// `v - o`, of the shear and of the products, relative to the exact edge
/// functions of the float32 inputs, whose signs are those of the exact edge
/// volumes `d.(B x C)` the arbiter (`verify::hits::arbiter`) computes.
#[inline(always)]
pub fn watertight_e_error(max_xt: f32, max_yt: f32, max_zt: f32) -> f32 {
    use super::offset::gamma;
    let delta_x = gamma(5) * (max_xt + max_zt);
    let delta_y = gamma(5) * (max_yt + max_zt);
    2.0 * (gamma(2) * max_xt * max_yt + delta_y * max_xt + delta_x * max_yt)
}

/// The watertight test in double precision from the float32 inputs: the
/// fallback of [`intersect_watertight`] when a single-precision edge sign is
/// uncertain or a distance is not provably positive.
///
/// Woop, Benthin and Wald fall back to double precision only when an edge
/// function is exactly 0, and recompute it from the *single-precision*
/// sheared coordinates; but the shear's rounding (`u (|x| + |z|)` per
/// coordinate) is already in those, and for a grazing ray far from a small
/// triangle it exceeds the edge function itself, so a nonzero edge function
/// can have the wrong sign (issue 12's dragon_res3 ray: a hit 9% inside an
/// edge at 0.07 degrees was missed). Here `v - o` (exact for float32 data of
/// similar magnitude), the shear and the products are all double precision,
/// whose error is about `2^-29` of the single-precision bound. Neighbours
/// compute a shared edge's function from the same two vertices with the same
/// operations, so they find exactly opposite values: the test stays
/// watertight.
#[inline(never)]
pub fn intersect_watertight_f64(
    ray: &Ray,
    wr: &WatertightRay,
    v0: Vec3,
    v1: Vec3,
    v2: Vec3,
) -> Option<(f32, f32, f32)> {
    let [kx, ky, kz] = wr.k;
    let o = ray.origin.as_dvec3();
    let d = ray.dir.as_dvec3();
    let (sx, sy, sz) = (d[kx] / d[kz], d[ky] / d[kz], 1.0 / d[kz]);
    let (qa, qb, qc) = (v0.as_dvec3() - o, v1.as_dvec3() - o, v2.as_dvec3() - o);
    let shear = |q: glam::DVec3| (q[kx] - sx * q[kz], q[ky] - sy * q[kz], sz * q[kz]);
    let (ax, ay, az) = shear(qa);
    let (bx, by, bz) = shear(qb);
    let (cx, cy, cz) = shear(qc);
    let e0 = cx * by - cy * bx;
    let e1 = ax * cy - ay * cx;
    let e2 = bx * ay - by * ax;
    if (e0 < 0.0 || e1 < 0.0 || e2 < 0.0) && (e0 > 0.0 || e1 > 0.0 || e2 > 0.0) {
        return None;
    }
    let det = e0 + e1 + e2;
    if det == 0.0 {
        return None;
    }
    let t = (e0 * az + e1 * bz + e2 * cz) / det;
    let t32 = t as f32;
    if !(t32 >= ray.t_min && t32 <= ray.t_max) {
        return None;
    }
    // The provably-positive-t check of the single-precision test (pbrt-v4
    // 6.8.7) with double-precision gammas, and with the shear's rounding
    // bounded by the shear itself: pbrt bounds the error of `q_x - s_x q_z`
    // by `gamma(5) (|x'| + |z'|)`, which for a ray with a zero direction
    // component (`s_x = 0`, no shear and no rounding) across a triangle thin
    // in `x` exceeds the edge functions by orders of magnitude and made this
    // check refuse true hits far from any tie (corpus: a mesh 1e-30 thick hit
    // by axis-aligned rays, docs/campaigns.md). Here the error of the sheared
    // `x` is `gamma(5) (|q_x| + |s_x q_z|)`, valid for any direction's scale.
    // `eta` covers a product's absolute rounding should it underflow.
    let g = |n: f64| n * f64::EPSILON * 0.5 / (1.0 - n * f64::EPSILON * 0.5);
    let eta = f64::from_bits(1); // 2^-1074, the least positive f64
    let max_q = |k: usize| qa[k].abs().max(qb[k].abs()).max(qc[k].abs());
    let max_xt = ax.abs().max(bx.abs()).max(cx.abs());
    let max_yt = ay.abs().max(by.abs()).max(cy.abs());
    let max_zt = az.abs().max(bz.abs()).max(cz.abs());
    let (max_qx, max_qy, max_qz) = (max_q(kx), max_q(ky), max_q(kz));
    let delta_z = g(3.0) * max_zt + eta;
    let delta_x = g(5.0) * (max_qx + sx.abs() * max_qz) + eta;
    let delta_y = g(5.0) * (max_qy + sy.abs() * max_qz) + eta;
    let delta_e = 2.0 * (g(2.0) * max_xt * max_yt + delta_y * max_xt + delta_x * max_yt) + 4.0 * eta;
    let max_e = e0.abs().max(e1.abs()).max(e2.abs());
    let t_err = 3.0 * (g(3.0) * max_e * max_zt + delta_e * max_zt + delta_z * max_e + 4.0 * eta) / det.abs();
    if t <= t_err {
        return None;
    }
    Some((t32, (e1 / det) as f32, (e2 / det) as f32))
}

/// Bound on the absolute error of the watertight test's `t` (pbrt-v4, section
/// 6.8.7), from the sheared vertices `(x, y, z)` relative to the ray origin,
/// the edge functions and `1 / det`.
#[inline]
pub fn watertight_t_error(a: [f32; 3], b: [f32; 3], c: [f32; 3], e: [f32; 3], inv_det: f32) -> f32 {
    use super::offset::gamma;
    let max_xt = a[0].abs().max(b[0].abs()).max(c[0].abs());
    let max_yt = a[1].abs().max(b[1].abs()).max(c[1].abs());
    let max_zt = a[2].abs().max(b[2].abs()).max(c[2].abs());
    let delta_z = gamma(3) * max_zt;
    let delta_e = watertight_e_error(max_xt, max_yt, max_zt);
    let max_e = e[0].abs().max(e[1].abs()).max(e[2].abs());
    3.0 * (gamma(3) * max_e * max_zt + delta_e * max_zt + delta_z * max_e + T_ETA) * inv_det.abs()
}

/// The watertight test's `t` error bound for `ray` and triangle `(v0, v1, v2)`
/// (see [`watertight_t_error`]); `None` for a triangle parallel to the ray.
pub fn watertight_t_error_for(ray: &Ray, v0: Vec3, v1: Vec3, v2: Vec3) -> Option<f32> {
    let wr = WatertightRay::new(ray.dir);
    let [kx, ky, kz] = wr.k;
    let s = wr.s;
    let shear = |p: Vec3| {
        let q = p - ray.origin;
        [q[kx] - s.x * q[kz], q[ky] - s.y * q[kz], s.z * q[kz]]
    };
    let (a, b, c) = (shear(v0), shear(v1), shear(v2));
    let e0 = c[0] * b[1] - c[1] * b[0];
    let e1 = a[0] * c[1] - a[1] * c[0];
    let e2 = b[0] * a[1] - b[1] * a[0];
    let det = e0 + e1 + e2;
    (det != 0.0).then(|| watertight_t_error(a, b, c, [e0, e1, e2], 1.0 / det))
}

/// Moller-Trumbore intersection: `Some((t, u, v))` when the ray meets the
/// triangle within `[t_min, t_max]`. Only an exactly singular determinant is
/// rejected (no absolute epsilon: the data's scale is unknown).
#[inline]
pub fn intersect_moller_trumbore(ray: &Ray, v0: Vec3, v1: Vec3, v2: Vec3) -> Option<(f32, f32, f32)> {
    let e1 = v1 - v0;
    let e2 = v2 - v0;
    let p = ray.dir.cross(e2);
    let det = e1.dot(p);
    if det == 0.0 || !det.is_finite() {
        return None;
    }
    let inv_det = 1.0 / det;
    let tv = ray.origin - v0;
    let u = tv.dot(p) * inv_det;
    if !(0.0..=1.0).contains(&u) {
        return None;
    }
    let q = tv.cross(e1);
    let v = ray.dir.dot(q) * inv_det;
    if v < 0.0 || u + v > 1.0 {
        return None;
    }
    let t = e2.dot(q) * inv_det;
    if !(t >= ray.t_min && t <= ray.t_max) {
        return None;
    }
    Some((t, u, v))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tri() -> [Vec3; 3] {
        [Vec3::new(0.0, 0.0, 0.0), Vec3::new(1.0, 0.0, 0.0), Vec3::new(0.0, 1.0, 0.0)]
    }

    #[test]
    fn both_tests_agree_on_an_interior_hit() {
        let [a, b, c] = tri();
        let r = Ray::new(Vec3::new(0.25, 0.5, 2.0), Vec3::new(0.0, 0.0, -1.0));
        let (t, u, v) = intersect_watertight(&r, &WatertightRay::new(r.dir), a, b, c).unwrap();
        assert_eq!((t, u, v), (2.0, 0.25, 0.5));
        let (t2, u2, v2) = intersect_moller_trumbore(&r, a, b, c).unwrap();
        assert_eq!((t2, u2, v2), (2.0, 0.25, 0.5));
    }

    #[test]
    fn shared_edge_is_hit_by_exactly_one_side_or_both() {
        // Two triangles sharing the diagonal (1,0)-(0,1) of the unit square.
        let a = [Vec3::new(0.0, 0.0, 0.0), Vec3::new(1.0, 0.0, 0.0), Vec3::new(0.0, 1.0, 0.0)];
        let b = [Vec3::new(1.0, 0.0, 0.0), Vec3::new(1.0, 1.0, 0.0), Vec3::new(0.0, 1.0, 0.0)];
        for i in 0..1000 {
            let s = i as f32 / 999.0;
            let p = Vec3::new(s, 1.0 - s, 0.0);
            let o = Vec3::new(0.3, 0.7, 1.0) * 3.1;
            let r = Ray::new(o, p - o);
            let wr = WatertightRay::new(r.dir);
            let ha = intersect_watertight(&r, &wr, a[0], a[1], a[2]).is_some();
            let hb = intersect_watertight(&r, &wr, b[0], b[1], b[2]).is_some();
            assert!(ha || hb, "ray {i} leaked through the shared edge");
        }
    }

    #[test]
    fn range_is_closed() {
        let [a, b, c] = tri();
        let r = Ray::with_range(Vec3::new(0.2, 0.2, 1.0), Vec3::new(0.0, 0.0, -1.0), 0.0, 1.0);
        assert!(intersect_watertight(&r, &WatertightRay::new(r.dir), a, b, c).is_some());
        let r = Ray::with_range(r.origin, r.dir, 0.0, 0.999);
        assert!(intersect_watertight(&r, &WatertightRay::new(r.dir), a, b, c).is_none());
    }

    #[test]
    fn degenerate_triangle_is_never_hit() {
        let r = Ray::new(Vec3::new(0.5, 0.0, 1.0), Vec3::new(0.0, 0.0, -1.0));
        let (a, b, c) = (Vec3::ZERO, Vec3::X, Vec3::X * 2.0);
        assert!(intersect_watertight(&r, &WatertightRay::new(r.dir), a, b, c).is_none());
        assert!(intersect_moller_trumbore(&r, a, b, c).is_none());
    }
}
