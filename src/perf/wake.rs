//! How long an idle pool thread takes to start work it is handed: a fact
//! of the host (its scheduler, its virtual CPUs) that a parallel build of a
//! few milliseconds measures as much as the builder.
//!
//! A rayon worker that finds no work sleeps within microseconds. Work handed
//! to the pool then waits until the kernel runs the woken thread, which on
//! most machines takes microseconds. Some virtual machines place a woken
//! thread on the busy CPU of the thread that woke it and move it to the idle
//! one only at a later scheduler tick (milliseconds): a two-thread build
//! shorter than a few ticks then runs mostly on one thread, and how much
//! depends on the minute. `rtdiff bench --race` measures the delay with
//! [`idle_wake`] and prints it beside the build scaling it bears on.

use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};

use serde::Serialize;

/// The delays [`idle_wake`] measured on one pool.
#[derive(Clone, Debug, Serialize)]
pub struct IdleWake {
    /// Threads of the pool.
    pub threads: usize,
    /// How long each try left the pool idle before handing it work.
    pub idle_ms: f64,
    /// Per try, milliseconds from handing work to every other thread of the
    /// pool until the last of them started it (the try's cap when one never
    /// did, see [`idle_wake`]).
    pub delays_ms: Vec<f64>,
}

impl IdleWake {
    /// The median delay in milliseconds, as the race takes its medians
    /// ([`super::clock::median`]); NaN without a try.
    pub fn median_ms(&self) -> f64 {
        if self.delays_ms.is_empty() { f64::NAN } else { super::clock::median(self.delays_ms.clone()) }
    }
}

/// The longest a try waits for the pool's other threads.
const CAP: Duration = Duration::from_millis(100);

/// Measure, `tries` times, how long `pool`'s other threads take to start a
/// task after the pool has been idle for `idle`: from inside the pool, one
/// thread hands every other thread a task (`rayon::spawn_broadcast`) and
/// keeps its own core busy, as a build's first pass does, until each has
/// started it (at most [`CAP`]). `None` for a pool of one thread.
pub fn idle_wake(pool: &rayon::ThreadPool, idle: Duration, tries: usize) -> Option<IdleWake> {
    let threads = pool.current_num_threads();
    if threads < 2 {
        return None;
    }
    let delays_ms = (0..tries)
        .map(|_| {
            std::thread::sleep(idle);
            pool.install(|| {
                let start = Instant::now();
                let caller = rayon::current_thread_index();
                // The latest start among the other threads, in nanoseconds
                // after `start` plus one (0: none yet), and how many started.
                let latest = Arc::new(AtomicU64::new(0));
                let started = Arc::new(AtomicU64::new(0));
                let (l, s) = (latest.clone(), started.clone());
                rayon::spawn_broadcast(move |ctx| {
                    if Some(ctx.index()) != caller {
                        l.fetch_max(start.elapsed().as_nanos() as u64 + 1, Ordering::AcqRel);
                        s.fetch_add(1, Ordering::AcqRel);
                    }
                });
                let others = (threads - 1) as u64;
                while started.load(Ordering::Acquire) < others && start.elapsed() < CAP {
                    std::hint::spin_loop();
                }
                if started.load(Ordering::Acquire) < others {
                    return CAP.as_secs_f64() * 1e3;
                }
                latest.load(Ordering::Acquire).saturating_sub(1) as f64 * 1e-6
            })
        })
        .collect();
    Some(IdleWake { threads, idle_ms: idle.as_secs_f64() * 1e3, delays_ms })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_one_thread_pool_has_no_other_thread_to_wake() {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
        assert!(idle_wake(&pool, Duration::from_millis(1), 3).is_none());
    }

    /// Each try gives one delay, at most the cap, and most tries see every
    /// other thread start its task (the task reaches them, not the caller
    /// alone) well within it, even on a loaded test machine.
    #[test]
    fn each_try_is_timed_and_the_other_threads_start() {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(2).build().unwrap();
        let w = idle_wake(&pool, Duration::from_millis(2), 5).unwrap();
        assert_eq!((w.threads, w.delays_ms.len()), (2, 5));
        let cap = CAP.as_secs_f64() * 1e3;
        assert!(w.delays_ms.iter().all(|&d| (0.0..=cap).contains(&d)), "{:?}", w.delays_ms);
        assert!(w.median_ms() < cap, "{:?}", w.delays_ms);
    }

    #[test]
    fn the_median_is_the_middle_try() {
        let w = IdleWake { threads: 2, idle_ms: 20.0, delays_ms: vec![4.0, 0.1, 3.0, 0.2, 0.3] };
        assert_eq!(w.median_ms(), 0.3);
        assert!(IdleWake { delays_ms: vec![], ..w }.median_ms().is_nan());
    }
}
