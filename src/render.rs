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

/// Render row `y` into `row`: [`render_pixel`] for every pixel, with each
/// round of camera rays (one per pixel for each sample and lens sample)
/// traced as one batch ([`Tracer::intersect_batch`]) and then shaded pixel
/// by pixel. Each pixel draws from its own random stream in the same order as
/// [`render_pixel`] and sums in the same order, so the row is bit-identical
/// to rendering its pixels one by one.
pub fn render_row(
    scene: &Scene,
    tracer: &dyn Tracer,
    integ: &dyn Integrator,
    plan: &Plan,
    y: u32,
    row: &mut [Vec3],
    c: &mut Counters,
) {
    let w = row.len();
    let mut rngs: Vec<Pcg32> = (0..w).map(|x| Pcg32::for_pixel(scene.seed, x as u32, y)).collect();
    let mut sums = vec![Vec3::ZERO; w];
    let mut lens = vec![Vec3::ZERO; w];
    let mut at = vec![(0.0f32, 0.0f32); w];
    let mut rays = vec![crate::geometry::Ray::new(Vec3::ZERO, Vec3::Z); w];
    let mut hits = vec![None; w];
    let n = if plan.depth_of_field { scene.params.dof_samples } else { 1 };
    for s in 0..scene.spp {
        for k in 0..n {
            for x in 0..w {
                let rng = &mut rngs[x];
                if k == 0 {
                    let (ox, oy) = pixel_offset(s, scene.spp, rng);
                    at[x] = (x as f32 + ox, y as f32 + oy);
                    lens[x] = Vec3::ZERO;
                }
                let (px, py) = at[x];
                rays[x] = if plan.depth_of_field {
                    let (lu, lv) = (rng.next_f32(), rng.next_f32());
                    scene.camera.lens_ray(px, py, lu, lv)
                } else {
                    scene.camera.ray(px, py)
                };
            }
            tracer.intersect_batch(&rays, &mut hits);
            for x in 0..w {
                let l = integ.radiance_with_hit(&rays[x], hits[x], &mut rngs[x], c);
                if plan.depth_of_field {
                    lens[x] += l;
                } else {
                    sums[x] += l;
                }
            }
        }
        if plan.depth_of_field {
            for x in 0..w {
                sums[x] += lens[x] / n as f32;
            }
        }
    }
    for (px, sum) in row.iter_mut().zip(sums) {
        *px = sum / scene.spp as f32;
    }
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
///
/// A count equal to that of the pool the caller is in (the global pool
/// outside any) runs `work` there rather than on a new pool. Starting a pool
/// per call made repeated renders in one process slow and erratic when the
/// threads fill the cores, as the previous pool's threads wind down beside the
/// new ones: `cornell_box_parallelogram_light`, 400x400, 2 threads on 2 cores,
/// native renders took 92 ms (quartiles 83-100) after a native render and 80
/// ms after an Embree one; on the caller's pool, 77 ms after either.
pub fn with_threads<T: Send>(threads: Option<usize>, work: impl FnOnce() -> T + Send) -> Result<T> {
    match threads {
        Some(0) => Err(Error::Invalid("--threads must be at least 1".into())),
        Some(n) if n == rayon::current_num_threads() => Ok(work()),
        Some(n) => Ok(rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build()
            .map_err(|e| Error::Invalid(format!("cannot start {n} threads: {e}")))?
            .install(work)),
        None => Ok(work()),
    }
}

/// The pool size for rendering `height` rows with `threads` (`--threads`;
/// None: the global pool): checked against the limits and capped at one
/// thread per row, since work is split by rows (a 3-row render with
/// `--threads 1024` would only spend time starting threads).
pub fn render_threads(threads: Option<usize>, height: u32) -> Result<Option<usize>> {
    if let Some(n) = threads {
        crate::limits::check_flag("--threads", n, 1, crate::limits::MAX_THREADS)?;
    }
    Ok(threads.map(|n| n.min(height.max(1) as usize)))
}

/// The most rows one rayon task renders. Left to rayon's adaptive split,
/// a render whose rows differ in cost could leave a thread idle: the monkey
/// at 400x400 on 2 threads took 14.3 ms of wall clock for 22.7 ms of CPU
/// time (1.6 cores busy); with at most 8 rows per task 11.6 ms for 23.0 ms,
/// and Embree's render, whose rows cost more evenly, 14.0 ms either way
/// (stop 30, medians of 40 renders in one process, tracers alternated).
/// Tasks of 8 rows cost nothing measurable on the other scenes (cornell_box
/// 29.6 -> 29.5 ms, dragon 11.6 -> 11.1 ms with 16 rows).
const ROWS_PER_TASK: usize = 8;

/// Render `scene` with hits from `tracer`.
pub fn render(scene: &Scene, tracer: &dyn Tracer, opts: &RenderOptions) -> Result<RenderResult> {
    let threads = render_threads(opts.threads, scene.height)?;
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
            .with_max_len(ROWS_PER_TASK)
            .map(|(y, row)| {
                let mut c = Counters::default();
                render_row(scene, tracer, integ.as_ref(), &plan, y as u32, row, &mut c);
                bar.inc(1);
                c
            })
            .collect::<Vec<Counters>>()
    };
    let rows = with_threads(threads, work)?;
    let seconds = start.elapsed().as_secs_f64();
    bar.finish_and_clear();
    let mut counters = Counters::default();
    rows.iter().for_each(|c| counters.add(c));
    Ok(RenderResult { image, counters, plan, seconds })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Overrides;

    /// scenes/all_features.json at 24x16 and its tracer.
    fn small_all_features() -> (Scene, Box<dyn crate::accel::Tracer>) {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/all_features.json");
        let ov = Overrides { width: Some(24), height: Some(16), ..Default::default() };
        let scene = Scene::load_with(&path, &ov).unwrap();
        let tracer = crate::backends::build_tracer(scene.prims.clone(), &scene.accel).unwrap();
        (scene, tracer)
    }

    /// Rows rendered with batched camera and shadow rays are bit-identical
    /// to pixels rendered one by one ([`render_pixel`], single rays), with
    /// every feature on (depth of field, 4 samples, transparency, glossy,
    /// area lights), and count the same work.
    #[test]
    fn batched_rows_equal_single_pixels() {
        let (scene, tracer) = small_all_features();
        let plan = scene.plan();
        let integ = integrator::create(&scene, tracer.as_ref(), plan);
        let (mut ca, mut cb) = (Counters::default(), Counters::default());
        for y in 0..scene.height {
            let mut row = vec![Vec3::ZERO; scene.width as usize];
            render_row(&scene, tracer.as_ref(), integ.as_ref(), &plan, y, &mut row, &mut ca);
            for (x, px) in row.iter().enumerate() {
                let one = render_pixel(&scene, integ.as_ref(), &plan, x as u32, y, &mut cb);
                assert_eq!(px.to_array().map(f32::to_bits), one.to_array().map(f32::to_bits), "pixel {x} {y}");
            }
        }
        assert_eq!(ca, cb);
        assert!(ca.shadow_rays > 0 && ca.secondary_rays > 0);
    }

    /// The batched shadow rays (any-hit first, the transparency walk only for
    /// occluded rays) give the colour of the one-ray-at-a-time walk that the
    /// debug recorder follows.
    #[test]
    fn batched_shadow_rays_equal_the_recorded_walk() {
        let (scene, tracer) = small_all_features();
        let w = integrator::Whitted::new(&scene, tracer.as_ref(), scene.plan());
        let (mut ca, mut cb) = (Counters::default(), Counters::default());
        for y in 0..scene.height {
            for x in 0..scene.width {
                let ray = scene.camera.ray(x as f32 + 0.5, y as f32 + 0.5);
                let (mut ra, mut rb) = (Pcg32::for_pixel(1, x, y), Pcg32::for_pixel(1, x, y));
                let a = w.trace(&ray, 0, &mut ra, &mut ca);
                let mut rec = integrator::debug::RayTree::default();
                let b = w.trace_as(integrator::debug::RayKind::Camera, &ray, 0, &mut rb, &mut cb, &mut rec);
                assert_eq!(a.to_array().map(f32::to_bits), b.to_array().map(f32::to_bits), "pixel {x} {y}");
            }
        }
        assert_eq!(ca, cb);
    }
}
