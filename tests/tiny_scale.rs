//! Geometry at the bottom of single precision's range, every ray judged by the
//! exact arbiter: closed meshes scaled down to 1e-17 .. 1e-40 (where the
//! watertight test's edge functions, `det` and `t e_i z_i` products fall into
//! the subnormals), and a mesh flattened to 1e-30 in one axis crossed by
//! axis-aligned rays (the corpus' mangled `multiWordName.bin.stl`, where the
//! double-precision fallback's `t` bound refused true hits; docs/campaigns.md).
//! Every native walk (8-wide on each instruction set this CPU runs, single
//! rays and batches; the binary walk; brute force) must be exact on every ray
//! that is not ill-conditioned.

mod common;

use std::sync::Arc;

use glam::Vec3;
use rtdiff::accel::Tracer;
use rtdiff::accel::brute::BruteForce;
use rtdiff::backends::{AccelConfig, Traversal};
use rtdiff::bvh::{BvhTracer, WalkIsa};
use rtdiff::geometry::primitives::{Primitives, Triangle};
use rtdiff::geometry::{Hit, Ray, TriangleTest};
use rtdiff::rng::Pcg32;
use rtdiff::verify::hits::arbiter::{Arbiter, Verdict, replay_line};

/// Rays per case.
const RAYS: usize = 1000;

/// An icosphere (320 triangles) with its vertices multiplied by `scale` axis by axis.
fn sphere(scale: Vec3) -> Primitives {
    let (pos, idx) = common::icosphere(2);
    let triangles = idx.iter().map(|t| Triangle { v: t.map(|i| pos[i as usize] * scale) }).collect();
    Primitives { triangles, spheres: vec![] }
}

/// Rays from outside the mesh at interior points of random triangles: from
/// random directions, and along a random axis (direction `+-1` on it, 0 on
/// the others; `flat_axis` excluded).
fn rays(prims: &Primitives, scale: f32, flat_axis: Option<usize>, rng: &mut Pcg32) -> Vec<Ray> {
    (0..RAYS)
        .map(|i| {
            let t = &prims.triangles[rng.below(prims.triangles.len() as u32) as usize];
            let (b1, b2) = (rng.range(0.05, 0.9), rng.next_f32());
            let b2 = b2 * (0.95 - b1);
            let target = t.v[0] + (t.v[1] - t.v[0]) * b1 + (t.v[2] - t.v[0]) * b2;
            let dir = if i % 2 == 0 && flat_axis.is_none() {
                rng.unit_vector()
            } else {
                let axes: Vec<usize> = (0..3).filter(|&a| Some(a) != flat_axis).collect();
                let mut d = Vec3::ZERO;
                d[axes[rng.below(axes.len() as u32) as usize]] = if rng.next_f32() < 0.5 { -1.0 } else { 1.0 };
                d
            };
            Ray::new(target - dir * (3.0 * scale), dir)
        })
        .collect()
}

/// The native tracers under test, by name.
fn tracers(prims: &Arc<Primitives>) -> Vec<(String, Box<dyn Tracer>)> {
    let mut out: Vec<(String, Box<dyn Tracer>)> = Vec::new();
    for isa in WalkIsa::supported() {
        let mut t = BvhTracer::new(prims, AccelConfig::default().bvh());
        assert!(t.force_isa(isa));
        out.push((format!("fast {isa:?}"), Box::new(t)));
    }
    let basic = AccelConfig { traversal: Traversal::Basic, ..Default::default() };
    out.push(("basic".into(), Box::new(BvhTracer::new(prims, basic.bvh()))));
    out.push(("brute".into(), Box::new(BruteForce::new(prims.clone(), TriangleTest::Watertight))));
    out
}

/// Judge every tracer on `rays` (single rays and one batch); the failures, and
/// how many well-conditioned rays hit something.
fn judge(case: &str, prims: Primitives, rays: &[Ray]) -> (Vec<String>, usize) {
    let prims = Arc::new(prims);
    let arb = Arbiter::new(prims.clone());
    let truths: Vec<_> = rays.iter().map(|r| arb.truth(r)).collect();
    let mut failures = Vec::new();
    for (name, t) in tracers(&prims) {
        let mut batch: Vec<Option<Hit>> = vec![None; rays.len()];
        t.intersect_batch(rays, &mut batch);
        for (i, (r, truth)) in rays.iter().zip(&truths).enumerate() {
            if truth.ill_conditioned() {
                continue;
            }
            for (how, hit) in [("single", t.intersect(r)), ("batch", batch[i])] {
                let v = arb.judge(r, truth, hit.map(|h| h.prim));
                if v != Verdict::Exact && failures.len() < 20 {
                    failures.push(format!(
                        "{case}: {name} ({how}) ray {i}: {v:?}, returned {:?}, exact {:?} at {:?}: {}",
                        hit.map(|h| h.prim),
                        truth.prims,
                        truth.t_f64(),
                        replay_line(r)
                    ));
                }
            }
            let blocked = !truth.prims.is_empty();
            if t.occluded(r) != blocked && failures.len() < 20 {
                failures.push(format!("{case}: {name} occluded ray {i}: {}", replay_line(r)));
            }
        }
    }
    let hits = truths.iter().filter(|t| !t.ill_conditioned() && !t.prims.is_empty()).count();
    (failures, hits)
}

#[test]
fn meshes_scaled_into_the_subnormals_are_traced_exactly() {
    let mut rng = Pcg32::new(49, 1);
    let mut failures = Vec::new();
    for scale in [1.0f32, 1e-17, 1e-18, 1e-19, 1e-20, 1e-21, 1e-22, 1e-30, 1e-40] {
        let prims = sphere(Vec3::splat(scale));
        let rays = rays(&prims, scale, None, &mut rng);
        let (f, hits) = judge(&format!("scale {scale:e}"), prims, &rays);
        assert!(hits > RAYS / 2, "scale {scale:e}: only {hits} well-conditioned hits");
        failures.extend(f);
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn a_mesh_flattened_to_1e_30_is_traced_exactly_by_axis_aligned_rays() {
    let mut rng = Pcg32::new(49, 2);
    let mut failures = Vec::new();
    for (axis, thickness) in [(1, 1e-30f32), (0, 1e-30), (2, 1e-36)] {
        let mut scale = Vec3::ONE;
        scale[axis] = thickness;
        let prims = sphere(scale);
        let rays = rays(&prims, 1.0, Some(axis), &mut rng);
        let (f, hits) = judge(&format!("axis {axis} flattened to {thickness:e}"), prims, &rays);
        assert!(hits > RAYS / 2, "axis {axis}: only {hits} well-conditioned hits");
        failures.extend(f);
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
