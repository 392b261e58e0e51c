//! Hostile-input fuzzing, quick mode (part of `scripts/test.sh`): a sample of
//! the systematic truncations and the random mutations of
//! `examples/fuzz_inputs.rs` (the long mode, a million inputs and more), run
//! in-process through the library with a time limit per input. No input may
//! panic, hang or be refused with a message that does not name its file.

use std::sync::mpsc;
use std::time::{Duration, Instant};

use rtdiff::fuzz::{Corpus, Runner, generate};

/// A few seconds of work on a loaded machine is expected per input at most;
/// a hang in a validated input is what this catches.
const TIME_LIMIT: Duration = Duration::from_secs(60);

#[test]
fn quick_fuzz_finds_no_panic_hang_or_unhelpful_message() {
    let root = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let corpus = Corpus::load(&root).expect("corpus");
    let trunc = corpus.truncations();
    // Every 23rd truncation, then 2500 random mutations.
    let indices: Vec<u64> = (0..trunc).step_by(23).chain(trunc + 1_000_000..trunc + 1_002_500).collect();
    let dir = std::env::temp_dir().join(format!("rtdiff-fuzz-quick-{}", std::process::id()));
    let (tx, rx) = mpsc::channel::<(u64, Result<(), String>)>();
    let n = indices.len();
    let worker_root = root.clone();
    let worker_dir = dir.clone();
    std::thread::spawn(move || {
        let runner = Runner::new(&worker_root, &worker_dir).expect("runner");
        std::panic::set_hook(Box::new(|_| {}));
        for i in indices {
            let input = generate(&corpus, 7, i);
            let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| runner.run(&input)));
            let r = match r {
                Ok(Ok(_)) => Ok(()),
                Ok(Err(m)) => Err(format!("unhelpful: {m} ({} from {}: {})", input.kind.name(), input.base, input.how)),
                Err(_) => Err(format!("panic ({} from {}: {})", input.kind.name(), input.base, input.how)),
            };
            if tx.send((i, r)).is_err() {
                return;
            }
        }
    });
    let start = Instant::now();
    let mut failures = Vec::new();
    for _ in 0..n {
        match rx.recv_timeout(TIME_LIMIT) {
            Ok((i, Err(m))) => failures.push(format!("input 7:{i}: {m}")),
            Ok(_) => {}
            Err(_) => panic!("an input ran longer than {TIME_LIMIT:?} (hang): {failures:?}"),
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
    eprintln!("quick fuzz: {n} inputs in {:.1} s", start.elapsed().as_secs_f64());
    assert!(
        failures.is_empty(),
        "{} failures (replay with fuzz_inputs --replay SEED:INDEX):\n{}",
        failures.len(),
        failures.join("\n")
    );
}
