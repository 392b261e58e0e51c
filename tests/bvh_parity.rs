//! Every builder x traversal returns exactly the brute-force closest hit
//! (same distance bits, same primitive, same barycentrics) and any-hit agrees
//! with "a closest hit exists", on 100k rays per scene.

mod common;

use std::sync::Arc;

use common::{cornell, load_mesh, spheres};
use rayon::prelude::*;
use rtdiff::accel::{BruteForce, Tracer};
use rtdiff::backends::{AccelConfig, Traversal, build_tracer, native_variants};
use rtdiff::bvh::BvhTracer;
use rtdiff::bvh::WalkIsa;
use rtdiff::geometry::{Hit, Primitives, TriangleTest};
use rtdiff::rays::mixed_rays;

const RAYS: usize = 100_000;
/// Rays for the alternative (Moller-Trumbore) triangle test, which only
/// re-checks the shared leaf code on two traversals: a fifth of the set keeps
/// the suite's brute-force cost down.
const MT_RAYS: usize = 20_000;

fn same(a: &Option<Hit>, b: &Option<Hit>) -> bool {
    match (a, b) {
        (None, None) => true,
        (Some(a), Some(b)) => {
            a.t.to_bits() == b.t.to_bits()
                && a.prim == b.prim
                && a.u.to_bits() == b.u.to_bits()
                && a.v.to_bits() == b.v.to_bits()
        }
        _ => false,
    }
}

fn check_tracer(label: &str, tracer: &dyn Tracer, rays: &[rtdiff::geometry::Ray], truth: &[Option<Hit>]) {
    let (closest_bad, any_bad) = rays
        .par_iter()
        .zip(truth)
        .map(|(r, t)| {
            let h = tracer.intersect(r);
            (usize::from(!same(&h, t)), usize::from(tracer.occluded(r) != t.is_some()))
        })
        .reduce(|| (0, 0), |a, b| (a.0 + b.0, a.1 + b.1));
    if closest_bad > 0 {
        let i = rays.iter().zip(truth).position(|(r, t)| !same(&tracer.intersect(r), t)).unwrap();
        panic!(
            "{label} {}: {closest_bad} closest-hit mismatches of {}; first: ray {:?} got {:?} want {:?}",
            tracer.name(),
            rays.len(),
            rays[i],
            tracer.intersect(&rays[i]),
            truth[i]
        );
    }
    assert_eq!(any_bad, 0, "{label} {}: {any_bad} any-hit disagreements", tracer.name());
}

fn check_scene(label: &str, prims: Primitives, seed: u64) {
    let prims = Arc::new(prims);
    let all_rays = mixed_rays(&prims, RAYS, seed);
    for test in [TriangleTest::Watertight, TriangleTest::MollerTrumbore] {
        let rays = if test == TriangleTest::Watertight { &all_rays[..] } else { &all_rays[..MT_RAYS] };
        let brute = BruteForce::new(prims.clone(), test);
        let truth: Vec<Option<Hit>> = rays.par_iter().map(|r| brute.intersect(r)).collect();
        let hits = truth.iter().filter(|h| h.is_some()).count();
        // The ray mix aims two thirds of the rays at primitives: a scene where
        // almost nothing is hit would make the comparison vacuous.
        assert!(hits > rays.len() / 4, "{label}: only {hits} hits");
        let configs: Vec<AccelConfig> = if test == TriangleTest::Watertight {
            native_variants()
        } else {
            // The alternative triangle test goes through the same leaf code: check it on two paths.
            native_variants()
                .into_iter()
                .filter(|c| matches!(c.traversal, Traversal::Basic | Traversal::Fast))
                .map(|c| AccelConfig { triangle_test: test, ..c })
                .collect()
        };
        for cfg in configs {
            let tracer = build_tracer(prims.clone(), &cfg).unwrap();
            check_tracer(label, tracer.as_ref(), rays, &truth);
        }
        // The fast path's walks compiled for every narrower instruction set this CPU runs must agree
        // too (the portable one is the only one on CPUs without AVX2; AVX2 the widest without AVX-512).
        for &isa in &WalkIsa::supported()[1..] {
            let mut narrower = BvhTracer::new(&prims, &AccelConfig { triangle_test: test, ..Default::default() });
            assert!(narrower.force_isa(isa));
            check_tracer(&format!("{label} ({} walks)", isa.name()), &narrower, rays, &truth);
        }
        println!("{label} {test:?}: {hits} of {} rays hit; all variants identical to brute force", rays.len());
    }
}

#[test]
fn suzanne() {
    check_scene("suzanne", load_mesh("suzanne").to_primitives(), 1);
}

#[test]
fn teapot() {
    check_scene("teapot", load_mesh("teapot").to_primitives(), 2);
}

#[test]
fn bunny() {
    check_scene("bunny", load_mesh("bunny").to_primitives(), 3);
}

#[test]
fn dragon_res4() {
    check_scene("dragon_res4", load_mesh("dragon_res4").to_primitives(), 4);
}

#[test]
fn cornell_box() {
    check_scene("cornell", cornell(1.0, 0.0), 5);
}

#[test]
fn spheres_and_floor() {
    check_scene("spheres", spheres(), 6);
}

#[test]
fn empty_scene_has_no_hits() {
    let prims = Arc::new(Primitives::default());
    let r = rtdiff::geometry::Ray::new(glam::Vec3::ZERO, glam::Vec3::X);
    for cfg in native_variants() {
        let t = build_tracer(prims.clone(), &cfg).unwrap();
        assert!(t.intersect(&r).is_none() && !t.occluded(&r), "{}", t.name());
    }
}
