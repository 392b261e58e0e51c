//! The machine a report was measured on: CPU, cores, compiler, commit, Embree.

use std::path::Path;
use std::process::Command;

use serde::{Deserialize, Serialize};

/// Facts that head every performance table.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MachineFacts {
    /// CPU model name (`/proc/cpuinfo`), or `unknown`.
    pub cpu: String,
    /// Logical cores available to this process.
    pub cores: usize,
    /// Threads the renders use when not told otherwise (rayon's pool).
    pub threads: usize,
    /// The compiler that built this binary.
    pub rustc: String,
    /// Commit of the source tree (with `-dirty` when it has uncommitted changes), or `unknown`.
    pub commit: String,
    /// Embree version, or why there is none.
    pub embree: String,
    /// Operating system and architecture.
    pub os: String,
}

impl MachineFacts {
    /// Gather the facts of this machine and build.
    pub fn gather() -> Self {
        Self {
            cpu: cpu_model().unwrap_or_else(|| "unknown".into()),
            cores: std::thread::available_parallelism().map_or(1, |n| n.get()),
            threads: rayon::current_num_threads(),
            rustc: env!("RTDIFF_RUSTC_VERSION").to_string(),
            commit: commit(Path::new(env!("CARGO_MANIFEST_DIR"))).unwrap_or_else(|| "unknown".into()),
            embree: embree_version(),
            os: format!("{} {}", std::env::consts::OS, std::env::consts::ARCH),
        }
    }
}

fn cpu_model() -> Option<String> {
    let info = std::fs::read_to_string("/proc/cpuinfo").ok()?;
    info.lines()
        .find(|l| l.starts_with("model name"))
        .and_then(|l| l.split_once(':'))
        .map(|(_, v)| v.trim().to_string())
}

fn commit(dir: &Path) -> Option<String> {
    let out = Command::new("git").arg("-C").arg(dir).args(["rev-parse", "--short=12", "HEAD"]).output().ok()?;
    if !out.status.success() {
        return None;
    }
    let hash = String::from_utf8(out.stdout).ok()?.trim().to_string();
    let dirty = Command::new("git")
        .arg("-C")
        .arg(dir)
        .args(["status", "--porcelain", "--untracked-files=no"])
        .output()
        .ok()
        .is_some_and(|o| !o.stdout.is_empty());
    Some(if dirty { format!("{hash}-dirty") } else { hash })
}

#[cfg(feature = "embree")]
fn embree_version() -> String {
    match crate::embree::Device::new("").and_then(|d| d.version()) {
        Ok(v) => format!("{}.{}.{}", v / 10000, v / 100 % 100, v % 100),
        Err(e) => format!("unavailable ({e})"),
    }
}

#[cfg(not(feature = "embree"))]
fn embree_version() -> String {
    "not built (build with --features embree)".into()
}
