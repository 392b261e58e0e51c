//! Whole renders raced: `--tracer native` against `--tracer embree` (the
//! scene's own accelerator settings otherwise) on every scene, interleaved
//! round by round in one process, on 1 and 2 threads, each render timed from
//! the tracer's build to the last pixel (on one thread the process's CPU
//! time, which the machine's other load does not inflate; on more, the wall
//! clock; post-processing is the same for both and not timed). Each scene's two images are also compared
//! with [`crate::verify::image::agreement`] at the tolerance of
//! `tests/embree_render.rs` (96 x 96, one sample per pixel).

use std::path::{Path, PathBuf};
use std::time::Instant;

use serde::Serialize;

use crate::backends::{AccelConfig, Backend, build_tracer};
use crate::error::Result;
use crate::render::{RenderOptions, render};
use crate::scene::{Overrides, Scene};
use crate::verify::image::agreement::{Agreement, agreement};

use super::race::Contest;

/// One scene's race.
#[derive(Clone, Debug, Serialize)]
pub struct SceneRace {
    /// The scene file.
    pub scene: PathBuf,
    /// Image size raced.
    pub size: (u32, u32),
    /// One contest per thread count (`name` = the scene's file name, opponent `embree`).
    pub contests: Vec<Contest>,
    /// How the two tracers' images agree (96 x 96, one sample per pixel).
    pub agreement: Agreement,
}

/// What to race.
#[derive(Clone, Debug, Serialize)]
pub struct RenderRaceOptions {
    /// Interleaved rounds (at least; short renders get more, see [`rounds_for`]).
    pub rounds: usize,
    /// Thread counts.
    pub threads: Vec<usize>,
    /// Image width and height of the timed renders.
    pub size: u32,
}

/// Every `.json` scene in `dir`, sorted by name.
pub fn scenes_in(dir: &Path) -> Result<Vec<PathBuf>> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(dir)
        .map_err(|e| crate::Error::file(dir, format!("cannot list the scenes: {e}")))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "json"))
        .collect();
    v.sort();
    Ok(v)
}

/// The scene's accelerator with backend `b` (the `--tracer` flag).
fn with_backend(scene: &Scene, b: Backend) -> AccelConfig {
    AccelConfig { backend: b, ..scene.accel }
}

/// Build and render `scene` with `cfg` on `threads` threads: wall-clock
/// seconds, on one thread too. The process's CPU time would also count
/// worker threads that spin while idle (rayon's, and the TBB workers behind
/// Embree's device): measured on all_features at 400x400, one thread, it gave
/// Embree 2.65 s where `rtdiff render --tracer embree --threads 1` takes 1.37 s
/// of wall clock and 1.36 s of user time, a 2x advantage to rtdiff that is
/// not real. Rounds alternate the two tracers, so load from other processes
/// falls on both.
fn timed_render(scene: &Scene, cfg: &AccelConfig, threads: usize) -> Result<f64> {
    // The build runs on the render's threads too (Embree's device takes the pool's size).
    let start = Instant::now();
    crate::render::with_threads(Some(threads), || -> Result<()> {
        let tracer = build_tracer(scene.prims.clone(), cfg)?;
        render(scene, tracer.as_ref(), &RenderOptions { threads: None, quiet: true })?;
        Ok(())
    })??;
    Ok(start.elapsed().as_secs_f64())
}

/// Seconds of renders per tracer that a short scene's race takes at least
/// (more rounds, up to [`MAX_ROUND_FACTOR`] times those asked for).
const MIN_RACE_SECONDS: f64 = 0.5;

/// The most rounds a short scene gets, as a multiple of the rounds asked for.
pub const MAX_ROUND_FACTOR: usize = 8;

/// Rounds for a scene whose slower warm-up render took `warm` seconds: at
/// least `rounds`, and more for short renders, whose times on a shared
/// machine swing with the other tenants' load (a 12 ms render on 2 threads
/// measured 8 to 15 ms from round to round, so 7 rounds gave medians 0.92 to
/// 1.2 from one run to the next); interleaving keeps each round's pair under
/// the same load.
pub fn rounds_for(rounds: usize, warm: f64) -> usize {
    let wanted = if warm > 0.0 { (MIN_RACE_SECONDS / warm).ceil() as usize } else { usize::MAX };
    wanted.clamp(rounds, rounds * MAX_ROUND_FACTOR)
}

/// Race native against Embree on `scene_path`.
pub fn race_scene(scene_path: &Path, opts: &RenderRaceOptions) -> Result<SceneRace> {
    let ov = Overrides { width: Some(opts.size), height: Some(opts.size), ..Default::default() };
    let scene = Scene::load_with(scene_path, &ov)?;
    let (native, embree) = (with_backend(&scene, Backend::Native), with_backend(&scene, Backend::Embree));
    let name = scene_path.file_name().map_or_else(String::new, |n| n.to_string_lossy().into_owned());
    let mut contests = Vec::new();
    for &threads in &opts.threads {
        let mut c = Contest {
            name: name.clone(),
            opponent: "embree".into(),
            threads,
            rays: 0,
            hits: 0,
            opponent_hits: 0,
            times: Vec::new(),
            walls: Vec::new(),
        };
        // One untimed render each first: page in the scene's textures and meshes for both.
        let warm = timed_render(&scene, &native, threads)?.max(timed_render(&scene, &embree, threads)?);
        for round in 0..rounds_for(opts.rounds, warm) {
            let (a, b) = if round % 2 == 0 {
                let a = timed_render(&scene, &native, threads)?;
                (a, timed_render(&scene, &embree, threads)?)
            } else {
                let b = timed_render(&scene, &embree, threads)?;
                (timed_render(&scene, &native, threads)?, b)
            };
            c.times.push((a, b));
        }
        contests.push(c);
    }
    let small = Overrides { width: Some(96), height: Some(96), spp: Some(1), ..Default::default() };
    let check = Scene::load_with(scene_path, &small)?;
    let ta = build_tracer(check.prims.clone(), &with_backend(&check, Backend::Native))?;
    let tb = build_tracer(check.prims.clone(), &with_backend(&check, Backend::Embree))?;
    let quiet = RenderOptions { threads: None, quiet: true };
    let (ia, ib) = (render(&check, ta.as_ref(), &quiet)?, render(&check, tb.as_ref(), &quiet)?);
    let agreement = agreement(&check, &ia.image, ta.as_ref(), &ib.image, tb.as_ref());
    Ok(SceneRace { scene: scene_path.to_path_buf(), size: (scene.width, scene.height), contests, agreement })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn short_renders_get_more_rounds() {
        // Long renders keep the rounds asked for.
        assert_eq!(rounds_for(7, 1.0), 7);
        assert_eq!(rounds_for(7, 0.2), 7);
        // 12 ms renders: 0.5 s / 12 ms = 42 rounds.
        assert_eq!(rounds_for(7, 0.012), 42);
        // Capped at 8 times the rounds asked for.
        assert_eq!(rounds_for(7, 0.001), 56);
        assert_eq!(rounds_for(3, 0.0), 24);
    }
}
