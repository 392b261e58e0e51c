//! Stopwatches for single-threaded and parallel work on a shared machine.

use std::time::Instant;

use crate::error::{Error, Result};

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
#[derive(Clone, Copy, Debug)]
pub struct Clock {
    /// Measure CPU time of the calling thread instead of wall-clock time.
    pub cpu: bool,
}

impl Clock {
    /// A start mark.
    pub fn now(&self) -> (Instant, Option<f64>) {
        (Instant::now(), if self.cpu { thread_cpu_seconds() } else { None })
    }

    /// Seconds since `start`.
    pub fn since(&self, start: (Instant, Option<f64>)) -> f64 {
        match (start.1, if self.cpu { thread_cpu_seconds() } else { None }) {
            (Some(a), Some(b)) => b - a,
            _ => start.0.elapsed().as_secs_f64(),
        }
    }
}

/// The median of `v` (the upper one for an even count).
pub fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// Median, first and last quartile of `v` (sorted in place).
pub fn quartiles(v: &mut [f64]) -> (f64, f64, f64) {
    v.sort_by(f64::total_cmp);
    let at = |q: f64| v[((v.len() - 1) as f64 * q).round() as usize];
    (at(0.5), at(0.25), at(0.75))
}

/// Time `f` `runs` times; median seconds and the first result. With
/// `cpu_time`, measures the calling thread's CPU time (single-threaded work only).
pub fn timed<T>(runs: usize, cpu_time: bool, mut f: impl FnMut() -> T) -> (f64, T) {
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

/// CPU seconds the whole process has used so far (user and system, every thread); 0 where the
/// platform does not say.
pub fn process_cpu_seconds() -> f64 {
    #[cfg(unix)]
    {
        // SAFETY: an all-zero rusage is a valid value for getrusage to overwrite.
        let mut ru: libc::rusage = unsafe { std::mem::zeroed() };
        // SAFETY: ru is a valid, writable rusage.
        if unsafe { libc::getrusage(libc::RUSAGE_SELF, &mut ru) } == 0 {
            let t = |v: libc::timeval| v.tv_sec as f64 + v.tv_usec as f64 * 1e-6;
            return t(ru.ru_utime) + t(ru.ru_stime);
        }
    }
    0.0
}

/// Thread CPU seconds of one call of `f`.
pub fn cpu_seconds<T>(f: impl FnOnce() -> T) -> (f64, T) {
    let clock = Clock { cpu: true };
    let start = clock.now();
    let r = f();
    (clock.since(start), r)
}

/// A rayon pool with one thread.
pub fn single_pool() -> Result<rayon::ThreadPool> {
    rayon::ThreadPoolBuilder::new().num_threads(1).build().map_err(|e| Error::Invalid(e.to_string()))
}
