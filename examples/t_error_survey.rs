//! How far the watertight test's single-precision distance strays from the
//! exact one, against the estimates that decide when it falls back to double
//! precision (`geometry::triangle::watertight_t_spread_error` and friends).
//!
//! For each mesh and ray set (the race's camera, incoherent and shadow rays and
//! the parity sets of `rtdiff rays`), every closest hit is recomputed in single
//! precision without any fallback and compared with the exact hit
//! ([`Arbiter::evaluate`]) in units of the parity bound
//! (`verify::hits::bounds`). For each fallback rule: the share of hits it
//! sends to double precision, and among those it keeps in single precision
//! the largest error over the bound and how many exceed it.
//!
//! `cargo run --release --example t_error_survey -- [rays per set] mesh...`

use std::sync::Arc;

use glam::{DVec3, Vec3};
use rtdiff::backends::{AccelConfig, build_tracer};
use rtdiff::geometry::offset::gamma;
use rtdiff::geometry::triangle::{
    E_FLOOR, SIGN_MARGIN, T_SPREAD_MAX, WatertightRay, watertight_e_error, watertight_t_error,
};
use rtdiff::geometry::{Primitives, Ray};
use rtdiff::perf::bench::RaySets;
use rtdiff::rays::sets::{SetKind, generate};
use rtdiff::verify::hits::K_ROUNDING;
use rtdiff::verify::hits::arbiter::Arbiter;

const U: f32 = f32::EPSILON * 0.5;

/// The single-precision pipeline of `intersect_watertight` on one hit, with
/// the quantities each fallback rule reads. `None` when the test would fall
/// back for another reason (an uncertain sign, an unprovable `t`) or miss.
struct Sample {
    t: f32,
    /// `delta_e spread |1/det| / (u t)`: the rule in use.
    old: f32,
    /// The same over `u max(|o|_inf / |d|, t / sqrt 3)`, a lower bound of the parity bound's scale.
    old_o: f32,
    /// Product rounding only: `2 gamma(2) max_x max_y spread |1/det| / (u t)`.
    prod: f32,
    /// `delta_e spread |1/det|` over a lower bound of the parity bound: `32 u max(|o|, t |d|)_inf
    /// max(|grad t|_1 / sqrt 2, 1 / (sqrt 3 |d|_inf))`.
    grad: f32,
    /// The rule's term in units of `u t`, to compare with the error.
    term_ut: f32,
    /// Shear rounding through the plane's slope: `delta_xy (|Nx| + |Ny|) |1/det| / (u t)`.
    shear: f32,
}

fn sample(ray: &Ray, v: [Vec3; 3]) -> Option<Sample> {
    let wr = WatertightRay::new(ray.dir);
    let [kx, ky, kz] = wr.k;
    let s = wr.s;
    let sh = |p: Vec3| {
        let a = p - ray.origin;
        Vec3::new(a[kx] - s.x * a[kz], a[ky] - s.y * a[kz], s.z * a[kz])
    };
    let (a, b, c) = (sh(v[0]), sh(v[1]), sh(v[2]));
    let e0 = c.x * b.y - c.y * b.x;
    let e1 = a.x * c.y - a.y * c.x;
    let e2 = b.x * a.y - b.y * a.x;
    let max_xt = a.x.abs().max(b.x.abs()).max(c.x.abs());
    let max_yt = a.y.abs().max(b.y.abs()).max(c.y.abs());
    let max_zt = a.z.abs().max(b.z.abs()).max(c.z.abs());
    let de = watertight_e_error(max_xt, max_yt, max_zt);
    let min_e = e0.abs().min(e1.abs()).min(e2.abs());
    if min_e <= SIGN_MARGIN * de || min_e <= E_FLOOR {
        return None;
    }
    if (e0 < 0.0 || e1 < 0.0 || e2 < 0.0) && (e0 > 0.0 || e1 > 0.0 || e2 > 0.0) {
        return None;
    }
    let det = e0 + e1 + e2;
    let inv_det = 1.0 / det;
    let t = (e0 * a.z + e1 * b.z + e2 * c.z) * inv_det;
    if !(t >= ray.t_min && t <= ray.t_max) {
        return None;
    }
    if t <= watertight_t_error(a.to_array(), b.to_array(), c.to_array(), [e0, e1, e2], inv_det) {
        return None;
    }
    let spread = (a.z - t).abs() + (b.z - t).abs() + (c.z - t).abs();
    let (ba, ca) = (b - a, c - a);
    let nx = ba.y * ca.z - ba.z * ca.y;
    let ny = ba.z * ca.x - ba.x * ca.z;
    let delta_xy = gamma(5) * (max_xt.max(max_yt) + max_zt);
    let ut = U * t;
    let scale = U * (ray.origin.abs().max_element() / ray.dir.length()).max(t * (1.0 / 3f32.sqrt()));
    let dz = ray.dir.abs().max_element();
    let ro = ray.origin.abs().max_element() / dz;
    let g1 = nx.abs() + ny.abs();
    let lhs = de * spread;
    let rhs = 32.0 * U * ro.max(t) * (g1 * dz / 2f32.sqrt()).max(det.abs() / 3f32.sqrt());
    Some(Sample {
        t,
        grad: lhs / rhs,
        term_ut: de * spread * inv_det.abs() / ut,
        old: de * spread * inv_det.abs() / ut,
        old_o: de * spread * inv_det.abs() / scale,
        prod: 2.0 * gamma(2) * max_xt * max_yt * spread * inv_det.abs() / ut,
        shear: delta_xy * (nx.abs() + ny.abs()) * inv_det.abs() / ut,
    })
}

/// The parity bound on `t` (unit-free copy of `verify::hits::bounds`).
fn t_bound(ray: &Ray, t: f32, v: [Vec3; 3]) -> f64 {
    let [p0, p1, p2] = v.map(|p| p.as_dvec3());
    let n = (p1 - p0).cross(p2 - p0).normalize_or_zero();
    let d = ray.dir.as_dvec3();
    let c = (d.dot(n) / d.length()).abs().max(1e-300);
    let p = ray.at(t).as_dvec3();
    let mag = ray.origin.as_dvec3().abs().max_element() + p.abs().max_element();
    K_ROUNDING * (U as f64) * mag / c / d.length()
}

/// A fallback rule: a name and whether it sends a sample to double precision.
type Rule = (&'static str, Box<dyn Fn(&Sample) -> bool>);

fn rules() -> Vec<Rule> {
    let mut r: Vec<Rule> = vec![("old 256", Box::new(|s: &Sample| s.old > T_SPREAD_MAX / U))];
    for k in [1.0f32, 2.0, 4.0, 8.0] {
        let name: &'static str = Box::leak(format!("grad {k}").into_boxed_str());
        r.push((name, Box::new(move |s: &Sample| s.grad > k)));
    }
    r.push(("none", Box::new(move |_: &Sample| false)));
    r
}

fn main() -> rtdiff::Result<()> {
    let mut args: Vec<String> = std::env::args().skip(1).collect();
    let count: usize = args.first().and_then(|s| s.parse().ok()).unwrap_or(20_000);
    if args.first().is_some_and(|s| s.parse::<usize>().is_ok()) {
        args.remove(0);
    }
    let rules = rules();
    println!(
        "{:<12} {:<14} {:>7} | rule: fallback %, max err/bound kept, kept beyond 1, kept beyond 0.5",
        "mesh", "set", "hits"
    );
    for path in &args {
        let ctx = rtdiff::rays::load_context(std::path::Path::new(path))?;
        let prims = ctx.prims.clone();
        let cfg = AccelConfig::default();
        let tracer = build_tracer(prims.clone(), &cfg)?;
        let mut sets: Vec<(String, Arc<Primitives>, Vec<Ray>)> = Vec::new();
        let race = RaySets::framed(&prims, 256, count, tracer.as_ref());
        sets.push(("race-camera".into(), prims.clone(), race.primary.clone()));
        sets.push(("race-incoh".into(), prims.clone(), race.incoherent.clone()));
        sets.push(("race-shadow".into(), prims.clone(), race.shadow.clone()));
        let oracle_for = |p: Arc<Primitives>| build_tracer(p, &AccelConfig::default());
        for kind in SetKind::ALL {
            for s in generate(&ctx, kind, 7, count, tracer.as_ref(), &oracle_for)? {
                sets.push((s.name.clone(), s.prims.clone(), s.rays));
            }
        }
        let name = std::path::Path::new(path).file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
        for (set, p, rays) in sets {
            let tr = build_tracer(p.clone(), &cfg)?;
            let arb = Arbiter::new(p.clone());
            let mut fell = vec![0usize; rules.len()];
            let mut worst = vec![0f64; rules.len()];
            let mut beyond = vec![0usize; rules.len()];
            let mut half = vec![0usize; rules.len()];
            let mut n = 0usize;
            let mut err_per_term = 0f64;
            for r in &rays {
                let Some(h) = tr.intersect(r) else { continue };
                let Some(tri) = p.triangles.get(h.prim as usize) else { continue };
                let Some(s) = sample(r, tri.v) else { continue };
                n += 1;
                let exact = arb.evaluate(r, h.prim);
                let abs_err = (s.t as f64 - exact.t_f64).abs();
                let err = abs_err / t_bound(r, s.t, tri.v);
                if s.term_ut > 64.0 {
                    err_per_term = err_per_term.max(abs_err / (s.term_ut as f64 * (U as f64) * s.t as f64));
                }
                for (i, (_, rule)) in rules.iter().enumerate() {
                    if rule(&s) {
                        fell[i] += 1;
                    } else {
                        worst[i] = worst[i].max(err);
                        beyond[i] += usize::from(err > 1.0);
                        half[i] += usize::from(err > 0.5);
                    }
                }
            }
            let _ = DVec3::ZERO;
            print!("{name:<12} {set:<14} {n:>7} {err_per_term:.3} |");
            for (i, (rn, _)) in rules.iter().enumerate() {
                print!(
                    " {rn}: {:.2}% {:.2} {} {};",
                    100.0 * fell[i] as f64 / n.max(1) as f64,
                    worst[i],
                    beyond[i],
                    half[i]
                );
            }
            println!();
        }
    }
    Ok(())
}
