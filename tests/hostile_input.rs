//! Issue 13: every cause of a panic, abort, hang, runaway allocation, useless
//! message or silently accepted input has a test here. For each limit of
//! `rtdiff::limits`, an input at the limit works and one past it gets an
//! error naming the file, the field and the limit.

mod common;

use std::path::Path;
use std::process::Command;
use std::sync::Arc;

use common::{temp_dir, write};
use glam::Vec3;
use rtdiff::accel::{BruteForce, Tracer};
use rtdiff::backends::{AccelConfig, build_tracer};
use rtdiff::geometry::{Primitives, Ray, Triangle};
use rtdiff::limits;
use rtdiff::render::{RenderOptions, render};
use rtdiff::scene::Scene;

const TRI: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";

/// A scene with one triangle, a 2x2 image and `extra` JSON fields merged in at the top level.
fn scene_text(extra: &str) -> String {
    let comma = if extra.trim().is_empty() { "" } else { "," };
    format!(
        r#"{{ "image": {{ "width": 2, "height": 2 }}, "meshes": [ {{ "file": "t.obj" }} ],
             "camera": {{ "position": [0.2, 0.2, -2], "look_at": [0.2, 0.2, 0] }},
             "lights": [ {{ "type": "point", "position": [0, 0, -1], "color": [1, 1, 1] }} ]{comma} {extra} }}"#
    )
}

fn load(dir: &Path, json: &str) -> rtdiff::Result<Scene> {
    write(dir, "t.obj", TRI);
    let s = write(dir, "s.json", json);
    Scene::load(&s)
}

#[track_caller]
fn refused(dir: &Path, json: &str, needles: &[&str]) {
    let err = load(dir, json).expect_err("the scene must be refused").to_string();
    assert!(err.contains("s.json"), "error does not name the file: {err}");
    for n in needles {
        assert!(err.contains(n), "error lacks {n:?}: {err}");
    }
}

/// Render `scene` quietly on one thread.
fn render_ok(scene: &Scene) -> rtdiff::render::RenderResult {
    let tracer = build_tracer(scene.prims.clone(), &scene.accel).expect("tracer");
    render(scene, tracer.as_ref(), &RenderOptions { threads: Some(1), quiet: true }).expect("render")
}

#[test]
fn non_finite_numbers_are_refused_with_their_json_path() {
    let d = temp_dir("hostile-nonfinite");
    let cases = [
        (r#""camera": { "position": [1e39, 0, -2] }"#, "camera.position[0]"),
        (r#""camera": { "focus_distance": 1e39 }"#, "camera.focus_distance"),
        (r#""image": { "background": [0, 1e39, 0] }"#, "image.background[1]"),
        (r#""params": { "bloom": { "scale": 1e39 } }"#, "params.bloom.scale"),
        (r#""spheres": [ { "center": [0, 0, 0], "radius": 1e39 } ]"#, "spheres[0].radius"),
    ];
    for (extra, path) in cases {
        let json = format!(r#"{{ {extra} }}"#);
        refused(&d, &json, &[path, "finite"]);
    }
    let lights = r#""lights": [ {"type": "point", "position": [0, 1, 0], "color": [1, 1, 1]},
        {"type": "point", "position": [0, 1, 0], "color": [1, 1, 1]},
        {"type": "point", "position": [0, 1, 0], "color": [1, 1e39, 1]} ]"#;
    refused(&d, &format!("{{ {lights} }}"), &["lights[2].color[1]", "must be a finite number, got inf"]);
    let mesh = |t: &str| format!(r#"{{ "meshes": [ {{ "file": "t.obj", "transform": {{ {t} }} }} ] }}"#);
    refused(&d, &mesh(r#""translate": [1e39, 0, 0]"#), &["meshes[0].transform.translate[0]"]);
    refused(&d, &mesh(r#""scale": [1, 1e39, 1]"#), &["meshes[0].transform.scale[1]"]);
    refused(&d, &mesh(r#""rotate": [0, 0, 1e39]"#), &["meshes[0].transform.rotate[2]"]);
}

#[test]
fn coordinates_at_the_limit_work_and_past_it_are_refused() {
    let d = temp_dir("hostile-coord");
    // A triangle placed 1e12 away (the limit) loads and builds.
    let at = r#""meshes": [ { "file": "t.obj", "transform": { "translate": [1e12, 0, 0] } } ]"#;
    let s = load(&d, &format!("{{ {at} }}")).expect("at the limit");
    assert_eq!(s.prims.triangles.len(), 1);
    // Scaled past it, the vertex is refused after the transform.
    let past =
        r#""meshes": [ { "file": "t.obj", "transform": { "scale": [1e12, 1e12, 1e12], "translate": [1e12, 0, 0] } } ]"#;
    refused(&d, &format!("{{ {past} }}"), &["meshes[0] (t.obj)", "vertex 2", "coordinate limit 1e12"]);
    refused(&d, r#"{ "camera": { "position": [0, 0, -1.1e12] } }"#, &["camera.position[2]", "1e12"]);
}

/// The real cause of `index -1` in `bvh/collapse.rs`: box areas that overflow
/// f32 made every SAH cost infinite, so no split was chosen and the collapse
/// asked for zero lanes. Validation keeps scenes far from it; the BVH itself
/// now survives it and still agrees with brute force.
#[test]
fn bvh_survives_overflowing_box_areas_and_agrees_with_brute_force() {
    let big = 1.0e37f32;
    let mut prims = Primitives::default();
    for i in 0..40 {
        let o = Vec3::new(i as f32 * 1e35, (i % 7) as f32 * 1e35, 0.0);
        prims.triangles.push(Triangle { v: [o, o + Vec3::new(big, 0.0, 0.0), o + Vec3::new(0.0, big, 1e30)] });
    }
    let prims = Arc::new(prims);
    let brute = BruteForce::new(prims.clone(), Default::default());
    for cfg in rtdiff::verify::hits::native_variants() {
        let t = build_tracer(prims.clone(), &AccelConfig { backend: rtdiff::backends::Backend::Native, ..cfg })
            .expect("builds");
        for k in 0..50 {
            let r = Ray::new(Vec3::new(k as f32 * 1e35, k as f32 * 3e34, -1e30), Vec3::Z);
            assert_eq!(t.intersect(&r).map(|h| h.prim), brute.intersect(&r).map(|h| h.prim), "{}", t.name());
        }
    }
}

#[test]
fn image_size_and_samples_limits() {
    let d = temp_dir("hostile-image");
    // At the side limit: a 16384 x 1 image renders.
    let s = load(&d, &scene_text("").replace(r#""width": 2, "height": 2"#, r#""width": 16384, "height": 1"#))
        .expect("16384 wide");
    assert_eq!(render_ok(&s).image.pixels.len(), 16_384);
    let past = scene_text("").replace(r#""width": 2"#, r#""width": 16385"#);
    refused(&d, &past, &["image.width", "16385 exceeds the limit 16384"]);
    // Pixel count: 8192 x 4096 = 2^25 is accepted by validation, 8192 x 4097 is not.
    let f =
        rtdiff::scene::validate::parse_scene(Path::new("s.json"), r#"{ "image": { "width": 8192, "height": 4096 } }"#)
            .expect("parses");
    rtdiff::scene::validate::check_file(&f, Path::new("s.json")).expect("2^25 pixels");
    refused(&d, r#"{ "image": { "width": 8192, "height": 4097 } }"#, &["image", "over the limit of 33554432 pixels"]);
    refused(&d, r#"{ "image": { "width": 0, "height": 8 } }"#, &["0x8", "empty"]);
    // spp at the limit renders one pixel; past it, refused.
    let one = |extra: &str| scene_text(extra).replace(r#""width": 2, "height": 2"#, r#""width": 1, "height": 1"#);
    let s = load(&d, &one("").replace(r#""height": 1"#, r#""height": 1, "spp": 65536"#)).expect("spp 65536");
    assert!(render_ok(&s).image.pixels[0].is_finite());
    refused(
        &d,
        &one("").replace(r#""height": 1"#, r#""height": 1, "spp": 65537"#),
        &["image.spp", "65537 exceeds the limit 65536"],
    );
    // Feature samples at the limit (an area light sampled 4096 times).
    let area = r#""lights": [ {"type": "parallelogram", "v0": [0, 0, -1], "edge01": [0.5, 0, 0], "edge02": [0, 0.5, 0],
        "colors": [[1,1,1],[1,1,1],[1,1,1],[1,1,1]]} ]"#;
    let json =
        one("").replace(r#""lights": [ { "type": "point", "position": [0, 0, -1], "color": [1, 1, 1] } ]"#, area);
    for (field, at) in [("light_samples", 4096), ("glossy_samples", 4096), ("dof_samples", 4096)] {
        let ok = json.replacen('{', &format!(r#"{{ "params": {{ "{field}": {at} }},"#), 1);
        let s = load(&d, &ok).unwrap_or_else(|e| panic!("{field} {at}: {e}"));
        assert!(render_ok(&s).image.pixels[0].is_finite());
        let past = json.replacen('{', &format!(r#"{{ "params": {{ "{field}": {} }},"#, at + 1), 1);
        refused(&d, &past, &[&format!("params.{field}"), "4097 exceeds the limit 4096"]);
    }
}

/// A closed box of mirrors seen from inside: every ray bounces until the depth limit.
fn mirror_box(dir: &Path, depth: u64) -> rtdiff::Result<Scene> {
    write(dir, "box.obj", &common::quad_obj(common::square_facing_minus_z(1.0, 1.0)));
    let faces =
        [[0.0, 0.0, 0.0], [0.0, 180.0, 0.0], [0.0, 90.0, 0.0], [0.0, -90.0, 0.0], [90.0, 0.0, 0.0], [-90.0, 0.0, 0.0]];
    let meshes: Vec<String> = faces
        .iter()
        .map(|r| {
            format!(
                r#"{{ "file": "box.obj", "material": "mirror", "transform": {{ "rotate": [{}, {}, {}] }} }}"#,
                r[0], r[1], r[2]
            )
        })
        .collect();
    let json = format!(
        r#"{{ "image": {{ "width": 2, "height": 2 }}, "params": {{ "max_depth": {depth} }},
             "camera": {{ "position": [0, 0, 0], "look_at": [0.3, 0.2, 1] }},
             "materials": {{ "mirror": {{ "kd": [0.1, 0.1, 0.1], "ks": [0.9, 0.9, 0.9] }} }},
             "meshes": [ {} ],
             "lights": [ {{ "type": "point", "position": [0.1, 0.2, 0.3], "color": [1, 1, 1] }} ] }}"#,
        meshes.join(", ")
    );
    let s = write(dir, "s.json", &json);
    Scene::load(&s)
}

#[test]
fn closed_mirror_box_at_max_depth_renders_and_past_it_is_refused() {
    let d = temp_dir("hostile-mirror");
    let s = mirror_box(&d, limits::MAX_DEPTH as u64).expect("depth 64");
    let r = render_ok(&s);
    // Every camera ray bounced to the limit: 4 pixels x 65 rays.
    assert_eq!(r.counters.primary_rays + r.counters.secondary_rays, 4 * (limits::MAX_DEPTH as u64 + 1));
    for depth in [65u64, 1_000_000_000] {
        let e = mirror_box(&d, depth).expect_err("refused").to_string();
        assert!(e.contains("s.json") && e.contains("params.max_depth") && e.contains("exceeds the limit 64"), "{e}");
    }
}

#[test]
fn worst_case_ray_count_is_bounded() {
    let d = temp_dir("hostile-work");
    // A glass-and-mirror material doubles the ray tree per level: depth 64 would never finish.
    let json = scene_text(
        r#""params": { "max_depth": 64 }, "features": { "transparency": true },
           "materials": { "glass": { "ks": [0.5, 0.5, 0.5], "transparency": 0.5 } }"#,
    )
    .replace(r#""file": "t.obj""#, r#""file": "t.obj", "material": "glass""#);
    let s = load(&d, &json).expect("loads");
    let tracer = build_tracer(s.prims.clone(), &s.accel).expect("tracer");
    let e = render(&s, tracer.as_ref(), &RenderOptions { threads: Some(1), quiet: true }).expect_err("too much work");
    assert!(e.to_string().contains("over the limit of 1.100e12"), "{e}");
    // Depth 8 of the same scene renders.
    let s = load(&d, &json.replace(r#""max_depth": 64"#, r#""max_depth": 8"#)).expect("loads");
    assert!(rtdiff::scene::validate::worst_case_rays(&s) <= limits::MAX_RENDER_RAYS);
    render_ok(&s);
}

#[test]
fn bloom_kernel_limit() {
    let d = temp_dir("hostile-bloom");
    let json = |k: f32| {
        scene_text(&format!(
            r#""features": {{ "bloom": true }}, "params": {{ "bloom": {{ "kernel_size": {k}, "threshold": 0 }} }}"#
        ))
    };
    let s = load(&d, &json(limits::MAX_BLOOM_KERNEL)).expect("kernel 1024");
    let img = render_ok(&s).image;
    let out = rtdiff::post::bloom::bloom(&img, &s.params.bloom);
    assert!(out.pixels.iter().all(|p| p.is_finite()));
    refused(&d, &json(1025.0), &["params.bloom.kernel_size", "1025"]);
    refused(&d, &json(1e30), &["params.bloom.kernel_size"]);
}

#[test]
fn threads_limit() {
    let d = temp_dir("hostile-threads");
    let s = load(&d, &scene_text("")).expect("scene");
    let tracer = build_tracer(s.prims.clone(), &s.accel).expect("tracer");
    let at = render(&s, tracer.as_ref(), &RenderOptions { threads: Some(limits::MAX_THREADS), quiet: true });
    assert!(at.is_ok(), "{:?}", at.err());
    let past = render(&s, tracer.as_ref(), &RenderOptions { threads: Some(limits::MAX_THREADS + 1), quiet: true });
    assert!(past.expect_err("refused").to_string().contains("--threads 1025 exceeds the limit 1024"));
}

#[test]
fn arrays_in_place_of_objects_and_unknown_fields_are_refused() {
    let d = temp_dir("hostile-shape");
    refused(
        &d,
        r#"{ "camera": [[0, 0, 3], [0, 0, 0], [0, 1, 0], 50, 0, null] }"#,
        &["camera: expected an object", "array"],
    );
    refused(&d, r#"{ "image": [8, 8, 1, 0, [0, 0, 0]] }"#, &["image: expected an object"]);
    refused(&d, r#"{ "lights": [ ["point", [0, 1, 0], [1, 1, 1]] ] }"#, &["lights[0]: expected an object"]);
    refused(
        &d,
        r#"{ "meshes": [ { "file": "t.obj", "transform": [[1,1,1],[0,0,0],[0,0,0]] } ] }"#,
        &["meshes[0].transform: expected an object"],
    );
    refused(
        &d,
        r#"{ "params": { "ray_offset": { "kind": "fixed", "epsilon": 1e-4, "scale": 2 } } }"#,
        &["unknown field `scale`"],
    );
    refused(
        &d,
        r#"{ "params": { "ray_offset": { "kind": "robust", "epsilon": 1e-4 } } }"#,
        &["params.ray_offset", "unknown field `epsilon`"],
    );
    refused(&d, r#"{ "materials": { "m": { "kd": [1, 1, 1], "kss": 1 } } }"#, &["materials.m", "unknown field `kss`"]);
}

#[test]
fn empty_and_missing_paths_name_the_scene_and_the_field() {
    let d = temp_dir("hostile-paths");
    refused(&d, r#"{ "meshes": [ { "file": "" } ] }"#, &["meshes[0].file", "is empty"]);
    refused(&d, r#"{ "materials": { "m": { "kd_texture": "" } } }"#, &["materials.m.kd_texture", "is empty"]);
    refused(
        &d,
        r#"{ "materials": { "m": { "kd_texture": "gone.png" } } }"#,
        &["materials.m.kd_texture", "gone.png", "not found"],
    );
    refused(&d, r#"{ "meshes": [ { "file": "t.obj" }, { "file": "gone.obj" } ] }"#, &["meshes[1].file", "gone.obj"]);
}

#[test]
fn scene_file_size_and_item_count_limits() {
    let d = temp_dir("hostile-size");
    let at = format!("{{}}{}", " ".repeat(limits::MAX_SCENE_FILE_BYTES as usize - 2));
    let s = write(&d, "big.json", &at);
    Scene::load(&s).expect("16 MiB scene");
    let s = write(&d, "big.json", &format!("{at} "));
    let e = Scene::load(&s).expect_err("too big").to_string();
    assert!(e.contains("big.json") && e.contains("over the limit of 16777216 bytes"), "{e}");
    let spheres = |n: usize| {
        let one = r#"{ "center": [0, 0, 0], "radius": 1 }"#;
        format!(r#"{{ "spheres": [ {} ] }}"#, vec![one; n].join(","))
    };
    load(&d, &spheres(limits::MAX_SCENE_ITEMS)).expect("65536 spheres");
    refused(&d, &spheres(limits::MAX_SCENE_ITEMS + 1), &["spheres (count)", "65537 exceeds the limit 65536"]);
}

#[test]
fn texture_size_is_checked_before_decoding() {
    let d = temp_dir("hostile-texture");
    let at = d.join("at.png");
    image::RgbImage::new(limits::MAX_TEXTURE_SIDE, 1).save(&at).expect("png");
    let t = rtdiff::texture::Texture::load(&at, false).expect("16384 x 1");
    assert_eq!(t.width, 16_384);
    let past = d.join("past.png");
    image::RgbImage::new(limits::MAX_TEXTURE_SIDE + 1, 1).save(&past).expect("png");
    let e = rtdiff::texture::Texture::load(&past, false).expect_err("refused").to_string();
    assert!(e.contains("past.png") && e.contains("16385x1") && e.contains("limit of 16384"), "{e}");
    // A header claiming 65535 x 65535 is refused without allocating 50 GB.
    let mut bytes = std::fs::read(&at).expect("read");
    bytes[16..20].copy_from_slice(&65_535u32.to_be_bytes());
    bytes[20..24].copy_from_slice(&65_535u32.to_be_bytes());
    let crc = crc32(&bytes[12..29]);
    bytes[29..33].copy_from_slice(&crc.to_be_bytes());
    let huge = d.join("huge.png");
    std::fs::write(&huge, &bytes).expect("write");
    let e = rtdiff::texture::Texture::load(&huge, false).expect_err("refused").to_string();
    assert!(e.contains("huge.png") && e.contains("65535x65535"), "{e}");
}

fn crc32(data: &[u8]) -> u32 {
    let mut c = 0xffff_ffffu32;
    for &b in data {
        c ^= b as u32;
        for _ in 0..8 {
            c = if c & 1 != 0 { 0xedb8_8320 ^ (c >> 1) } else { c >> 1 };
        }
    }
    !c
}

#[test]
fn ray_csv_limits() {
    let p = Path::new("rays.csv");
    let ok = rtdiff::rays::file::parse_rays(p, "1e12,0,0,0,0,1,0,inf\n").expect("at the limit");
    assert_eq!(ok.len(), 1);
    let e =
        rtdiff::rays::file::parse_rays(p, "0,0,0,0,0,1,0,1\n1.1e12,0,0,0,0,1,0,inf\n").expect_err("past").to_string();
    assert!(e.contains("rays.csv") && e.contains("line 2") && e.contains("1e12"), "{e}");
    let e = rtdiff::rays::file::parse_rays(p, "0,0,0,0,0,1e39,0,1\n").expect_err("inf").to_string();
    assert!(e.contains("line 1") && e.contains("finite"), "{e}");
}

fn rtdiff_cmd(args: &[&str]) -> (i32, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_rtdiff")).args(args).output().expect("runs");
    let err = String::from_utf8_lossy(&out.stderr).to_string();
    assert!(!err.contains("panicked"), "{err}");
    (out.status.code().unwrap_or(-1), err)
}

#[test]
fn count_flags_have_limits_named_in_errors_and_help() {
    let d = temp_dir("hostile-flags");
    let s = write(&d, "t.obj", TRI);
    let s = s.to_str().unwrap();
    for (args, needle) in [
        (vec!["parity", s, "--count", "16777217"], "16777217 is not in 1..=16777216"),
        (vec!["parity", s, "--sweep-count", "16777217"], "is not in 0..=16777216"),
        (vec!["parity", s, "--examples", "10001"], "is not in 0..=10000"),
        (vec!["bench", s, "--size", "4097"], "4097 is not in 1..=4096"),
        (vec!["bench", s, "--incoherent", "16777217"], "is not in 0..=16777216"),
        (vec!["bench", s, "--runs", "0"], "0 is not in 1..=10000"),
        (vec!["bench", s, "--race", "10001"], "is not in 1..=10000"),
        (vec!["render", s, "-o", "x.png", "--spp", "65537"], "65537 is not in 1..=65536"),
        (vec!["render", s, "-o", "x.png", "--width", "16385"], "16385 is not in 1..=16384"),
        (vec!["render", s, "-o", "x.png", "--threads", "100000"], "100000 is not in 1..=1024"),
        (vec!["render", s, "-o", "x.png", "--spp", "99999999999999999999"], "--spp"),
    ] {
        let (code, err) = rtdiff_cmd(&args);
        assert_eq!(code, 2, "{args:?}: {err}");
        assert!(err.contains(needle), "{args:?}: {err}");
    }
    // A race-only option without `--race` is refused, not ignored.
    let (code, err) = rtdiff_cmd(&["bench", s, "--triangle-test", "moller-trumbore"]);
    assert_eq!(code, 1, "{err}");
    assert!(err.contains("--triangle-test applies to --race only"), "{err}");
    let (code, err) = rtdiff_cmd(&["bench", s, "--embree-max-isa", "avx2"]);
    assert_eq!(code, 1, "{err}");
    assert!(err.contains("--embree-max-isa applies to --race only"), "{err}");
    let (code, err) = rtdiff_cmd(&["bench", s, "--rtdiff-isa", "avx2"]);
    assert_eq!(code, 1, "{err}");
    assert!(err.contains("--rtdiff-isa applies to --race only"), "{err}");
    let (code, err) = rtdiff_cmd(&["bench", s, "--build-repeats", "2"]);
    assert_eq!(code, 1, "{err}");
    assert!(err.contains("--build-repeats applies to --race only"), "{err}");
    let (code, err) = rtdiff_cmd(&["bench", s, "--race", "1", "--build-repeats", "0"]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("0 is not in 1..=100"), "{err}");
    let (code, err) = rtdiff_cmd(&["bench", s, "--race", "1", "--rtdiff-isa", "sse9"]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("'sse9'") && err.contains("avx512, avx2, portable"), "{err}");
    let (code, err) = rtdiff_cmd(&["bench", s, "--race", "1", "--embree-max-isa", "avx3"]);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("\"avx3\"") && err.contains("sse2, sse42, avx, avx2, avx512"), "{err}");
    let (code, err) = rtdiff_cmd(&["render", "--help"]);
    let _ = err;
    assert_eq!(code, 0);
    let help = Command::new(env!("CARGO_BIN_EXE_rtdiff")).args(["render", "--help"]).output().expect("help");
    let help = String::from_utf8_lossy(&help.stdout);
    assert!(help.contains("Limits") && help.contains("max_depth 64") && help.contains("spp 65536"), "{help}");
}

#[test]
fn all_degenerate_mesh_warns_in_trace_and_parity() {
    let d = temp_dir("hostile-degenerate");
    let obj = write(&d, "flat.obj", "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\nf 1 3 2\n");
    let rays = write(&d, "r.csv", "0,0,-1,0,0,1,0,inf\n");
    let out = d.join("h.csv");
    let (code, err) =
        rtdiff_cmd(&["trace", obj.to_str().unwrap(), "--rays", rays.to_str().unwrap(), "--out", out.to_str().unwrap()]);
    assert!(err.contains("warning") && err.contains("flat.obj") && err.contains("zero area"), "trace {code}: {err}");
    let (_, err) =
        rtdiff_cmd(&["parity", obj.to_str().unwrap(), "--reference", "brute", "--count", "10", "--default-only"]);
    assert!(err.contains("warning") && err.contains("flat.obj") && err.contains("zero area"), "parity: {err}");
    // Same through a scene file.
    write(&d, "flat2.obj", "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n");
    let s = write(&d, "s.json", r#"{ "meshes": [ { "file": "flat2.obj" } ] }"#);
    let (_, err) =
        rtdiff_cmd(&["trace", s.to_str().unwrap(), "--rays", rays.to_str().unwrap(), "--out", out.to_str().unwrap()]);
    assert!(err.contains("warning") && err.contains("zero area"), "trace scene: {err}");
}

/// Every backend the build has, over `prims`: each native builder x traversal, brute force
/// (both triangle tests) and Embree.
fn every_tracer(prims: &Arc<Primitives>) -> Vec<Box<dyn Tracer>> {
    use rtdiff::backends::Backend;
    use rtdiff::geometry::TriangleTest;
    let mut cfgs = rtdiff::backends::native_variants();
    cfgs.push(AccelConfig { backend: Backend::Brute, ..Default::default() });
    cfgs.push(AccelConfig {
        backend: Backend::Brute,
        triangle_test: TriangleTest::MollerTrumbore,
        ..Default::default()
    });
    if cfg!(feature = "embree") {
        cfgs.push(AccelConfig { backend: Backend::Embree, ..Default::default() });
    }
    cfgs.iter().map(|c| build_tracer(prims.clone(), c).expect("tracer")).collect()
}

/// The cause of the long fuzz run's panics `index out of bounds: the len is 1 but
/// the index is 4294967295` (in `bvh/wide.rs`): a ray with a NaN component (a
/// shadow ray leaving a sphere too small for its centre's magnitude, whose hit
/// point rounded onto the centre) makes every 8-wide box test pass, empty lanes
/// (child `u32::MAX`) included. Embree crashes on the same ray. Every tracer now
/// answers "no hit" for a ray that is not `Ray::is_traceable`; huge finite rays are
/// traced without a panic.
#[test]
fn rays_that_cannot_be_traced_hit_nothing_in_every_tracer() {
    let mut prims = common::cornell(1.0, 0.0);
    prims.spheres = common::spheres().spheres;
    let prims = Arc::new(prims);
    let (n, inf) = (f32::NAN, f32::INFINITY);
    let o = Vec3::new(0.5, 0.5, -1.0);
    let untraceable = [
        Ray::new(o, Vec3::splat(n)),
        Ray::new(Vec3::splat(n), Vec3::Z),
        Ray::new(Vec3::new(0.5, n, -1.0), Vec3::Z),
        Ray::new(o, Vec3::new(0.0, n, 1.0)),
        Ray::new(o, Vec3::ZERO),
        Ray::new(o, Vec3::new(0.0, 0.0, inf)),
        Ray::new(Vec3::new(-inf, 0.5, -1.0), Vec3::Z),
        Ray::with_range(o, Vec3::Z, n, n),
        Ray::with_range(o, Vec3::Z, 0.0, n),
        Ray::with_range(o, Vec3::Z, n, inf),
        Ray::with_range(o, Vec3::Z, 2.0, 1.0),
    ];
    let huge = [
        Ray::new(Vec3::new(0.5, 0.5, -1e30), Vec3::Z),
        Ray::new(o, Vec3::new(0.0, 0.0, 1e38)),
        Ray::new(o, Vec3::splat(1e-45)),
        Ray::new(Vec3::splat(3e38), Vec3::splat(-3e38)),
        Ray::with_range(o, Vec3::Z, -3e38, 3e38),
    ];
    for t in every_tracer(&prims) {
        for r in &untraceable {
            assert!(!r.is_traceable());
            assert_eq!(t.intersect(r), None, "{} {r:?}", t.name());
            assert!(!t.occluded(r), "{} {r:?}", t.name());
        }
        for r in &huge {
            assert!(r.is_traceable());
            let _ = (t.intersect(r), t.occluded(r));
        }
    }
}

/// Scene JSON: `spheres.json`'s three spheres over a ground sphere, before a
/// mirror wall of two triangles, with every coordinate and radius times `s`.
/// Lit by `spheres.json`'s point light in the Phong model (no falloff) or, with
/// `area`, by a parallelogram light in the physical model (radiance times
/// area over squared distance: both scale-free).
fn scaled_spheres_scene(s: f64, area: bool) -> String {
    let v = |x: f64, y: f64, z: f64| format!("[{}, {}, {}]", x * s, y * s, z * s);
    let sphere = |c: String, r: f64| format!(r#"{{ "center": {c}, "radius": {} }}"#, r * s);
    let (model, light) = if area {
        let c = "[40, 40, 40]";
        let corners = format!(r#""colors": [{c}, {c}, {c}, {c}]"#);
        let e = (v(1.0, 2.0, 3.0), v(2.0, 0.0, 0.0), v(0.0, 0.0, 2.0));
        (
            "physical",
            format!(r#"{{ "type": "parallelogram", "v0": {}, "edge01": {}, "edge02": {}, {corners} }}"#, e.0, e.1, e.2),
        )
    } else {
        ("phong", format!(r#"{{ "type": "point", "position": {}, "color": [1, 1, 1] }}"#, v(3.0, 0.0, 3.0)))
    };
    format!(
        r#"{{ "image": {{ "width": 48, "height": 48 }}, "shading_model": "{model}", "params": {{ "light_samples": 4 }},
             "camera": {{ "position": {}, "look_at": {}, "fov": 50 }},
             "materials": {{ "mirror": {{ "kd": [0.3, 0.3, 0.3], "ks": [0.6, 0.6, 0.6] }} }},
             "spheres": [ {}, {}, {}, {} ],
             "meshes": [ {{ "file": "wall.obj", "material": "mirror",
                            "transform": {{ "scale": {}, "translate": {} }} }} ],
             "lights": [ {light} ] }}"#,
        v(0.0, 0.0, 0.0),
        v(0.0, 0.0, 1.0),
        sphere(v(3.0, -2.0, 10.2), 1.0),
        sphere(v(-2.0, 2.0, 4.0), 2.0),
        sphere(v(0.0, 0.0, 6.0), 0.75),
        sphere(v(0.0, -100.0, 5.0), 96.5),
        v(8.0, 8.0, 1.0),
        v(0.0, 0.0, 12.0),
    )
}

/// Large but finite coordinates, up to the limit: scaling a scene by a power of
/// two scales every floating-point result exactly (no rounding changes, no
/// overflow below the limit), and directions, shading and the error-bound
/// offsets are relative, so the image must be bit-identical to the unscaled
/// one, in every backend. Before, the sphere test's `a (r^2 - |l|^2)`
/// overflowed f32 for shadow rays of length ~1e11 (`a` ~ 1e22, `r^2` ~ 1e23):
/// `t = c / inf = 0`, a false hit at the shadow ray's origin that blackened half
/// of this image.
#[test]
fn a_scene_scaled_by_a_power_of_two_to_the_coordinate_limit_renders_bit_identically() {
    let d = temp_dir("hostile-scaled");
    write(&d, "wall.obj", &common::quad_obj(common::square_facing_minus_z(1.0, 0.0)));
    let s = 2f64.powi(33); // the ground sphere's centre at -8.6e11, radius 8.3e11
    assert!(100.0 * s <= limits::MAX_COORDINATE as f64 && 200.0 * s > limits::MAX_COORDINATE as f64);
    for area in [false, true] {
        let small = Scene::load(&write(&d, "small.json", &scaled_spheres_scene(1.0, area))).expect("unscaled");
        let large = Scene::load(&write(&d, "large.json", &scaled_spheres_scene(s, area))).expect("at the limit");
        let opts = RenderOptions { threads: Some(2), quiet: true };
        for (ts, tl) in every_tracer(&small.prims).into_iter().zip(every_tracer(&large.prims)) {
            let name = format!("{}, area light {area}", ts.name());
            let a = render(&small, ts.as_ref(), &opts).expect("render").image;
            let b = render(&large, tl.as_ref(), &opts).expect("render").image;
            let lit = a.pixels.iter().filter(|p| p.max_element() > 0.02).count();
            assert!(lit > a.pixels.len() / 2, "{name}: the test scene is mostly lit ({lit} pixels)");
            let differ = a.pixels.iter().zip(&b.pixels).filter(|(x, y)| x != y).count();
            assert_eq!(differ, 0, "{name}: {differ} of {} pixels differ after scaling by 2^33", a.pixels.len());
        }
    }
}

/// The long fuzz run's other panics: `spheres.json` with a sphere of radius 0.75
/// moved to z = 4294967295 or 1e12, where one unit in the last place of the
/// centre is 512 or 131072: the sphere's surface cannot be told from its centre.
/// Such a sphere is refused at load time (spheres near the origin are not
/// affected); one at the limit ratio renders.
#[test]
fn spheres_too_small_for_their_centres_magnitude_are_refused() {
    let d = temp_dir("hostile-small-sphere");
    // The camera 4 radii in front of the sphere (at the origin when that rounds onto the centre).
    let sphere_scene = |z: f64, r: f64| {
        let eye = if (z - 4.0 * r) as f32 == z as f32 { 0.0 } else { z - 4.0 * r };
        format!(
            r#"{{ "image": {{ "width": 6, "height": 6 }}, "shading_model": "phong",
                 "camera": {{ "position": [0, 0, {eye}], "look_at": [0, 0, {z}], "fov": 30 }},
                 "spheres": [ {{ "center": [0, 0, 6], "radius": 1 }}, {{ "center": [0, 0, {z}], "radius": {r} }} ],
                 "lights": [ {{ "type": "point", "position": [1, 1, {}], "color": [1, 1, 1] }} ] }}"#,
            z - 3.0 * r
        )
    };
    for z in [4_294_967_295.0, 1e12] {
        let e = load(&d, &sphere_scene(z, 0.75)).expect_err("refused").to_string();
        assert!(e.contains("s.json") && e.contains("spheres[1].radius") && e.contains("2^-20"), "{e}");
    }
    // At the ratio (z = 1e6, radius 2^-20 * 1e6 = 0.95): it loads, and the camera
    // 4 radii away sees it in the middle pixels, lit and finite.
    let z = 1e6f64;
    let r = z * limits::MIN_SPHERE_RADIUS_RELATIVE as f64;
    let s = load(&d, &sphere_scene(z, r)).expect("at the ratio");
    let img = render_ok(&s).image;
    assert!(img.pixels.iter().all(|p| p.is_finite()));
    assert!(img.pixels[2 * 6 + 2].max_element() > 0.0, "centre pixel {:?}", img.pixels[2 * 6 + 2]);
    let e = load(&d, &sphere_scene(z, r * 0.999)).expect_err("past the ratio").to_string();
    assert!(e.contains("spheres[1].radius") && e.contains("below the limit"), "{e}");
}

#[test]
fn primitive_count_limit_names_the_mesh_and_the_limit() {
    use rtdiff::scene::validate::check_primitive_total;
    let p = Path::new("s.json");
    let max = limits::MAX_PRIMITIVES;
    check_primitive_total(p, "meshes[1] (a.obj)", max - 10, 10).expect("at the limit");
    let e = check_primitive_total(p, "meshes[1] (a.obj)", max - 10, 11).expect_err("past").to_string();
    assert!(e.contains("s.json") && e.contains("meshes[1] (a.obj)") && e.contains("over the limit of 67108864"), "{e}");
    // No overflow for absurd counts.
    assert!(check_primitive_total(p, "spheres", usize::MAX, usize::MAX).is_err());
}

/// A gzip bomb: a small file that decompresses without end. Decompression stops
/// one byte past the limit (`limits::MAX_MESH_FILE_BYTES` for `load_mesh`; a
/// small limit here, through the same function) with an error naming the file.
#[test]
fn gzip_decompression_is_capped() {
    use std::io::Write;
    let d = temp_dir("hostile-gzip");
    let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\n".repeat(1 << 16) + "f 1 2 3\n"; // 1.5 MiB
    let mut enc = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::best());
    enc.write_all(text.as_bytes()).expect("gzip");
    let gz = d.join("bomb.obj.gz");
    std::fs::write(&gz, enc.finish().expect("gzip")).expect("write");
    assert!(std::fs::metadata(&gz).unwrap().len() < 16 << 10, "compresses well");
    let n = text.len() as u64;
    let at = rtdiff::mesh::compressed::read_bytes_limited(&gz, n).expect("at the limit");
    assert_eq!(at.len() as u64, n);
    let e = rtdiff::mesh::compressed::read_bytes_limited(&gz, n - 1).expect_err("past the limit").to_string();
    assert!(e.contains("bomb.obj.gz") && e.contains(&format!("more than {} bytes", n - 1)), "{e}");
    // Through load_mesh (the real limit, 4 GiB): the file loads.
    let m = rtdiff::mesh::load_mesh(&gz, rtdiff::mesh::Content::Geometry).expect("loads");
    assert_eq!(m.indices.len(), 1);
    assert_eq!(limits::MAX_MESH_FILE_BYTES, 4 << 30);
}

/// A mesh file's raw vertices may be anything finite (a transform brings them
/// within the coordinate limit); their face normals' products overflowed f32
/// beyond ~1e19 and the vertex normals came out zero (black shading).
#[test]
fn vertex_normals_of_huge_raw_coordinates() {
    let d = temp_dir("hostile-huge-normals");
    let p = write(&d, "huge.obj", "v 0 0 0\nv 1e30 0 0\nv 0 1e30 0\nf 1 2 3\n");
    let m = rtdiff::mesh::load_mesh(&p, rtdiff::mesh::Content::WithMaterials).expect("loads");
    assert!(m.normals.iter().all(|n| *n == Vec3::Z), "{:?}", m.normals);
    // Through a scene that scales it down to the limit.
    let json = r#"{ "meshes": [ { "file": "huge.obj", "transform": { "scale": [1e-19, 1e-19, 1e-19] } } ] }"#;
    let s = Scene::load(&write(&d, "s.json", json)).expect("scene");
    assert!(s.triangle_shading[0].normals.iter().all(|n| (*n - Vec3::Z).length() < 1e-6));
}

/// Mesh transforms with scales far from 1: the f32 inverse transpose of
/// `diag(1e-19)` overflows (its determinant underflows) and the normals came
/// out zero; a zero scale has no inverse. Normals keep their direction (a
/// mirroring scale flips them with the winding), a flattened axis gets them.
#[test]
fn normals_survive_extreme_and_zero_scales() {
    let d = temp_dir("hostile-scales");
    write(&d, "t.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nvn 0 0 1\nvn 0 0 1\nf 1//1 2//2 3//3\n");
    let normal = |scale: &str| {
        let json = format!(r#"{{ "meshes": [ {{ "file": "t.obj", "transform": {{ "scale": {scale} }} }} ] }}"#);
        let s = Scene::load(&write(&d, "s.json", &json)).expect("scene");
        let n = s.triangle_shading[0].normals[0];
        // The geometric normal (winding) agrees with the shading normal.
        assert!(s.prims.triangles[0].normal().dot(n) >= 0.0, "{scale}: winding");
        n
    };
    for scale in ["[1e-19, 1e-19, 1e-19]", "[1e-30, 1e-30, 1e-30]", "[1e12, 1e12, 1e12]", "[2, 3, 0]"] {
        assert_eq!(normal(scale), Vec3::Z, "{scale}");
    }
    assert_eq!(normal("[-1e-19, 1e-19, 1e-19]"), Vec3::Z, "mirrored in x: z stays");
    assert_eq!(normal("[1e-19, 1e-19, -1e-19]"), -Vec3::Z, "mirrored in z");
}
