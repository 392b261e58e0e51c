//! Hostile-input fuzzing, long mode (the quick mode is `tests/fuzz_quick.rs`).
//!
//! ```sh
//! cargo build --release --features embree && \
//! cargo run --release --features embree --example fuzz_inputs -- --count 1000000
//! cargo run --release --features embree --example fuzz_inputs -- --replay SEED:INDEX
//! ```
//!
//! The parent process starts a worker child (this program with `--worker`)
//! that runs inputs `rtdiff::fuzz::generate(seed, i)` in-process through the
//! library, catching panics, and reports each input on stdout before and
//! after running it. The parent classifies: a panic (caught), an abort (the
//! child dies: stack overflow, abort), a hang (no progress within
//! `--time-limit` seconds: the child is killed) or an OOM (the child's
//! allocator refuses to exceed `--alloc-cap-mb` and exits after reporting);
//! after a death it restarts the child past the culprit. Every `--spawn-every`
//! inputs the worker also runs the `rtdiff` binary on the input and checks its
//! exit code (0, 1 or clap's 2; never a signal or 101) and message. Every
//! input is loaded (validated); every `--deep-every`-th accepted one is also
//! built, rendered, traced or run through parity. Each failure is printed
//! with its replay command.

use std::alloc::{GlobalAlloc, Layout, System};
use std::collections::BTreeMap;
use std::io::{BufRead, BufReader, Write};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use std::time::{Duration, Instant};

use rtdiff::fuzz::{Corpus, Input, Kind, Outcome, Runner, generate};

/// Allocator that counts live bytes and stops the process, after saying so,
/// before it exceeds the cap (a runaway allocation, caught before the OOM killer).
struct Capped;

static LIVE: AtomicUsize = AtomicUsize::new(0);
static CAP: AtomicUsize = AtomicUsize::new(usize::MAX);
static CURRENT: AtomicU64 = AtomicU64::new(u64::MAX);

fn over_cap(size: usize) {
    let live = LIVE.load(Ordering::Relaxed);
    if live.saturating_add(size) > CAP.load(Ordering::Relaxed) {
        // No allocation here: format into a stack buffer and write(2) it.
        let mut buf = [0u8; 96];
        let mut w = &mut buf[..];
        let _ = write!(w, "\noom {} {}\n", CURRENT.load(Ordering::Relaxed), size);
        let n = 96 - w.len();
        // SAFETY: buf holds n initialised bytes; fd 1 is stdout.
        unsafe {
            libc::write(1, buf.as_ptr().cast(), n);
            libc::_exit(3);
        }
    }
}

// SAFETY: forwards to the system allocator; only adds accounting.
unsafe impl GlobalAlloc for Capped {
    unsafe fn alloc(&self, l: Layout) -> *mut u8 {
        over_cap(l.size());
        LIVE.fetch_add(l.size(), Ordering::Relaxed);
        // SAFETY: same layout contract as the caller's.
        unsafe { System.alloc(l) }
    }
    unsafe fn dealloc(&self, p: *mut u8, l: Layout) {
        LIVE.fetch_sub(l.size(), Ordering::Relaxed);
        // SAFETY: p was allocated by System with layout l.
        unsafe { System.dealloc(p, l) }
    }
    unsafe fn alloc_zeroed(&self, l: Layout) -> *mut u8 {
        over_cap(l.size());
        LIVE.fetch_add(l.size(), Ordering::Relaxed);
        // SAFETY: same layout contract as the caller's.
        unsafe { System.alloc_zeroed(l) }
    }
    unsafe fn realloc(&self, p: *mut u8, l: Layout, new: usize) -> *mut u8 {
        if new > l.size() {
            over_cap(new - l.size());
        }
        LIVE.fetch_add(new, Ordering::Relaxed);
        LIVE.fetch_sub(l.size(), Ordering::Relaxed);
        // SAFETY: p was allocated by System with layout l.
        unsafe { System.realloc(p, l, new) }
    }
}

#[global_allocator]
static ALLOC: Capped = Capped;

struct Opts {
    count: u64,
    start: u64,
    seed: u64,
    time_limit: f64,
    alloc_cap_mb: usize,
    spawn_every: u64,
    jobs: u64,
    deep_every: u64,
    worker: bool,
    replay: Option<(u64, u64)>,
    bin: PathBuf,
    root: PathBuf,
}

fn parse_opts() -> Result<Opts, String> {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let exe = std::env::current_exe().map_err(|e| e.to_string())?;
    // target/release/examples/fuzz_inputs -> target/release/rtdiff
    let bin = exe.parent().and_then(Path::parent).map(|p| p.join("rtdiff")).unwrap_or_default();
    let mut o = Opts {
        count: 100_000,
        start: 0,
        seed: 1,
        time_limit: 20.0,
        alloc_cap_mb: 3072,
        spawn_every: 2000,
        jobs: 1,
        deep_every: 8,
        worker: false,
        replay: None,
        bin,
        root,
    };
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mut i = 0;
    let num = |i: usize| -> Result<&str, String> { args.get(i).map(String::as_str).ok_or("missing value".into()) };
    while i < args.len() {
        let a = args[i].as_str();
        let bad = |e: &dyn std::fmt::Display| format!("{a}: {e}");
        match a {
            "--count" => o.count = num(i + 1)?.parse().map_err(|e| bad(&e))?,
            "--start" => o.start = num(i + 1)?.parse().map_err(|e| bad(&e))?,
            "--seed" => o.seed = num(i + 1)?.parse().map_err(|e| bad(&e))?,
            "--time-limit" => o.time_limit = num(i + 1)?.parse().map_err(|e| bad(&e))?,
            "--alloc-cap-mb" => o.alloc_cap_mb = num(i + 1)?.parse().map_err(|e| bad(&e))?,
            "--spawn-every" => o.spawn_every = num(i + 1)?.parse().map_err(|e| bad(&e))?,
            "--deep-every" => o.deep_every = num(i + 1)?.parse().map_err(|e| bad(&e))?,
            "--jobs" => o.jobs = num(i + 1)?.parse().map_err(|e| bad(&e))?,
            "--bin" => o.bin = PathBuf::from(num(i + 1)?),
            "--replay" => {
                let (s, k) = num(i + 1)?.split_once(':').ok_or("--replay SEED:INDEX")?;
                o.replay = Some((s.parse().map_err(|e| bad(&e))?, k.parse().map_err(|e| bad(&e))?));
            }
            "--worker" => {
                o.worker = true;
                i += 1;
                continue;
            }
            _ => return Err(format!("unknown argument {a}")),
        }
        i += 2;
    }
    Ok(o)
}

fn main() {
    let o = match parse_opts() {
        Ok(o) => o,
        Err(e) => {
            eprintln!("fuzz_inputs: {e}");
            std::process::exit(2);
        }
    };
    if o.worker {
        worker(&o);
    } else if let Some((seed, index)) = o.replay {
        replay(&o, seed, index);
    } else {
        std::process::exit(supervise(&o));
    }
}

fn scratch(tag: &str) -> PathBuf {
    let shm = Path::new("/dev/shm");
    let base = if shm.is_dir() { shm.to_path_buf() } else { std::env::temp_dir() };
    let d = base.join(format!("rtdiff-fuzz-{tag}-{}", std::process::id()));
    let _ = std::fs::create_dir_all(&d);
    d
}

/// Run the `rtdiff` binary on a staged input; `Err` says what is wrong.
fn spawn_check(o: &Opts, runner: &Runner, input: &Input, outcome: &Outcome) -> Result<bool, String> {
    if !o.bin.exists() {
        return Ok(false);
    }
    let dir = &runner.dir;
    let mut cmd = Command::new(&o.bin);
    let named = match input.kind {
        Kind::Scene => {
            if !matches!(outcome, Outcome::Refused(_)) {
                return Ok(false); // accepted scenes may legitimately render for long at full size
            }
            cmd.arg("render").arg(dir.join("scene.json")).arg("-o").arg(dir.join("out.png")).arg("--quiet");
            Some("scene.json")
        }
        Kind::Obj | Kind::Mtl => {
            std::fs::write(dir.join("one.csv"), rtdiff::fuzz::BASE_RAYS).map_err(|e| e.to_string())?;
            cmd.arg("trace").arg(runner.path_of(Kind::Obj)).args(["--rays"]).arg(dir.join("one.csv"));
            cmd.arg("--out").arg(dir.join("hits.csv"));
            Some(if input.kind == Kind::Obj { "mesh.obj" } else { ".mtl" })
        }
        Kind::Rays => {
            cmd.arg("trace").arg(o.root.join("scenes/cube.json")).arg("--rays").arg(dir.join("rays.csv"));
            cmd.arg("--out").arg(dir.join("hits.csv"));
            Some("rays.csv")
        }
        Kind::Gltf | Kind::Glb | Kind::Stl => {
            std::fs::write(dir.join("one.csv"), rtdiff::fuzz::BASE_RAYS).map_err(|e| e.to_string())?;
            cmd.arg("trace").arg(runner.path_of(input.kind)).args(["--rays"]).arg(dir.join("one.csv"));
            cmd.arg("--out").arg(dir.join("hits.csv"));
            Some(input.kind.file_name())
        }
        Kind::Texture => return Ok(false),
        Kind::Flags => {
            if !matches!(outcome, Outcome::Refused(_)) {
                return Ok(false);
            }
            cmd.current_dir(&o.root).args(
                input
                    .args()
                    .iter()
                    .map(|a| if a == "out.png" { dir.join("out.png").display().to_string() } else { a.clone() }),
            );
            None
        }
    };
    let mut child = cmd.stdout(Stdio::null()).stderr(Stdio::piped()).spawn().map_err(|e| e.to_string())?;
    let start = Instant::now();
    let status = loop {
        if let Some(s) = child.try_wait().map_err(|e| e.to_string())? {
            break s;
        }
        if start.elapsed().as_secs_f64() > o.time_limit * 3.0 {
            let _ = child.kill();
            let _ = child.wait();
            return Err("the binary did not finish in time".into());
        }
        std::thread::sleep(Duration::from_millis(5));
    };
    let mut err = String::new();
    if let Some(mut s) = child.stderr.take() {
        let _ = std::io::Read::read_to_string(&mut s, &mut err);
    }
    let code = status.code();
    if err.contains("panicked") || code.is_none() || code == Some(101) {
        return Err(format!("binary exit {code:?}: {}", err.trim()));
    }
    if code != Some(0) {
        let first = err.lines().next().unwrap_or_default();
        let prefix_ok = first.starts_with("rtdiff: error:") || (input.kind == Kind::Flags && code == Some(2));
        if !prefix_ok || named.is_some_and(|n| !err.contains(n)) {
            return Err(format!("binary exit {code:?} with an unhelpful message: {}", err.trim()));
        }
    }
    Ok(true)
}

fn worker(o: &Opts) {
    CAP.store(o.alloc_cap_mb << 20, Ordering::Relaxed);
    std::panic::set_hook(Box::new(|_| {}));
    let corpus = Corpus::load(&o.root).unwrap_or_else(|e| panic!("corpus: {e}"));
    let runner = Runner::new(&o.root, &scratch("worker")).unwrap_or_else(|e| panic!("runner: {e}"));
    let out = std::io::stdout();
    for i in o.start..o.start + o.count {
        let input = generate(&corpus, o.seed, i);
        {
            let mut w = out.lock();
            let _ = writeln!(w, "start {i} {}", input.kind.name());
            let _ = w.flush();
        }
        CURRENT.store(i, Ordering::Relaxed);
        let deep = o.deep_every <= 1 || i % o.deep_every == 0;
        let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| runner.run_with(&input, deep)));
        let line = match r {
            Ok(Ok(outcome)) => {
                let spawned = if o.spawn_every > 0 && i % o.spawn_every == 0 {
                    match spawn_check(o, &runner, &input, &outcome) {
                        Ok(true) => " spawned",
                        Ok(false) => "",
                        Err(e) => {
                            let mut w = out.lock();
                            let _ = writeln!(w, "spawnfail {i} {}", e.replace('\n', " | "));
                            ""
                        }
                    }
                } else {
                    ""
                };
                match outcome {
                    Outcome::Accepted { ran: true } => format!("ran {i}{spawned}"),
                    Outcome::Accepted { ran: false } => format!("loaded {i}{spawned}"),
                    Outcome::Refused(_) => format!("refused {i}{spawned}"),
                }
            }
            Ok(Err(msg)) => format!("badmsg {i} {}", msg.replace('\n', " | ")),
            Err(p) => {
                let msg = p
                    .downcast_ref::<String>()
                    .cloned()
                    .or_else(|| p.downcast_ref::<&str>().map(|s| s.to_string()))
                    .unwrap_or_default();
                format!("panic {i} {}", msg.replace('\n', " | "))
            }
        };
        let mut w = out.lock();
        let _ = writeln!(w, "{line}");
        let _ = w.flush();
    }
    let _ = std::fs::remove_dir_all(&runner.dir);
}

#[derive(Default)]
struct Tally {
    by_kind: BTreeMap<&'static str, u64>,
    ran: u64,
    loaded: u64,
    refused: u64,
    spawned: u64,
    failures: Vec<(String, u64, String)>,
    /// The slowest inputs, `(seconds, index)`, longest first: where the time per
    /// input grows with something, before it becomes a hang.
    slowest: Vec<(f64, u64)>,
}

/// How many of the slowest inputs the summary lists.
const SLOWEST: usize = 5;

impl Tally {
    fn timed(&mut self, secs: f64, index: u64) {
        self.slowest.push((secs, index));
        self.slowest.sort_by(|a, b| b.0.total_cmp(&a.0));
        self.slowest.truncate(SLOWEST);
    }
}

static DONE: AtomicU64 = AtomicU64::new(0);
static FAILED: AtomicU64 = AtomicU64::new(0);

/// Supervise workers over inputs `start..end` (restarting after a death).
fn run_range(o: &Opts, start: u64, end: u64) -> Result<Tally, String> {
    let exe = std::env::current_exe().map_err(|e| e.to_string())?;
    let mut next = start;
    let mut t = Tally::default();
    while next < end {
        let mut child = Command::new(&exe)
            .args(["--worker", "--seed", &o.seed.to_string(), "--start", &next.to_string()])
            .args(["--count", &(end - next).to_string(), "--spawn-every", &o.spawn_every.to_string()])
            .args(["--alloc-cap-mb", &o.alloc_cap_mb.to_string(), "--time-limit", &o.time_limit.to_string()])
            .args(["--deep-every", &o.deep_every.to_string()])
            .arg("--bin")
            .arg(&o.bin)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .map_err(|e| format!("worker: {e}"))?;
        let stdout = child.stdout.take().ok_or("no worker stdout")?;
        let (tx, rx) = std::sync::mpsc::channel::<String>();
        std::thread::spawn(move || {
            for line in BufReader::new(stdout).lines().map_while(Result::ok) {
                if tx.send(line).is_err() {
                    break;
                }
            }
        });
        let mut current: Option<u64> = None;
        let mut started = Instant::now();
        let mut oom = false;
        loop {
            match rx.recv_timeout(Duration::from_secs_f64(o.time_limit)) {
                Ok(line) => {
                    let mut parts = line.splitn(3, ' ');
                    let (tag, idx) = (parts.next().unwrap_or(""), parts.next().unwrap_or(""));
                    let i: u64 = idx.parse().unwrap_or(u64::MAX);
                    let rest = parts.next().unwrap_or("").to_string();
                    match tag {
                        "start" => {
                            current = Some(i);
                            started = Instant::now();
                            *t.by_kind.entry(kind_name(&rest)).or_default() += 1;
                        }
                        "ran" | "loaded" | "refused" => {
                            t.timed(started.elapsed().as_secs_f64(), i);
                            match tag {
                                "ran" => t.ran += 1,
                                "loaded" => t.loaded += 1,
                                _ => t.refused += 1,
                            }
                            t.spawned += rest.contains("spawned") as u64;
                            current = None;
                            next = i + 1;
                            DONE.fetch_add(1, Ordering::Relaxed);
                        }
                        "panic" | "badmsg" => {
                            t.failures.push((tag.to_uppercase(), i, rest));
                            current = None;
                            next = i + 1;
                            DONE.fetch_add(1, Ordering::Relaxed);
                            FAILED.fetch_add(1, Ordering::Relaxed);
                        }
                        "spawnfail" => {
                            t.failures.push(("SPAWN".into(), i, rest));
                            FAILED.fetch_add(1, Ordering::Relaxed);
                        }
                        "oom" => oom = true,
                        _ => {}
                    }
                }
                Err(std::sync::mpsc::RecvTimeoutError::Timeout) => {
                    let _ = child.kill();
                    let _ = child.wait();
                    if let Some(i) = current {
                        t.failures.push(("HANG".into(), i, format!("no result within {} s", o.time_limit)));
                        FAILED.fetch_add(1, Ordering::Relaxed);
                        next = i + 1;
                    }
                    break;
                }
                Err(std::sync::mpsc::RecvTimeoutError::Disconnected) => {
                    let status = child.wait().map_err(|e| e.to_string())?;
                    if let Some(i) = current {
                        let mut err = String::new();
                        if let Some(mut s) = child.stderr.take() {
                            let _ = std::io::Read::read_to_string(&mut s, &mut err);
                        }
                        let what = if oom { "OOM" } else { "ABORT" };
                        let tail: String = err.lines().rev().take(3).collect::<Vec<_>>().join(" | ");
                        t.failures.push((what.into(), i, format!("worker ended with {status}: {tail}")));
                        FAILED.fetch_add(1, Ordering::Relaxed);
                        next = i + 1;
                    } else if !status.success() && next < end {
                        return Err(format!("worker failed outside an input: {status}"));
                    }
                    break;
                }
            }
        }
    }
    Ok(t)
}

fn supervise(o: &Opts) -> i32 {
    let t0 = Instant::now();
    let end = o.start + o.count;
    let corpus = Corpus::load(&o.root).unwrap_or_else(|e| panic!("corpus: {e}"));
    println!(
        "fuzz_inputs: seed {}, inputs {}..{} ({} systematic truncations first), {} workers, time limit {} s, \
         allocation cap {} MiB, binary spawned every {} inputs ({}); every {}th input is also built, rendered, traced or run through parity",
        o.seed,
        o.start,
        end,
        corpus.truncations(),
        o.jobs,
        o.time_limit,
        o.alloc_cap_mb,
        o.spawn_every,
        o.bin.display(),
        o.deep_every
    );
    let jobs = o.jobs.max(1);
    let per = o.count.div_ceil(jobs);
    let results: Vec<Result<Tally, String>> = std::thread::scope(|sc| {
        let handles: Vec<_> = (0..jobs)
            .map(|k| {
                let (a, b) = (o.start + k * per, (o.start + (k + 1) * per).min(end));
                sc.spawn(move || run_range(o, a, b))
            })
            .collect();
        let mut last = Instant::now();
        while handles.iter().any(|h| !h.is_finished()) {
            std::thread::sleep(Duration::from_millis(200));
            if last.elapsed() > Duration::from_secs(60) {
                last = Instant::now();
                eprintln!(
                    "fuzz_inputs: {}/{} inputs, {:.0} s, {} failures",
                    DONE.load(Ordering::Relaxed),
                    o.count,
                    t0.elapsed().as_secs_f64(),
                    FAILED.load(Ordering::Relaxed)
                );
            }
        }
        handles.into_iter().map(|h| h.join().unwrap_or_else(|_| Err("supervisor thread panicked".into()))).collect()
    });
    let mut t = Tally::default();
    for r in results {
        match r {
            Ok(x) => {
                for (k, v) in x.by_kind {
                    *t.by_kind.entry(k).or_default() += v;
                }
                t.ran += x.ran;
                t.loaded += x.loaded;
                t.refused += x.refused;
                t.spawned += x.spawned;
                t.failures.extend(x.failures);
                for (s, i) in x.slowest {
                    t.timed(s, i);
                }
            }
            Err(e) => {
                eprintln!("fuzz_inputs: {e}");
                return 2;
            }
        }
    }
    let secs = t0.elapsed().as_secs_f64();
    let count = |tag: &str| t.failures.iter().filter(|f| f.0 == tag).count();
    let tried: u64 = t.by_kind.values().sum();
    println!(
        "inputs tried: {tried} in {secs:.1} s ({:.0}/s); by kind: {}",
        tried as f64 / secs,
        t.by_kind.iter().map(|(k, v)| format!("{k} {v}")).collect::<Vec<_>>().join(", ")
    );
    println!(
        "accepted and run: {}, accepted (validated only, too costly to render): {}, refused with a message: {}, \
         binary spawned: {}",
        t.ran, t.loaded, t.refused, t.spawned
    );
    println!(
        "panics: {}, aborts: {}, hangs: {}, OOM: {}, unhelpful messages: {}, binary failures: {}",
        count("PANIC"),
        count("ABORT"),
        count("HANG"),
        count("OOM"),
        count("BADMSG"),
        count("SPAWN")
    );
    let slow: Vec<String> = t
        .slowest
        .iter()
        .map(|&(s, i)| {
            let input = generate(&corpus, o.seed, i);
            format!("{s:.2} s input {i} ({} from {}: {})", input.kind.name(), input.base, input.how)
        })
        .collect();
    println!("slowest inputs (time limit {} s): {}", o.time_limit, slow.join("; "));
    for (tag, i, msg) in t.failures.iter().take(50) {
        let input = generate(&corpus, o.seed, *i);
        println!(
            "{tag} input {i} ({} from {}: {}): {msg}\n  replay: cargo run --release --features embree --example \
             fuzz_inputs -- --replay {}:{i}",
            input.kind.name(),
            input.base,
            input.how,
            o.seed
        );
    }
    if t.failures.is_empty() { 0 } else { 1 }
}

fn kind_name(s: &str) -> &'static str {
    Kind::ALL.iter().find(|k| k.name() == s).map(|k| k.name()).unwrap_or("?")
}

fn replay(o: &Opts, seed: u64, index: u64) {
    let corpus = Corpus::load(&o.root).unwrap_or_else(|e| panic!("corpus: {e}"));
    let input = generate(&corpus, seed, index);
    let dir = scratch("replay");
    let runner = Runner::new(&o.root, &dir).unwrap_or_else(|e| panic!("runner: {e}"));
    let path = runner.stage(&input).unwrap_or_else(|e| panic!("stage: {e}"));
    println!("input {seed}:{index}: {} from {}: {}", input.kind.name(), input.base, input.how);
    if input.kind == Kind::Flags {
        println!("args: {}", input.args().join(" "));
    } else {
        println!("written to {}", path.display());
    }
    // Not caught: a panic shows its message and backtrace.
    println!("{:?}", runner.run(&input));
}
