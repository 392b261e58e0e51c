//! `rtdiff bench`: parses the arguments, runs [`crate::perf::bench`] or
//! [`crate::perf::race`] and prints their reports as tables.

use std::path::PathBuf;

use crate::backends::{Builder, Traversal};
use crate::bvh::WalkIsa;
use crate::cli::render::parse_triangle_test;
use crate::error::{Error, Result};
use crate::geometry::TriangleTest;
use crate::limits;
use crate::perf::bench::{BenchOptions, BenchReport, SHADOW_LIGHTS};
use crate::perf::race::{EmbreeIsa, MeshRace, RaceOptions, is_embree};
use crate::perf::render_race::{RenderRaceOptions, SceneRace};

/// Arguments of `rtdiff bench`.
#[derive(clap::Args, Debug)]
pub struct BenchArgs {
    /// Scene files, or meshes (.obj, .ply, .gltf, .glb, .stl; normalised to the unit sphere); default
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
    /// Instead of the tables: race rtdiff (`bvh-sah/fast`, through the public
    /// `Tracer` calls, single rays and batches) against Embree robust and
    /// default, MEDIUM and HIGH (called through its C API as its
    /// documentation shows), for this many interleaved rounds on each
    /// `--threads` count, on camera rays (the mesh framed by its bounding
    /// sphere), incoherent rays from inside its box and shadow rays, and
    /// print per workload the hit rate, each side's time per ray and every
    /// median ratio with its quartiles (needs `--features embree`). Default
    /// meshes: suzanne, dragon_87k and dragon_full from assets/.
    #[arg(long, value_name = "ROUNDS", value_parser = limits::ranged::<usize>(1, limits::MAX_RUNS as u64))]
    pub race: Option<usize>,
    /// Builds of each contestant per race round, interleaved, each a sample
    /// of the build contests (1 to 100; default 3).
    #[arg(long, value_parser = limits::ranged::<usize>(1, 100))]
    pub build_repeats: Option<usize>,
    /// Thread counts of the race (comma-separated, 1 to 1024 each).
    #[arg(long, value_delimiter = ',', default_value = "1,2", value_parser = limits::ranged::<usize>(1, limits::MAX_THREADS as u64))]
    pub threads: Vec<usize>,
    /// With `--race`: also race whole renders, `--tracer native` against
    /// `--tracer embree`, on every scene in this folder (default scenes/),
    /// and check that their images agree. Scenes with short renders get
    /// more rounds (at least 0.5 s of renders per tracer, up to 8x `ROUNDS`).
    #[arg(long, value_name = "DIR", num_args = 0..=1, default_missing_value = "scenes")]
    pub renders: Option<PathBuf>,
    /// Width and height of the raced renders (16 to 4096).
    #[arg(long, default_value_t = 400, value_parser = limits::ranged::<u32>(16, limits::MAX_BENCH_SIZE as u64))]
    pub render_size: u32,
    /// With `--race`: skip the meshes (only the renders).
    #[arg(long)]
    pub renders_only: bool,
    /// With `--race`: rtdiff's triangle test (`watertight`, the default, or
    /// `moller-trumbore`: not watertight, like Embree's default mode).
    #[arg(long, default_value = "watertight", value_parser = parse_triangle_test)]
    pub triangle_test: TriangleTest,
    /// With `--race`: the widest instruction set Embree's kernels may use
    /// (`sse2`, `sse42`, `avx`, `avx2`, `avx512`; Embree's `max_isa`). By
    /// default Embree runs the widest this CPU has, AVX-512 on CPUs that
    /// have it (as rtdiff's closest-hit walk does); with `--rtdiff-isa avx2`,
    /// `avx2` races both on the same instruction set, as on a CPU without
    /// AVX-512.
    #[arg(long, value_name = "ISA", value_parser = parse_embree_isa)]
    pub embree_max_isa: Option<EmbreeIsa>,
    /// With `--race`: the instruction set of rtdiff's walks (`avx512`,
    /// `avx2`, `portable`; by default the widest this CPU runs).
    #[arg(long, value_name = "ISA", value_enum)]
    pub rtdiff_isa: Option<WalkIsa>,
    /// With `--race`: also race this tracer, `plugin:PATH` (a shared library
    /// implementing include/rtdiff_tracer.h), against rtdiff and Embree on
    /// the same rays in the same rounds (repeatable).
    #[arg(long, value_name = "plugin:PATH")]
    pub tracer: Vec<String>,
    /// Also write the race's typed report as JSON to this file.
    #[arg(long, value_name = "FILE")]
    pub json: Option<PathBuf>,
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
    if let Some(rounds) = args.race {
        return race(args, rounds);
    }
    if args.triangle_test != TriangleTest::Watertight {
        // The tables time every builder and traversal with the default test.
        return Err(Error::Invalid("--triangle-test applies to --race only".into()));
    }
    if args.embree_max_isa.is_some() {
        return Err(Error::Invalid("--embree-max-isa applies to --race only".into()));
    }
    if args.rtdiff_isa.is_some() {
        return Err(Error::Invalid("--rtdiff-isa applies to --race only".into()));
    }
    if args.build_repeats.is_some() {
        return Err(Error::Invalid("--build-repeats applies to --race only".into()));
    }
    if !args.tracer.is_empty() {
        return Err(Error::Invalid("--tracer applies to --race only".into()));
    }
    let scenes =
        if args.scenes.is_empty() { default_meshes(&["dragon_87k", "dragon_full"]) } else { args.scenes.clone() };
    for s in &scenes {
        let prims = crate::rays::load_primitives(s, true)?;
        println!("\n## {} ({} primitives, {} rayon threads)", s.display(), prims.len(), rayon::current_num_threads());
        print_bench(&crate::perf::bench::run(&s.display().to_string(), prims, &opts)?);
    }
    Ok(())
}

/// The meshes of `assets/` named `names` (`.obj`) that are present.
fn default_meshes(names: &[&str]) -> Vec<PathBuf> {
    let d = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("assets");
    let found: Vec<PathBuf> = names.iter().map(|n| d.join(format!("{n}.obj"))).filter(|p| p.exists()).collect();
    if found.is_empty() { vec![d.join(format!("{}.obj", names[0]))] } else { found }
}

/// The plugins of `--tracer plugin:PATH`, loaded (rtdiff and Embree always race).
fn race_plugins(tracers: &[String]) -> Result<Vec<crate::plugin::PluginId>> {
    let mut ids = Vec::new();
    for t in tracers {
        match t.strip_prefix("plugin:") {
            Some(path) if !path.is_empty() => {
                let id = crate::plugin::load(std::path::Path::new(path))?;
                if !ids.contains(&id) {
                    ids.push(id);
                }
            }
            _ => {
                return Err(Error::Invalid(format!(
                    "--tracer {t:?}: the race always runs rtdiff and Embree; --tracer adds plugin:PATH (a shared library implementing include/rtdiff_tracer.h)"
                )));
            }
        }
    }
    Ok(ids)
}

/// Everything `rtdiff bench --race` measured.
#[derive(serde::Serialize)]
struct RaceRun<'a> {
    meshes: &'a [MeshRace],
    renders: &'a [SceneRace],
    threads: &'a [usize],
    rounds: usize,
    /// How long an idle thread of each multi-thread pool took to start work.
    idle_wake: &'a [crate::perf::wake::IdleWake],
}

/// `rtdiff bench --race`: the meshes, then the renders, then the goals.
fn race(args: &BenchArgs, rounds: usize) -> Result<()> {
    let opts = args.options();
    let mut meshes = Vec::new();
    // The host's delay in waking an idle pool thread, which two-thread
    // builds of a few milliseconds measure too (`perf::wake`).
    let mut wakes = Vec::new();
    if !args.renders_only {
        for &t in args.threads.iter().filter(|&&t| t > 1) {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(t)
                .build()
                .map_err(|e| Error::Invalid(format!("cannot start {t} threads: {e}")))?;
            if let Some(w) = crate::perf::wake::idle_wake(&pool, std::time::Duration::from_millis(20), 5) {
                print_idle_wake(&w);
                wakes.push(w);
            }
        }
        let files = if args.scenes.is_empty() {
            default_meshes(&["suzanne", "dragon_87k", "dragon_full"])
        } else {
            args.scenes.clone()
        };
        let ropts = RaceOptions {
            rounds,
            build_repeats: args.build_repeats.unwrap_or(crate::perf::race::DEFAULT_BUILD_REPEATS),
            threads: args.threads.clone(),
            batches: true,
            triangle_test: args.triangle_test,
            embree_max_isa: args.embree_max_isa,
            rtdiff_isa: args.rtdiff_isa,
            plugins: race_plugins(&args.tracer)?,
        };
        for s in &files {
            let prims = crate::rays::load_primitives(s, true)?;
            eprintln!("racing {} ...", s.display());
            let m = crate::perf::race::race_bench_sets(
                &s.display().to_string(),
                &prims,
                opts.size,
                opts.incoherent,
                &ropts,
            )?;
            print_mesh_race(&m, rounds);
            meshes.push(m);
        }
    }
    let mut renders = Vec::new();
    if let Some(dir) = &args.renders {
        let dir = if dir.is_relative() && !dir.exists() {
            PathBuf::from(env!("CARGO_MANIFEST_DIR")).join(dir)
        } else {
            dir.clone()
        };
        let ropts = RenderRaceOptions { rounds, threads: args.threads.clone(), size: args.render_size };
        for s in crate::perf::render_race::scenes_in(&dir)? {
            eprintln!("racing renders of {} ...", s.display());
            renders.push(crate::perf::render_race::race_scene(&s, &ropts)?);
        }
        print_render_race(&renders, rounds);
    }
    print_goals(&meshes, &renders, &wakes);
    if let Some(path) = &args.json {
        let run = RaceRun { meshes: &meshes, renders: &renders, threads: &args.threads, rounds, idle_wake: &wakes };
        let text = serde_json::to_string_pretty(&run).map_err(|e| Error::Invalid(e.to_string()))?;
        crate::output::write(path, text)?;
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
        "\nrays: primary {} ({} hit), incoherent {}, shadow {} (towards {}, a quarter of the image each)",
        r.rays.primary,
        r.rays.primary_hits,
        r.rays.incoherent,
        r.rays.shadow,
        SHADOW_LIGHTS.map(|l| l.to_string()).join(", ")
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

/// Print one mesh's race: one line per thread count, workload and Embree mode.
pub fn print_mesh_race(m: &MeshRace, rounds: usize) {
    println!(
        "\n## {} ({} primitives; rtdiff tree {:.1} bytes per primitive): rtdiff {} against Embree{}, {rounds} interleaved rounds ({} builds of each per round)",
        m.mesh,
        m.primitives,
        m.rtdiff_bytes_per_primitive,
        m.rtdiff,
        plugins(m).iter().map(|p| format!(" and {p}")).collect::<String>(),
        m.build_repeats
    );
    println!(
        "instruction sets: rtdiff {}{}, Embree {}{}",
        m.rtdiff_isa,
        if m.rtdiff_isa_set { " (set by --rtdiff-isa)" } else { "" },
        m.embree_isa.name(),
        if m.embree_capped { " (capped by --embree-max-isa)" } else { " (the widest this CPU runs)" }
    );
    if !m.embree_memory.is_empty() {
        let theirs: Vec<String> =
            m.embree_memory.iter().map(|e| format!("{} {:.1}", e.opponent, e.bvh_bytes_per_primitive)).collect();
        let geometry = m.embree_memory.first().map_or(0.0, |e| e.geometry_bytes_per_primitive);
        println!(
            "memory per primitive: rtdiff tree {:.1} bytes; Embree acceleration structure {} bytes (and {geometry:.1} of geometry buffers)",
            m.rtdiff_bytes_per_primitive,
            theirs.join(", ")
        );
    }
    println!(
        "ratio = opponent's time / rtdiff's time in the same round (above 1: rtdiff faster); 1 thread: CPU time, more: wall clock; \
         Embree called through its C API as its documentation shows, rtdiff through Box<dyn Tracer>, plugins through their ABI calls; hits = rtdiff's share of the rays that hit"
    );
    println!(
        "{:>3} {:<18} {:<22} {:>6} {:>16} {:>18} {:>7} {:>7} {:>7} {:>7}",
        "thr", "workload", "opponent", "hits", "rtdiff (median)", "opponent (median)", "ratio", "q1", "q3", "wins"
    );
    for c in &m.contests {
        let s = c.summary();
        let (a, b, hits) = if c.rays > 0 {
            let ns = |t: f64| format!("{:.1} ns/ray", t * 1e9 / c.rays as f64);
            (ns(s.rtdiff_s), ns(s.opponent_s), format!("{:.1}%", 100.0 * c.hit_rate()))
        } else {
            (format!("{:.2} ms", s.rtdiff_s * 1e3), format!("{:.2} ms", s.opponent_s * 1e3), "-".into())
        };
        println!(
            "{:>3} {:<18} {:<22} {:>6} {:>16} {:>18} {:>7.3} {:>7.3} {:>7.3} {:>4}/{}",
            c.threads,
            c.name,
            c.opponent,
            hits,
            a,
            b,
            s.ratio,
            s.q1,
            s.q3,
            s.wins,
            c.times.len()
        );
    }
    let mut counts: Vec<usize> = m.contests.iter().map(|c| c.threads).filter(|&t| t > 1).collect();
    counts.dedup();
    for t in counts {
        let opponents: Vec<&str> =
            m.contests.iter().filter(|c| c.name == "build" && c.threads == t).map(|c| c.opponent.as_str()).collect();
        let mut line = String::new();
        for o in opponents {
            if let Some((ours, theirs)) = m.build_scaling(o, t) {
                if line.is_empty() {
                    line = format!("rtdiff {ours:.2}x");
                }
                line.push_str(&format!(", {o} {theirs:.2}x"));
            }
        }
        if !line.is_empty() {
            println!("build scaling 1 -> {t} threads (median wall clock of 1 thread / of {t}): {line}");
        }
    }
    for (set, opp, a, b) in &m.hit_count_differences {
        println!("note: {} hits differ on {set} against {opp}: rtdiff {a}, {opp} {b}", a.abs_diff(*b));
    }
    print_plugins_against_embree(m);
}

/// The plugins raced on `m`, by label.
fn plugins(m: &MeshRace) -> Vec<String> {
    let mut labels: Vec<String> = Vec::new();
    for c in m.contests.iter().filter(|c| !crate::perf::race::is_embree(&c.opponent)) {
        if !labels.contains(&c.opponent) {
            labels.push(c.opponent.clone());
        }
    }
    labels
}

/// Each plugin against Embree's MEDIUM modes and rtdiff, round by round
/// ([`MeshRace::versus`]): the plugin's time per ray and the medians of the
/// others' time over the plugin's (above 1: the plugin is faster).
fn print_plugins_against_embree(m: &MeshRace) {
    for p in plugins(m) {
        println!(
            "\n{p} against Embree and rtdiff (ratio = the other's time / the plugin's in the same round; above 1: the plugin is faster; median [q1, q3])"
        );
        let against = ["embree-medium", "embree-medium-default", "rtdiff"];
        println!(
            "{:>3} {:<18} {:>16} {:>24} {:>24} {:>24}",
            "thr",
            "workload",
            p.as_str(),
            against[0],
            against[1],
            "rtdiff"
        );
        for c in m.contests.iter().filter(|c| c.opponent == p) {
            let s = c.summary();
            let own = if c.rays > 0 {
                format!("{:.1} ns/ray", s.opponent_s * 1e9 / c.rays as f64)
            } else {
                format!("{:.2} ms", s.opponent_s * 1e3)
            };
            let cells: Vec<String> = against
                .iter()
                .map(|&o| {
                    // The other's time over the plugin's: the plugin as the subject.
                    m.versus(&c.name, c.threads, &p, o)
                        .map_or("-".into(), |(r, q1, q3)| format!("{r:.3} [{q1:.3}, {q3:.3}]"))
                })
                .collect();
            println!("{:>3} {:<18} {:>16} {:>24} {:>24} {:>24}", c.threads, c.name, own, cells[0], cells[1], cells[2]);
        }
    }
}

/// Print the whole-render races.
pub fn print_render_race(r: &[SceneRace], rounds: usize) {
    println!(
        "\n## Whole renders, --tracer native against --tracer embree (build + render; wall clock), {rounds} interleaved rounds (short renders more, up to {}: column `wins` counts them)",
        rounds * crate::perf::render_race::MAX_ROUND_FACTOR
    );
    println!(
        "{:<36} {:>9} {:>3} {:>10} {:>10} {:>7} {:>7} {:>7} {:>7}  images (96x96, 1 spp)",
        "scene", "size", "thr", "native ms", "embree ms", "ratio", "q1", "q3", "wins"
    );
    for s in r {
        for c in &s.contests {
            let m = c.summary();
            let a = &s.agreement;
            println!(
                "{:<36} {:>9} {:>3} {:>10.1} {:>10.1} {:>7.3} {:>7.3} {:>7.3} {:>4}/{}  {} ({} ties, {} over, max {:.1e})",
                c.name,
                format!("{}x{}", s.size.0, s.size.1),
                c.threads,
                m.rtdiff_s * 1e3,
                m.opponent_s * 1e3,
                m.ratio,
                m.q1,
                m.q3,
                m.wins,
                c.times.len(),
                if a.passes() { "agree" } else { "DIFFER" },
                a.primary_ties,
                a.over,
                a.max_rel
            );
        }
    }
}

/// The host's idle-thread wake delay, as the race's first line.
fn print_idle_wake(w: &crate::perf::wake::IdleWake) {
    let (lo, hi) = w.delays_ms.iter().fold((f64::INFINITY, 0.0f64), |(a, b), &d| (a.min(d), b.max(d)));
    println!(
        "host: an idle thread of a {}-thread pool started work {:.2} ms after it was handed it (median of {}, \
         {lo:.2}-{hi:.2} ms, each after {:.0} ms idle)",
        w.threads,
        w.median_ms(),
        w.delays_ms.len(),
        w.idle_ms
    );
}

/// Print the goals with the worst median ratio among the contests
/// each covers, with the host's idle-thread wake delays `wakes` beside the
/// build scaling.
pub fn print_goals(meshes: &[MeshRace], renders: &[SceneRace], wakes: &[crate::perf::wake::IdleWake]) {
    let all: Vec<&crate::perf::race::Contest> = meshes.iter().flat_map(|m| &m.contests).collect();
    let single = ["build", crate::perf::race::CAMERA, "incoherent", "shadow"];
    let worst = |f: &dyn Fn(&crate::perf::race::Contest) -> bool| {
        all.iter()
            .filter(|c| f(c))
            .map(|c| (c.summary().ratio, c.name.clone(), c.opponent.clone()))
            .min_by(|a, b| a.0.total_cmp(&b.0))
    };
    println!("\n## Goals (worst median ratio among the contests each covers)");
    if let Some(m) = meshes.iter().find(|m| m.triangle_test == TriangleTest::MollerTrumbore) {
        println!(
            "rtdiff ran as {} (Moller-Trumbore, not watertight, like Embree's default mode): the lines against \
             Embree's default mode compare like for like, those against its robust mode do not",
            m.rtdiff
        );
    }
    let line = |goal: &str, target: f64, w: Option<(f64, String, String)>| match w {
        Some((r, n, o)) => {
            println!("{:<62} {:>7.3} {:<5} (worst: {n} vs {o})", goal, r, if r >= target { "met" } else { "NOT" })
        }
        None => println!("{goal:<62}       - (not measured)"),
    };
    line(
        "1 thread >= 1.15x Embree robust MEDIUM (build, 3 ray sets)",
        1.15,
        worst(&|c| c.threads == 1 && c.opponent == "embree-medium" && single.contains(&c.name.as_str())),
    );
    line(
        "1 thread >= 1.0x Embree default MEDIUM (build, 3 ray sets)",
        1.0,
        worst(&|c| c.threads == 1 && c.opponent == "embree-medium-default" && single.contains(&c.name.as_str())),
    );
    line(
        "2 threads >= 1.0x Embree robust MEDIUM (build, 3 ray sets)",
        1.0,
        worst(&|c| c.threads == 2 && c.opponent == "embree-medium" && single.contains(&c.name.as_str())),
    );
    line(
        "batches >= 1.0x Embree's 8-wide packets (MEDIUM, robust and default)",
        1.0,
        worst(&|c| c.name.starts_with("batch") && is_embree(&c.opponent) && c.opponent.contains("medium")),
    );
    // Scaling of each contender's own builds; the goal's figure is rtdiff's
    // scaling over the opponent's (at least 1: rtdiff scales as well),
    // judged against Embree's MEDIUM builds, like for like with rtdiff's
    // binned SAH (issue 49; HIGH stays in the table).
    let scaling = meshes
        .iter()
        .flat_map(|m| {
            let opponents = m.contests.iter().filter(|c| c.name == "build" && c.threads == 2);
            opponents.filter(|c| is_embree(&c.opponent) && c.opponent.contains("medium")).filter_map(move |c| {
                let (ours, theirs) = m.build_scaling(&c.opponent, 2)?;
                Some((ours / theirs, format!("{} build", m.mesh), c.opponent.clone()))
            })
        })
        .min_by(|a, b| a.0.total_cmp(&b.0));
    let scaled = scaling.is_some();
    line("build: 2-thread scaling >= Embree MEDIUM's (rtdiff's / Embree's)", 1.0, scaling);
    if let Some(w) = wakes.iter().find(|w| w.threads == 2).filter(|_| scaled) {
        println!(
            "  (an idle thread of the host's 2-thread pool started work after {:.2} ms, median: a build \
             of a few ms scales with the host's scheduler as well as with the builder)",
            w.median_ms()
        );
    }
    // Embree's bytes over rtdiff's (at least 1: rtdiff's tree is no larger).
    let memory = meshes
        .iter()
        .flat_map(|m| {
            m.embree_memory.iter().map(move |e| {
                (
                    e.bvh_bytes_per_primitive / m.rtdiff_bytes_per_primitive,
                    format!("{} memory", m.mesh),
                    e.opponent.clone(),
                )
            })
        })
        .min_by(|a, b| a.0.total_cmp(&b.0));
    line("memory per primitive <= Embree's acceleration structure", 1.0, memory);
    let renders_worst = renders
        .iter()
        .flat_map(|s| &s.contests)
        .map(|c| (c.summary().ratio, c.name.clone(), format!("embree, {} thread(s)", c.threads)))
        .min_by(|a, b| a.0.total_cmp(&b.0));
    line("whole renders: native >= 1.0x embree on every scene, 1 and 2 threads", 1.0, renders_worst);
    if !renders.is_empty() {
        let differ: Vec<String> =
            renders.iter().filter(|s| !s.agreement.passes()).map(|s| s.scene.display().to_string()).collect();
        println!(
            "{:<62} {}",
            "whole renders: the same images",
            if differ.is_empty() { "met".into() } else { format!("NOT: {differ:?}") }
        );
    }
}

/// `--embree-max-isa`'s value parser.
fn parse_embree_isa(s: &str) -> std::result::Result<EmbreeIsa, String> {
    EmbreeIsa::parse(s).map_err(|e| e.to_string())
}
