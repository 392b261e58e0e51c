//! Embree 4 timing on one mesh, single-threaded (device config "threads=1"):
//! build time per quality, then rtcIntersect1 / rtcOccluded1 throughput on
//! the harness's primary, incoherent and shadow rays (one thread, one device
//! kept alive, so TBB uses one thread).
//!
//! `cargo run --release --features embree --example embree_bench -- assets/dragon_87k.obj [rays]`

use std::sync::Arc;
use std::time::Instant;

use rtdiff::accel::{EmbreeQuality, Tracer};
use rtdiff::embree::{Device, EmbreeTracer};
use rtdiff::rays::{SetKind, generate};

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(|a, b| a.total_cmp(b));
    v[v.len() / 2]
}

fn main() -> rtdiff::Result<()> {
    let mut args = std::env::args().skip(1);
    let path = args.next().unwrap_or_else(|| "assets/dragon_87k.obj".into());
    let n: usize = args.next().and_then(|s| s.parse().ok()).unwrap_or(1_000_000);
    let ctx = rtdiff::rays::load_context(std::path::Path::new(&path))?;
    let device = Device::new("threads=1")?;
    println!("{path}: {} triangles, Embree {}, threads=1", ctx.prims.len(), device.version()?);
    let mut high = None;
    for q in [EmbreeQuality::Low, EmbreeQuality::Medium, EmbreeQuality::High] {
        let mut times = Vec::new();
        for _ in 0..3 {
            let t0 = Instant::now();
            let t = EmbreeTracer::with_device(&device, ctx.prims.clone(), q)?;
            times.push(t0.elapsed().as_secs_f64() * 1e3);
            if q == EmbreeQuality::High {
                high = Some(t);
            }
        }
        println!("build {q:?}: {:.1} ms (median of 3)", median(times));
    }
    let tracer = high.expect("built above");
    let oracle_for = |p: Arc<rtdiff::geometry::Primitives>| {
        Ok(Box::new(EmbreeTracer::with_device(&device, p, EmbreeQuality::High)?) as Box<dyn Tracer>)
    };
    for kind in [SetKind::Primary, SetKind::Incoherent, SetKind::Shadow] {
        let set = generate(&ctx, kind, 1, n, &tracer, &oracle_for)?.remove(0);
        let (mut ti, mut to) = (Vec::new(), Vec::new());
        let mut hits = 0;
        for _ in 0..3 {
            let t0 = Instant::now();
            hits = set.rays.iter().filter(|r| tracer.intersect(r).is_some()).count();
            ti.push(set.rays.len() as f64 / t0.elapsed().as_secs_f64() / 1e6);
            let t0 = Instant::now();
            let occ = set.rays.iter().filter(|r| tracer.occluded(r)).count();
            to.push(set.rays.len() as f64 / t0.elapsed().as_secs_f64() / 1e6);
            assert!(occ >= hits, "occluded must cover every closest hit");
        }
        println!(
            "{:<10} {} rays, {:.1}% hit: rtcIntersect1 {:.2} Mrays/s, rtcOccluded1 {:.2} Mrays/s (median of 3)",
            kind.name(),
            set.rays.len(),
            100.0 * hits as f64 / set.rays.len() as f64,
            median(ti),
            median(to)
        );
    }
    // Coherent primary rays in 4 x 2 pixel tiles: rtcIntersect1 per ray vs one
    // rtcIntersect8 per tile (the only workload where packets can pay).
    let (w, h) = ctx.image;
    let mut tiles = Vec::new();
    for ty in (0..h - 1).step_by(2) {
        for tx in (0..w - 3).step_by(4) {
            let tile: Vec<_> =
                (0..8).map(|k| (ctx.camera)((tx + k % 4) as f32 + 0.5, (ty + k / 4) as f32 + 0.5)).collect();
            tiles.push(tile);
        }
    }
    let nrays = (tiles.len() * 8) as f64;
    let (mut t1, mut t8, mut o1, mut o8) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    for _ in 0..3 {
        let t0 = Instant::now();
        let a: usize = tiles.iter().flatten().filter(|r| tracer.intersect(r).is_some()).count();
        t1.push(nrays / t0.elapsed().as_secs_f64() / 1e6);
        let t0 = Instant::now();
        let b: usize = tiles.iter().map(|t| tracer.intersect8(t).iter().flatten().count()).sum();
        t8.push(nrays / t0.elapsed().as_secs_f64() / 1e6);
        assert_eq!(a, b);
        let t0 = Instant::now();
        let a: usize = tiles.iter().flatten().filter(|r| tracer.occluded(r)).count();
        o1.push(nrays / t0.elapsed().as_secs_f64() / 1e6);
        let t0 = Instant::now();
        let b: usize = tiles.iter().map(|t| tracer.occluded8(t).iter().filter(|&&o| o).count()).sum();
        o8.push(nrays / t0.elapsed().as_secs_f64() / 1e6);
        assert_eq!(a, b);
    }
    println!(
        "coherent primary {} rays (4x2 tiles): rtcIntersect1 {:.2} vs rtcIntersect8 {:.2} Mrays/s; rtcOccluded1 {:.2} vs rtcOccluded8 {:.2} Mrays/s",
        nrays,
        median(t1),
        median(t8),
        median(o1),
        median(o8)
    );
    Ok(())
}
