//! The batch entry points (`Tracer::intersect_batch` / `occluded_batch`: the
//! 8-ray packets of the 8-wide tree, ray by ray elsewhere) return exactly the
//! brute-force answers, bit for bit, on coherent camera rays (whole packets
//! take the packet paths, including one triangle against eight rays), on
//! their shadow rays, and on the incoherent parity rays (packets with mixed
//! direction signs), for every builder and traversal, the portable code, and
//! scenes with spheres among the triangles. Embree's batches (`rtcIntersect8`
//! / `rtcOccluded8`) give its single-ray answers.

mod common;

use std::sync::Arc;

use common::{cornell, load_mesh, spheres};
use glam::Vec3;
use rtdiff::accel::{BruteForce, Tracer};
use rtdiff::backends::{AccelConfig, build_tracer, native_variants};
use rtdiff::bvh::BvhTracer;
use rtdiff::bvh::WalkIsa;
use rtdiff::camera::Camera;
use rtdiff::geometry::offset::SpawnOffset;
use rtdiff::geometry::{Hit, Primitives, Ray, Sphere, TriangleTest};

fn bits(h: &Option<Hit>) -> Option<(u32, u32, u32, u32)> {
    h.map(|h| (h.t.to_bits(), h.prim, h.u.to_bits(), h.v.to_bits()))
}

/// Camera rays of the default view, their shadow rays towards a light, and random rays.
fn rays_for(prims: &Arc<Primitives>) -> Vec<Ray> {
    let brute = BruteForce::new(prims.clone(), TriangleTest::Watertight);
    let camera = Camera::default_view(96, 96).pixel_centre_rays();
    let hits: Vec<Option<Hit>> = camera.iter().map(|r| brute.intersect(r)).collect();
    let shadow = rtdiff::rays::shadow_rays(prims, &camera, &hits, Vec3::new(-1.0, 1.0, -1.0), SpawnOffset::Robust);
    let mut rays = camera;
    rays.extend(shadow);
    rays.extend(rtdiff::rays::mixed_rays(prims, 6_000, 17));
    rays.extend(diagonal_fans(prims));
    rays
}

/// Camera-like fans of rays around the two space diagonals (towards `-(1, 1,
/// 1)` and `+(1, 1, 1)`), rows of 8 neighbouring rays aimed at the scene:
/// their largest direction component changes from ray to ray, so packets
/// whose rays need different axis permutations in the watertight test reach
/// the same leaves together (the packet test's per-lane permutations), with
/// direction components all negative in one fan (the permutation's swap) and
/// all positive in the other. Plus their shadow rays towards a light on the
/// diagonal.
fn diagonal_fans(prims: &Arc<Primitives>) -> Vec<Ray> {
    let b = (0..prims.len()).map(|i| prims.bounds(i)).reduce(|a, b| a.union(b)).expect("a non-empty scene");
    let (c, r) = (b.center(), b.extent().length() * 0.5);
    let diag = Vec3::ONE.normalize();
    let (u, v) = (Vec3::new(1.0, -1.0, 0.0).normalize(), Vec3::new(1.0, 1.0, -2.0).normalize());
    let mut fans = Vec::new();
    for side in [1.0f32, -1.0] {
        let origin = c + side * 2.5 * r * diag;
        for y in 0..32 {
            for x in 0..64 {
                let (dx, dy) = ((x as f32 - 31.5) / 160.0, (y as f32 - 15.5) / 80.0);
                fans.push(Ray::new(origin, (-side * diag + dx * u + dy * v).normalize()));
            }
        }
    }
    let brute = BruteForce::new(prims.clone(), TriangleTest::Watertight);
    let hits: Vec<Option<Hit>> = fans.iter().map(|r| brute.intersect(r)).collect();
    let light = c + 3.0 * r * diag;
    let shadow = rtdiff::rays::shadow_rays(prims, &fans, &hits, light, SpawnOffset::Robust);
    fans.extend(shadow);
    fans
}

fn check_batches(label: &str, t: &dyn Tracer, rays: &[Ray], truth: &[Option<Hit>]) {
    let mut closest = vec![None; rays.len()];
    let mut any = vec![false; rays.len()];
    t.intersect_batch(rays, &mut closest);
    t.occluded_batch(rays, &mut any);
    for (i, want) in truth.iter().enumerate() {
        assert_eq!(bits(&closest[i]), bits(want), "{label} {}: ray {i} {:?}", t.name(), rays[i]);
        assert_eq!(any[i], want.is_some(), "{label} {}: any-hit of ray {i} {:?}", t.name(), rays[i]);
    }
}

fn check_scene(label: &str, prims: Primitives) {
    let prims = Arc::new(prims);
    let rays = rays_for(&prims);
    for test in [TriangleTest::Watertight, TriangleTest::MollerTrumbore] {
        let brute = BruteForce::new(prims.clone(), test);
        let truth: Vec<Option<Hit>> = rays.iter().map(|r| brute.intersect(r)).collect();
        assert!(truth.iter().filter(|h| h.is_some()).count() > rays.len() / 5, "{label}: too few hits");
        for cfg in native_variants() {
            let cfg = AccelConfig { triangle_test: test, ..cfg };
            check_batches(label, build_tracer(prims.clone(), &cfg).unwrap().as_ref(), &rays, &truth);
        }
        for &isa in &WalkIsa::supported()[1..] {
            let mut narrower = BvhTracer::new(&prims, &AccelConfig { triangle_test: test, ..Default::default() });
            assert!(narrower.force_isa(isa));
            check_batches(&format!("{label} ({} walks)", isa.name()), &narrower, &rays, &truth);
        }
    }
}

#[test]
fn suzanne() {
    check_scene("suzanne", load_mesh("suzanne").to_primitives());
}

#[test]
fn bunny() {
    check_scene("bunny", load_mesh("bunny").to_primitives());
}

#[test]
fn cornell_box() {
    check_scene("cornell", cornell(1.0, 0.0));
}

#[test]
fn spheres_alone_and_among_triangles() {
    check_scene("spheres", spheres());
    let mut mixed = load_mesh("suzanne").to_primitives();
    let b = mixed.world_bounds();
    mixed.spheres = (0..12)
        .map(|i| Sphere { center: b.min + (b.max - b.min) * (i as f32 / 12.0), radius: 0.05 * (b.max - b.min).x })
        .collect();
    check_scene("suzanne with spheres", mixed);
}

#[cfg(feature = "embree")]
#[test]
fn embree_batches_give_its_single_ray_answers() {
    use rtdiff::backends::{Backend, EmbreeMode, EmbreeQuality};
    let prims = Arc::new(load_mesh("bunny").to_primitives());
    let rays = rays_for(&prims);
    for mode in [EmbreeMode::Robust, EmbreeMode::Default] {
        let cfg = AccelConfig {
            backend: Backend::Embree,
            embree_quality: EmbreeQuality::Medium,
            embree_mode: mode,
            ..Default::default()
        };
        let t = build_tracer(prims.clone(), &cfg).unwrap();
        let truth: Vec<Option<Hit>> = rays.iter().map(|r| t.intersect(r)).collect();
        check_batches("bunny", t.as_ref(), &rays, &truth);
    }
}
