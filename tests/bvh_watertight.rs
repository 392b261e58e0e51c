//! Watertightness: rays aimed at points on shared edges and at shared
//! vertices of closed meshes (the bunny's interior edges, a generated
//! icosphere) never pass through the surface.

mod common;

use std::collections::HashMap;
use std::sync::Arc;

use common::{icosphere, load_mesh};
use glam::Vec3;
use rayon::prelude::*;
use rtdiff::backends::{AccelConfig, Builder, Traversal, build_tracer};
use rtdiff::geometry::{Primitives, Ray, Triangle, TriangleTest};
use rtdiff::rng::Pcg32;

/// Smallest cosine between an aimed ray and the faces meeting at its target:
/// rays cross the surface clearly instead of grazing it.
const MIN_COS: f32 = 0.5;

/// Rays aimed at edge points (two per interior edge, plus the midpoint) and at
/// vertices whose whole fan is interior, from outside along a direction on
/// the front side of every face meeting there. Each ray is `o + t (p - o)`,
/// so the surface point it aims at lies at `t = 1`.
fn aimed_rays(pos: &[Vec3], faces: &[[u32; 3]], seed: u64) -> Vec<Ray> {
    let unit_n: Vec<Vec3> = faces
        .iter()
        .map(|f| (pos[f[1] as usize] - pos[f[0] as usize]).cross(pos[f[2] as usize] - pos[f[0] as usize]).normalize())
        .collect();
    let mut edges: HashMap<(u32, u32), Vec<usize>> = HashMap::new();
    for (fi, f) in faces.iter().enumerate() {
        for k in 0..3 {
            let (a, b) = (f[k], f[(k + 1) % 3]);
            edges.entry((a.min(b), a.max(b))).or_default().push(fi);
        }
    }
    let lo = pos.iter().fold(Vec3::INFINITY, |a, &p| a.min(p));
    let hi = pos.iter().fold(Vec3::NEG_INFINITY, |a, &p| a.max(p));
    let dist = (hi - lo).length(); // origins one mesh diameter away from their target
    let mut rng = Pcg32::new(seed, 5);
    let mut rays = Vec::new();
    // A direction `w` well in front of every face in `fs` (cosine > MIN_COS), if the average normal is one.
    let front = |fs: &[usize], rng: &mut Pcg32| -> Option<Vec3> {
        let avg = fs.iter().map(|&f| unit_n[f]).sum::<Vec3>().normalize_or_zero();
        if fs.iter().any(|&f| unit_n[f].dot(avg) <= MIN_COS) {
            return None;
        }
        let w = (avg + 0.3 * rng.unit_vector()).normalize_or_zero();
        Some(if fs.iter().all(|&f| unit_n[f].dot(w) > MIN_COS) { w } else { avg })
    };
    let mut keys: Vec<_> = edges.keys().copied().collect();
    keys.sort_unstable();
    let mut interior_vertex = vec![true; pos.len()];
    for (&(a, b), fs) in &edges {
        if fs.len() != 2 {
            interior_vertex[a as usize] = false;
            interior_vertex[b as usize] = false;
        }
    }
    for (a, b) in keys {
        let fs = &edges[&(a, b)];
        if fs.len() != 2 {
            continue;
        }
        let (pa, pb) = (pos[a as usize], pos[b as usize]);
        for s in [0.5, rng.next_f32(), rng.next_f32()] {
            let p = pa + s * (pb - pa);
            if let Some(w) = front(fs, &mut rng) {
                let o = p + dist * w;
                rays.push(Ray::new(o, p - o));
            }
        }
    }
    let mut fans: Vec<Vec<usize>> = vec![Vec::new(); pos.len()];
    for (fi, f) in faces.iter().enumerate() {
        for &v in f {
            fans[v as usize].push(fi);
        }
    }
    for (v, fs) in fans.iter().enumerate() {
        if interior_vertex[v]
            && !fs.is_empty()
            && let Some(w) = front(fs, &mut rng)
        {
            let o = pos[v] + dist * w;
            rays.push(Ray::new(o, pos[v] - o));
        }
    }
    rays
}

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
/// `2 sqrt(3) ulp / MIN_COS`; divided by the ray length this is a distance in
/// `t`. Twice that, and never below 1e-4 (800 ulps of 1, covering the rounding
/// of `t` itself). A leaking ray instead travels on to another sheet of the
/// surface, at least a chord `2 r MIN_COS` further for the sphere.
fn tolerance(pos: &[Vec3], ray_len: f32) -> f32 {
    let max_coord = pos.iter().fold(0.0f32, |m, p| m.max(p.abs().max_element()));
    let ulp = max_coord * f32::EPSILON;
    (2.0 * 2.0 * 3f32.sqrt() * ulp / MIN_COS / ray_len).max(1e-4)
}

fn check(label: &str, pos: &[Vec3], faces: &[[u32; 3]], seed: u64) {
    let rays = aimed_rays(pos, faces, seed);
    let lo = pos.iter().fold(Vec3::INFINITY, |a, &p| a.min(p));
    let hi = pos.iter().fold(Vec3::NEG_INFINITY, |a, &p| a.max(p));
    let tol = tolerance(pos, (hi - lo).length());
    assert!(rays.len() > 1000, "{label}: only {} aimed rays", rays.len());
    let tris = faces.iter().map(|f| Triangle { v: f.map(|i| pos[i as usize]) }).collect();
    let prims = Arc::new(Primitives { triangles: tris, spheres: Vec::new() });
    for builder in [Builder::Median, Builder::SahVolume, Builder::Sah] {
        for traversal in [Traversal::Basic, Traversal::PriorityQueue, Traversal::Fast] {
            let cfg = AccelConfig { builder, traversal, ..Default::default() };
            let (c, a) = leaks(&prims, &rays, &cfg, tol);
            assert_eq!((c, a), (0, 0), "{label} {builder:?}/{traversal:?}: rays passed through (closest, any-hit)");
        }
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
