//! The render loop: pixels in parallel, deterministic per-pixel sampling,
//! progress on stderr.

use std::time::Instant;

use glam::Vec3;
use rayon::prelude::*;

use crate::accel::Tracer;
use crate::error::{Error, Result};
use crate::features::Plan;
use crate::film::Image;
use crate::integrator::{self, Counters, Integrator};
use crate::rng::Pcg32;
use crate::scene::Scene;

/// How to run a render.
#[derive(Clone, Debug, Default)]
pub struct RenderOptions {
    /// Worker threads (default: all cores). The image does not depend on it.
    pub threads: Option<usize>,
    /// No progress bar.
    pub quiet: bool,
}

/// What a render produced.
#[derive(Clone, Debug)]
pub struct RenderResult {
    /// The image before post-processing.
    pub image: Image,
    /// Work counters.
    pub counters: Counters,
    /// The features the render actually used.
    pub plan: Plan,
    /// Wall-clock render time in seconds.
    pub seconds: f64,
}

/// Camera sample `s` of `spp` inside a pixel: the centre for one sample,
/// jittered strata for a square count, uniform positions otherwise.
#[inline]
fn pixel_offset(s: u32, spp: u32, rng: &mut Pcg32) -> (f32, f32) {
    if spp == 1 {
        return (0.5, 0.5);
    }
    let k = (spp as f32).sqrt().round() as u32;
    if k * k == spp {
        let (i, j) = (s % k, s / k);
        ((i as f32 + rng.next_f32()) / k as f32, (j as f32 + rng.next_f32()) / k as f32)
    } else {
        (rng.next_f32(), rng.next_f32())
    }
}

/// Render one pixel: the pixel's own random stream, its camera (and lens)
/// samples, averaged. Public for tools that must trace exactly the render's
/// rays (the heatmaps of [`crate::debug`]).
#[inline]
pub fn render_pixel(scene: &Scene, integ: &dyn Integrator, plan: &Plan, x: u32, y: u32, c: &mut Counters) -> Vec3 {
    let mut rng = Pcg32::for_pixel(scene.seed, x, y);
    let mut sum = Vec3::ZERO;
    for s in 0..scene.spp {
        let (ox, oy) = pixel_offset(s, scene.spp, &mut rng);
        let (px, py) = (x as f32 + ox, y as f32 + oy);
        if plan.depth_of_field {
            let n = scene.params.dof_samples;
            let mut lens = Vec3::ZERO;
            for _ in 0..n {
                let (lu, lv) = (rng.next_f32(), rng.next_f32());
                lens += integ.radiance(&scene.camera.lens_ray(px, py, lu, lv), &mut rng, c);
            }
            sum += lens / n as f32;
        } else {
            sum += integ.radiance(&scene.camera.ray(px, py), &mut rng, c);
        }
    }
    sum / scene.spp as f32
}

/// A progress bar over `rows` image rows on stderr (hidden when `quiet`;
/// indicatif also hides it when stderr is not a terminal).
pub fn progress_bar(rows: u64, quiet: bool, msg: &'static str) -> indicatif::ProgressBar {
    if quiet {
        return indicatif::ProgressBar::hidden();
    }
    let b = indicatif::ProgressBar::with_draw_target(Some(rows), indicatif::ProgressDrawTarget::stderr());
    if let Ok(style) = indicatif::ProgressStyle::with_template("{msg} [{bar:40}] {pos}/{len} rows, {eta} left") {
        b.set_style(style.progress_chars("=> "));
    }
    b.set_message(msg);
    b
}

/// Run `work` on a pool of `threads` workers (None: the global pool of all cores).
pub fn with_threads<T: Send>(threads: Option<usize>, work: impl FnOnce() -> T + Send) -> Result<T> {
    match threads {
        Some(0) => Err(Error::Invalid("--threads must be at least 1".into())),
        Some(n) => Ok(rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build()
            .map_err(|e| Error::Invalid(format!("cannot start {n} threads: {e}")))?
            .install(work)),
        None => Ok(work()),
    }
}

/// Render `scene` with hits from `tracer`.
pub fn render(scene: &Scene, tracer: &dyn Tracer, opts: &RenderOptions) -> Result<RenderResult> {
    if let Some(n) = opts.threads {
        crate::limits::check_flag("--threads", n, 1, crate::limits::MAX_THREADS)?;
    }
    crate::scene::validate::check_render_work(scene)?;
    let plan = scene.plan();
    let integ = integrator::create(scene, tracer, plan);
    let (w, h) = (scene.width, scene.height);
    let bar = progress_bar(h as u64, opts.quiet, "rendering");
    let mut image = Image::new(w, h);
    let start = Instant::now();
    let work = || {
        image
            .pixels
            .par_chunks_mut(w as usize)
            .enumerate()
            .map(|(y, row)| {
                let mut c = Counters::default();
                for (x, px) in row.iter_mut().enumerate() {
                    *px = render_pixel(scene, integ.as_ref(), &plan, x as u32, y as u32, &mut c);
                }
                bar.inc(1);
                c
            })
            .collect::<Vec<Counters>>()
    };
    // Work is split by rows: a pool larger than the image's row count (a
    // 3-row render with `--threads 1024`) would only spend time starting threads.
    let rows = with_threads(opts.threads.map(|n| n.min(h as usize)), work)?;
    let seconds = start.elapsed().as_secs_f64();
    bar.finish_and_clear();
    let mut counters = Counters::default();
    rows.iter().for_each(|c| counters.add(c));
    Ok(RenderResult { image, counters, plan, seconds })
}
