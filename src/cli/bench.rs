//! `rtdiff bench`: build time per builder and traversal throughput per
//! tracer on primary, incoherent and shadow ray sets, single-threaded and
//! with all threads. Tracers come from [`crate::accel::build_tracer`], so
//! Embree rows appear when the crate is built with `--features embree`.

use std::path::PathBuf;
use std::sync::Arc;
use std::time::Instant;

use glam::Vec3;
use rayon::prelude::*;

use crate::accel::{AccelConfig, Backend, Builder, EmbreeQuality, Tracer, Traversal, build_tracer};
use crate::bvh::rays::{Camera, incoherent_rays, shadow_rays};
use crate::error::{Error, Result};
use crate::geometry::offset::SpawnOffset;
use crate::geometry::{Hit, Primitives, Ray};
use crate::limits;

/// Arguments of `rtdiff bench`.
#[derive(clap::Args, Debug)]
pub struct BenchArgs {
    /// Scene files, or OBJ meshes (normalised to the unit sphere); default
    /// assets/dragon_87k.obj and assets/dragon_full.obj when present.
    pub scenes: Vec<PathBuf>,
    /// Timed runs per measurement (the median is reported; 1 to 10000).
    #[arg(long, default_value_t = 3, value_parser = limits::ranged::<usize>(1, limits::MAX_RUNS as u64))]
    pub runs: usize,
    /// Primary image width and height (rays = size^2; 1 to 4096, so at most 2^24 rays).
    #[arg(long, default_value_t = 512, value_parser = limits::ranged::<u32>(1, limits::MAX_BENCH_SIZE as u64))]
    pub size: u32,
    /// Number of incoherent rays (0 to 2^24).
    #[arg(long, default_value_t = 262_144, value_parser = limits::ranged::<usize>(0, limits::MAX_RAYS as u64))]
    pub incoherent: usize,
    /// Builders to time (all when none is given).
    #[arg(long, value_enum)]
    pub builder: Vec<Builder>,
    /// Traversals to time (all when none is given).
    #[arg(long, value_enum)]
    pub traversal: Vec<Traversal>,
    /// Skip the all-threads measurements.
    #[arg(long)]
    pub single_only: bool,
    /// Primitives per leaf for the median builder (1 to 2^20).
    #[arg(long, default_value_t = 1, value_parser = limits::ranged::<usize>(1, limits::MAX_LEAF_SIZE as u64))]
    pub leaf_size: usize,
    /// Bins per axis for the sah builder (2 to 256).
    #[arg(long, default_value_t = 16, value_parser = limits::ranged::<usize>(limits::MIN_BINS as u64, limits::MAX_BINS as u64))]
    pub bins: usize,
    /// Instead of the tables: race sah/fast against Embree MEDIUM for this
    /// many interleaved rounds on one thread and report the median ratios
    /// (needs `--features embree`).
    #[arg(long, value_name = "ROUNDS", value_parser = limits::ranged::<usize>(1, limits::MAX_RUNS as u64))]
    pub race: Option<usize>,
}

/// The benchmark's point light.
pub const LIGHT: Vec3 = Vec3::new(-1.0, 1.0, -1.0);

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// Ray sets of one scene.
struct RaySets {
    primary: Vec<Ray>,
    incoherent: Vec<Ray>,
    shadow: Vec<Ray>,
}

/// Result of one tracer on one ray set: closest hits or occlusion flags.
#[derive(PartialEq)]
enum Answers {
    Closest(Vec<Option<Hit>>),
    Any(Vec<bool>),
}

fn trace(tracer: &dyn Tracer, rays: &[Ray], any: bool, parallel: bool) -> Answers {
    match (any, parallel) {
        (false, false) => Answers::Closest(rays.iter().map(|r| tracer.intersect(r)).collect()),
        (false, true) => Answers::Closest(rays.par_iter().with_min_len(256).map(|r| tracer.intersect(r)).collect()),
        (true, false) => Answers::Any(rays.iter().map(|r| tracer.occluded(r)).collect()),
        (true, true) => Answers::Any(rays.par_iter().with_min_len(256).map(|r| tracer.occluded(r)).collect()),
    }
}

/// Disagreements with the reference answers: different hit/miss or primitive.
fn disagreements(a: &Answers, b: &Answers) -> usize {
    match (a, b) {
        (Answers::Closest(a), Answers::Closest(b)) => {
            a.iter().zip(b).filter(|(x, y)| x.map(|h| h.prim) != y.map(|h| h.prim)).count()
        }
        (Answers::Any(a), Answers::Any(b)) => a.iter().zip(b).filter(|(x, y)| x != y).count(),
        _ => usize::MAX,
    }
}

/// CPU time consumed by the calling thread, in seconds (unaffected by other
/// processes competing for the cores of a shared machine).
#[cfg(unix)]
fn thread_cpu_seconds() -> Option<f64> {
    let mut ts = libc::timespec { tv_sec: 0, tv_nsec: 0 };
    // SAFETY: ts is a valid, writable timespec.
    let rc = unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut ts) };
    (rc == 0).then_some(ts.tv_sec as f64 + ts.tv_nsec as f64 * 1e-9)
}

#[cfg(not(unix))]
fn thread_cpu_seconds() -> Option<f64> {
    None
}

/// A stopwatch: the thread's CPU time for single-threaded work (when the
/// platform has it), wall-clock time otherwise.
pub(crate) struct Clock {
    /// Measure CPU time of the calling thread instead of wall-clock time.
    pub(crate) cpu: bool,
}

impl Clock {
    pub(crate) fn now(&self) -> (Instant, Option<f64>) {
        (Instant::now(), if self.cpu { thread_cpu_seconds() } else { None })
    }

    pub(crate) fn since(&self, start: (Instant, Option<f64>)) -> f64 {
        match (start.1, if self.cpu { thread_cpu_seconds() } else { None }) {
            (Some(a), Some(b)) => b - a,
            _ => start.0.elapsed().as_secs_f64(),
        }
    }
}

/// Time `f` `runs` times; median seconds and the first result. With
/// `cpu_time`, measures the calling thread's CPU time (single-threaded work only).
fn timed<T>(runs: usize, cpu_time: bool, mut f: impl FnMut() -> T) -> (f64, T) {
    let clock = Clock { cpu: cpu_time };
    let mut times = Vec::with_capacity(runs);
    let start = clock.now();
    let first = f();
    times.push(clock.since(start));
    for _ in 1..runs {
        let start = clock.now();
        std::hint::black_box(f());
        times.push(clock.since(start));
    }
    (median(times), first)
}

pub(crate) fn single_pool() -> Result<rayon::ThreadPool> {
    rayon::ThreadPoolBuilder::new().num_threads(1).build().map_err(|e| Error::Invalid(e.to_string()))
}

/// Embree builds on one device made with `"threads=1"` and kept alive (so no
/// thread-pool start-up is timed): wall clock and CPU time of the calling
/// thread, which does all the work with one thread.
#[cfg(feature = "embree")]
fn embree_single_thread_builds(prims: &Arc<Primitives>, runs: usize) -> Result<()> {
    use crate::embree::{Device, EmbreeTracer};
    let device = Device::new("threads=1")?;
    for q in [EmbreeQuality::Low, EmbreeQuality::Medium, EmbreeQuality::High] {
        let (cpu, r) = timed(runs, true, || EmbreeTracer::with_device(&device, prims.clone(), q).map(|_| ()));
        r?;
        let (wall, _) = timed(runs, false, || EmbreeTracer::with_device(&device, prims.clone(), q).map(|_| ()));
        let name = format!("embree {} (threads=1; wall)", value_name(&q));
        println!("{name:<32} {:>12.2} {:>12.2}", cpu * 1e3, wall * 1e3);
    }
    Ok(())
}

/// Run `rtdiff bench`.
pub fn run(args: &BenchArgs) -> Result<()> {
    if args.runs == 0 || args.size == 0 {
        return Err(Error::Invalid("--runs and --size must be positive".into()));
    }
    if args.race == Some(0) {
        return Err(Error::Invalid("--race needs at least one round".into()));
    }
    if args.bins < 2 {
        return Err(Error::Invalid(format!("--bins must be at least 2 (got {})", args.bins)));
    }
    let scenes = if args.scenes.is_empty() {
        let d = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("assets");
        let mut v = vec![d.join("dragon_87k.obj")];
        if d.join("dragon_full.obj").exists() {
            v.push(d.join("dragon_full.obj"));
        }
        v
    } else {
        args.scenes.clone()
    };
    for s in &scenes {
        let prims = super::bvh_stats::load_primitives(s, true)?;
        println!("\n## {} ({} primitives, {} rayon threads)", s.display(), prims.len(), rayon::current_num_threads());
        bench_scene(args, prims)?;
    }
    Ok(())
}

fn bench_scene(args: &BenchArgs, prims: Arc<Primitives>) -> Result<()> {
    if let Some(rounds) = args.race {
        return race_scene(args, &prims, rounds);
    }
    let one = single_pool()?;
    let builders = if args.builder.is_empty() {
        vec![Builder::Median, Builder::SahVolume, Builder::Sah]
    } else {
        args.builder.clone()
    };
    let traversals = if args.traversal.is_empty() {
        vec![
            Traversal::Basic,
            Traversal::PriorityQueue,
            Traversal::SortedVector,
            Traversal::NthElement,
            Traversal::Fast,
        ]
    } else {
        args.traversal.clone()
    };

    // Build times.
    println!(
        "\n### Build (median of {} runs; ms; 1 thread = CPU time of the building thread, all threads = wall clock)",
        args.runs
    );
    println!("{:<32} {:>12} {:>12}", "structure", "1 thread", "all threads");
    let mut configs: Vec<AccelConfig> = Vec::new();
    for &builder in &builders {
        for (label, traversal) in [("binary", Traversal::Basic), ("binary + 8-wide", Traversal::Fast)] {
            let cfg =
                AccelConfig { builder, traversal, leaf_size: args.leaf_size, bins: args.bins, ..Default::default() };
            let (t1, _) = one.install(|| timed(args.runs, true, || build_tracer(prims.clone(), &cfg).map(|_| ())));
            let (tn, _) = timed(args.runs, false, || build_tracer(prims.clone(), &cfg).map(|_| ()));
            let name = format!("bvh-{} {label}", value_name(&builder));
            println!("{name:<32} {:>12.2} {:>12.2}", t1 * 1e3, tn * 1e3);
        }
        for &traversal in &traversals {
            configs.push(AccelConfig {
                builder,
                traversal,
                leaf_size: args.leaf_size,
                bins: args.bins,
                ..Default::default()
            });
        }
    }
    for q in [EmbreeQuality::Low, EmbreeQuality::Medium, EmbreeQuality::High] {
        let cfg = AccelConfig { backend: Backend::Embree, embree_quality: q, ..Default::default() };
        match timed(args.runs, false, || build_tracer(prims.clone(), &cfg).map(|_| ())) {
            (t, Ok(())) => {
                println!("{:<32} {:>12} {:>12.2}", format!("embree {}", value_name(&q)), "-", t * 1e3);
                configs.push(cfg);
            }
            (_, Err(e)) => {
                println!("embree not built ({e})");
                break;
            }
        }
    }
    #[cfg(feature = "embree")]
    embree_single_thread_builds(&prims, args.runs)?;

    // Ray sets: shadow rays start at the primary hits of the reference tracer.
    let reference = build_tracer(prims.clone(), &AccelConfig::default())?;
    let (sets, n_hit) = ray_sets(args, &prims, reference.as_ref());
    println!(
        "\nrays: primary {} ({} hit), incoherent {}, shadow {} (towards {LIGHT})",
        sets.primary.len(),
        n_hit,
        sets.incoherent.len(),
        sets.shadow.len()
    );
    let set_list: [(&str, &[Ray], bool); 3] =
        [("primary", &sets.primary, false), ("incoherent", &sets.incoherent, false), ("shadow", &sets.shadow, true)];
    let refs: Vec<Answers> = set_list.iter().map(|(_, r, any)| trace(reference.as_ref(), r, *any, true)).collect();

    let modes: &[bool] = if args.single_only { &[false] } else { &[false, true] };
    for &parallel in modes {
        println!(
            "\n### Traversal, {} (Mrays/s, median of {} runs; x = ratio to the same builder's basic; diff = rays whose hit primitive differs from bvh-sah/fast)",
            if parallel {
                format!("{} threads, wall clock", rayon::current_num_threads())
            } else {
                "1 thread, CPU time of the tracing thread".into()
            },
            args.runs
        );
        println!(
            "{:<32} {:>9} {:>7} {:>9} {:>7} {:>9} {:>7} {:>6}",
            "tracer", "primary", "x", "incoh.", "x", "shadow", "x", "diff"
        );
        let mut basic: Vec<(Builder, [f64; 3])> = Vec::new();
        for cfg in &configs {
            let tracer = build_tracer(prims.clone(), cfg)?;
            let mut mr = [0.0; 3];
            let mut diff = 0;
            for (k, (_, rays, any)) in set_list.iter().enumerate() {
                let (t, ans) = if parallel {
                    timed(args.runs, false, || trace(tracer.as_ref(), rays, *any, true))
                } else {
                    one.install(|| timed(args.runs, true, || trace(tracer.as_ref(), rays, *any, false)))
                };
                mr[k] = rays.len() as f64 / t / 1e6;
                diff += disagreements(&ans, &refs[k]);
            }
            if cfg.backend == Backend::Native && cfg.traversal == Traversal::Basic {
                basic.push((cfg.builder, mr));
            }
            let base = basic.iter().find(|(b, _)| *b == cfg.builder && cfg.backend == Backend::Native).map(|b| b.1);
            let ratio = |k: usize| base.map_or("-".to_string(), |b| format!("{:.2}", mr[k] / b[k]));
            println!(
                "{:<32} {:>9.2} {:>7} {:>9.2} {:>7} {:>9.2} {:>7} {:>6}",
                tracer.name(),
                mr[0],
                ratio(0),
                mr[1],
                ratio(1),
                mr[2],
                ratio(2),
                diff
            );
        }
    }
    Ok(())
}

/// The three ray sets of a scene: primary rays from the default camera,
/// incoherent rays, and shadow rays from the primary hits towards [`LIGHT`].
fn ray_sets(args: &BenchArgs, prims: &Arc<Primitives>, reference: &dyn Tracer) -> (RaySets, usize) {
    let primary = Camera::scene_default().rays(args.size, args.size);
    let hits: Vec<Option<Hit>> = primary.par_iter().map(|r| reference.intersect(r)).collect();
    let shadow = shadow_rays(prims, &primary, &hits, LIGHT, SpawnOffset::Robust);
    let n_hit = hits.iter().filter(|h| h.is_some()).count();
    (RaySets { primary, incoherent: incoherent_rays(&prims.world_bounds(), args.incoherent, 2024), shadow }, n_hit)
}

#[cfg(feature = "embree")]
fn race_scene(args: &BenchArgs, prims: &Arc<Primitives>, rounds: usize) -> Result<()> {
    let reference = build_tracer(prims.clone(), &AccelConfig::default())?;
    let (sets, _) = ray_sets(args, prims, reference.as_ref());
    super::race::race(
        prims,
        &[("primary", &sets.primary, false), ("incoherent", &sets.incoherent, false), ("shadow", &sets.shadow, true)],
        rounds,
    )
}

#[cfg(not(feature = "embree"))]
fn race_scene(_: &BenchArgs, _: &Arc<Primitives>, _: usize) -> Result<()> {
    Err(Error::Invalid(
        "--race needs the Embree backend: run scripts/setup-embree.sh and build with --features embree".into(),
    ))
}

fn value_name<T: clap::ValueEnum>(v: &T) -> String {
    v.to_possible_value().map_or_else(String::new, |p| p.get_name().to_string())
}
