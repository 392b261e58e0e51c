//! Rays aimed straight at the shared edges and closed vertices of a mesh
//! ([`Topology`]), each from in front of every triangle meeting at its target:
//! a watertight tracer must hit the surface at or before the target.

use glam::Vec3;

use crate::geometry::{Primitives, Ray};

use super::{Rng, Topology};

/// Rays at the shared edges (the midpoint and two random points of each) and
/// at the closed vertices of `prims.triangles`, in that order. Each starts one
/// scene diameter (the diagonal of the bounds) from its target `p`, along a
/// direction whose cosine with the unit normal of every triangle meeting at
/// `p` exceeds `min_cos` (a random tilt of their mean normal, or the mean
/// itself; targets whose triangles have no such direction are skipped). The
/// direction is `p - origin`, so the target lies at `t = 1`.
pub fn front_facing_rays(prims: &Primitives, seed: u64, min_cos: f32) -> Vec<Ray> {
    let topo = Topology::new(prims);
    let unit_n: Vec<Vec3> = prims.triangles.iter().map(|t| t.normal().normalize_or_zero()).collect();
    let dist = prims.world_bounds().extent().length();
    let mut rng = Rng::stream(seed, 5);
    // A direction well in front of every triangle of `tris`, if their mean normal is one.
    let front = |tris: &[u32], rng: &mut Rng| -> Option<Vec3> {
        let avg = tris.iter().map(|&t| unit_n[t as usize]).sum::<Vec3>().normalize_or_zero();
        if tris.iter().any(|&t| unit_n[t as usize].dot(avg) <= min_cos) {
            return None;
        }
        let w = (avg + 0.3 * rng.unit_vector()).normalize_or_zero();
        Some(if tris.iter().all(|&t| unit_n[t as usize].dot(w) > min_cos) { w } else { avg })
    };
    let mut rays = Vec::new();
    let mut aim = |p: Vec3, w: Vec3| {
        let o = p + dist * w;
        rays.push(Ray::new(o, p - o));
    };
    for &(a, b, t0, t1) in &topo.shared_edges {
        for s in [0.5, rng.f32(), rng.f32()] {
            let p = a + s * (b - a);
            if let Some(w) = front(&[t0, t1], &mut rng) {
                aim(p, w);
            }
        }
    }
    for (p, fan) in &topo.closed_vertices {
        if let Some(w) = front(fan, &mut rng) {
            aim(*p, w);
        }
    }
    rays
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::{BruteForce, Tracer};
    use crate::geometry::TriangleTest;

    #[test]
    fn every_ray_reaches_its_target_from_the_front() {
        let prims = crate::rays::sets::tetra();
        let rays = front_facing_rays(&prims, 1, 0.5);
        // A tetrahedron: 6 shared edges x 3 points; its vertex fans (normals 109 degrees apart) have no
        // direction within 60 degrees of all three faces.
        assert_eq!(rays.len(), 18);
        assert_eq!(rays, front_facing_rays(&prims, 1, 0.5));
        let tracer = BruteForce::new(prims.clone(), TriangleTest::Watertight);
        for r in &rays {
            let h = tracer.intersect(r).expect("an aimed ray hits");
            assert!(h.t <= 1.0 + 1e-5, "hit at {} beyond the target", h.t);
            assert!(prims.triangles[h.prim as usize].normal().dot(r.dir) < 0.0, "hit from behind");
        }
        let rays = front_facing_rays(&prims, 1, 0.0);
        assert_eq!(rays.len(), 18 + 4, "with min_cos 0 the vertices are aimed at too");
    }
}
