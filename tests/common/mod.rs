//! Helpers shared by the integration tests: scenes built in memory from
//! small OBJ files written to a temporary folder, and the meshes and
//! procedural scenes of the BVH tests (their rays come from `rtdiff::rays`).

#![allow(dead_code)]

pub mod checks;
pub mod references;

use std::path::{Path, PathBuf};

use glam::Vec3;
use rtdiff::backends;
use rtdiff::backends::AccelConfig;
use rtdiff::film::Image;
use rtdiff::geometry::{Primitives, Sphere, Triangle};
use rtdiff::mesh::{Content, Mesh, load_mesh as load_mesh_file};
use rtdiff::render::{RenderOptions, RenderResult, render};
use rtdiff::rng::Pcg32;
use rtdiff::scene::{Scene, SceneFile};
/// The repository's root folder.
pub fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// Run `cmd` and return its standard output; a failure to start or a non-zero exit panics
/// with the command and both outputs.
pub fn run(cmd: &mut std::process::Command) -> String {
    let out = cmd.output().unwrap_or_else(|e| panic!("{cmd:?}: {e}"));
    assert!(
        out.status.success(),
        "{cmd:?} failed:\n{}\n{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// Every scene file in `scenes/`, sorted.
pub fn scene_files() -> Vec<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    let mut names: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "json"))
        .collect();
    names.sort();
    names
}

/// A fresh temporary folder for one test.
pub fn temp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("rtdiff-test-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Write `text` to `dir/name` and return the path.
pub fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

/// OBJ text for a quad (two triangles) with corners `c` (counter-clockwise seen
/// from the side its normal points to) and uvs at the corners.
pub fn quad_obj(c: [Vec3; 4]) -> String {
    let mut s = String::new();
    for p in c {
        s += &format!("v {} {} {}\n", p.x, p.y, p.z);
    }
    s += "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n";
    s += "f 1/1 2/2 3/3\nf 1/1 3/3 4/4\n";
    s
}

/// A square of half-size `h` in the plane `z = z0`, facing -z (towards a camera at negative z).
pub fn square_facing_minus_z(h: f32, z0: f32) -> [Vec3; 4] {
    // Seen from -z, with x to the left (right-handed, y up): counter-clockwise is
    // (+x,-y) -> (-x,-y) -> (-x,+y) -> (+x,+y); its normal (v1-v0)x(v2-v0) is -z.
    [Vec3::new(h, -h, z0), Vec3::new(-h, -h, z0), Vec3::new(-h, h, z0), Vec3::new(h, h, z0)]
}

/// Parse a scene from JSON text (meshes relative to `dir`).
pub fn scene(dir: &Path, json: &str) -> Scene {
    let file: SceneFile = serde_json::from_str(json).expect("valid test scene");
    Scene::from_file(&file, dir, &dir.join("test.json")).expect("scene loads")
}

/// Render with the brute-force oracle (and optionally a given thread count).
pub fn render_with(scene: &Scene, threads: Option<usize>) -> RenderResult {
    let cfg = AccelConfig { backend: backends::Backend::Brute, ..scene.accel };
    let tracer = backends::build_tracer(scene.prims.clone(), &cfg).unwrap();
    render(scene, tracer.as_ref(), &RenderOptions { threads, quiet: true }).unwrap()
}

/// Render and return the image.
pub fn render_image(scene: &Scene) -> Image {
    render_with(scene, Some(1)).image
}

/// Assert two colours agree to `rel` relative error (per channel, against the larger magnitude).
#[track_caller]
pub fn assert_close(a: Vec3, b: Vec3, rel: f32) {
    for i in 0..3 {
        let scale = a[i].abs().max(b[i].abs()).max(1e-30);
        assert!((a[i] - b[i]).abs() <= rel * scale, "channel {i}: {a} vs {b} (rel {rel})");
    }
}

/// Load `assets/NAME.obj`.
pub fn load_mesh(name: &str) -> Mesh {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("assets").join(format!("{name}.obj"));
    load_mesh_file(&path, Content::WithMaterials).unwrap_or_else(|e| panic!("{e}"))
}

fn quad(out: &mut Vec<Triangle>, a: Vec3, b: Vec3, c: Vec3, d: Vec3) {
    out.push(Triangle { v: [a, b, c] });
    out.push(Triangle { v: [a, c, d] });
}

/// Number of room triangles at the start of [`cornell`]; boxes follow, 10 triangles each.
pub const CORNELL_ROOM_TRIS: usize = 10;

/// Axis-aligned boxes standing in the Cornell-like room: (min, max).
pub const CORNELL_BOXES: [([f32; 3], [f32; 3]); 2] =
    [([0.13, 0.0, 0.45], [0.43, 0.3, 0.75]), ([0.55, 0.0, 0.15], [0.85, 0.6, 0.45])];

/// A Cornell-like box of 30 triangles: a unit room open towards -z (floor,
/// ceiling, back, left and right walls) and two boxes on the floor (five
/// faces each, no bottom), all in `[0, 1]^3` mapped by `x * scale + shift`.
pub fn cornell(scale: f32, shift: f32) -> Primitives {
    let mut t = Vec::new();
    let p = |x: f32, y: f32, z: f32| Vec3::new(x, y, z);
    quad(&mut t, p(0., 0., 0.), p(1., 0., 0.), p(1., 0., 1.), p(0., 0., 1.)); // floor
    quad(&mut t, p(0., 1., 0.), p(0., 1., 1.), p(1., 1., 1.), p(1., 1., 0.)); // ceiling
    quad(&mut t, p(0., 0., 1.), p(1., 0., 1.), p(1., 1., 1.), p(0., 1., 1.)); // back
    quad(&mut t, p(0., 0., 0.), p(0., 0., 1.), p(0., 1., 1.), p(0., 1., 0.)); // left
    quad(&mut t, p(1., 0., 0.), p(1., 1., 0.), p(1., 1., 1.), p(1., 0., 1.)); // right
    for (lo, hi) in CORNELL_BOXES {
        let (x0, y0, z0, x1, y1, z1) = (lo[0], lo[1], lo[2], hi[0], hi[1], hi[2]);
        quad(&mut t, p(x0, y1, z0), p(x1, y1, z0), p(x1, y1, z1), p(x0, y1, z1)); // top
        quad(&mut t, p(x0, y0, z0), p(x1, y0, z0), p(x1, y1, z0), p(x0, y1, z0)); // front
        quad(&mut t, p(x0, y0, z1), p(x0, y1, z1), p(x1, y1, z1), p(x1, y0, z1)); // back
        quad(&mut t, p(x0, y0, z0), p(x0, y1, z0), p(x0, y1, z1), p(x0, y0, z1)); // left
        quad(&mut t, p(x1, y0, z0), p(x1, y0, z1), p(x1, y1, z1), p(x1, y1, z0)); // right
    }
    for tri in &mut t {
        tri.v = tri.v.map(|v| v * scale + Vec3::splat(shift));
    }
    Primitives { triangles: t, spheres: Vec::new() }
}

/// 150 random spheres of radii spanning two decades above a floor made of two triangles.
pub fn spheres() -> Primitives {
    let mut rng = Pcg32::new(7, 3);
    let spheres = (0..150)
        .map(|_| Sphere {
            center: rng.in_box(Vec3::splat(-1.0), Vec3::splat(1.0)),
            radius: 0.01 * 100f32.powf(rng.next_f32()) * 0.3,
        })
        .collect();
    let mut triangles = Vec::new();
    let y = -1.2;
    quad(&mut triangles, Vec3::new(-2., y, -2.), Vec3::new(2., y, -2.), Vec3::new(2., y, 2.), Vec3::new(-2., y, 2.));
    Primitives { triangles, spheres }
}

/// An icosphere: the icosahedron subdivided `levels` times, vertices on the unit sphere.
pub fn icosphere(levels: u32) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let g = (1.0 + 5f32.sqrt()) / 2.0;
    let mut pos: Vec<Vec3> = [
        (-1., g, 0.),
        (1., g, 0.),
        (-1., -g, 0.),
        (1., -g, 0.),
        (0., -1., g),
        (0., 1., g),
        (0., -1., -g),
        (0., 1., -g),
        (g, 0., -1.),
        (g, 0., 1.),
        (-g, 0., -1.),
        (-g, 0., 1.),
    ]
    .iter()
    .map(|&(x, y, z)| Vec3::new(x, y, z).normalize())
    .collect();
    let mut faces: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..levels {
        let mut mid = std::collections::HashMap::new();
        let mut midpoint = |a: u32, b: u32, pos: &mut Vec<Vec3>| -> u32 {
            *mid.entry((a.min(b), a.max(b))).or_insert_with(|| {
                pos.push(((pos[a as usize] + pos[b as usize]) * 0.5).normalize());
                pos.len() as u32 - 1
            })
        };
        let mut next = Vec::with_capacity(faces.len() * 4);
        for [a, b, c] in faces {
            let ab = midpoint(a, b, &mut pos);
            let bc = midpoint(b, c, &mut pos);
            let ca = midpoint(c, a, &mut pos);
            next.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        faces = next;
    }
    (pos, faces)
}

/// The Python of `.venv/` (made by `scripts/mitsuba/setup.sh`, found by
/// [`rtdiff::perf::mitsuba_python::venv_python`]), or `None` with a note on stderr naming `test`
/// when it is missing; with `RTDIFF_REQUIRE_PYTHON=1` (set by `scripts/test.sh`) a missing
/// environment fails instead of skipping.
pub fn venv_python(test: &str) -> Option<PathBuf> {
    let root = root();
    if let Some(py) = rtdiff::perf::mitsuba_python::venv_python(&root) {
        return Some(py);
    }
    let why = rtdiff::perf::mitsuba_python::missing_environment(&root).unwrap_or_default();
    if python_required() {
        panic!("RTDIFF_REQUIRE_PYTHON=1 but {why}");
    }
    eprintln!("{test}: skipped, {why}");
    None
}

/// True when `RTDIFF_REQUIRE_PYTHON=1` (set by `scripts/test.sh`): Python-backed checks must run.
pub fn python_required() -> bool {
    std::env::var("RTDIFF_REQUIRE_PYTHON").is_ok_and(|v| v == "1")
}
