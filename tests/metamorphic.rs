//! Metamorphic hit tests: transform a scene and its rays in a way whose
//! effect on every hit is known exactly, and check the native tracer (and
//! Embree, and the exact arbiter) against that effect over the adversarial
//! ray sets (edges, vertices, grazing, axis-parallel).
//!
//! The mesh is normalised to the unit sphere and its coordinates rounded to
//! multiples of 2^-12, so that translations by multiples of 2^-12, scaling by
//! powers of two, quarter-turn rotations (signed coordinate permutations) and
//! the split of a triangle at the point `(v0 + v1) / 4 + v2 / 2` are all
//! exact in single precision. Expected effects:
//!
//! | transform | primitive | distance |
//! |---|---|---|
//! | rotate by quarter turns | same | same (rounding aside: the test's axes change) |
//! | scale by `2^k` (positions, origins) | same | `2^k t`, bit for bit |
//! | permute primitives | `perm(p)` | bit for bit |
//! | duplicate every primitive | the original (ties keep the lowest id) | bit for bit |
//! | split every triangle into three | one of its three pieces | same (rounding aside) |
//! | translate by `T` (origins rounded) | same unless the ray's margin is below 2 units | same (rounding aside) |
//!
//! A native answer differing from the expected one is accepted only where the
//! arbiter finds the ray ill-conditioned (in the original or the transformed
//! scene) or both answers exact (an exact tie); "rounding aside" distances are
//! checked against the parity harness's bound. The arbiter's own exact answers
//! are checked to transform exactly as the table says, on a sample of rays.

use std::sync::Arc;

use glam::Vec3;
use rtdiff::accel::Tracer;
use rtdiff::backends::{AccelConfig, build_tracer};
use rtdiff::geometry::{Hit, Primitives, Ray, Triangle};
use rtdiff::rays::{RayContext, SetKind};
use rtdiff::verify::hits::arbiter::{Arbiter, Truth, Verdict, replay_line};

/// Rays per adversarial set.
const RAYS: usize = 6000;
/// Rays per set whose exact answers are compared between scenes.
const EXACT_SAMPLE: usize = 150;

fn quantised_mesh(name: &str) -> Arc<Primitives> {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("assets").join(name);
    let mut mesh = rtdiff::mesh::load_mesh(&path, rtdiff::mesh::Content::Geometry)
        .unwrap_or_else(|e| panic!("{e} (run scripts/fetch-assets.sh)"));
    rtdiff::geometry::normalize::normalize_to_unit_sphere(&mut mesh.positions);
    for p in &mut mesh.positions {
        *p = (*p * 4096.0).round() / 4096.0;
    }
    Arc::new(mesh.to_primitives())
}

struct Transform {
    name: &'static str,
    prims: Arc<Primitives>,
    ray: Box<dyn Fn(&Ray) -> Ray>,
    /// Original id of a transformed primitive.
    back: Box<dyn Fn(u32) -> u32>,
    /// `t` factor, and whether native distances must match bit for bit.
    scale: f32,
    bitwise: bool,
    /// Exact answers must map exactly (all but translation, whose rounded origins change them).
    exact_map: bool,
}

fn map_prims(p: &Primitives, f: impl Fn(Vec3) -> Vec3) -> Arc<Primitives> {
    Arc::new(Primitives {
        triangles: p.triangles.iter().map(|t| Triangle { v: t.v.map(&f) }).collect(),
        spheres: vec![],
    })
}

fn transforms(base: &Arc<Primitives>) -> Vec<Transform> {
    let n = base.triangles.len() as u32;
    let id = |p: u32| p;
    let mut v = Vec::new();
    // Quarter turns: 90 degrees about z, then 270 degrees about x.
    let rz = |p: Vec3| Vec3::new(-p.y, p.x, p.z);
    v.push(Transform {
        name: "rotate z 90",
        prims: map_prims(base, rz),
        ray: Box::new(move |r: &Ray| Ray::with_range(rz(r.origin), rz(r.dir), r.t_min, r.t_max)),
        back: Box::new(id),
        scale: 1.0,
        bitwise: false,
        exact_map: true,
    });
    let rx = |p: Vec3| Vec3::new(p.x, p.z, -p.y);
    v.push(Transform {
        name: "rotate x 270",
        prims: map_prims(base, rx),
        ray: Box::new(move |r: &Ray| Ray::with_range(rx(r.origin), rx(r.dir), r.t_min, r.t_max)),
        back: Box::new(id),
        scale: 1.0,
        bitwise: false,
        exact_map: true,
    });
    for s in [8.0f32, 1.0 / 64.0] {
        v.push(Transform {
            name: if s > 1.0 { "scale 2^3" } else { "scale 2^-6" },
            prims: map_prims(base, move |p| p * s),
            ray: Box::new(move |r: &Ray| Ray::with_range(r.origin * s, r.dir, r.t_min * s, r.t_max * s)),
            back: Box::new(id),
            scale: s,
            bitwise: true,
            exact_map: true,
        });
    }
    // A fixed pseudo-random permutation: new[perm[i]] = old[i].
    let mut perm: Vec<u32> = (0..n).collect();
    let mut rng = rtdiff::rays::Rng::new(12);
    for i in (1..perm.len()).rev() {
        perm.swap(i, rng.below(i + 1));
    }
    let mut inv = vec![0u32; n as usize];
    let mut tris = base.triangles.clone();
    for (i, &p) in perm.iter().enumerate() {
        tris[p as usize] = base.triangles[i];
        inv[p as usize] = i as u32;
    }
    v.push(Transform {
        name: "permute",
        prims: Arc::new(Primitives { triangles: tris, spheres: vec![] }),
        ray: Box::new(|r: &Ray| *r),
        back: Box::new(move |p| inv[p as usize]),
        scale: 1.0,
        bitwise: true,
        exact_map: true,
    });
    let mut tris = base.triangles.clone();
    tris.extend_from_slice(&base.triangles);
    v.push(Transform {
        name: "duplicate",
        prims: Arc::new(Primitives { triangles: tris, spheres: vec![] }),
        ray: Box::new(|r: &Ray| *r),
        back: Box::new(move |p| p % n),
        scale: 1.0,
        bitwise: true,
        exact_map: true,
    });
    // Split: (v0, v1, c), (v1, v2, c), (v2, v0, c) with c = v0/4 + v1/4 + v2/2, exact and coplanar.
    let tris = base
        .triangles
        .iter()
        .flat_map(|t| {
            let [a, b, c] = t.v;
            let m = a * 0.25 + b * 0.25 + c * 0.5;
            [Triangle { v: [a, b, m] }, Triangle { v: [b, c, m] }, Triangle { v: [c, a, m] }]
        })
        .collect();
    v.push(Transform {
        name: "split in three",
        prims: Arc::new(Primitives { triangles: tris, spheres: vec![] }),
        ray: Box::new(|r: &Ray| *r),
        back: Box::new(|p| p / 3),
        scale: 1.0,
        bitwise: false,
        exact_map: true,
    });
    let t = Vec3::new(0.375, -1.25, 2.0);
    v.push(Transform {
        name: "translate",
        prims: map_prims(base, move |p| p + t),
        ray: Box::new(move |r: &Ray| Ray::with_range(r.origin + t, r.dir, r.t_min, r.t_max)),
        back: Box::new(id),
        scale: 1.0,
        bitwise: false,
        exact_map: false,
    });
    v
}

fn trace(tracer: &dyn Tracer, rays: &[Ray]) -> Vec<Option<Hit>> {
    rays.iter().map(|r| tracer.intersect(r)).collect()
}

/// The parity harness's bound on a distance difference (K = 32 units).
fn t_bound(arb: &Arbiter, ray: &Ray, h: &Hit) -> f64 {
    32.0 * arb.unit_bounds(ray, h.prim, h.t as f64).0
}

struct Judged {
    truth: Truth,
    verdict: Verdict,
}

fn judge(arb: &Arbiter, ray: &Ray, h: &Option<Hit>) -> Judged {
    let truth = arb.truth(ray);
    let verdict = arb.judge(ray, &truth, h.map(|h| h.prim));
    Judged { truth, verdict }
}

fn check_mesh(name: &str) {
    let base = quantised_mesh(name);
    let ctx = RayContext::with_defaults(base.clone());
    let native_cfg = AccelConfig::default();
    let native = build_tracer(base.clone(), &native_cfg).unwrap();
    let oracle_for = |p: Arc<Primitives>| build_tracer(p, &native_cfg);
    let base_arb = Arbiter::new(base.clone());
    let transforms = transforms(&base);
    let mut failures = Vec::new();
    for kind in [SetKind::Edges, SetKind::Vertices, SetKind::Grazing, SetKind::Axis] {
        let set = rtdiff::rays::generate(&ctx, kind, 2026, RAYS, native.as_ref(), &oracle_for).unwrap().remove(0);
        let hits = trace(native.as_ref(), &set.rays);
        for tf in &transforms {
            let tracer = build_tracer(tf.prims.clone(), &native_cfg).unwrap();
            let arb = Arbiter::new(tf.prims.clone());
            let rays: Vec<Ray> = set.rays.iter().map(|r| (tf.ray)(r)).collect();
            let got = trace(tracer.as_ref(), &rays);
            #[cfg(feature = "embree")]
            let embree = {
                let cfg = AccelConfig { backend: rtdiff::backends::Backend::Embree, ..Default::default() };
                trace(build_tracer(tf.prims.clone(), &cfg).unwrap().as_ref(), &rays)
            };
            let mut mismatches = 0;
            for i in 0..rays.len() {
                let (h0, h1) = (hits[i], got[i]);
                let same_prim = h0.map(|h| h.prim) == h1.map(|h| (tf.back)(h.prim));
                let dist_ok = match (h0, h1) {
                    (Some(a), Some(b)) if same_prim => {
                        if tf.bitwise {
                            b.t == a.t * tf.scale && b.u == a.u && b.v == a.v
                        } else {
                            (b.t as f64 - a.t as f64 * tf.scale as f64).abs() <= t_bound(&arb, &rays[i], &b)
                        }
                    }
                    _ => true,
                };
                let mut explained = same_prim && dist_ok;
                if !explained && dist_ok {
                    // A different primitive: fine on an exact tie or an ill-conditioned ray.
                    mismatches += 1;
                    let j0 = judge(&base_arb, &set.rays[i], &h0);
                    let j1 = judge(&arb, &rays[i], &h1);
                    let both_exact = j0.verdict == Verdict::Exact && j1.verdict == Verdict::Exact;
                    let ill = |j: &Judged| if tf.exact_map { j.truth.ill_conditioned() } else { j.truth.margin <= 2.0 };
                    // Both exact: an exact tie (the exact answer of the transformed
                    // ray holds the original answer too), which for the exact
                    // transforms is the only way both can be exact.
                    let tie = h0.is_some_and(|a| j1.truth.prims.iter().any(|&p| (tf.back)(p) == a.prim));
                    explained = (both_exact && (tf.exact_map || tie)) || ill(&j0) || ill(&j1);
                }
                if !explained {
                    failures.push(format!(
                        "{name} {} {}: ray {i}: {:?} -> {:?} ({})",
                        tf.name,
                        set.name,
                        h0,
                        h1,
                        replay_line(&set.rays[i])
                    ));
                }
                #[cfg(feature = "embree")]
                if embree[i].map(|h| h.prim) != h1.map(|h| h.prim) {
                    // Embree as a second oracle: where it differs, native must be
                    // exact unless the ray is ill-conditioned.
                    let j1 = judge(&arb, &rays[i], &h1);
                    if j1.verdict != Verdict::Exact && !j1.truth.ill_conditioned() {
                        failures.push(format!(
                            "{name} {} {}: ray {i}: native {:?} not exact, embree {:?}: {}",
                            tf.name,
                            set.name,
                            h1,
                            embree[i],
                            replay_line(&rays[i])
                        ));
                    }
                }
            }
            // The arbiter's exact answers transform exactly.
            if tf.exact_map {
                for (i, (r0, r1)) in set.rays.iter().zip(&rays).enumerate().take(EXACT_SAMPLE) {
                    let t0 = base_arb.truth(r0);
                    let t1 = arb.truth(r1);
                    let mut mapped: Vec<u32> = t1.prims.iter().map(|&p| (tf.back)(p)).collect();
                    mapped.sort_unstable();
                    mapped.dedup();
                    let dist = |t: &Truth| t.t_f64().map(|x| x.to_bits());
                    let scaled = t0.t_f64().map(|x| (x * tf.scale as f64).to_bits());
                    if mapped != t0.prims || dist(&t1) != scaled {
                        failures.push(format!(
                            "{name} {} {}: exact answer of ray {i} {:?} at {:?} became {:?} at {:?}",
                            tf.name,
                            set.name,
                            t0.prims,
                            t0.t_f64(),
                            t1.prims,
                            t1.t_f64()
                        ));
                    }
                }
            }
            eprintln!("{name} {:<15} {:<9}: {mismatches} primitive changes, all judged", tf.name, set.name);
        }
    }
    assert!(failures.is_empty(), "{} failures:\n{}", failures.len(), failures.join("\n"));
}

#[test]
fn suzanne_metamorphic() {
    check_mesh("suzanne.obj");
}

#[test]
fn teapot_metamorphic() {
    check_mesh("teapot.obj");
}
