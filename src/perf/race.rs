//! The race behind `rtdiff bench --race ROUNDS`: rtdiff's production
//! configuration (`bvh-sah/fast`, built by [`crate::backends::build_tracer`]
//! exactly as users build it) against Embree 4 in every mode a user may pick
//! (robust and default scene flags, MEDIUM and HIGH quality), on the same
//! rays, each library called as its users call it: rtdiff through the public
//! [`crate::accel::Tracer`] calls (`intersect`, `occluded`, and the batch
//! calls `intersect_batch` / `occluded_batch`) of a `Box<dyn Tracer>`, Embree
//! through its C API as its documentation shows (a `RTCRayHit` filled per ray
//! and `rtcIntersect1`, an `RTCRay` and `rtcOccluded1`, eight-ray packets
//! and `rtcIntersect8` / `rtcOccluded8`; see `direct`), not through rtdiff's
//! `EmbreeTracer` wrapper, whose checks and conversion to rtdiff's `Hit`
//! cost Embree's side about 80 instructions per ray (docs/bvh.md). Neither
//! side's answers are converted: each counts its hits. On 1 and 2 threads,
//! interleaved round by round in one process.
//!
//! On a shared machine the load changes from second to second, so lone
//! absolute times mean little. Each round times rtdiff and every Embree mode
//! back to back on the same chunk of rays (in an order drawn afresh for every
//! round and chunk, see `run_order`) and records each ratio; the report
//! gives the median ratio and its quartiles over the rounds. A ratio above 1
//! means rtdiff is faster (throughput ratio for rays, time ratio Embree /
//! rtdiff for builds). One thread is timed by the CPU time of the working
//! thread, more threads by the wall clock.
//!
//! Like for like: rtdiff's watertight test is exact where Embree's robust
//! mode is only watertight along edges and its default mode is neither
//! (docs/embree.md, finding 1), so rtdiff against `embree-*` (robust) is the
//! like-for-like comparison; against `embree-*-default` rtdiff does more
//! work per triangle than its opponent. With
//! [`RaceOptions::triangle_test`] set to Moller-Trumbore (`rtdiff bench
//! --race N --triangle-test moller-trumbore`) rtdiff uses a test that is
//! not watertight either, which makes `embree-*-default` the like-for-like
//! opponent.
//!
//! Plugins (`rtdiff bench --race N --tracer plugin:PATH`, [`RaceOptions::plugins`])
//! race as further opponents on the same rays in the same rounds, so that a
//! library's author reads its time against rtdiff's and Embree's from one
//! run ([`MeshRace::versus`] compares any two contestants round by round).

use std::sync::Arc;

use serde::Serialize;

use crate::backends::{EmbreeMode, EmbreeQuality};
use crate::error::Result;
use crate::geometry::{Primitives, Ray};

use super::clock::{median, quartiles};

/// The camera rays' name in the race ([`super::bench::RaySets::framed`]: the
/// mesh seen from the default view's direction, its bounding sphere as tall
/// as the image, so that most rays miss it, about 80% on the race's meshes).
pub const CAMERA: &str = "camera";

/// The Embree modes rtdiff races against, robust first.
pub const EMBREE_MODES: [(EmbreeQuality, EmbreeMode); 4] = [
    (EmbreeQuality::Medium, EmbreeMode::Robust),
    (EmbreeQuality::High, EmbreeMode::Robust),
    (EmbreeQuality::Medium, EmbreeMode::Default),
    (EmbreeQuality::High, EmbreeMode::Default),
];

/// One contest over the rounds: rtdiff against one opponent (an Embree mode
/// or a plugin) on one workload.
#[derive(Clone, Debug, Serialize)]
pub struct Contest {
    /// `build`, a ray set's name, or `batch <set>` for the batch calls.
    pub name: String,
    /// The opponent's label: an Embree mode (`embree-medium`,
    /// `embree-high-default`, ...) or a plugin (`plugin:NAME`).
    pub opponent: String,
    /// Threads both contenders used.
    pub threads: usize,
    /// Rays in the set (0 for the build).
    pub rays: usize,
    /// Rays of the set that rtdiff found a hit for (closest hit) or occluded
    /// (any hit), in the first round (0 for the build).
    pub hits: usize,
    /// The same count from the opponent (an Embree mode or a plugin).
    pub opponent_hits: usize,
    /// Per-round seconds, rtdiff then the opponent.
    pub times: Vec<(f64, f64)>,
    /// Builds only: per-round wall-clock seconds, rtdiff then the opponent (with
    /// one thread `times` holds CPU time; the wall clock compares thread
    /// counts, [`MeshRace::build_scaling`]). Empty for ray sets.
    pub walls: Vec<(f64, f64)>,
}

/// Summary of a contest: medians and the spread of the per-round ratio.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct ContestSummary {
    /// Median seconds of rtdiff.
    pub rtdiff_s: f64,
    /// Median seconds of the opponent.
    pub opponent_s: f64,
    /// Median of the opponent's time / rtdiff's time (above 1: rtdiff faster).
    pub ratio: f64,
    /// First quartile of the ratio.
    pub q1: f64,
    /// Third quartile of the ratio.
    pub q3: f64,
    /// Rounds rtdiff won.
    pub wins: usize,
}

impl Contest {
    /// The share of the set's rays that hit (rtdiff's count; 0 for the build).
    pub fn hit_rate(&self) -> f64 {
        if self.rays == 0 { 0.0 } else { self.hits as f64 / self.rays as f64 }
    }

    /// Medians and ratio quartiles over the rounds.
    pub fn summary(&self) -> ContestSummary {
        let mut ratio: Vec<f64> = self.times.iter().map(|(r, e)| e / r).collect();
        let mut ours: Vec<f64> = self.times.iter().map(|t| t.0).collect();
        let mut theirs: Vec<f64> = self.times.iter().map(|t| t.1).collect();
        let (m, q1, q3) = quartiles(&mut ratio);
        let wins = ratio.iter().filter(|&&r| r > 1.0).count();
        let (mo, _, _) = quartiles(&mut ours);
        let (me, _, _) = quartiles(&mut theirs);
        ContestSummary { rtdiff_s: mo, opponent_s: me, ratio: m, q1, q3, wins }
    }
}

/// Builds of each contestant per round when `--build-repeats` is not given
/// ([`RaceOptions::build_repeats`]).
pub const DEFAULT_BUILD_REPEATS: usize = 3;

/// Everything the race measured on one mesh.
#[derive(Clone, Debug, Serialize)]
pub struct MeshRace {
    /// The mesh (or scene) file.
    pub mesh: String,
    /// Primitives in it.
    pub primitives: usize,
    /// Builds of each contestant per round ([`RaceOptions::build_repeats`]).
    pub build_repeats: usize,
    /// rtdiff's tracer (`Tracer::name`: `bvh-sah/fast`, with ` mt` for the Moller-Trumbore test).
    pub rtdiff: String,
    /// rtdiff's triangle test ([`RaceOptions::triangle_test`]).
    pub triangle_test: crate::geometry::TriangleTest,
    /// Bytes of rtdiff's tree (nodes and leaf packets) per primitive.
    pub rtdiff_bytes_per_primitive: f64,
    /// What each Embree mode's scene holds per primitive (its memory monitor;
    /// the builds of the first thread count raced), beside rtdiff's tree.
    pub embree_memory: Vec<EmbreeMemory>,
    /// The instruction sets of rtdiff's traversal
    /// ([`crate::bvh::WalkIsa::summary`]).
    pub rtdiff_isa: String,
    /// Whether rtdiff's walks were set by [`RaceOptions::rtdiff_isa`] (not the widest this CPU runs).
    pub rtdiff_isa_set: bool,
    /// The instruction set of the kernels Embree ran ([`EmbreeIsa::running`]).
    pub embree_isa: EmbreeIsa,
    /// Whether Embree was capped below the widest set this CPU runs (`--embree-max-isa`).
    pub embree_capped: bool,
    /// Every contest, by thread count, workload and opponent.
    pub contests: Vec<Contest>,
    /// Workloads on which an opponent's hit count differs from rtdiff's: `(set, opponent, rtdiff, opponent's)`.
    pub hit_count_differences: Vec<(String, String, usize, usize)>,
}

/// Memory of one Embree mode's scene per primitive, from Embree's memory
/// monitor (`embree::SceneMemory`, with the `embree` feature).
#[derive(Clone, Debug, Serialize)]
pub struct EmbreeMemory {
    /// The Embree mode's label.
    pub opponent: String,
    /// The acceleration structure (nodes and leaf primitives): what compares
    /// with rtdiff's tree, whose leaf packets also hold the vertices.
    pub bvh_bytes_per_primitive: f64,
    /// Embree's copy of the geometry (vertex and index buffers), which a
    /// scene keeps beside its acceleration structure.
    pub geometry_bytes_per_primitive: f64,
}

impl MeshRace {
    /// How the builds scale from one thread to `threads`: the median
    /// one-thread wall-clock build time over the median `threads`-thread
    /// one, for rtdiff and for Embree mode `opponent` (each contender's own
    /// ratio, so a shared machine's slow minutes slow both sides of it).
    /// `None` when either thread count was not raced.
    pub fn build_scaling(&self, opponent: &str, threads: usize) -> Option<(f64, f64)> {
        let walls = |t: usize| {
            self.contests
                .iter()
                .find(|c| c.name == "build" && c.opponent == opponent && c.threads == t && !c.walls.is_empty())
                .map(|c| {
                    let ours = median(c.walls.iter().map(|w| w.0).collect());
                    let theirs = median(c.walls.iter().map(|w| w.1).collect());
                    (ours, theirs)
                })
        };
        let (one, many) = (walls(1)?, walls(threads)?);
        Some((one.0 / many.0, one.1 / many.1))
    }

    /// `subject` against `opponent` on workload `name` with `threads`, each
    /// an opponent's label or `"rtdiff"`: the median and quartiles over the
    /// rounds of the opponent's time / the subject's in the same round
    /// (above 1: the subject is faster). `None` when either was not raced.
    pub fn versus(&self, name: &str, threads: usize, subject: &str, opponent: &str) -> Option<(f64, f64, f64)> {
        let times = |who: &str| -> Option<Vec<f64>> {
            let mut cs = self.contests.iter().filter(|c| c.name == name && c.threads == threads);
            if who == "rtdiff" {
                cs.next().map(|c| c.times.iter().map(|t| t.0).collect())
            } else {
                cs.find(|c| c.opponent == who).map(|c| c.times.iter().map(|t| t.1).collect())
            }
        };
        let (a, b) = (times(subject)?, times(opponent)?);
        let mut ratios: Vec<f64> = a.iter().zip(&b).map(|(s, o)| o / s).collect();
        (!ratios.is_empty()).then(|| quartiles(&mut ratios))
    }
}

/// What to race.
#[derive(Clone, Debug, Serialize)]
pub struct RaceOptions {
    /// Interleaved rounds.
    pub rounds: usize,
    /// Builds of each contestant per round, interleaved (each a sample of
    /// the build contests). A round's builds take a fraction of its time, and
    /// on a shared two-core machine a build's time swings by 10-40% from
    /// one to the next (the other core taken, memory pages dropped by the
    /// system and faulted back in): with three builds per round, a race of
    /// seven rounds takes its build medians over 21 samples instead of 7.
    pub build_repeats: usize,
    /// Thread counts, each raced separately (1: CPU time; more: wall clock).
    pub threads: Vec<usize>,
    /// Also race the batch calls (`intersect_batch` / `occluded_batch`).
    pub batches: bool,
    /// rtdiff's triangle test: watertight (the default, like for like with
    /// Embree's robust mode) or Moller-Trumbore (like for like with its
    /// default mode: neither is watertight).
    pub triangle_test: crate::geometry::TriangleTest,
    /// The widest instruction set Embree's kernels may use (its device's
    /// `max_isa`); `None`: the widest this CPU runs.
    pub embree_max_isa: Option<EmbreeIsa>,
    /// The instruction set of rtdiff's walks ([`crate::bvh::WideBvh::set_isa`]);
    /// `None`: the widest this CPU runs, as users get them.
    pub rtdiff_isa: Option<crate::bvh::WalkIsa>,
    /// Plugins (`--tracer plugin:PATH`) raced as further opponents, after
    /// the Embree modes: each builds its scene from the ABI's buffers (made
    /// once, outside the timing, as Embree's indexed mesh is) and traces
    /// through the ABI's calls.
    pub plugins: Vec<crate::plugin::PluginId>,
}

/// An instruction set Embree's x86 kernels are built for.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum EmbreeIsa {
    /// SSE2.
    Sse2,
    /// SSE4.2.
    Sse42,
    /// AVX.
    Avx,
    /// AVX2 with FMA (what rtdiff's walks use).
    Avx2,
    /// AVX-512 (F, CD, DQ, BW, VL: Skylake-X and later, Zen 4 and later).
    Avx512,
}

impl EmbreeIsa {
    /// Every value, narrowest first.
    pub const ALL: [EmbreeIsa; 5] = [Self::Sse2, Self::Sse42, Self::Avx, Self::Avx2, Self::Avx512];

    /// The name Embree's device configuration (`max_isa=`) and the command line use.
    pub fn name(self) -> &'static str {
        match self {
            Self::Sse2 => "sse2",
            Self::Sse42 => "sse42",
            Self::Avx => "avx",
            Self::Avx2 => "avx2",
            Self::Avx512 => "avx512",
        }
    }

    /// The value named `s` (see [`Self::name`]).
    pub fn parse(s: &str) -> Result<Self> {
        Self::ALL.into_iter().find(|i| i.name() == s).ok_or_else(|| {
            let names: Vec<&str> = Self::ALL.iter().map(|i| i.name()).collect();
            crate::Error::Invalid(format!("unknown instruction set {s:?}: expected one of {}", names.join(", ")))
        })
    }

    /// The widest of these this CPU runs, as Embree's runtime dispatch
    /// chooses it (each level needs the features Embree requires for it).
    pub fn widest_on_this_cpu() -> Self {
        #[cfg(target_arch = "x86_64")]
        {
            use std::arch::is_x86_feature_detected as has;
            if has!("avx512f") && has!("avx512cd") && has!("avx512dq") && has!("avx512bw") && has!("avx512vl") {
                return Self::Avx512;
            }
            if has!("avx2") && has!("fma") && has!("bmi1") && has!("bmi2") && has!("lzcnt") {
                return Self::Avx2;
            }
            if has!("avx") {
                return Self::Avx;
            }
            if has!("sse4.2") {
                return Self::Sse42;
            }
        }
        Self::Sse2
    }

    /// The kernels Embree runs on this CPU under the cap `max`.
    pub fn running(max: Option<Self>) -> Self {
        let widest = Self::widest_on_this_cpu();
        max.map_or(widest, |m| m.min(widest))
    }
}

/// [`race_mesh`] on the benchmark's ray sets of `prims` ([`super::bench::RaySets`]:
/// `size` x `size` camera rays ([`CAMERA`], [`super::bench::RaySets::framed`]),
/// `incoherent` incoherent rays (from inside the mesh's box), and shadow rays
/// from the camera rays' hits of the default configuration).
pub fn race_bench_sets(
    mesh: &str,
    prims: &Arc<Primitives>,
    size: u32,
    incoherent: usize,
    opts: &RaceOptions,
) -> Result<MeshRace> {
    let reference = crate::backends::build_tracer(prims.clone(), &crate::backends::AccelConfig::default())?;
    let sets = super::bench::RaySets::framed(prims, size, incoherent, reference.as_ref());
    let list = sets.list().map(|(n, r, a)| (if n == "primary" { CAMERA } else { n }, r, a));
    race_mesh(mesh, prims, &list, opts)
}

/// A workload: name, rays, any-hit, batch call.
pub type Workload<'a> = (String, &'a [Ray], bool, bool);

/// The single-ray and (optionally) batch workloads of `sets`
/// (`(name, rays, any-hit)`); batches go through the coherent sets only
/// (camera and shadow rays).
pub fn workloads<'a>(sets: &[(&'static str, &'a [Ray], bool)], batches: bool) -> Vec<Workload<'a>> {
    let mut w: Vec<Workload> = sets.iter().map(|(n, r, a)| (n.to_string(), *r, *a, false)).collect();
    if batches {
        w.extend(
            sets.iter().filter(|(n, _, _)| *n != "incoherent").map(|(n, r, a)| (format!("batch {n}"), *r, *a, true)),
        );
    }
    w
}

/// A contestant on a workload: a tracer behind rtdiff's interface (rtdiff's
/// own as users hold it, or a plugin's scene, whose calls go straight to the
/// ABI's), or an Embree scene called through its C API.
#[cfg(feature = "embree")]
#[derive(Clone, Copy)]
enum Contender<'a> {
    Tracer(&'a dyn crate::accel::Tracer),
    Embree(&'a crate::embree::Scene),
}

/// An opponent of rtdiff in the race: an Embree mode or a plugin.
#[cfg(feature = "embree")]
#[derive(Clone, Copy, Debug)]
enum Opponent {
    Embree(EmbreeQuality, EmbreeMode),
    Plugin(crate::plugin::PluginId),
}

#[cfg(feature = "embree")]
impl Opponent {
    /// The label in reports (`embree-medium`, ..., `plugin:NAME`).
    fn label(self) -> String {
        match self {
            Opponent::Embree(q, m) => crate::backends::embree_label(q, m),
            Opponent::Plugin(id) => id.plugin().label(),
        }
    }

    /// The build phase: 0 with rtdiff's builds (Embree's MEDIUM modes), 1
    /// Embree's HIGH modes, 2 the plugins (see `race_mesh`).
    fn phase(self) -> usize {
        match self {
            Opponent::Embree(EmbreeQuality::Medium, _) => 0,
            Opponent::Embree(..) => 1,
            Opponent::Plugin(_) => 2,
        }
    }
}

/// True when `label` names one of Embree's modes (not a plugin).
pub fn is_embree(label: &str) -> bool {
    label.starts_with("embree-")
}

/// Trace `rays` with `c` the way the workload asks; the number of hits.
#[cfg(feature = "embree")]
fn run(c: Contender, rays: &[Ray], any: bool, batch: bool, threads: usize) -> usize {
    use crate::geometry::Hit;
    use rayon::prelude::*;
    // Each thread takes whole slices of this many rays (packets of 8 stay whole).
    let per = rays.len().div_ceil(threads.max(1)).next_multiple_of(8).max(8);
    let one = |rs: &[Ray]| -> usize {
        match (c, any, batch) {
            // Each ray is written afresh just before its call (`fresh`), as
            // a renderer makes it, not read in place from the set's array.
            (Contender::Tracer(t), false, false) => rs.iter().filter(|r| t.intersect(&fresh(r)).is_some()).count(),
            (Contender::Tracer(t), true, false) => rs.iter().filter(|r| t.occluded(&fresh(r))).count(),
            (Contender::Tracer(t), false, true) => {
                let mut out: Vec<Option<Hit>> = vec![None; rs.len()];
                t.intersect_batch(rs, &mut out);
                out.iter().filter(|h| h.is_some()).count()
            }
            (Contender::Tracer(t), true, true) => {
                let mut out = vec![false; rs.len()];
                t.occluded_batch(rs, &mut out);
                out.iter().filter(|&&o| o).count()
            }
            (Contender::Embree(s), false, false) => direct::intersect1(s, rs),
            (Contender::Embree(s), true, false) => direct::occluded1(s, rs),
            (Contender::Embree(s), false, true) => direct::intersect8(s, rs),
            (Contender::Embree(s), true, true) => direct::occluded8(s, rs),
        }
    };
    if threads <= 1 { one(rays) } else { rays.par_chunks(per).map(one).sum() }
}

/// A copy of `r` written to memory just before the call that reads it, as
/// users make each ray just before tracing it (a camera ray, a shadow ray
/// spawned at a hit), so that the call meets the ray in the store buffer
/// rather than in the cache, as it does in a renderer. Embree's side
/// likewise fills its `RTCRayHit` per ray (`direct`). The difference is not
/// small: a load wider than the stores that wrote the ray, or straddling
/// two of them, waits until they reach the cache, which cost rtdiff's walk
/// 15-20 cycles per call before stop 47's entry read the ray field by field
/// (suzanne's camera rays, 80% of which miss: 37.8 against 30.2 ns per ray
/// read in place; docs/bvh.md).
#[cfg(feature = "embree")]
#[inline(always)]
fn fresh(r: &Ray) -> Ray {
    std::hint::black_box(*r)
}

/// Embree called as its documentation and tutorials show (`rtcIntersect1`:
/// "the ray/hit structure is initialised, then passed"; `geomID ==
/// RTC_INVALID_GEOMETRY_ID` means a miss; `rtcOccluded1` sets `tfar` to
/// `-inf` on a hit): one structure filled per ray from the race's rays, the
/// call, one comparison. The race's rays are all traceable (Embree's kernels
/// assume valid rays), which `race_mesh` checks.
#[cfg(feature = "embree")]
mod direct {
    use crate::embree::{Scene, ffi};
    use crate::geometry::Ray;

    #[inline(always)]
    fn ray1(r: &Ray) -> ffi::RTCRay {
        ffi::RTCRay {
            org_x: r.origin.x,
            org_y: r.origin.y,
            org_z: r.origin.z,
            tnear: r.t_min,
            dir_x: r.dir.x,
            dir_y: r.dir.y,
            dir_z: r.dir.z,
            time: 0.0,
            tfar: r.t_max,
            mask: u32::MAX,
            id: 0,
            flags: 0,
        }
    }

    /// Closest-hit queries, one `rtcIntersect1` per ray; the number of hits.
    pub(super) fn intersect1(scene: &Scene, rays: &[Ray]) -> usize {
        let raw = scene.raw();
        let mut hits = 0;
        for r in rays {
            let mut rh = ffi::RTCRayHit {
                ray: ray1(r),
                hit: ffi::RTCHit {
                    geomID: ffi::RTC_INVALID_GEOMETRY_ID,
                    instID: [ffi::RTC_INVALID_GEOMETRY_ID; ffi::RTC_MAX_INSTANCE_LEVEL_COUNT],
                    ..Default::default()
                },
            };
            // SAFETY: a committed scene alive for the call; `rh` is a 16-byte
            // aligned RTCRayHit of the 4.4 layout (96 bytes, asserted in
            // ffi.rs); a traceable ray; NULL arguments are Embree's defaults.
            unsafe { ffi::rtcIntersect1(raw, &mut rh, std::ptr::null_mut()) };
            hits += usize::from(rh.hit.geomID != ffi::RTC_INVALID_GEOMETRY_ID);
        }
        hits
    }

    /// Occlusion queries, one `rtcOccluded1` per ray; the number occluded.
    pub(super) fn occluded1(scene: &Scene, rays: &[Ray]) -> usize {
        let raw = scene.raw();
        let mut hits = 0;
        for r in rays {
            let mut ray = ray1(r);
            // SAFETY: as in `intersect1`, with the 48-byte RTCRay.
            unsafe { ffi::rtcOccluded1(raw, &mut ray, std::ptr::null_mut()) };
            hits += usize::from(ray.tfar == f32::NEG_INFINITY);
        }
        hits
    }

    /// Up to eight rays into the lanes of `r8`; the mask of the active lanes.
    #[inline(always)]
    fn ray8(rays: &[Ray], r8: &mut ffi::RTCRay8) -> ffi::Valid8 {
        let mut valid = ffi::Valid8::default();
        for (k, r) in rays.iter().enumerate() {
            valid.0[k] = -1;
            (r8.org_x[k], r8.org_y[k], r8.org_z[k]) = (r.origin.x, r.origin.y, r.origin.z);
            (r8.dir_x[k], r8.dir_y[k], r8.dir_z[k]) = (r.dir.x, r.dir.y, r.dir.z);
            (r8.tnear[k], r8.tfar[k], r8.mask[k]) = (r.t_min, r.t_max, u32::MAX);
        }
        valid
    }

    /// Closest-hit queries in packets of eight (`rtcIntersect8`); the number of hits.
    pub(super) fn intersect8(scene: &Scene, rays: &[Ray]) -> usize {
        let raw = scene.raw();
        let mut hits = 0;
        for chunk in rays.chunks(8) {
            let mut rh = ffi::RTCRayHit8::default();
            let valid = ray8(chunk, &mut rh.ray);
            rh.hit.geomID = [ffi::RTC_INVALID_GEOMETRY_ID; 8];
            // SAFETY: a committed scene; `valid` and `rh` are 32-byte aligned
            // and laid out as the 4.4 RTCRayHit8 (asserted in ffi.rs);
            // inactive lanes are neither read nor written.
            unsafe { ffi::rtcIntersect8(&valid, raw, &mut rh, std::ptr::null_mut()) };
            hits += rh.hit.geomID[..chunk.len()].iter().filter(|&&g| g != ffi::RTC_INVALID_GEOMETRY_ID).count();
        }
        hits
    }

    /// Occlusion queries in packets of eight (`rtcOccluded8`); the number occluded.
    pub(super) fn occluded8(scene: &Scene, rays: &[Ray]) -> usize {
        let raw = scene.raw();
        let mut hits = 0;
        for chunk in rays.chunks(8) {
            let mut r8 = ffi::RTCRay8::default();
            let valid = ray8(chunk, &mut r8);
            // SAFETY: as in `intersect8`, with the 384-byte RTCRay8.
            unsafe { ffi::rtcOccluded8(&valid, raw, &mut r8, std::ptr::null_mut()) };
            hits += r8.tfar[..chunk.len()].iter().filter(|&&t| t == f32::NEG_INFINITY).count();
        }
        hits
    }
}

/// Race rtdiff against every Embree mode of [`EMBREE_MODES`] and every
/// plugin of [`RaceOptions::plugins`] on `prims` with the workloads `sets`
/// (`(name, rays, any-hit)`).
#[cfg(feature = "embree")]
pub fn race_mesh(
    mesh: &str,
    prims: &Arc<Primitives>,
    sets: &[(&'static str, &[Ray], bool)],
    opts: &RaceOptions,
) -> Result<MeshRace> {
    use super::clock::{Clock, cpu_seconds};
    use crate::backends::{AccelConfig, build_tracer};
    use crate::embree::{Device, Scene};
    if opts.rounds == 0 {
        return Err(crate::Error::Invalid("--race needs at least one round".into()));
    }
    let cfg = AccelConfig { triangle_test: opts.triangle_test, ..AccelConfig::default() };
    if let Some(isa) = opts.rtdiff_isa
        && !isa.is_supported()
    {
        return Err(crate::Error::Invalid(format!("this CPU does not run rtdiff's {} walks", isa.name())));
    }
    // rtdiff's tracer as users build it (`build_tracer`), its walks then
    // switched to the instruction set asked for, if any.
    let build_ours = |prims: Arc<Primitives>| -> Result<Box<dyn crate::accel::Tracer>> {
        match opts.rtdiff_isa {
            None => build_tracer(prims, &cfg),
            Some(isa) => {
                let mut t = crate::bvh::BvhTracer::new(&prims, &cfg);
                t.force_isa(isa);
                Ok(Box::new(t))
            }
        }
    };
    // Embree's kernels assume valid rays; the race's sets hold no other.
    if let Some((name, _, _)) = sets.iter().find(|(_, rays, _)| !rays.iter().all(Ray::is_traceable)) {
        return Err(crate::Error::Invalid(format!("the race's {name} rays include one that cannot be traced")));
    }
    let loads = workloads(sets, opts.batches);
    // Embree gets the mesh as its users hand it over: an indexed mesh
    // (vertices welded by position), unless spheres need the wrapper's soup.
    let indexed = prims.spheres.is_empty().then(|| crate::rays::topology::welded(prims));
    let embree_scene = |device: &Device, q: EmbreeQuality, m: EmbreeMode| -> Result<Scene> {
        match &indexed {
            Some((positions, indices)) => Scene::indexed(device, positions, indices, q, m),
            None => Scene::with_mode(device, prims, q, m),
        }
    };
    // A plugin gets the ABI's buffers, made once before any timing.
    let plugin_buffers = if opts.plugins.is_empty() { None } else { Some(crate::plugin::PluginBuffers::new(prims)?) };
    let build_plugin = |id: crate::plugin::PluginId| -> Result<crate::plugin::PluginTracer> {
        let buffers = plugin_buffers.as_ref().expect("buffers made when plugins race");
        crate::plugin::PluginTracer::from_buffers(id, buffers)
    };
    let opponents: Vec<Opponent> = EMBREE_MODES
        .iter()
        .map(|&(q, m)| Opponent::Embree(q, m))
        .chain(opts.plugins.iter().map(|&id| Opponent::Plugin(id)))
        .collect();
    let build_repeats = opts.build_repeats.max(1);
    let mut contests = Vec::new();
    let mut hit_count_differences = Vec::new();
    let mut bytes = 0.0;
    let mut embree_memory = Vec::new();
    let mut isa = "portable";
    let mut rtdiff = String::new();
    for &threads in &opts.threads {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .map_err(|e| crate::Error::Invalid(format!("cannot start {threads} threads: {e}")))?;
        // One device per thread count, alone while it is used: Embree runs
        // every device with the largest thread count of the live ones.
        let max_isa = opts.embree_max_isa.map(|i| format!(",max_isa={}", i.name())).unwrap_or_default();
        let config = format!("threads={threads}{max_isa}");
        // Without the memory monitor that rtdiff's wrapper registers (a call
        // per allocation of every build), as users make a device; a
        // monitored one measures the memory, apart.
        let device = Device::unmonitored(&config)?;
        let clock = Clock { cpu: threads == 1 };
        // Thread CPU time for one thread, the wall clock otherwise.
        let time = |f: &mut dyn FnMut() -> usize| -> (f64, usize) {
            if threads == 1 {
                cpu_seconds(f)
            } else {
                let s = clock.now();
                let r = f();
                (clock.since(s), r)
            }
        };
        let names: Vec<String> = opponents.iter().map(|o| o.label()).collect();
        let m = names.len();
        // What each side's structure holds, from one build each (dropped
        // before the builds are timed).
        {
            let mut probe = pool.install(|| crate::bvh::BvhTracer::new(prims, &cfg));
            if let Some(isa) = opts.rtdiff_isa {
                probe.force_isa(isa);
            }
            rtdiff = crate::accel::Tracer::name(&probe);
            if let Some(w) = probe.wide() {
                bytes = w.bytes() as f64 / prims.len().max(1) as f64;
                isa = w.isa().summary();
            }
        }
        if embree_memory.is_empty() {
            let per = |b: i64| b as f64 / prims.len().max(1) as f64;
            let monitored = Device::new(&config)?;
            for (name, &(q, md)) in names.iter().zip(&EMBREE_MODES) {
                let mem = embree_scene(&monitored, q, md)?.memory();
                embree_memory.push(EmbreeMemory {
                    opponent: name.clone(),
                    bvh_bytes_per_primitive: per(mem.bvh_bytes),
                    geometry_bytes_per_primitive: per(mem.geometry_bytes),
                });
            }
        }
        let first = contests.len();
        for name in &names {
            contests.push(Contest {
                name: "build".into(),
                opponent: name.clone(),
                threads,
                rays: 0,
                hits: 0,
                opponent_hits: 0,
                times: Vec::new(),
                walls: Vec::new(),
            });
        }
        for (wname, rays, _, _) in &loads {
            for name in &names {
                contests.push(Contest {
                    name: wname.clone(),
                    opponent: name.clone(),
                    threads,
                    rays: rays.len(),
                    hits: 0,
                    opponent_hits: 0,
                    times: Vec::new(),
                    walls: Vec::new(),
                });
            }
        }
        // Builds first, with no structure of either side alive (as a user
        // builds a scene): rtdiff's sah + 8-wide collapse + packets on the
        // pool, each Embree mode on the device; construction only. Every
        // repetition of every round builds rtdiff and Embree's two MEDIUM
        // modes in a shuffled order; the two HIGH modes build afterwards, in
        // a phase of their own, each build compared with rtdiff's build of
        // the same repetition. A HIGH build (spatial splits in the default
        // mode, many times the memory traffic) then never comes right before
        // a build the goals compare: interleaved, it slowed the MEDIUM builds
        // after it by 5-15% (suzanne, dragon_full), against an outside loop
        // that builds no HIGH scene. The plugins build last, in a third
        // phase, each compared with rtdiff's build of the same repetition.
        let phases: Vec<Vec<usize>> = (0..3).map(|p| (0..m).filter(|&k| opponents[k].phase() == p).collect()).collect();
        let samples = opts.rounds * build_repeats;
        let (mut ours, mut theirs) = (vec![(0.0, 0.0); samples], vec![vec![(0.0, 0.0); m]; samples]);
        let build = |k: Option<usize>| -> Result<(f64, f64)> {
            let (t, w, r) = pool.install(|| match k {
                None => time_result(threads, &clock, &mut || build_ours(prims.clone()).map(|_| 0)),
                Some(k) => match opponents[k] {
                    Opponent::Embree(q, md) => {
                        time_result(threads, &clock, &mut || embree_scene(&device, q, md).map(|_| 0))
                    }
                    Opponent::Plugin(id) => time_result(threads, &clock, &mut || build_plugin(id).map(|_| 0)),
                },
            });
            r.map(|_| (t, w))
        };
        for (phase, modes) in phases.iter().enumerate() {
            for round in 0..opts.rounds {
                for rep in 0..build_repeats {
                    let part = if rep == 0 { 0 } else { usize::MAX - rep };
                    let sample = round * build_repeats + rep;
                    // Phase 0: the MEDIUM modes and rtdiff (index `modes.len()`).
                    let n = modes.len() + usize::from(phase == 0);
                    for i in run_order(n, round, part) {
                        match modes.get(i) {
                            None => ours[sample] = build(None)?,
                            Some(&k) => theirs[sample][k] = build(Some(k))?,
                        }
                    }
                }
            }
        }
        for sample in 0..samples {
            let (ot, ow) = ours[sample];
            for k in 0..m {
                let (tt, tw) = theirs[sample][k];
                contests[first + k].times.push((ot, tt));
                contests[first + k].walls.push((ow, tw));
            }
        }
        // Then the rays: each contestant traces a whole set in its turn, in
        // an order shuffled afresh for every round and set, as a renderer
        // traces all its rays through one library (so each finds its own
        // structure in the caches, not the others': in chunks of 8,192 rays
        // alternating between the five contestants, as before stop 47,
        // dragon_87k's incoherent rays took 40% longer on each side and
        // Embree's shadow rays 20% longer, rtdiff's not at all).
        let ours = pool.install(|| build_ours(prims.clone()))?;
        enum Built {
            Embree(Scene),
            Plugin(crate::plugin::PluginTracer),
        }
        let theirs: Vec<Built> = opponents
            .iter()
            .map(|&o| match o {
                Opponent::Embree(q, md) => embree_scene(&device, q, md).map(Built::Embree),
                Opponent::Plugin(id) => build_plugin(id).map(Built::Plugin),
            })
            .collect::<Result<_>>()?;
        for round in 0..opts.rounds {
            for (w, (wname, rays, any, batch)) in loads.iter().enumerate() {
                let (mut ta, mut tb, mut ha, mut hb) = (0.0, vec![0.0; m], 0, vec![0; m]);
                for k in run_order(m + 1, round, 1 + w) {
                    let who = match theirs.get(k) {
                        None => Contender::Tracer(ours.as_ref()),
                        Some(Built::Embree(s)) => Contender::Embree(s),
                        Some(Built::Plugin(p)) => Contender::Tracer(p),
                    };
                    let (t, h) = pool.install(|| time(&mut || run(who, rays, *any, *batch, threads)));
                    if k == m {
                        (ta, ha) = (t, h);
                    } else {
                        (tb[k], hb[k]) = (t, h);
                    }
                }
                for k in 0..m {
                    let c = &mut contests[first + m * (w + 1) + k];
                    c.times.push((ta, tb[k]));
                    if round == 0 {
                        (c.hits, c.opponent_hits) = (ha, hb[k]);
                        if ha != hb[k] {
                            hit_count_differences.push((wname.clone(), names[k].clone(), ha, hb[k]));
                        }
                    }
                }
            }
        }
        drop(theirs);
        drop(device);
    }
    Ok(MeshRace {
        mesh: mesh.to_string(),
        primitives: prims.len(),
        build_repeats,
        rtdiff,
        triangle_test: opts.triangle_test,
        rtdiff_bytes_per_primitive: bytes,
        embree_memory,
        rtdiff_isa: isa.to_string(),
        rtdiff_isa_set: opts.rtdiff_isa.is_some(),
        embree_isa: EmbreeIsa::running(opts.embree_max_isa),
        embree_capped: opts.embree_max_isa.is_some_and(|m| m < EmbreeIsa::widest_on_this_cpu()),
        contests,
        hit_count_differences,
    })
}

/// The order in which the `n` contestants (index `n - 1`: rtdiff) run in
/// part `part` (0: the builds, `1 + c`: ray chunk `c`) of round `round`: a
/// permutation drawn from a generator seeded by both, so that over the rounds
/// each contestant goes first, last and after every other one about equally
/// often.
///
/// A rotation (`(slot + round) % n`, before stop 25) kept the cyclic order,
/// so each contestant always ran right after the same one: rtdiff's build
/// always followed Embree's HIGH-quality default-mode build (the heaviest,
/// 1.7 ms on suzanne against about 0.2 ms for the others) and Embree's
/// default MEDIUM build always followed its robust HIGH one. The predecessor
/// moves a small build by 10-30% (docs/bvh.md, issue 16, sixth pass).
#[cfg(feature = "embree")]
fn run_order(n: usize, round: usize, part: usize) -> Vec<usize> {
    let mut rng = crate::rng::Pcg32::new(round as u64, part as u64);
    let mut order: Vec<usize> = (0..n).collect();
    for i in (1..n).rev() {
        order.swap(i, rng.below(i as u32 + 1) as usize);
    }
    order
}

/// Time `f` with the race's clock for `threads` (the thread's CPU time for
/// one thread, the wall clock for more), and by the wall clock as well.
#[cfg(feature = "embree")]
fn time_result(
    threads: usize,
    clock: &super::clock::Clock,
    f: &mut dyn FnMut() -> Result<usize>,
) -> (f64, f64, Result<usize>) {
    let wall = std::time::Instant::now();
    if threads == 1 {
        let (t, r) = super::clock::cpu_seconds(f);
        (t, wall.elapsed().as_secs_f64(), r)
    } else {
        let s = clock.now();
        let r = f();
        let t = clock.since(s);
        (t, t, r)
    }
}

/// Without the Embree backend there is nothing to race.
#[cfg(not(feature = "embree"))]
pub fn race_mesh(
    _: &str,
    _: &Arc<Primitives>,
    _: &[(&'static str, &[Ray], bool)],
    _: &RaceOptions,
) -> Result<MeshRace> {
    Err(crate::Error::Invalid(
        "--race needs the Embree backend: run scripts/setup-embree.sh and build with --features embree".into(),
    ))
}

#[cfg(all(test, feature = "embree"))]
mod tests {
    use super::run_order;

    #[test]
    fn every_contestant_follows_every_other() {
        // Five contestants as in the race; over 60 rounds each ordered pair
        // (a right after b) occurs, and each order is a permutation.
        let n = 5;
        let mut follows = vec![vec![0u32; n]; n];
        for round in 0..60 {
            let order = run_order(n, round, 0);
            let mut sorted = order.clone();
            sorted.sort_unstable();
            assert_eq!(sorted, (0..n).collect::<Vec<_>>());
            for w in order.windows(2) {
                follows[w[1]][w[0]] += 1;
            }
            assert_eq!(order, run_order(n, round, 0), "deterministic");
        }
        for (a, row) in follows.iter().enumerate() {
            for (b, &count) in row.iter().enumerate() {
                assert!(a == b || count > 0, "{a} never ran right after {b}");
            }
        }
    }

    #[test]
    fn embree_isa_names_parse_back_and_caps_never_raise_the_set() {
        use super::EmbreeIsa;
        for isa in EmbreeIsa::ALL {
            assert_eq!(EmbreeIsa::parse(isa.name()).unwrap(), isa);
            // A cap at or above what the CPU runs changes nothing; below, it is the cap.
            let widest = EmbreeIsa::widest_on_this_cpu();
            assert_eq!(EmbreeIsa::running(Some(isa)), isa.min(widest));
        }
        assert_eq!(EmbreeIsa::running(None), EmbreeIsa::widest_on_this_cpu());
        let err = EmbreeIsa::parse("avx3").unwrap_err().to_string();
        assert!(err.contains("avx3") && err.contains("avx512"), "{err}");
    }
}
