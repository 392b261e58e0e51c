//! The one place rtdiff runs Mitsuba 3: the project's Python environment
//! (`.venv/`, made by `scripts/mitsuba/setup.sh`) on `scripts/mitsuba/sweep.py`,
//! which renders scenes exported by [`crate::scene::export::mitsuba`] with the
//! `rtdiff_whitted` plugin and times each render with its JIT kernels already
//! compiled.

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};

/// The Python of `root/.venv`, if the environment exists.
pub fn venv_python(root: &Path) -> Option<PathBuf> {
    let py = root.join(".venv/bin/python");
    py.exists().then_some(py)
}

/// Why there is no Mitsuba environment under `root`, or `None` when there is one.
pub fn missing_environment(root: &Path) -> Option<String> {
    venv_python(root).is_none().then(|| {
        format!("Mitsuba is not set up ({} is missing: run scripts/mitsuba/setup.sh)", root.join(".venv").display())
    })
}

/// One exported scene rendered once per seed.
#[derive(Clone, Debug, Serialize)]
pub struct SweepJob {
    /// A folder written by `rtdiff export --to mitsuba`.
    pub scene_dir: PathBuf,
    /// Seeds of the renders (the plugin's sampler streams).
    pub seeds: Vec<u64>,
    /// One EXR per seed.
    pub outputs: Vec<PathBuf>,
    /// Passes per render (by default the scene's samples per pixel times its lens samples).
    pub passes: Option<u32>,
}

/// What `sweep.py` reports for one image.
#[derive(Clone, Debug, Deserialize)]
pub struct SweepRender {
    /// The EXR written.
    pub output: PathBuf,
    /// The seed.
    pub seed: u64,
    /// Passes (samples per pixel times lens samples).
    pub passes: u32,
    /// Scene load time (not in `render_seconds`).
    pub load_seconds: f64,
    /// The scene's one-pass warm-up, JIT compilation included (not in `render_seconds`).
    pub warmup_seconds: f64,
    /// The render itself, kernels compiled.
    pub render_seconds: f64,
}

#[derive(Deserialize)]
struct Closing {
    mitsuba: String,
    variant: String,
}

/// Every render of a sweep, and the Mitsuba that made them.
#[derive(Clone, Debug)]
pub struct SweepResult {
    /// One entry per image, in job order.
    pub renders: Vec<SweepRender>,
    /// "Mitsuba 3.9.1 (llvm_ad_rgb)".
    pub mitsuba: String,
}

/// Render `jobs` with Mitsuba in one Python process, calling `tick` after each image.
pub fn sweep(root: &Path, jobs: &[SweepJob], work: &Path, mut tick: impl FnMut()) -> Result<SweepResult> {
    let py = venv_python(root).ok_or_else(|| Error::Invalid(missing_environment(root).unwrap_or_default()))?;
    let script = root.join("scripts/mitsuba/sweep.py");
    let jobs_path = work.join("mitsuba-jobs.json");
    let text = serde_json::to_string(&serde_json::json!({ "renders": jobs }))
        .map_err(|e| Error::file(&jobs_path, format!("cannot serialise: {e}")))?;
    crate::output::write(&jobs_path, text)?;
    let mut child = Command::new(&py)
        .arg(&script)
        .arg(&jobs_path)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .map_err(|e| Error::file(&py, format!("cannot run: {e}")))?;
    let stdout = child.stdout.take().expect("piped stdout");
    // Read stderr on its own thread so that a chatty Python cannot block on a full pipe.
    let mut stderr = child.stderr.take().expect("piped stderr");
    let err_reader = std::thread::spawn(move || {
        let mut s = String::new();
        std::io::Read::read_to_string(&mut stderr, &mut s).ok();
        s
    });
    let mut renders = Vec::new();
    let mut closing = None;
    for line in BufReader::new(stdout).lines() {
        let line = line.map_err(|e| Error::file(&script, format!("cannot read its output: {e}")))?;
        if let Ok(r) = serde_json::from_str::<SweepRender>(&line) {
            renders.push(r);
            tick();
        } else if let Ok(c) = serde_json::from_str::<Closing>(&line) {
            closing = Some(c);
        }
    }
    let status = child.wait().map_err(|e| Error::file(&script, format!("cannot wait for it: {e}")))?;
    let err = err_reader.join().unwrap_or_default();
    let expected: usize = jobs.iter().map(|j| j.seeds.len()).sum();
    match closing {
        Some(c) if status.success() && renders.len() == expected => {
            Ok(SweepResult { renders, mitsuba: format!("Mitsuba {} ({})", c.mitsuba, c.variant) })
        }
        _ => Err(Error::file(
            &script,
            format!(
                "{status}, {} of {expected} renders: {}",
                renders.len(),
                err.lines().rev().find(|l| !l.trim().is_empty()).unwrap_or("no message")
            ),
        )),
    }
}
