//! Watertightness: rays aimed at points on shared edges and at shared
//! vertices of closed meshes (the bunny's interior edges, a generated
//! icosphere) never pass through the surface.

mod common;

use std::sync::Arc;

use common::{icosphere, load_mesh};
use glam::Vec3;
use rayon::prelude::*;
use rtdiff::backends::{AccelConfig, build_tracer, native_variants};
use rtdiff::geometry::{Primitives, Ray, Triangle, TriangleTest};
use rtdiff::rays::front_facing_rays;

/// Smallest cosine between an aimed ray and the faces meeting at its target:
/// rays cross the surface clearly instead of grazing it.
const MIN_COS: f32 = 0.5;

/// Count rays that leak: no hit at all, or a first hit beyond the aimed point
/// (`t = 1`) by more than `tol`.
fn leaks(prims: &Arc<Primitives>, rays: &[Ray], cfg: &AccelConfig, tol: f32) -> (usize, usize) {
    let tracer = build_tracer(prims.clone(), cfg).unwrap();
    let closest = rays.par_iter().filter(|r| tracer.intersect(r).is_none_or(|h| h.t > 1.0 + tol)).count();
    let any = rays.par_iter().filter(|r| !tracer.occluded(&Ray { t_max: 1.0 + tol, ..**r })).count();
    (closest, any)
}

/// Tolerance on the hit distance past the aimed point.
///
/// The aimed point and the vertices are rounded to floats: the point lies off
/// the true surface by at most about 2 ulps of the largest coordinate, which
/// along a ray meeting the faces at cosine >= MIN_COS is at most
/// `2 sqrt(3) ulp / MIN_COS`; divided by the ray length (one scene diameter,
/// see [`front_facing_rays`]) this is a distance in `t`. Twice that, and never
/// below 1e-4 (800 ulps of 1, covering the rounding of `t` itself). A leaking
/// ray instead travels on to another sheet of the surface, at least a chord
/// `2 r MIN_COS` further for the sphere.
fn tolerance(prims: &Primitives) -> f32 {
    let bounds = prims.world_bounds();
    let ulp = bounds.max_abs_coord() * f32::EPSILON;
    let ray_len = bounds.extent().length();
    (2.0 * 2.0 * 3f32.sqrt() * ulp / MIN_COS / ray_len).max(1e-4)
}

fn check(label: &str, pos: &[Vec3], faces: &[[u32; 3]], seed: u64) {
    let tris = faces.iter().map(|f| Triangle { v: f.map(|i| pos[i as usize]) }).collect();
    let prims = Arc::new(Primitives { triangles: tris, spheres: Vec::new() });
    let rays = front_facing_rays(&prims, seed, MIN_COS);
    let tol = tolerance(&prims);
    assert!(rays.len() > 1000, "{label}: only {} aimed rays", rays.len());
    for cfg in native_variants() {
        let (c, a) = leaks(&prims, &rays, &cfg, tol);
        assert_eq!((c, a), (0, 0), "{label} {}: rays passed through (closest, any-hit)", cfg.label());
    }
    // For comparison only: the non-watertight test may or may not leak on these rays.
    let mt = AccelConfig { triangle_test: TriangleTest::MollerTrumbore, ..Default::default() };
    let (c, _) = leaks(&prims, &rays, &mt, tol);
    println!(
        "{label}: {} rays through edges and vertices (t tolerance {tol:.1e}), 0 leaks watertight, {c} with Moller-Trumbore",
        rays.len()
    );
}

#[test]
fn bunny_edges_and_vertices_do_not_leak() {
    let m = load_mesh("bunny");
    check("bunny", &m.positions, &m.indices, 1);
}

#[test]
fn icosphere_edges_and_vertices_do_not_leak() {
    let (pos, faces) = icosphere(4);
    check("icosphere", &pos, &faces, 2);
    // The same sphere far from the origin and tiny: coordinates with few significant bits left.
    let moved: Vec<Vec3> = pos.iter().map(|p| *p * 1e-3 + Vec3::splat(100.0)).collect();
    check("icosphere (1e-3 at 100)", &moved, &faces, 3);
}
