//! The whole pipeline in one call: scene -> acceleration structure ->
//! integrator -> film -> post-processing, returning the final image and typed,
//! serialisable statistics. The CLI, the tests and the image comparisons all
//! render through [`render_scene`], so none of them sees a different image.

use std::path::PathBuf;
use std::time::Instant;

use serde::Serialize;

use crate::accel::Tracer;
use crate::backends::build_tracer;
use crate::error::Result;
use crate::features::Plan;
use crate::film::Image;
use crate::integrator::Counters;
use crate::post::bloom::{self, BloomStages};
use crate::render::{RenderOptions, render};
use crate::scene::Scene;

/// What a render did: the `rtdiff render --stats` file.
#[derive(Clone, Debug, Serialize)]
pub struct RenderStats {
    /// The scene file.
    pub scene: PathBuf,
    /// Triangles in the scene.
    pub triangles: usize,
    /// Spheres in the scene.
    pub spheres: usize,
    /// The tracer's label ([`crate::backends::AccelConfig::label`]).
    pub tracer: String,
    /// Acceleration-structure build time, milliseconds (wall clock).
    pub build_ms: f64,
    /// Render time, milliseconds (wall clock, post-processing excluded).
    pub render_ms: f64,
    /// Rays of every kind.
    pub rays: u64,
    /// Million rays per second over the render time.
    pub mrays_per_s: f64,
    /// Work counters.
    pub counters: Counters,
    /// The features the render actually used.
    pub plan: Plan,
}

/// A rendered scene.
#[derive(Clone, Debug)]
pub struct Rendered {
    /// The final image, post-processing (bloom) included.
    pub image: Image,
    /// The bloom stages, when the plan has bloom.
    pub bloom: Option<BloomStages>,
    /// Statistics.
    pub stats: RenderStats,
}

/// Render `scene` to its final image with the tracer its `accel` asks for.
pub fn render_scene(scene: &Scene, opts: &RenderOptions) -> Result<Rendered> {
    // One pool of the render's threads for the build and the render,
    // whichever the backend: a pool per stage started and stopped its threads
    // twice.
    let threads = crate::render::render_threads(opts.threads, scene.height)?;
    crate::render::with_threads(threads, || {
        let t0 = Instant::now();
        let tracer = build_tracer(scene.prims.clone(), &scene.accel)?;
        let build_ms = t0.elapsed().as_secs_f64() * 1e3;
        // Already on the pool: the render runs on it as it stands.
        let mut out = render_with(scene, tracer.as_ref(), &RenderOptions { threads: None, ..opts.clone() })?;
        out.stats.build_ms = build_ms;
        Ok(out)
    })?
}

/// Render `scene` to its final image with a `tracer` the caller built (for
/// callers that use it for more than the render, like `rtdiff debug --draw`);
/// [`RenderStats::build_ms`] is then 0.
pub fn render_with(scene: &Scene, tracer: &dyn Tracer, opts: &RenderOptions) -> Result<Rendered> {
    let result = render(scene, tracer, opts)?;
    let (image, bloom) = if result.plan.bloom {
        let st = bloom::bloom_stages(&result.image, &scene.params.bloom);
        (st.result.clone(), Some(st))
    } else {
        (result.image, None)
    };
    let rays = result.counters.total_rays();
    let stats = RenderStats {
        scene: scene.path.clone(),
        triangles: scene.prims.triangles.len(),
        spheres: scene.prims.spheres.len(),
        tracer: tracer.name(),
        build_ms: 0.0,
        render_ms: result.seconds * 1e3,
        rays,
        mrays_per_s: rays as f64 / result.seconds.max(1e-9) / 1e6,
        counters: result.counters,
        plan: result.plan,
    };
    Ok(Rendered { image, bloom, stats })
}
