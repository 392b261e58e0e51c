//! Normalisation: of meshes, the one definition used by the scene loader
//! (`"normalize": true`), `bench`, `parity`, `trace` and the tests, so that
//! all of them trace the same vertices to the bit; and of vectors whose
//! squared length overflows `f32` ([`unit_or_zero`], [`scaled_length`]).

use glam::{DVec3, Vec3};

/// Translate and scale vertices so that their mean is at the origin and the
/// farthest vertex at distance 1 (the default camera's framing).
///
/// Everything is computed in double precision (the mean of 10^6 f32
/// vertices summed in f32 would lose about 3 significant digits) and each
/// vertex is rounded to f32 once, at the end.
pub fn normalize_to_unit_sphere(positions: &mut [Vec3]) {
    let Some((c, s)) = unit_sphere_map(positions) else { return };
    for p in positions {
        *p = ((p.as_dvec3() - c) * s).as_vec3();
    }
}

/// The map of [`normalize_to_unit_sphere`], `p -> (p - c) s`, as `(c, s)`: `c` the mean of
/// the positions, `s` one over the largest distance from it (1 when that is 0); `None`
/// without positions.
pub fn unit_sphere_map(positions: &[Vec3]) -> Option<(DVec3, f64)> {
    if positions.is_empty() {
        return None;
    }
    let sum = positions.iter().fold(DVec3::ZERO, |a, p| a + p.as_dvec3());
    let c = sum / positions.len() as f64;
    let r = positions.iter().map(|p| (p.as_dvec3() - c).length()).fold(0.0, f64::max);
    Some((c, if r > 0.0 { 1.0 / r } else { 1.0 }))
}

/// `2^-e` for the exponent `e` of `m` (`2^e <= m < 2^(e+1)`), `m` finite and
/// positive: multiplying by it brings `m` into `[1, 2)` exactly (no rounding).
#[inline]
pub fn pow2_recip(m: f32) -> f32 {
    let e = ((m.to_bits() >> 23) & 0xff) as i32 - 127; // subnormals: -127, close enough
    2f32.powi(-e)
}

/// `v / |v|`, or zero for a zero or non-finite `v`, also where `|v|^2`
/// overflows or underflows `f32`: a triangle's `(v1 - v0) x (v2 - v0)` has
/// components up to 1.6e25 for vertices within [`crate::limits::MAX_COORDINATE`],
/// whose square overflows, and glam's `normalize_or_zero` then gives zero.
/// Such a `v` is first scaled by a power of two, which changes no rounding,
/// so the result equals `normalize_or_zero` wherever that does not overflow.
#[inline]
pub fn unit_or_zero(v: Vec3) -> Vec3 {
    let n = v.normalize_or_zero();
    if n != Vec3::ZERO || v == Vec3::ZERO {
        return n;
    }
    let m = v.abs().max_element();
    if !(m.is_finite() && m > 0.0 && v.is_finite()) {
        return Vec3::ZERO;
    }
    (v * pow2_recip(m)).normalize_or_zero()
}

/// `|v|`, also where `|v|^2` overflows or underflows `f32` (see [`unit_or_zero`]).
#[inline]
pub fn scaled_length(v: Vec3) -> f32 {
    let l = v.length();
    if (l.is_finite() && l > 0.0) || v == Vec3::ZERO || !v.is_finite() {
        return l;
    }
    let s = pow2_recip(v.abs().max_element());
    (v * s).length() / s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normalised_mesh_fits_the_unit_sphere() {
        let mut p = vec![Vec3::new(10.0, 0.0, 0.0), Vec3::new(12.0, 0.0, 0.0), Vec3::new(11.0, 3.0, 0.0)];
        normalize_to_unit_sphere(&mut p);
        let m = p.iter().map(|v| v.length()).fold(0.0, f32::max);
        assert!((m - 1.0).abs() < 1e-6);
        let mean = p.iter().map(|v| v.as_dvec3()).sum::<DVec3>() / 3.0;
        assert!(mean.length() < 1e-7, "{mean}");
    }

    #[test]
    fn unit_and_length_of_vectors_whose_square_overflows() {
        // ~(2e12)^2: the cross product of two edges at the coordinate limit.
        let unit = Vec3::new(4.0, 3.0, 0.0).normalize();
        let v = Vec3::new(4.0, 3.0, 0.0) * 2f32.powi(80);
        assert_eq!(v.normalize_or_zero(), Vec3::ZERO, "glam overflows");
        assert_eq!(unit_or_zero(v), unit);
        assert_eq!(scaled_length(v), 5.0 * 2f32.powi(80));
        let tiny = Vec3::new(4.0, 3.0, 0.0) * 2f32.powi(-100);
        assert_eq!(tiny.normalize_or_zero(), Vec3::ZERO, "glam underflows");
        assert_eq!(unit_or_zero(tiny), unit);
        assert_eq!(scaled_length(tiny), 5.0 * 2f32.powi(-100));
        // Ordinary vectors: exactly glam's result.
        for v in [Vec3::new(1.0, 2.0, 3.0), Vec3::new(-1e-3, 7e5, 0.3), Vec3::new(0.1, 0.0, 0.0)] {
            assert_eq!(unit_or_zero(v), v.normalize_or_zero());
            assert_eq!(scaled_length(v), v.length());
        }
        for v in [Vec3::ZERO, Vec3::new(f32::NAN, 1.0, 0.0), Vec3::new(f32::INFINITY, 0.0, 0.0)] {
            assert_eq!(unit_or_zero(v), Vec3::ZERO);
        }
    }
}
