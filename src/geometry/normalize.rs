//! Mesh normalisation, the one definition used by the scene loader
//! (`"normalize": true`), `bench`, `parity`, `trace` and the tests, so that
//! all of them trace the same vertices to the bit.

use glam::{DVec3, Vec3};

/// Translate and scale vertices so that their mean is at the origin and the
/// farthest vertex at distance 1 (the default camera's framing).
///
/// Everything is computed in double precision (the mean of 10^6 f32
/// vertices summed in f32 would lose about 3 significant digits) and each
/// vertex is rounded to f32 once, at the end.
pub fn normalize_to_unit_sphere(positions: &mut [Vec3]) {
    if positions.is_empty() {
        return;
    }
    let sum = positions.iter().fold(DVec3::ZERO, |a, p| a + p.as_dvec3());
    let c = sum / positions.len() as f64;
    let r = positions.iter().map(|p| (p.as_dvec3() - c).length()).fold(0.0, f64::max);
    let s = if r > 0.0 { 1.0 / r } else { 1.0 };
    for p in positions {
        *p = ((p.as_dvec3() - c) * s).as_vec3();
    }
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
}
