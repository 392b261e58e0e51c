//! Helpers shared by the integration tests: scenes built in memory from
//! small OBJ files written to a temporary folder.

#![allow(dead_code)]

use std::path::{Path, PathBuf};

use glam::Vec3;
use rtdiff::accel::{self, AccelConfig};
use rtdiff::film::Image;
use rtdiff::render::{RenderOptions, RenderResult, render};
use rtdiff::scene::{Scene, SceneFile};

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
    let cfg = AccelConfig { backend: accel::Backend::Brute, ..scene.accel };
    let tracer = accel::build_tracer(scene.prims.clone(), &cfg).unwrap();
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
