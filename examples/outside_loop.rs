//! An independent per-ray timing loop: rtdiff and Embree 4 called as each
//! library's users call them, on rays this loop makes itself, by one clock.
//!
//! `cargo run --release --features embree --example outside_loop -- [OPTIONS] MESH...`
//!
//! Options: `--runs N` (interleaved runs per cell, default 7), `--size N`
//! (camera image N x N, default 512), `--incoherent N` (default 262144),
//! `--frame F` (the bounding sphere's diameter over the image height, default
//! 1.0: the mesh is seen small, so most camera rays miss), `--view X,Y,Z`
//! (the eye's direction from the mesh's centre, default 0.45,0.3,0.84),
//! `--fov DEG` (default 45), `--lights X,Y,Z;...` (point lights in the
//! mesh's unit-sphere frame, one per band of image rows; default one light
//! three radii from the centre), `--rtdiff-isa
//! avx2|avx512` and `--embree-max-isa avx2|avx512` (cap each library's
//! instruction set, as on a CPU without AVX-512), `--clock wall|cpu` (default
//! wall: `Instant`; cpu: the thread's CPU time, for a loaded host),
//! `--split` (each ray set also as two cells, `SET-hits` and `SET-misses`,
//! by Embree default's answer: which rays a difference comes from),
//! `--triangle-test watertight|moller-trumbore` (rtdiff's triangle test,
//! default watertight: what the watertight test costs against Embree's
//! default mode, which is not watertight), `--only SET:WHO` (trace one
//! cell, `camera`, `incoherent-hits`, ..., `--runs` times by `rtdiff`,
//! `embree-default` or `embree-robust`, untimed: for profilers).
//!
//! Nothing here comes from the race (`rtdiff bench --race`): the mesh is
//! loaded as a user loads it (no normalisation), framed by its own camera
//! (a pinhole looking at the bounding sphere from an oblique direction),
//! incoherent rays start inside the bounding box with directions from this
//! file's own generator, and shadow rays start at the camera rays' hits
//! (Embree's hit point, pushed off along its geometric normal) towards a
//! point light. rtdiff is built by `build_tracer` and called once per ray
//! through `Box<dyn Tracer>` (`intersect`, `occluded`); Embree through its C
//! API alone (`rtcNewDevice`, `rtcNewScene`, an indexed triangle geometry
//! holding the mesh's vertex and index buffers, `rtcCommitScene`, then a
//! `RTCRayHit` filled per ray and `rtcIntersect1` / `rtcOccluded1`, as its
//! tutorials do), with default scene flags and with `RTC_SCENE_FLAG_ROBUST`,
//! MEDIUM quality (the default). Both sides read the rays from the same
//! array of this file's own ray type, so each pays for turning it into its
//! library's input. One thread: a one-thread rayon pool for rtdiff, a
//! `threads=1` device for Embree.
//!
//! Each run times every contestant once per cell, in an order that rotates
//! from run to run; the table gives per contestant the hit rate and the
//! median ns per ray (or ms per build) with quartiles, and the median of
//! the per-run ratios Embree time / rtdiff time with their quartiles.

use std::borrow::Cow;
use std::ffi::CString;
use std::path::Path;
use std::sync::Arc;
use std::time::Instant;

use glam::Vec3;
use rtdiff::accel::Tracer;
use rtdiff::backends::{AccelConfig, build_tracer};
use rtdiff::embree::ffi;
use rtdiff::geometry::Ray;

/// A ray as this harness stores it: origin, direction, interval.
#[derive(Clone, Copy)]
struct UserRay {
    o: [f32; 3],
    d: [f32; 3],
    tnear: f32,
    tfar: f32,
}

/// A small generator of its own (xorshift64*), independent of rtdiff's.
struct XorShift(u64);

impl XorShift {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_f491_4f6c_dd1d)
    }
    fn unit(&mut self) -> f32 {
        (self.next() >> 40) as f32 / (1u64 << 24) as f32
    }
    /// A direction uniform on the sphere.
    fn direction(&mut self) -> Vec3 {
        let z = 2.0 * self.unit() - 1.0;
        let phi = std::f32::consts::TAU * self.unit();
        let s = (1.0 - z * z).max(0.0).sqrt();
        Vec3::new(s * phi.cos(), s * phi.sin(), z)
    }
}

struct Options {
    runs: usize,
    size: u32,
    incoherent: usize,
    frame: f32,
    /// Direction from the mesh's centre to the eye.
    view: Vec3,
    /// Vertical field of view, degrees.
    fov: f32,
    /// Point lights in the mesh's unit-sphere frame (vertex mean at the
    /// origin, farthest vertex at distance 1), one per band of image rows;
    /// empty: one light at three radii from the box's centre.
    lights: Vec<Vec3>,
    rtdiff_isa: Option<rtdiff::bvh::WalkIsa>,
    embree_max_isa: Option<String>,
    cpu_clock: bool,
    /// `--only SET:WHO`: trace one set `runs` times by one contestant, untimed (for profilers).
    only: Option<(String, usize)>,
    /// `--split`: each set also as its hits and its misses (by Embree default's answer).
    split: bool,
    /// `--triangle-test`: rtdiff's triangle test (its default: watertight).
    triangle_test: rtdiff::geometry::TriangleTest,
    meshes: Vec<String>,
}

fn parse_vec(s: &str) -> Option<Vec3> {
    let v: Vec<f32> = s.split(',').map(|c| c.trim().parse().ok()).collect::<Option<_>>()?;
    (v.len() == 3).then(|| Vec3::new(v[0], v[1], v[2]))
}

fn parse_args() -> rtdiff::Result<Options> {
    let mut o = Options {
        runs: 7,
        size: 512,
        incoherent: 262_144,
        frame: 1.0,
        view: Vec3::new(0.45, 0.3, 0.84),
        fov: 45.0,
        lights: Vec::new(),
        rtdiff_isa: None,
        embree_max_isa: None,
        cpu_clock: false,
        only: None,
        split: false,
        triangle_test: rtdiff::geometry::TriangleTest::default(),
        meshes: Vec::new(),
    };
    let bad = |m: String| rtdiff::Error::Invalid(m);
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        let mut value = || args.next().ok_or_else(|| bad(format!("{a} needs a value")));
        match a.as_str() {
            "--runs" => o.runs = value()?.parse().map_err(|_| bad("--runs: a count".into()))?,
            "--size" => o.size = value()?.parse().map_err(|_| bad("--size: a count".into()))?,
            "--incoherent" => o.incoherent = value()?.parse().map_err(|_| bad("--incoherent: a count".into()))?,
            "--frame" => o.frame = value()?.parse().map_err(|_| bad("--frame: a number".into()))?,
            "--fov" => o.fov = value()?.parse().map_err(|_| bad("--fov: degrees".into()))?,
            "--view" => o.view = parse_vec(&value()?).ok_or_else(|| bad("--view: X,Y,Z".into()))?,
            "--lights" => {
                let v = value()?;
                o.lights = v
                    .split(';')
                    .map(parse_vec)
                    .collect::<Option<_>>()
                    .ok_or_else(|| bad(format!("--lights {v}: X,Y,Z;X,Y,Z;...")))?;
            }
            "--rtdiff-isa" => {
                let v = value()?;
                let isa = rtdiff::bvh::WalkIsa::supported()
                    .into_iter()
                    .find(|i| i.name() == v)
                    .ok_or_else(|| bad(format!("--rtdiff-isa {v}: not a set this CPU runs")))?;
                o.rtdiff_isa = Some(isa);
            }
            "--embree-max-isa" => o.embree_max_isa = Some(value()?),
            "--clock" => {
                o.cpu_clock = match value()?.as_str() {
                    "wall" => false,
                    "cpu" => true,
                    v => return Err(bad(format!("--clock {v}: expected wall or cpu"))),
                }
            }
            "--split" => o.split = true,
            "--triangle-test" => {
                o.triangle_test = match value()?.as_str() {
                    "watertight" => rtdiff::geometry::TriangleTest::Watertight,
                    "moller-trumbore" => rtdiff::geometry::TriangleTest::MollerTrumbore,
                    v => return Err(bad(format!("--triangle-test {v}: expected watertight or moller-trumbore"))),
                }
            }
            "--only" => {
                let v = value()?;
                let (set, who) = v.split_once(':').ok_or_else(|| bad(format!("--only {v}: expected SET:WHO")))?;
                let who = ["rtdiff", "embree-default", "embree-robust"]
                    .iter()
                    .position(|w| *w == who)
                    .ok_or_else(|| bad(format!("--only {v}: WHO is rtdiff, embree-default or embree-robust")))?;
                let cells = ["camera", "incoherent", "shadow"]
                    .map(|b| [b.to_string(), format!("{b}-hits"), format!("{b}-misses")]);
                if !cells.iter().flatten().any(|c| c == set) {
                    return Err(bad(format!("--only {v}: SET is one of {}", cells.concat().join(", "))));
                }
                o.only = Some((set.to_string(), who));
            }
            s if s.starts_with("--") => return Err(bad(format!("unknown option {s}"))),
            _ => o.meshes.push(a),
        }
    }
    if o.meshes.is_empty() {
        o.meshes = vec!["assets/suzanne.obj".into()];
    }
    let positive = |x: f32| x.is_finite() && x > 0.0;
    if o.runs == 0 || o.size == 0 || !positive(o.frame) || !positive(o.fov) || o.fov >= 180.0 || o.view == Vec3::ZERO {
        return Err(bad("--runs, --size, --frame and --fov must be positive, --fov below 180, --view not zero".into()));
    }
    Ok(o)
}

/// Seconds on the chosen clock.
struct Clock {
    cpu: bool,
}

impl Clock {
    fn now(&self) -> f64 {
        if self.cpu {
            let mut ts = libc::timespec { tv_sec: 0, tv_nsec: 0 };
            // SAFETY: a valid, writable timespec.
            unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut ts) };
            ts.tv_sec as f64 + ts.tv_nsec as f64 * 1e-9
        } else {
            thread_local!(static EPOCH: Instant = Instant::now());
            EPOCH.with(|e| e.elapsed().as_secs_f64())
        }
    }
}

/// The Embree device handle, passed to the pool's thread (Embree's API is
/// thread-safe; the device outlives every use).
#[derive(Clone, Copy)]
struct Dev(ffi::RTCDevice);
// SAFETY: see above.
unsafe impl Send for Dev {}
// SAFETY: see above.
unsafe impl Sync for Dev {}

/// Embree, through its C API only.
struct EmbreeScene {
    device: ffi::RTCDevice,
    scene: ffi::RTCScene,
}

impl EmbreeScene {
    fn build(device: ffi::RTCDevice, positions: &[Vec3], indices: &[[u32; 3]], robust: bool) -> Self {
        // SAFETY: the calls of Embree's minimal tutorial, on a live device;
        // the buffers Embree returns hold the counts asked for.
        unsafe {
            let scene = ffi::rtcNewScene(device);
            if robust {
                ffi::rtcSetSceneFlags(scene, ffi::RTC_SCENE_FLAG_ROBUST);
            }
            let geom = ffi::rtcNewGeometry(device, ffi::RTC_GEOMETRY_TYPE_TRIANGLE);
            let vb = ffi::rtcSetNewGeometryBuffer(
                geom,
                ffi::RTC_BUFFER_TYPE_VERTEX,
                0,
                ffi::RTC_FORMAT_FLOAT3,
                12,
                positions.len(),
            )
            .cast::<[f32; 3]>();
            for (i, p) in positions.iter().enumerate() {
                *vb.add(i) = p.to_array();
            }
            let ib = ffi::rtcSetNewGeometryBuffer(
                geom,
                ffi::RTC_BUFFER_TYPE_INDEX,
                0,
                ffi::RTC_FORMAT_UINT3,
                12,
                indices.len(),
            )
            .cast::<[u32; 3]>();
            std::ptr::copy_nonoverlapping(indices.as_ptr(), ib, indices.len());
            ffi::rtcCommitGeometry(geom);
            ffi::rtcAttachGeometryByID(scene, geom, 0);
            ffi::rtcReleaseGeometry(geom);
            ffi::rtcCommitScene(scene);
            assert_eq!(ffi::rtcGetDeviceError(device), ffi::RTC_ERROR_NONE, "Embree failed to build the scene");
            Self { device, scene }
        }
    }

    #[inline(always)]
    fn intersect(&self, r: &UserRay) -> Option<(f32, u32, Vec3)> {
        let mut rh = ffi::RTCRayHit {
            ray: rtc_ray(r),
            hit: ffi::RTCHit {
                geomID: ffi::RTC_INVALID_GEOMETRY_ID,
                instID: [ffi::RTC_INVALID_GEOMETRY_ID; ffi::RTC_MAX_INSTANCE_LEVEL_COUNT],
                ..Default::default()
            },
        };
        // SAFETY: committed scene, a 4.4-layout RTCRayHit, default arguments.
        unsafe { ffi::rtcIntersect1(self.scene, &mut rh, std::ptr::null_mut()) };
        (rh.hit.geomID != ffi::RTC_INVALID_GEOMETRY_ID)
            .then(|| (rh.ray.tfar, rh.hit.primID, Vec3::new(rh.hit.Ng_x, rh.hit.Ng_y, rh.hit.Ng_z)))
    }

    #[inline(always)]
    fn occluded(&self, r: &UserRay) -> bool {
        let mut ray = rtc_ray(r);
        // SAFETY: committed scene, a 48-byte RTCRay, default arguments.
        unsafe { ffi::rtcOccluded1(self.scene, &mut ray, std::ptr::null_mut()) };
        ray.tfar == f32::NEG_INFINITY
    }

    /// Whether `r` hits (closest hit) or is occluded (`any`): Embree's answer for one ray.
    fn answers_hit(&self, r: &UserRay, any: bool) -> bool {
        if any { self.occluded(r) } else { self.intersect(r).is_some() }
    }
}

/// The ray as Embree's `RTCRay`, every geometry accepted (mask all ones).
#[inline(always)]
fn rtc_ray(r: &UserRay) -> ffi::RTCRay {
    ffi::RTCRay {
        org_x: r.o[0],
        org_y: r.o[1],
        org_z: r.o[2],
        tnear: r.tnear,
        dir_x: r.d[0],
        dir_y: r.d[1],
        dir_z: r.d[2],
        time: 0.0,
        tfar: r.tfar,
        mask: u32::MAX,
        id: 0,
        flags: 0,
    }
}

impl Drop for EmbreeScene {
    fn drop(&mut self) {
        // SAFETY: the scene came from rtcNewScene and is released once.
        unsafe { ffi::rtcReleaseScene(self.scene) };
        let _ = self.device;
    }
}

/// The harness's own camera: a pinhole looking at the bounding sphere's
/// centre from direction `view`, far enough that the sphere's radius spans
/// `frame` of the image's half height (`frame` 1: the sphere is as tall as
/// the image), `fov` degrees vertically, y up.
fn camera_rays(centre: Vec3, radius: f32, size: u32, frame: f32, view: Vec3, fov: f32) -> Vec<UserRay> {
    let tan = (0.5 * fov.to_radians()).tan();
    let back = view.normalize();
    let dist = radius / (frame * tan);
    let eye = centre + dist * back;
    let fwd = -back;
    let right = fwd.cross(Vec3::Y).normalize();
    let up = right.cross(fwd);
    let mut rays = Vec::with_capacity((size * size) as usize);
    for y in 0..size {
        for x in 0..size {
            let px = (2.0 * (x as f32 + 0.5) / size as f32 - 1.0) * tan;
            let py = (1.0 - 2.0 * (y as f32 + 0.5) / size as f32) * tan;
            let d = (fwd + px * right + py * up).normalize();
            rays.push(UserRay { o: eye.to_array(), d: d.to_array(), tnear: 0.0, tfar: f32::INFINITY });
        }
    }
    rays
}

fn incoherent_rays(lo: Vec3, hi: Vec3, n: usize) -> Vec<UserRay> {
    let mut g = XorShift(0x9e37_79b9_7f4a_7c15);
    (0..n)
        .map(|_| {
            let o = lo + (hi - lo) * Vec3::new(g.unit(), g.unit(), g.unit());
            UserRay { o: o.to_array(), d: g.direction().to_array(), tnear: 0.0, tfar: f32::INFINITY }
        })
        .collect()
}

/// From each camera ray's hit (Embree's) towards a light: the origin pushed
/// off the surface along the geometric normal, on the light's side. The image's rows are split into as many bands as there are
/// `lights`, band `k` lit by light `k`.
fn shadow_rays(embree: &EmbreeScene, camera: &[UserRay], size: u32, lights: &[Vec3], eps: f32) -> Vec<UserRay> {
    let per_band = (size as usize).div_ceil(lights.len()) * size as usize;
    camera
        .iter()
        .enumerate()
        .filter_map(|(i, r)| {
            let light = lights[i / per_band];
            let (t, _, ng) = embree.intersect(r)?;
            let d = Vec3::from(r.d);
            let p = Vec3::from(r.o) + t * d;
            // Off the surface on the light's side (as pbrt's spawned rays
            // leave it): a light behind the surface sends the ray into the mesh.
            let n = ng.normalize_or_zero();
            let n = if n.dot(light - p) < 0.0 { -n } else { n };
            let o = p + eps * n;
            let to = light - o;
            let dist = to.length();
            Some(UserRay { o: o.to_array(), d: (to / dist).to_array(), tnear: 0.0, tfar: dist })
        })
        .collect()
}

#[inline(always)]
fn to_ray(r: &UserRay) -> Ray {
    Ray::with_range(Vec3::from(r.o), Vec3::from(r.d), r.tnear, r.tfar)
}

/// One traced set by one contestant: hits (and, for closest hits, the sum of
/// the distances, so the answers are used).
#[inline(never)]
fn trace_rtdiff(t: &dyn Tracer, rays: &[UserRay], any: bool) -> (usize, f64) {
    let (mut hits, mut sum) = (0, 0.0f64);
    for r in rays {
        if any {
            hits += usize::from(t.occluded(&to_ray(r)));
        } else if let Some(h) = t.intersect(&to_ray(r)) {
            hits += 1;
            sum += f64::from(h.t);
        }
    }
    (hits, sum)
}

#[inline(never)]
fn trace_embree(e: &EmbreeScene, rays: &[UserRay], any: bool) -> (usize, f64) {
    let (mut hits, mut sum) = (0, 0.0f64);
    for r in rays {
        if any {
            hits += usize::from(e.occluded(r));
        } else if let Some((t, _, _)) = e.intersect(r) {
            hits += 1;
            sum += f64::from(t);
        }
    }
    (hits, sum)
}

fn quartiles(mut v: Vec<f64>) -> (f64, f64, f64) {
    v.sort_by(f64::total_cmp);
    let at = |q: f64| v[((v.len() - 1) as f64 * q).round() as usize];
    (at(0.5), at(0.25), at(0.75))
}

/// Build and trace one mesh (on the one-thread pool's thread: every
/// contestant runs on the same thread).
fn run_mesh(o: &Options, clock: &Clock, Dev(device): Dev, mesh_path: &str) -> rtdiff::Result<()> {
    let mesh = rtdiff::mesh::load_mesh(Path::new(mesh_path), rtdiff::mesh::Content::Geometry)?;
    let prims = Arc::new(mesh.to_primitives());
    let (lo, hi) =
        mesh.positions.iter().fold((Vec3::splat(f32::MAX), Vec3::splat(f32::MIN)), |(l, h), p| (l.min(*p), h.max(*p)));
    let centre = 0.5 * (lo + hi);
    let radius = 0.5 * (hi - lo).length();
    let cfg = AccelConfig { triangle_test: o.triangle_test, ..AccelConfig::default() };
    let build_rtdiff = || -> rtdiff::Result<Box<dyn Tracer>> {
        match o.rtdiff_isa {
            None => build_tracer(prims.clone(), &cfg),
            Some(isa) => {
                let mut t = rtdiff::bvh::BvhTracer::new(&prims, &cfg);
                t.force_isa(isa);
                Ok(Box::new(t) as Box<dyn Tracer>)
            }
        }
    };
    let build_embree = |robust: bool| EmbreeScene::build(device, &mesh.positions, &mesh.indices, robust);
    // Builds: each contestant once per run, rotating the order.
    let runs = if o.only.is_some() { 0 } else { o.runs };
    let mut build_times = vec![Vec::new(); 3];
    let mut build_ratio = vec![Vec::new(); 2];
    // Three builds of each per run, each a sample.
    for run in 0..3 * runs {
        let mut t = [0.0; 3];
        for k in 0..3 {
            let who = (k + run) % 3;
            let s = clock.now();
            match who {
                0 => drop(std::hint::black_box(build_rtdiff()?)),
                w => drop(std::hint::black_box(build_embree(w == 2))),
            }
            t[who] = clock.now() - s;
        }
        for k in 0..3 {
            build_times[k].push(t[k] * 1e3);
        }
        build_ratio[0].push(t[1] / t[0]);
        build_ratio[1].push(t[2] / t[0]);
    }
    let name = Path::new(mesh_path).file_stem().map_or(mesh_path.to_string(), |s| s.to_string_lossy().into_owned());
    let cell = |v: &Vec<f64>, digits: usize| {
        let (m, a, b) = quartiles(v.clone());
        format!("{m:.digits$} ({a:.digits$}-{b:.digits$})")
    };
    if runs > 0 {
        println!(
            "| {name} | build (ms) | {} | | {} | {} | {} | {} | {} | |",
            mesh.indices.len(),
            cell(&build_times[0], 3),
            cell(&build_times[1], 3),
            cell(&build_times[2], 3),
            cell(&build_ratio[0], 3),
            cell(&build_ratio[1], 3),
        );
    }
    let ours = build_rtdiff()?;
    let theirs = [build_embree(false), build_embree(true)];
    let camera = camera_rays(centre, radius, o.size, o.frame, o.view, o.fov);
    let incoherent = incoherent_rays(lo, hi, o.incoherent);
    let lights: Vec<Vec3> = if o.lights.is_empty() {
        vec![centre + 3.0 * radius * Vec3::new(-0.4, 0.8, 0.45).normalize()]
    } else {
        // The unit-sphere frame: the vertices' mean, the farthest vertex's distance.
        let mean = mesh.positions.iter().fold(Vec3::ZERO, |a, p| a + *p) / mesh.positions.len().max(1) as f32;
        let far = mesh.positions.iter().fold(0f32, |m, p| m.max(p.distance(mean)));
        o.lights.iter().map(|l| mean + far * *l).collect()
    };
    let shadow = shadow_rays(&theirs[1], &camera, o.size, &lights, 1e-4 * radius);
    for (set, rays, any) in [("camera", &camera, false), ("incoherent", &incoherent, false), ("shadow", &shadow, true)]
    {
        // With `--split`, the set again as two cells, by Embree default's
        // answer: the rays that hit (or are occluded) and those that miss.
        let mut cells: Vec<(String, Cow<[UserRay]>)> = vec![(set.to_string(), Cow::Borrowed(rays))];
        if o.split || o.only.is_some() {
            let (hit, miss): (Vec<UserRay>, Vec<UserRay>) = rays.iter().partition(|r| theirs[0].answers_hit(r, any));
            cells.push((format!("{set}-hits"), Cow::Owned(hit)));
            cells.push((format!("{set}-misses"), Cow::Owned(miss)));
        }
        if let Some((only, who)) = &o.only {
            for (set, rays) in cells.iter().filter(|(c, _)| c == only) {
                let mut h = 0;
                for _ in 0..o.runs {
                    h = match who {
                        0 => trace_rtdiff(ours.as_ref(), rays, any),
                        w => trace_embree(&theirs[w - 1], rays, any),
                    }
                    .0;
                }
                println!("{name} {set}: {} rays traced {} times, {h} hit", rays.len(), o.runs);
            }
            continue;
        }
        for (set, rays) in &cells {
            // Hit/miss agreement of every ray, before timing.
            let disagree = rays
                .iter()
                .filter(|r| {
                    let a = if any { ours.occluded(&to_ray(r)) } else { ours.intersect(&to_ray(r)).is_some() };
                    let b = theirs[1].answers_hit(r, any);
                    a != b
                })
                .count();
            let mut times = vec![Vec::new(); 3];
            let mut ratio = vec![Vec::new(); 2];
            let mut hits = [0; 3];
            for run in 0..o.runs {
                let mut t = [0.0; 3];
                for k in 0..3 {
                    let who = (k + run) % 3;
                    let s = clock.now();
                    let (h, sum) = match who {
                        0 => trace_rtdiff(ours.as_ref(), rays, any),
                        w => trace_embree(&theirs[w - 1], rays, any),
                    };
                    t[who] = clock.now() - s;
                    std::hint::black_box(sum);
                    hits[who] = h;
                }
                for k in 0..3 {
                    times[k].push(t[k] * 1e9 / rays.len().max(1) as f64);
                }
                ratio[0].push(t[1] / t[0]);
                ratio[1].push(t[2] / t[0]);
            }
            println!(
                "| {name} | {set} | {} | {:.1}% | {} | {} | {} | {} | {} | {disagree} |",
                rays.len(),
                100.0 * hits[0] as f64 / rays.len().max(1) as f64,
                cell(&times[0], 1),
                cell(&times[1], 1),
                cell(&times[2], 1),
                cell(&ratio[0], 3),
                cell(&ratio[1], 3),
            );
            if hits[0] != hits[2] || hits[1] != hits[2] {
                println!("  (hits: rtdiff {}, embree-default {}, embree-robust {})", hits[0], hits[1], hits[2]);
            }
        }
    }
    Ok(())
}

fn main() -> rtdiff::Result<()> {
    let o = parse_args()?;
    let clock = Clock { cpu: o.cpu_clock };
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .map_err(|e| rtdiff::Error::Invalid(format!("cannot start a thread pool: {e}")))?;
    let config = match &o.embree_max_isa {
        Some(isa) => format!("threads=1,max_isa={isa}"),
        None => "threads=1".to_string(),
    };
    let c = CString::new(config.clone()).map_err(|_| rtdiff::Error::Invalid("bad --embree-max-isa".into()))?;
    // SAFETY: a NUL-terminated configuration string.
    let device = unsafe { ffi::rtcNewDevice(c.as_ptr()) };
    if device.is_null() {
        return Err(rtdiff::Error::Invalid(format!("Embree rejected the device configuration {config:?}")));
    }
    let rtdiff_isa = o.rtdiff_isa.unwrap_or(rtdiff::bvh::WalkIsa::supported()[0]);
    println!(
        "outside loop: one thread, {} clock, {} runs; rtdiff walks {}, Embree device \"{config}\"",
        if o.cpu_clock { "thread CPU" } else { "wall" },
        o.runs,
        rtdiff_isa.summary(),
    );
    println!(
        "| mesh | set | rays | hit rate | rtdiff ns/ray | embree-default ns/ray | embree-robust ns/ray | default / rtdiff | robust / rtdiff | hit/miss disagreements |"
    );
    println!("|---|---|---:|---:|---:|---:|---:|---:|---:|---:|");
    let dev = Dev(device);
    for mesh_path in &o.meshes {
        pool.install(|| run_mesh(&o, &clock, dev, mesh_path))?;
    }
    // SAFETY: every scene of the device was released above.
    unsafe { ffi::rtcReleaseDevice(device) };
    Ok(())
}
