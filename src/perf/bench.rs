//! The benchmark behind `rtdiff bench`: build time per builder and traversal
//! throughput per tracer on primary, incoherent and shadow ray sets,
//! single-threaded and with all threads. Tracers come from
//! [`crate::backends::build_tracer`], so Embree rows appear when the crate is
//! built with `--features embree`.

use std::sync::Arc;

use glam::Vec3;
use rayon::prelude::*;
use serde::Serialize;

use crate::accel::Tracer;
use crate::backends::{AccelConfig, Backend, Builder, EmbreeQuality, Traversal, build_tracer};
use crate::camera::Camera;
use crate::error::{Error, Result};
use crate::geometry::offset::SpawnOffset;
use crate::geometry::{Hit, Primitives, Ray};
use crate::rays::{incoherent_rays, shadow_rays};

use super::clock::{single_pool, timed};

/// The benchmark's point lights, one per quarter of the image (bands of
/// rows, top to bottom): the default light and its three mirror images that
/// flip two of its signs, the corners of a tetrahedron around the mesh. The
/// shadow rays of one light all leave the lit side of the surfaces in one
/// direction, so a traversal order can suit one light and not another: an
/// any-hit walk in lane order measured 2.5% faster than the nearest-last one
/// on dragon_87k's shadow rays towards the first light alone, and 26%
/// slower towards the fourth (docs/bvh.md, issue 16 tenth pass).
pub const SHADOW_LIGHTS: [Vec3; 4] =
    [crate::rays::DEFAULT_LIGHT, Vec3::new(1.0, 1.0, 1.0), Vec3::new(1.0, -1.0, -1.0), Vec3::new(-1.0, -1.0, 1.0)];

/// Seed of the incoherent rays.
pub const INCOHERENT_SEED: u64 = 2024;

/// What a benchmark run measures.
#[derive(Clone, Debug, Serialize)]
pub struct BenchOptions {
    /// Timed runs per measurement (the median is reported).
    pub runs: usize,
    /// Primary image width and height (rays = size^2).
    pub size: u32,
    /// Number of incoherent rays.
    pub incoherent: usize,
    /// Builders to time.
    pub builders: Vec<Builder>,
    /// Traversals to time.
    pub traversals: Vec<Traversal>,
    /// Skip the all-threads measurements.
    pub single_only: bool,
    /// Primitives per leaf for the median builder.
    pub leaf_size: usize,
    /// Bins per axis for the sah builder.
    pub bins: usize,
}

impl Default for BenchOptions {
    fn default() -> Self {
        Self {
            runs: 3,
            size: 512,
            incoherent: 262_144,
            builders: crate::backends::builders(),
            traversals: crate::backends::traversals(),
            single_only: false,
            leaf_size: 1,
            bins: 16,
        }
    }
}

impl BenchOptions {
    /// Reject counts that cannot be measured.
    pub fn validate(&self) -> Result<()> {
        if self.runs == 0 || self.size == 0 {
            return Err(Error::Invalid("--runs and --size must be positive".into()));
        }
        if self.bins < 2 {
            return Err(Error::Invalid(format!("--bins must be at least 2 (got {})", self.bins)));
        }
        Ok(())
    }
}

/// Build time of one structure, in milliseconds.
#[derive(Clone, Debug, Serialize)]
pub struct BuildRow {
    /// Structure label.
    pub structure: String,
    /// CPU time of the building thread on a one-thread pool.
    pub single_thread_ms: Option<f64>,
    /// Wall clock with all threads (for `threads=1` Embree rows: its wall clock).
    pub all_threads_ms: Option<f64>,
}

/// Throughput of one tracer.
#[derive(Clone, Debug, Serialize)]
pub struct TraversalRow {
    /// Tracer label.
    pub tracer: String,
    /// Million rays per second on the primary, incoherent and shadow rays.
    pub mrays_per_s: [f64; 3],
    /// The same over the same builder's `basic` traversal (native tracers only).
    pub ratio_to_basic: Option<[f64; 3]>,
    /// Rays whose hit primitive (or occlusion answer) differs from the reference `sah/fast`.
    pub differences: usize,
}

/// One traversal table: single-threaded (CPU time) or all threads (wall clock).
#[derive(Clone, Debug, Serialize)]
pub struct TraversalTable {
    /// Threads used.
    pub threads: usize,
    /// All threads, timed by the wall clock (otherwise one thread, timed by its CPU time).
    pub all_threads: bool,
    /// One row per tracer.
    pub rows: Vec<TraversalRow>,
}

/// The ray sets' sizes.
#[derive(Clone, Debug, Serialize)]
pub struct RayCounts {
    /// Primary rays.
    pub primary: usize,
    /// Primary rays that hit.
    pub primary_hits: usize,
    /// Incoherent rays.
    pub incoherent: usize,
    /// Shadow rays (one per primary hit).
    pub shadow: usize,
    /// The point lights the shadow rays go to, one per quarter of the image ([`SHADOW_LIGHTS`]).
    pub lights: Vec<[f32; 3]>,
}

/// Everything `rtdiff bench` measured on one scene.
#[derive(Clone, Debug, Serialize)]
pub struct BenchReport {
    /// Scene name.
    pub scene: String,
    /// Primitives in the scene.
    pub primitives: usize,
    /// Rayon threads of the all-threads measurements.
    pub threads: usize,
    /// Runs per measurement.
    pub runs: usize,
    /// Build times.
    pub builds: Vec<BuildRow>,
    /// Why Embree rows are missing, when they are.
    pub embree_unavailable: Option<String>,
    /// The ray sets.
    pub rays: RayCounts,
    /// Traversal tables (one thread, then all threads unless `single_only`).
    pub traversal: Vec<TraversalTable>,
}

/// The three ray sets of a scene.
pub struct RaySets {
    /// Primary rays from the default camera.
    pub primary: Vec<Ray>,
    /// Random origins and directions.
    pub incoherent: Vec<Ray>,
    /// From the primary hits towards [`SHADOW_LIGHTS`], one light per
    /// quarter of the image (consecutive rays share their light, so packets
    /// of them stay coherent).
    pub shadow: Vec<Ray>,
    /// Primary rays that hit.
    pub primary_hits: usize,
}

impl RaySets {
    /// Primary rays from the default camera at `size` x `size`, `incoherent`
    /// incoherent rays, and shadow rays from the primary hits of `reference`
    /// towards [`SHADOW_LIGHTS`] (rows `q * size / 4 ..` towards light `q`).
    pub fn new(prims: &Arc<Primitives>, size: u32, incoherent: usize, reference: &dyn Tracer) -> Self {
        Self::with_camera(prims, &Camera::default_view(size, size), incoherent, reference)
    }

    /// [`Self::new`] with the mesh framed as renders frame an object: seen
    /// from the default view's direction ([`crate::camera::DEFAULT_EYE`],
    /// [`crate::camera::DEFAULT_FOV`]) at the distance where its bounding
    /// sphere (around its box) is as tall as the image. The box covers about
    /// half the image and the mesh less: most camera rays miss, many of them
    /// the box itself (about 80% miss on suzanne and the dragons; the
    /// default view of a mesh normalised to the unit sphere, [`Self::new`],
    /// leaves more of them outside the box).
    pub fn framed(prims: &Arc<Primitives>, size: u32, incoherent: usize, reference: &dyn Tracer) -> Self {
        let b = prims.world_bounds();
        let (centre, radius) = (0.5 * (b.min + b.max), 0.5 * (b.max - b.min).length());
        let half = (0.5 * crate::camera::DEFAULT_FOV).to_radians();
        let eye = centre + radius / half.tan() * crate::camera::DEFAULT_EYE.normalize();
        let camera = Camera::look_at(eye, centre, Vec3::Y, crate::camera::DEFAULT_FOV, size, size);
        Self::with_camera(prims, &camera, incoherent, reference)
    }

    /// The sets with `camera`'s pixel-centre rays as the primary rays.
    fn with_camera(prims: &Arc<Primitives>, camera: &Camera, incoherent: usize, reference: &dyn Tracer) -> Self {
        let size = camera.width;
        assert_eq!(camera.width, camera.height, "the shadow rays' quarters assume a square image");
        let primary = camera.pixel_centre_rays();
        let hits: Vec<Option<Hit>> = primary.par_iter().map(|r| reference.intersect(r)).collect();
        let quarter = |q: usize| q * size as usize / SHADOW_LIGHTS.len() * size as usize;
        let shadow = SHADOW_LIGHTS
            .iter()
            .enumerate()
            .flat_map(|(q, &light)| {
                let rows = quarter(q)..quarter(q + 1);
                shadow_rays(prims, &primary[rows.clone()], &hits[rows], light, SpawnOffset::Robust)
            })
            .collect();
        let primary_hits = hits.iter().filter(|h| h.is_some()).count();
        let incoherent = incoherent_rays(&prims.world_bounds(), incoherent, INCOHERENT_SEED);
        Self { primary, incoherent, shadow, primary_hits }
    }

    /// `(name, rays, any-hit)` of each set.
    pub fn list(&self) -> [(&'static str, &[Ray], bool); 3] {
        [("primary", &self.primary, false), ("incoherent", &self.incoherent, false), ("shadow", &self.shadow, true)]
    }
}

/// Result of one tracer on one ray set: closest hits or occlusion flags.
#[derive(PartialEq)]
enum Answers {
    Closest(Vec<Option<Hit>>),
    Any(Vec<bool>),
}

fn trace(tracer: &dyn Tracer, rays: &[Ray], any: bool, parallel: bool) -> Answers {
    match (any, parallel) {
        (false, false) => Answers::Closest(rays.iter().map(|r| tracer.intersect(r)).collect()),
        (false, true) => Answers::Closest(rays.par_iter().with_min_len(256).map(|r| tracer.intersect(r)).collect()),
        (true, false) => Answers::Any(rays.iter().map(|r| tracer.occluded(r)).collect()),
        (true, true) => Answers::Any(rays.par_iter().with_min_len(256).map(|r| tracer.occluded(r)).collect()),
    }
}

/// Disagreements with the reference answers: different hit/miss or primitive.
fn disagreements(a: &Answers, b: &Answers) -> usize {
    match (a, b) {
        (Answers::Closest(a), Answers::Closest(b)) => {
            a.iter().zip(b).filter(|(x, y)| x.map(|h| h.prim) != y.map(|h| h.prim)).count()
        }
        (Answers::Any(a), Answers::Any(b)) => a.iter().zip(b).filter(|(x, y)| x != y).count(),
        _ => usize::MAX,
    }
}

/// Embree builds on one device made with `"threads=1"` and kept alive (so no
/// thread-pool start-up is timed): CPU time and wall clock of the calling
/// thread, which does all the work with one thread.
#[cfg(feature = "embree")]
fn embree_single_thread_builds(prims: &Arc<Primitives>, runs: usize) -> Result<Vec<BuildRow>> {
    use crate::embree::{Device, EmbreeTracer};
    let device = Device::new("threads=1")?;
    let mut rows = Vec::new();
    for q in [EmbreeQuality::Low, EmbreeQuality::Medium, EmbreeQuality::High] {
        let (cpu, r) = timed(runs, true, || EmbreeTracer::with_device(&device, prims.clone(), q).map(|_| ()));
        r?;
        let (wall, _) = timed(runs, false, || EmbreeTracer::with_device(&device, prims.clone(), q).map(|_| ()));
        rows.push(BuildRow {
            structure: format!("embree {} (threads=1; wall)", value_name(&q)),
            single_thread_ms: Some(cpu * 1e3),
            all_threads_ms: Some(wall * 1e3),
        });
    }
    Ok(rows)
}

#[cfg(not(feature = "embree"))]
fn embree_single_thread_builds(_: &Arc<Primitives>, _: usize) -> Result<Vec<BuildRow>> {
    Ok(Vec::new())
}

/// Benchmark `prims` (named `scene` in the report) with `opts`.
pub fn run(scene: &str, prims: Arc<Primitives>, opts: &BenchOptions) -> Result<BenchReport> {
    opts.validate()?;
    let one = single_pool()?;
    let mut builds = Vec::new();
    let mut configs: Vec<AccelConfig> = Vec::new();
    for &builder in &opts.builders {
        for (label, traversal) in [("binary", Traversal::Basic), ("binary + 8-wide", Traversal::Fast)] {
            let cfg =
                AccelConfig { builder, traversal, leaf_size: opts.leaf_size, bins: opts.bins, ..Default::default() };
            let (t1, _) = one.install(|| timed(opts.runs, true, || build_tracer(prims.clone(), &cfg).map(|_| ())));
            let (tn, _) = timed(opts.runs, false, || build_tracer(prims.clone(), &cfg).map(|_| ()));
            builds.push(BuildRow {
                structure: format!("bvh-{} {label}", value_name(&builder)),
                single_thread_ms: Some(t1 * 1e3),
                all_threads_ms: Some(tn * 1e3),
            });
        }
        for &traversal in &opts.traversals {
            configs.push(AccelConfig {
                builder,
                traversal,
                leaf_size: opts.leaf_size,
                bins: opts.bins,
                ..Default::default()
            });
        }
    }
    let mut embree_unavailable = None;
    for q in [EmbreeQuality::Low, EmbreeQuality::Medium, EmbreeQuality::High] {
        let cfg = AccelConfig { backend: Backend::Embree, embree_quality: q, ..Default::default() };
        match timed(opts.runs, false, || build_tracer(prims.clone(), &cfg).map(|_| ())) {
            (t, Ok(())) => {
                builds.push(BuildRow {
                    structure: format!("embree {}", value_name(&q)),
                    single_thread_ms: None,
                    all_threads_ms: Some(t * 1e3),
                });
                configs.push(cfg);
            }
            (_, Err(e)) => {
                embree_unavailable = Some(e.to_string());
                break;
            }
        }
    }
    builds.extend(embree_single_thread_builds(&prims, opts.runs)?);

    // Ray sets: shadow rays start at the primary hits of the reference tracer.
    let reference = build_tracer(prims.clone(), &AccelConfig::default())?;
    let sets = RaySets::new(&prims, opts.size, opts.incoherent, reference.as_ref());
    let set_list = sets.list();
    let refs: Vec<Answers> = set_list.iter().map(|(_, r, any)| trace(reference.as_ref(), r, *any, true)).collect();

    let modes: &[bool] = if opts.single_only { &[false] } else { &[false, true] };
    let mut traversal = Vec::new();
    for &parallel in modes {
        let mut rows = Vec::new();
        let mut basic: Vec<(Builder, [f64; 3])> = Vec::new();
        for cfg in &configs {
            let tracer = build_tracer(prims.clone(), cfg)?;
            let mut mr = [0.0; 3];
            let mut diff = 0;
            for (k, (_, rays, any)) in set_list.iter().enumerate() {
                let (t, ans) = if parallel {
                    timed(opts.runs, false, || trace(tracer.as_ref(), rays, *any, true))
                } else {
                    one.install(|| timed(opts.runs, true, || trace(tracer.as_ref(), rays, *any, false)))
                };
                mr[k] = rays.len() as f64 / t / 1e6;
                diff += disagreements(&ans, &refs[k]);
            }
            if cfg.backend == Backend::Native && cfg.traversal == Traversal::Basic {
                basic.push((cfg.builder, mr));
            }
            let base = basic.iter().find(|(b, _)| *b == cfg.builder && cfg.backend == Backend::Native).map(|b| b.1);
            rows.push(TraversalRow {
                tracer: tracer.name(),
                mrays_per_s: mr,
                ratio_to_basic: base.map(|b| [0, 1, 2].map(|k| mr[k] / b[k])),
                differences: diff,
            });
        }
        traversal.push(TraversalTable {
            threads: if parallel { rayon::current_num_threads() } else { 1 },
            all_threads: parallel,
            rows,
        });
    }
    Ok(BenchReport {
        scene: scene.to_string(),
        primitives: prims.len(),
        threads: rayon::current_num_threads(),
        runs: opts.runs,
        builds,
        embree_unavailable,
        rays: RayCounts {
            primary: sets.primary.len(),
            primary_hits: sets.primary_hits,
            incoherent: sets.incoherent.len(),
            shadow: sets.shadow.len(),
            lights: SHADOW_LIGHTS.iter().map(|l| l.to_array()).collect(),
        },
        traversal,
    })
}

/// The lower-case name clap gives `v`.
pub fn value_name<T: clap::ValueEnum>(v: &T) -> String {
    v.to_possible_value().map_or_else(String::new, |p| p.get_name().to_string())
}
