//! Numerical stability against mesh scale and offset: `parity`'s stress
//! report (leaks per million crossing rays, false self-intersections per
//! million spawned rays) for the watertight test, Moller-Trumbore and the
//! reference (Embree when built with it, else brute force), on each mesh
//! scaled by factors 1e-4..1e5 and moved up to 1e4 scene radii away.

use std::path::{Path, PathBuf};
use std::time::Instant;

use glam::Vec3;
use serde::Serialize;

use crate::error::{Error, Result};
use crate::rays::SetKind;
use crate::verify::hits::{self as parity, ParityOptions, Reference, StressRow};

/// Options of the stability sweep.
#[derive(Clone, Debug)]
pub struct StabilityOptions {
    /// Scenes (scene JSON or OBJ meshes).
    pub scenes: Vec<PathBuf>,
    /// Scale factors applied about the origin (offset 0).
    pub scales: Vec<f32>,
    /// Offsets in scene radii along (1, 1, 1)/sqrt(3) (scale 1).
    pub offsets: Vec<f32>,
    /// Rays per set.
    pub count: usize,
    /// Seed of the ray sets.
    pub seed: u64,
    /// No progress bar.
    pub quiet: bool,
}

impl StabilityOptions {
    /// The full sweep: the Cornell box and the monkey, 6 scales, 4 offsets, 40,000 rays per set.
    pub fn full(root: &Path) -> Self {
        Self {
            scenes: ["cornell_box_course.json", "monkey.json"].iter().map(|s| root.join("scenes").join(s)).collect(),
            scales: vec![1e-4, 1e-2, 1.0, 1e2, 1e4, 1e5],
            offsets: vec![1e1, 1e2, 1e3, 1e4],
            count: 40_000,
            seed: 1,
            quiet: false,
        }
    }

    /// Small and fast (CI): the Cornell box, 3 scales, 1 offset, 4,000 rays per set.
    pub fn quick(root: &Path) -> Self {
        Self {
            scenes: vec![root.join("scenes").join("cornell_box_course.json")],
            scales: vec![1e-4, 1.0, 1e5],
            offsets: vec![1e4],
            count: 4_000,
            ..Self::full(root)
        }
    }
}

/// The ray sets of the sweep: crossing rays (leaks) and spawned rays (self-intersections).
pub const SETS: [SetKind; 4] = [SetKind::Edges, SetKind::Vertices, SetKind::Shadow, SetKind::Surface];

/// One placement of one mesh.
#[derive(Clone, Debug, Serialize)]
pub struct StabilityPoint {
    /// Scene name (file stem).
    pub scene: String,
    /// Scale factor.
    pub scale: f32,
    /// Offset in scene radii.
    pub offset_radii: f32,
    /// Stress rows, one per ray set (see [`StressRow`]: columns watertight, Moller-Trumbore, reference).
    pub rows: Vec<StressRow>,
}

impl StabilityPoint {
    /// Leaks per million rays over the edge and vertex sets, per tracer.
    pub fn leaks_per_million(&self) -> [f64; 3] {
        weighted(&self.rows, &["edges", "vertices"], |r| (r.leaks_per_million, r.rays))
    }

    /// False self-intersections per million spawned rays (robust offset) over the shadow and surface sets.
    pub fn self_hits_per_million(&self) -> [f64; 3] {
        weighted(&self.rows, &["shadow", "surface"], |r| (r.self_hits_per_million, r.spawned_rays))
    }

    /// The same with the reports' fixed 1e-4 offset.
    pub fn self_hits_fixed_per_million(&self) -> [f64; 3] {
        weighted(&self.rows, &["shadow", "surface"], |r| (r.self_hits_fixed_offset_per_million, r.spawned_rays))
    }
}

/// Rate over the named sets, weighted by each set's denominator.
fn weighted(rows: &[StressRow], sets: &[&str], f: impl Fn(&StressRow) -> ([f64; 3], usize)) -> [f64; 3] {
    let mut num = [0.0; 3];
    let mut den = 0usize;
    for r in rows.iter().filter(|r| sets.contains(&r.set.as_str())) {
        let (rate, n) = f(r);
        for k in 0..3 {
            num[k] += rate[k] * n as f64;
        }
        den += n;
    }
    if den == 0 { [0.0; 3] } else { num.map(|x| x / den as f64) }
}

/// The stability report.
#[derive(Clone, Debug, Serialize)]
pub struct StabilityReport {
    /// Column labels: watertight, Moller-Trumbore, reference.
    pub tracers: [String; 3],
    /// Rays per set.
    pub count: usize,
    /// Seed.
    pub seed: u64,
    /// Every placement of every scene.
    pub points: Vec<StabilityPoint>,
    /// Total wall-clock seconds.
    pub seconds: f64,
}

/// Run the sweep.
pub fn run(opts: &StabilityOptions) -> Result<StabilityReport> {
    if opts.count == 0 {
        return Err(Error::Invalid("the stability sweep needs at least 1 ray per set".into()));
    }
    let start = Instant::now();
    let reference = if cfg!(feature = "embree") { Reference::Embree } else { Reference::Brute };
    let placements: Vec<(f32, f32)> =
        opts.scales.iter().map(|&s| (s, 0.0)).chain(opts.offsets.iter().map(|&o| (1.0, o))).collect();
    let bar = super::progress::bar((placements.len() * opts.scenes.len()) as u64, "report stability", opts.quiet);
    let popts = ParityOptions {
        sets: SETS.to_vec(),
        count: opts.count,
        seed: opts.seed,
        reference,
        variants: Vec::new(),
        sweep_count: None,
        stress: true,
        max_examples: 0,
        arbiter: false,
    };
    let mut points = Vec::new();
    let mut tracers = [String::new(), String::new(), String::new()];
    for path in &opts.scenes {
        let ctx = crate::rays::load_context(path)?;
        let name = path.file_stem().and_then(|s| s.to_str()).unwrap_or("scene").to_string();
        let b = ctx.prims.world_bounds();
        let radius = 0.5 * b.extent().length();
        for &(scale, offset_radii) in &placements {
            bar.set_message(format!("{name} x{scale:e} +{offset_radii:e}r"));
            let off = Vec3::splat(offset_radii * radius / 3f32.sqrt());
            let sub = ctx.transformed(scale, off);
            let r = parity::run(&sub, &popts)?;
            tracers = r.stress_tracers.clone();
            points.push(StabilityPoint { scene: name.clone(), scale, offset_radii, rows: r.stress });
            bar.inc(1);
        }
    }
    bar.finish_and_clear();
    Ok(StabilityReport { tracers, count: opts.count, seed: opts.seed, points, seconds: start.elapsed().as_secs_f64() })
}
