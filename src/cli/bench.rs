//! `rtdiff bench`: parses the arguments, runs [`crate::perf::bench`] or
//! [`crate::perf::race`] and prints their reports as tables.

use std::path::PathBuf;

use crate::backends::{Builder, Traversal};
use crate::error::{Error, Result};
use crate::limits;
use crate::perf::bench::{BenchOptions, BenchReport, LIGHT};
use crate::perf::race::RaceReport;

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

impl BenchArgs {
    /// The library options these arguments ask for.
    pub fn options(&self) -> BenchOptions {
        let d = BenchOptions::default();
        BenchOptions {
            runs: self.runs,
            size: self.size,
            incoherent: self.incoherent,
            builders: if self.builder.is_empty() { d.builders } else { self.builder.clone() },
            traversals: if self.traversal.is_empty() { d.traversals } else { self.traversal.clone() },
            single_only: self.single_only,
            leaf_size: self.leaf_size,
            bins: self.bins,
        }
    }
}

/// Run `rtdiff bench`.
pub fn run(args: &BenchArgs) -> Result<()> {
    let opts = args.options();
    opts.validate()?;
    if args.race == Some(0) {
        return Err(Error::Invalid("--race needs at least one round".into()));
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
        let prims = crate::rays::load_primitives(s, true)?;
        println!("\n## {} ({} primitives, {} rayon threads)", s.display(), prims.len(), rayon::current_num_threads());
        if let Some(rounds) = args.race {
            print_race(&crate::perf::race::race_bench_sets(&prims, opts.size, opts.incoherent, rounds)?);
        } else {
            print_bench(&crate::perf::bench::run(&s.display().to_string(), prims, &opts)?);
        }
    }
    Ok(())
}

/// Print a benchmark report as the `rtdiff bench` tables.
pub fn print_bench(r: &BenchReport) {
    println!(
        "\n### Build (median of {} runs; ms; 1 thread = CPU time of the building thread, all threads = wall clock)",
        r.runs
    );
    println!("{:<32} {:>12} {:>12}", "structure", "1 thread", "all threads");
    let ms = |v: Option<f64>| v.map_or("-".to_string(), |v| format!("{v:.2}"));
    for b in &r.builds {
        println!("{:<32} {:>12} {:>12}", b.structure, ms(b.single_thread_ms), ms(b.all_threads_ms));
    }
    if let Some(e) = &r.embree_unavailable {
        println!("embree not built ({e})");
    }
    println!(
        "\nrays: primary {} ({} hit), incoherent {}, shadow {} (towards {LIGHT})",
        r.rays.primary, r.rays.primary_hits, r.rays.incoherent, r.rays.shadow
    );
    for t in &r.traversal {
        println!(
            "\n### Traversal, {} (Mrays/s, median of {} runs; x = ratio to the same builder's basic; diff = rays whose hit primitive differs from bvh-sah/fast)",
            if t.all_threads {
                format!("{} threads, wall clock", t.threads)
            } else {
                "1 thread, CPU time of the tracing thread".into()
            },
            r.runs
        );
        println!(
            "{:<32} {:>9} {:>7} {:>9} {:>7} {:>9} {:>7} {:>6}",
            "tracer", "primary", "x", "incoh.", "x", "shadow", "x", "diff"
        );
        for row in &t.rows {
            let ratio = |k: usize| row.ratio_to_basic.map_or("-".to_string(), |b| format!("{:.2}", b[k]));
            let mr = row.mrays_per_s;
            println!(
                "{:<32} {:>9.2} {:>7} {:>9.2} {:>7} {:>9.2} {:>7} {:>6}",
                row.tracer,
                mr[0],
                ratio(0),
                mr[1],
                ratio(1),
                mr[2],
                ratio(2),
                row.differences
            );
        }
    }
}

/// Print a race report as the `rtdiff bench --race` table.
pub fn print_race(r: &RaceReport) {
    for (set, a, b) in &r.hit_count_differences {
        eprintln!("note: {} hits differ on {set}: rtdiff {a}, Embree {b}", a.abs_diff(*b));
    }
    println!(
        "\n### rtdiff sah/fast against Embree MEDIUM (rtcIntersect1 / rtcOccluded1), 1 thread, {} interleaved rounds",
        r.rounds
    );
    println!("ratio = Embree time / rtdiff time in the same round (above 1: rtdiff faster); CPU time of the thread");
    println!(
        "{:<12} {:>16} {:>16} {:>7} {:>7} {:>7} {:>7}",
        "", "rtdiff (median)", "Embree (median)", "ratio", "q1", "q3", "wins"
    );
    for c in &r.contests {
        let s = c.summary();
        let (a, b) = if c.rays > 0 {
            (
                format!("{:.2} Mrays/s", c.rays as f64 / s.rtdiff_s / 1e6),
                format!("{:.2} Mrays/s", c.rays as f64 / s.embree_s / 1e6),
            )
        } else {
            (format!("{:.2} ms", s.rtdiff_s * 1e3), format!("{:.2} ms", s.embree_s * 1e3))
        };
        println!(
            "{:<12} {:>16} {:>16} {:>7.3} {:>7.3} {:>7.3} {:>5}/{}",
            c.name,
            a,
            b,
            s.ratio,
            s.q1,
            s.q3,
            s.wins,
            c.times.len()
        );
    }
}
