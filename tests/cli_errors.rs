//! Bad input: every case exits non-zero with a message naming the file and
//! the problem, and never panics.

mod common;

use std::path::Path;
use std::process::Command;

use common::{temp_dir, write};

/// Run `rtdiff render SCENE -o dir/out.png EXTRA...`; return (exit code, stderr).
fn render(dir: &Path, scene: &Path, extra: &[&str]) -> (i32, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_rtdiff"))
        .arg("render")
        .arg(scene)
        .arg("-o")
        .arg(dir.join("out.png"))
        .args(["--width", "8", "--height", "8"])
        .args(extra)
        .output()
        .expect("rtdiff runs");
    let stderr = String::from_utf8_lossy(&out.stderr).to_string();
    assert!(!stderr.contains("panicked"), "rtdiff panicked: {stderr}");
    (out.status.code().unwrap_or(-1), stderr)
}

#[track_caller]
fn fails_with(dir: &Path, scene: &Path, extra: &[&str], needles: &[&str]) {
    let (code, err) = render(dir, scene, extra);
    assert_ne!(code, 0, "expected failure, got success: {err}");
    for n in needles {
        assert!(err.contains(n), "stderr lacks {n:?}: {err}");
    }
}

const TRI: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";

fn scene_with_mesh(dir: &Path, obj: &str, obj_text: &str) -> std::path::PathBuf {
    write(dir, obj, obj_text);
    write(dir, "s.json", &format!(r#"{{ "meshes": [ {{ "file": "{obj}" }} ] }}"#))
}

#[test]
fn missing_scene_file() {
    let d = temp_dir("err-missing");
    fails_with(&d, &d.join("nope.json"), &[], &["nope.json", "not found"]);
}

#[test]
fn malformed_json_reports_line_and_column() {
    let d = temp_dir("err-json");
    let s = write(&d, "s.json", "{\n  \"image\": { \"width\": 8,, }\n}\n");
    fails_with(&d, &s, &[], &["s.json", "line 2", "column"]);
}

#[test]
fn unknown_field_is_named() {
    let d = temp_dir("err-field");
    let s = write(&d, "s.json", r#"{ "image": { "widht": 8 } }"#);
    fails_with(&d, &s, &[], &["s.json", "unknown field `widht`"]);
}

#[test]
fn missing_obj_file() {
    let d = temp_dir("err-obj-missing");
    let s = write(&d, "s.json", r#"{ "meshes": [ { "file": "gone.obj" } ] }"#);
    fails_with(&d, &s, &[], &["gone.obj", "not found"]);
}

#[test]
fn broken_obj() {
    let d = temp_dir("err-obj-broken");
    let s = scene_with_mesh(&d, "broken.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 x\n");
    fails_with(&d, &s, &[], &["broken.obj:4:", "'x' is not an index"]);
}

#[test]
fn nan_vertex() {
    let d = temp_dir("err-nan");
    let s = scene_with_mesh(&d, "nan.obj", "v 0 0 0\nv 1 nan 0\nv 0 1 0\nf 1 2 3\n");
    fails_with(&d, &s, &[], &["nan.obj:2:", "'nan' is not a finite number"]);
}

#[test]
fn infinite_vertex() {
    let d = temp_dir("err-inf");
    let s = scene_with_mesh(&d, "inf.obj", "v 0 0 0\nv 1 0 0\nv 0 inf 0\nf 1 2 3\n");
    fails_with(&d, &s, &[], &["inf.obj:3:", "'inf' is not a finite number"]);
}

#[test]
fn zero_area_triangles_are_kept_with_a_warning() {
    let d = temp_dir("err-degenerate");
    let s = scene_with_mesh(&d, "degen.obj", &format!("{TRI}v 2 0 0\nf 1 2 4\n"));
    let (code, err) = render(&d, &s, &[]);
    assert_eq!(code, 0, "{err}");
    assert!(err.contains("1 zero-area triangles (kept, so that primitive ids are triangle positions"), "{err}");
}

#[test]
fn missing_texture() {
    let d = temp_dir("err-texture");
    write(&d, "t.obj", TRI);
    let s = write(
        &d,
        "s.json",
        r#"{ "materials": { "m": { "kd_texture": "nowhere.png" } }, "meshes": [ { "file": "t.obj", "material": "m" } ] }"#,
    );
    fails_with(&d, &s, &[], &["nowhere.png", "not found"]);
}

#[test]
fn zero_size_image() {
    let d = temp_dir("err-zero");
    let s = write(&d, "s.json", r#"{ "image": { "width": 0, "height": 8 } }"#);
    let out = Command::new(env!("CARGO_BIN_EXE_rtdiff"))
        .args(["render", s.to_str().unwrap(), "-o", d.join("z.png").to_str().unwrap()])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_ne!(out.status.code(), Some(0));
    assert!(
        err.contains("s.json") && err.contains("0x8") && err.contains("empty") && !err.contains("panicked"),
        "{err}"
    );
}

#[test]
fn negative_count() {
    let d = temp_dir("err-negative");
    let s = write(&d, "s.json", r#"{ "image": { "spp": -4 } }"#);
    fails_with(&d, &s, &[], &["s.json", "invalid value: integer `-4`"]);
    let s = write(&d, "p.json", r#"{ "params": { "light_samples": -1 } }"#);
    fails_with(&d, &s, &[], &["p.json", "invalid value: integer `-1`"]);
}

#[test]
fn unknown_material_name() {
    let d = temp_dir("err-material");
    write(&d, "t.obj", TRI);
    let s = write(&d, "s.json", r#"{ "meshes": [ { "file": "t.obj", "material": "gold" } ] }"#);
    fails_with(&d, &s, &[], &["s.json", "unknown material 'gold'"]);
}

#[test]
fn bad_command_line_values() {
    let d = temp_dir("err-cli");
    let s = write(&d, "s.json", "{}");
    fails_with(&d, &s, &["--feature", "warp=on"], &["unknown feature 'warp'"]);
    fails_with(&d, &s, &["--feature", "bloom=maybe"], &["on or off"]);
    fails_with(&d, &s, &["--threads", "0"], &["--threads", "0 is not in 1..=1024"]);
    let out = Command::new(env!("CARGO_BIN_EXE_rtdiff"))
        .args(["render", s.to_str().unwrap(), "-o", d.join("x.jpg").to_str().unwrap()])
        .output()
        .unwrap();
    assert_ne!(out.status.code(), Some(0));
    assert!(String::from_utf8_lossy(&out.stderr).contains("x.jpg: unknown output format"));
}

#[test]
fn empty_scene_renders_background() {
    let d = temp_dir("ok-empty");
    let s = write(&d, "s.json", r#"{ "image": { "background": [0, 0, 0] } }"#);
    let (code, err) = render(&d, &s, &["--quiet"]);
    assert_eq!(code, 0, "{err}");
    assert!(err.is_empty(), "--quiet printed: {err}");
}

#[test]
fn threads_one_and_two_write_identical_files() {
    let d = temp_dir("threads-files");
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell_box_parallelogram_light.json");
    for (t, name) in [("1", "a.png"), ("2", "b.png"), ("1", "a.exr"), ("2", "b.exr")] {
        let out = Command::new(env!("CARGO_BIN_EXE_rtdiff"))
            .args(["render", scene.to_str().unwrap(), "-o", d.join(name).to_str().unwrap()])
            .args(["--width", "48", "--height", "40", "--spp", "4", "--threads", t, "--quiet"])
            .args(["--feature", "glossy=on", "--feature", "bloom=on"])
            .output()
            .unwrap();
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    }
    assert_eq!(std::fs::read(d.join("a.png")).unwrap(), std::fs::read(d.join("b.png")).unwrap());
    assert_eq!(std::fs::read(d.join("a.exr")).unwrap(), std::fs::read(d.join("b.exr")).unwrap());
}
