//! The public single-ray path as an outside harness calls it, for profilers:
//! `build_tracer(.., AccelConfig { .. })` then one `Tracer::intersect` or
//! `Tracer::occluded` call per ray through `Box<dyn Tracer>`. The rays are
//! traced by `trace_all` (never inlined), so `valgrind --tool=callgrind
//! --toggle-collect=call_path::trace_all` counts only the tracing.
//!
//! `cargo run --release [--features embree] --example call_path -- MESH SET N TRACER [REPEAT]`
//! with SET one of `primary`, `incoherent`, `shadow`, `batch-primary`, `batch-shadow` (`shadow@K`,
//! `batch-shadow@K`: the whole image's shadow rays towards light K of `SHADOW_LIGHTS` alone), `miss` (rays
//! that leave the mesh's bounds: the per-call cost alone)
//! (N rays, traced REPEAT times when a fifth argument is given), `build-cold` (N
//! builds, each timed after builds by the other tracer, Embree on a device
//! with the pool's thread count as in the race; `--features embree`; the
//! median is printed), or `build` (N builds, each called from a pool of `RAYON_NUM_THREADS` threads and
//! timed by the wall clock, with the median and quartiles printed; a fifth argument pauses that many
//! milliseconds before each build, so that the pool's threads fall asleep; counted by
//! `--toggle-collect=call_path::build_all`), and TRACER one of `native`, `native-avx2` (the walks compiled for AVX2), `native-mt` (the Moller-Trumbore test), `embree`, `embree-default` (MEDIUM quality).

use std::path::Path;

use rtdiff::accel::Tracer;
use rtdiff::backends::{AccelConfig, Backend, Builder, EmbreeMode, EmbreeQuality, Traversal, build_tracer};
use rtdiff::geometry::offset::SpawnOffset;
use rtdiff::geometry::{Hit, Ray};
use rtdiff::perf::bench::{RaySets, SHADOW_LIGHTS};
use rtdiff::rays::workload::shadow_rays;

/// `n` builds of `prims` through `build_tracer` (profile with
/// `--toggle-collect=call_path::build_all`).
#[inline(never)]
fn build_all(prims: &std::sync::Arc<rtdiff::geometry::Primitives>, cfg: &AccelConfig, n: usize) -> rtdiff::Result<()> {
    for _ in 0..n {
        std::hint::black_box(build_tracer(prims.clone(), cfg)?);
    }
    Ok(())
}

#[inline(never)]
fn trace_all(t: &dyn Tracer, rays: &[Ray], any: bool, batch: bool) -> usize {
    if batch {
        if any {
            let mut out = vec![false; rays.len()];
            t.occluded_batch(rays, &mut out);
            out.iter().filter(|&&o| o).count()
        } else {
            let mut out: Vec<Option<Hit>> = vec![None; rays.len()];
            t.intersect_batch(rays, &mut out);
            out.iter().filter(|h| h.is_some()).count()
        }
    } else if any {
        rays.iter().filter(|r| t.occluded(r)).count()
    } else {
        rays.iter().filter(|r| t.intersect(r).is_some()).count()
    }
}

fn main() -> rtdiff::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mesh = args.first().map_or("assets/suzanne.obj", String::as_str);
    let set = args.get(1).map_or("primary", String::as_str);
    let n: usize = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(20_000);
    let which = args.get(3).map_or("native", String::as_str);
    let prims = rtdiff::rays::load_primitives(Path::new(mesh), true)?;
    let native = AccelConfig {
        backend: Backend::Native,
        builder: Builder::Sah,
        traversal: Traversal::Fast,
        ..Default::default()
    };
    let cfg = match which {
        "native" | "native-avx2" => native,
        "native-mt" => AccelConfig { triangle_test: rtdiff::geometry::TriangleTest::MollerTrumbore, ..native },
        "embree" | "embree-default" => AccelConfig {
            backend: Backend::Embree,
            embree_quality: EmbreeQuality::Medium,
            embree_mode: if which == "embree" { EmbreeMode::Robust } else { EmbreeMode::Default },
            ..Default::default()
        },
        other => return Err(rtdiff::Error::Invalid(format!("unknown tracer {other}"))),
    };
    if set == "build-cold" {
        // As in `rtdiff bench --race`: each timed build (CPU time of the
        // thread) follows builds by the other tracer (Embree: MEDIUM and HIGH
        // quality, robust and default mode), which leave the caches and the
        // branch predictor to someone else's code and data. Embree builds on
        // a device with the pool's thread count, as in the race: a default
        // device keeps worker threads spinning after each build, which takes
        // the other core (or hyperthread) from the timed build.
        #[cfg(feature = "embree")]
        let device = rtdiff::embree::Device::new(&format!("threads={}", rayon::current_num_threads()))?;
        #[cfg(feature = "embree")]
        let embree_build = |q: EmbreeQuality, m: EmbreeMode| -> rtdiff::Result<()> {
            std::hint::black_box(rtdiff::embree::EmbreeTracer::with_mode(&device, prims.clone(), q, m)?);
            Ok(())
        };
        #[cfg(not(feature = "embree"))]
        let embree_build = |_: EmbreeQuality, _: EmbreeMode| -> rtdiff::Result<()> {
            Err(rtdiff::Error::Invalid("build-cold needs --features embree".into()))
        };
        let timing_native = cfg.backend == Backend::Native;
        let other_build = || -> rtdiff::Result<()> {
            if timing_native {
                for (q, m) in rtdiff::perf::race::EMBREE_MODES {
                    embree_build(q, m)?;
                }
            } else {
                std::hint::black_box(build_tracer(prims.clone(), &native)?);
            }
            Ok(())
        };
        let timed_build = || -> rtdiff::Result<()> {
            if timing_native {
                build_tracer(prims.clone(), &cfg).map(|_| ())
            } else {
                embree_build(cfg.embree_quality, cfg.embree_mode)
            }
        };
        let (mut cpu, mut wall) = (Vec::with_capacity(n), Vec::with_capacity(n));
        for _ in 0..n {
            other_build()?;
            let start = std::time::Instant::now();
            let (t, r) = rtdiff::perf::clock::cpu_seconds(timed_build);
            wall.push(start.elapsed().as_secs_f64());
            r?;
            cpu.push(t);
        }
        cpu.sort_by(f64::total_cmp);
        wall.sort_by(f64::total_cmp);
        println!(
            "{mesh} build-cold {which}: median {:.4} ms CPU time of the calling thread, {:.4} ms wall clock, over {n} builds",
            1e3 * cpu[n / 2],
            1e3 * wall[n / 2]
        );
        return Ok(());
    }
    if set == "build" {
        // Each build timed on its own (wall clock), called from a thread of
        // a pool of `RAYON_NUM_THREADS` threads, as `rtdiff bench --race`
        // calls it; the median is printed. Embree builds on one device of
        // the pool's thread count, made before the first build (as in the
        // race); rtdiff's through `build_tracer`.
        let pool = rayon::ThreadPoolBuilder::new()
            .build()
            .map_err(|e| rtdiff::Error::Invalid(format!("cannot start the thread pool: {e}")))?;
        #[cfg(feature = "embree")]
        let device = rtdiff::embree::Device::new(&format!("threads={}", pool.current_num_threads()))?;
        let one_build = || -> rtdiff::Result<()> {
            if cfg.backend == Backend::Native {
                return build_all(&prims, &cfg, 1);
            }
            #[cfg(feature = "embree")]
            {
                let t = rtdiff::embree::EmbreeTracer::with_mode(
                    &device,
                    prims.clone(),
                    cfg.embree_quality,
                    cfg.embree_mode,
                );
                std::hint::black_box(t?);
                Ok(())
            }
            #[cfg(not(feature = "embree"))]
            Err(rtdiff::Error::Invalid("Embree builds need --features embree".into()))
        };
        // An optional pause before each build (fifth argument, milliseconds),
        // during which the pool's threads fall asleep, as they do in the race
        // while the other library builds on its own threads.
        let pause = std::time::Duration::from_millis(args.get(4).and_then(|s| s.parse().ok()).unwrap_or(0));
        let mut ms = Vec::with_capacity(n);
        for _ in 0..n {
            std::thread::sleep(pause);
            // Timed on the pool's thread, without the handoff to it.
            ms.push(pool.install(|| {
                let start = std::time::Instant::now();
                one_build().map(|()| start.elapsed().as_secs_f64() * 1e3)
            })?);
        }
        ms.sort_by(f64::total_cmp);
        let q = |f: f64| ms.get(((ms.len() - 1) as f64 * f).round() as usize).copied().unwrap_or(f64::NAN);
        println!(
            "{mesh} build {which}: {n} builds on {} threads, median {:.3} ms (quartiles {:.3}-{:.3})",
            pool.current_num_threads(),
            q(0.5),
            q(0.25),
            q(0.75)
        );
        return Ok(());
    }
    let reference = build_tracer(prims.clone(), &native)?;
    let sets = RaySets::new(&prims, 512, 262_144, reference.as_ref());
    // Rays that start outside the mesh's bounds and point away from it: the
    // per-call cost alone (entry, ray setup, one root test).
    let bounds = prims.world_bounds();
    let centre = 0.5 * (bounds.min + bounds.max);
    let far = 2.0 * (bounds.max - bounds.min).length().max(1.0);
    let miss: Vec<Ray> = sets
        .incoherent
        .iter()
        .map(|r| {
            let d = r.dir.normalize_or_zero();
            Ray::new(centre + far * d, d)
        })
        .collect();
    // `shadow@K` / `batch-shadow@K`: the whole image's shadow rays towards
    // light K of `SHADOW_LIGHTS` alone (the benchmark's set sends each
    // quarter of the image to another light).
    let per_light: Vec<Ray>;
    let (set, shadow) = match set.split_once('@') {
        None => (set, &sets.shadow),
        Some((s, k)) => {
            let light = k.parse::<usize>().ok().and_then(|k| SHADOW_LIGHTS.get(k));
            let (Some(&light), "shadow" | "batch-shadow") = (light, s) else {
                let n = SHADOW_LIGHTS.len();
                return Err(rtdiff::Error::Invalid(format!("{set}: expected shadow@K or batch-shadow@K, K below {n}")));
            };
            let hits: Vec<_> = sets.primary.iter().map(|r| reference.intersect(r)).collect();
            per_light = shadow_rays(&prims, &sets.primary, &hits, light, SpawnOffset::Robust);
            (s, &per_light)
        }
    };
    let (base, any, batch) = match set {
        "primary" => (&sets.primary, false, false),
        "incoherent" => (&sets.incoherent, false, false),
        "shadow" => (shadow, true, false),
        "batch-primary" => (&sets.primary, false, true),
        "batch-shadow" => (shadow, true, true),
        "miss" => (&miss, false, false),
        other => return Err(rtdiff::Error::Invalid(format!("unknown set {other}"))),
    };
    // A contiguous block from the middle of the set (whole image rows for
    // primary rays), so packets of consecutive rays stay coherent.
    let start = (base.len().saturating_sub(n)) / 2;
    let rays: Vec<Ray> = base[start..].iter().take(n).copied().collect();
    // `native-avx2`: the walks compiled for AVX2 (`WalkIsa::Avx2`, as
    // `rtdiff bench --race --rtdiff-isa avx2`), for a CPU without AVX-512.
    let tracer: Box<dyn Tracer> = if which == "native-avx2" {
        let mut t = rtdiff::bvh::BvhTracer::new(&prims, &cfg);
        if !t.force_isa(rtdiff::bvh::WalkIsa::Avx2) {
            return Err(rtdiff::Error::Invalid("this CPU does not run the AVX2 walks".into()));
        }
        Box::new(t)
    } else {
        build_tracer(prims, &cfg)?
    };
    let repeat: usize = args.get(4).and_then(|s| s.parse().ok()).unwrap_or(1);
    let mut hits = 0;
    for _ in 0..repeat.max(1) {
        hits = trace_all(tracer.as_ref(), &rays, any, batch);
    }
    println!("{mesh} {set} {}: {} rays, {hits} hit", tracer.name(), rays.len());
    Ok(())
}
