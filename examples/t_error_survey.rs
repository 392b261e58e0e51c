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
//! the largest error over the bound and how many exceed it; and the largest
//! error over the spread term wherever that term exceeds `64 u t`
//! (`err/term`). The rules: rtdiff's, the one before it (`2^8 u t`), one that
//! also bounds the cosine from the plane's slope, and none.
//!
//! `cargo run --release --example t_error_survey -- [rays per set] mesh...`

use std::sync::Arc;

use glam::Vec3;
use rtdiff::backends::{AccelConfig, build_tracer};
use rtdiff::geometry::triangle::{
    E_FLOOR, SIGN_MARGIN, WatertightRay, spread_scale, watertight_e_error, watertight_t_error, watertight_t_imprecise,
};
use rtdiff::geometry::{Hit, Primitives, Ray};
use rtdiff::perf::bench::RaySets;
use rtdiff::rays::sets::{SetKind, generate};
use rtdiff::verify::hits::arbiter::Arbiter;
use rtdiff::verify::hits::bounds;

const U: f32 = f32::EPSILON * 0.5;

/// The single-precision pipeline of `intersect_watertight` on one hit, with
/// the quantities each fallback rule reads. `None` when the test would fall
/// back for another reason (an uncertain sign, an unprovable `t`) or miss.
struct Sample {
    t: f32,
    /// The spread term `delta_e spread |1 / det|` in units of `u t`.
    old: f32,
    /// The rule in use (`geometry::triangle::watertight_t_imprecise`).
    now: bool,
    /// The spread term over a lower bound of the parity bound that keeps its
    /// cosine, from the plane's slope in the sheared frame: `32 u / sqrt 3
    /// max(ro, t) max(sqrt(3/2) |d|_inf (|N_x| + |N_y|), |det|) / |det|`.
    grad: f32,
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
    let dz = ray.dir.abs().max_element();
    let ro = spread_scale(ray, &wr);
    let slope = (nx.abs() + ny.abs()) * dz * 1.5f32.sqrt();
    Some(Sample {
        t,
        old: de * spread * inv_det.abs() / (U * t),
        now: watertight_t_imprecise(de, [a.z, b.z, c.z], t, det, ro),
        grad: de * spread / (32.0 / 3f32.sqrt() * U * ro.max(t) * slope.max(det.abs())),
    })
}

/// A fallback rule: a name and whether it sends a sample to double precision.
type Rule = (&'static str, Box<dyn Fn(&Sample) -> bool>);

fn rules() -> Vec<Rule> {
    vec![
        ("rtdiff", Box::new(|s: &Sample| s.now)),
        ("2^8 u t", Box::new(|s: &Sample| s.old > 256.0)),
        ("slope", Box::new(|s: &Sample| s.grad > 64.0 / (32.0 / 3f32.sqrt()))),
        ("none", Box::new(|_: &Sample| false)),
    ]
}

/// Print one line on stdout; a closed pipe (`| head`) ends the program
/// quietly, another write error with a message and exit status 1.
fn line(text: String) {
    use std::io::Write;
    let mut out = std::io::stdout().lock();
    if let Err(e) = writeln!(out, "{text}") {
        if e.kind() == std::io::ErrorKind::BrokenPipe {
            std::process::exit(0);
        }
        eprintln!("t_error_survey: cannot write to stdout: {e}");
        std::process::exit(1);
    }
}

fn main() -> rtdiff::Result<()> {
    let mut args: Vec<String> = std::env::args().skip(1).collect();
    let count: usize = args.first().and_then(|s| s.parse().ok()).unwrap_or(20_000);
    if args.first().is_some_and(|s| s.parse::<usize>().is_ok()) {
        args.remove(0);
    }
    let rules = rules();
    line(format!(
        "{:<12} {:<14} {:>7} {:>8} | per rule: hits decided in f64 %, max error / bound of the others, how many beyond 1, beyond 0.5",
        "mesh", "set", "hits", "err/term"
    ));
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
                let err = abs_err / bounds::of_hit(&p, r, &Hit { t: s.t, ..h }).0;
                if s.old > 64.0 {
                    err_per_term = err_per_term.max(abs_err / (s.old as f64 * (U as f64) * s.t as f64));
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
            let mut row = format!("{name:<12} {set:<14} {n:>7} {err_per_term:>8.3} |");
            for (i, (rn, _)) in rules.iter().enumerate() {
                row += &format!(
                    " {rn}: {:.2}% {:.2} {} {};",
                    100.0 * fell[i] as f64 / n.max(1) as f64,
                    worst[i],
                    beyond[i],
                    half[i]
                );
            }
            line(row);
        }
    }
    Ok(())
}
