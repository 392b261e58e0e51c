//! Another renderer's images (`rtdiff check-image`) and scenes handed to other renderers
//! (`rtdiff export --to obj`): rtdiff's own render stands in for the renderer under test, once
//! as it is (passes) and once with one feature broken (fails, the differing pixels classified).

mod common;

use std::path::Path;
use std::process::Command;

fn rtdiff(args: &[&str]) -> (i32, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_rtdiff")).current_dir(common::root()).args(args).output().unwrap();
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

#[test]
fn check_image_passes_a_right_render_and_explains_a_wrong_one() {
    let d = common::temp_dir("check-image");
    let (good, bad) = (d.join("cb.exr"), d.join("cb_no_shadows.exr"));
    let base = ["render", "scenes/cornell_box.json", "--width", "128", "--height", "128", "--quiet", "-o"];
    let (code, _, err) = rtdiff(&[&base[..], &[s(&good)]].concat());
    assert_eq!(code, 0, "{err}");
    let (code, _, err) = rtdiff(&[&base[..], &[s(&bad), "--feature", "hard_shadows=off"]].concat());
    assert_eq!(code, 0, "{err}");
    let (code, out, err) = rtdiff(&["check-image", "scenes/cornell_box.json", "--image", s(&good)]);
    assert_eq!(code, 0, "{out}{err}");
    assert!(out.starts_with("PASS") && out.contains("cornell_box.phong"), "{out}");
    let (code, out, err) = rtdiff(&["check-image", "scenes/cornell_box.json", "--image", s(&bad), "--json"]);
    assert_eq!(code, 2, "{out}{err}");
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    let exact = &v[0]["exact"];
    assert!(exact["agreeing"].as_f64().unwrap() < 0.99, "{exact}");
    // The missing shadows are no rounding: pixels the ray tree cannot explain.
    assert!(exact["classes"]["unexplained"].as_u64().unwrap() > 100, "{exact}");
    // A folder named like reference/ is checked file by file.
    std::fs::copy(&good, d.join("cornell_box.phong.exr")).unwrap();
    let (code, out, _) = rtdiff(&["check-image", "--image", s(&d)]);
    assert_eq!(code, 0, "{out}");
    // Wrong size, a scene without a reference, one render of a noisy scene: clear errors.
    let small = d.join("small.exr");
    let (code, _, err) =
        rtdiff(&["render", "scenes/cornell_box.json", "--width", "16", "--height", "16", "--quiet", "-o", s(&small)]);
    assert_eq!(code, 0, "{err}");
    let (code, _, err) = rtdiff(&["check-image", "scenes/cornell_box.json", "--image", s(&small)]);
    assert_eq!(code, 1);
    assert!(err.contains("16x16") && err.contains("128x128"), "{err}");
    let (code, _, err) = rtdiff(&["check-image", "scenes/cube.json", "--image", s(&good)]);
    assert_eq!(code, 1);
    assert!(err.contains("noisy") && err.contains("several renders"), "{err}");
}

#[test]
fn export_obj_keeps_primitive_ids_and_coordinates() {
    let d = common::temp_dir("export-obj");
    let (code, _, err) = rtdiff(&["export", "scenes/cornell_box.json", "--to", "obj", "-o", s(&d)]);
    assert_eq!(code, 0, "{err}");
    let obj = d.join("scene.obj");
    assert!(obj.is_file() && d.join("scene.mtl").is_file() && d.join("scene.json").is_file());
    // The same rays traced on the scene and on its OBJ hit the same primitives at the same distances.
    let rays = d.join("rays.csv");
    let (code, _, err) = rtdiff(&[
        "rays",
        "scenes/cornell_box.json",
        "--set",
        "primary,edges",
        "--count",
        "300",
        "--reference",
        "brute",
        "-o",
        s(&rays),
    ]);
    assert_eq!(code, 0, "{err}");
    let (a, b) = (d.join("a.csv"), d.join("b.csv"));
    for (scene, out) in [("scenes/cornell_box.json", &a), (s(&obj), &b)] {
        let (code, _, err) = rtdiff(&["trace", scene, "--rays", s(&rays), "--out", s(out)]);
        assert_eq!(code, 0, "{err}");
    }
    let (ha, hb) = (std::fs::read_to_string(&a).unwrap(), std::fs::read_to_string(&b).unwrap());
    assert!(ha.lines().filter(|l| l.starts_with("1,")).count() > 300, "{ha}");
    assert_eq!(ha, hb, "the OBJ traces differently from the scene");
}

#[test]
fn check_image_runs_welch_on_the_seeds_of_a_noisy_scene() {
    let render = |dir: &Path, seeds: std::ops::Range<u64>, extra: &[&str]| {
        for k in seeds {
            let out = dir.join(format!("cube.phong.s{k}.exr"));
            let seed = (1000 + k).to_string();
            let base =
                ["render", "scenes/cube.json", "--width", "128", "--height", "128", "--quiet", "--seed", &seed, "-o"];
            let (code, _, err) = rtdiff(&[&base[..], &[s(&out)], extra].concat());
            assert_eq!(code, 0, "{err}");
        }
    };
    // 32 renders with their own seeds, as tests/mitsuba_reference.rs checks rtdiff: no pixel rejected.
    let good = common::temp_dir("check-image-noisy");
    render(&good, 0..32, &[]);
    let (code, out, err) = rtdiff(&["check-image", "--image", s(&good)]);
    assert_eq!(code, 0, "{out}{err}");
    assert!(out.contains("cube.phong: 0 of") && out.contains("32 renders vs 64 reference seeds"), "{out}");
    // Shading switched off: every pixel rejected.
    let bad = common::temp_dir("check-image-noisy-bad");
    render(&bad, 0..4, &["--feature", "shading=off"]);
    let (code, out, _) = rtdiff(&["check-image", "--image", s(&bad)]);
    assert_eq!(code, 2, "{out}");
    assert!(out.starts_with("FAIL"), "{out}");
}
