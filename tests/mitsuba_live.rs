//! The whole image-oracle path, live: `rtdiff export` -> Mitsuba 3 (scripts/mitsuba/render.py
//! in the .venv made by scripts/mitsuba/setup.sh) -> comparison with rtdiff's own render.
//!
//! Needs the Python environment: scripts/test.sh makes it and sets
//! `RTDIFF_REQUIRE_PYTHON=1`, so in CI a missing environment is a failure. Without
//! that variable and without `.venv/`, the test says it is skipped and returns.

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;

use common::checks::{FDR, exact_check, exact_check_with, numerically_black, summary, welch_summary};
use common::references::{load, no_tweak, plain, reference, render_with};
use common::{root, run};

use glam::Vec3;
use rtdiff::backends;
use rtdiff::film::Image;
use rtdiff::geometry::offset::{MITSUBA_RAY_EPSILON, SpawnOffset};
use rtdiff::render::{RenderOptions, render};
use rtdiff::scene::{Overrides, Scene};
use rtdiff::verify::image::stats::{Moments, WelchOptions, variance_test, welch_test};

fn python() -> Option<PathBuf> {
    common::venv_python("mitsuba_live")
}

/// Export `scene` at `size`, render it with Mitsuba and with rtdiff; return both images.
fn round_trip(py: &Path, scene: &str, size: u32, extra: &[&str]) -> (Image, Image, serde_json::Value) {
    let dir = std::env::temp_dir().join(format!("rtdiff-live-{}-{scene}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let scene_path = root().join("scenes").join(format!("{scene}.json"));
    let s = size.to_string();
    let mut export = Command::new(env!("CARGO_BIN_EXE_rtdiff"));
    export.arg("export").arg(&scene_path).args(["--to", "mitsuba", "-o"]).arg(&dir);
    export.args(["--width", &s, "--height", &s, "--quiet"]).args(extra);
    run(&mut export);
    let exr = dir.join("mitsuba.exr");
    let json = run(Command::new(py).arg(root().join("scripts/mitsuba/render.py")).arg(&dir).arg("-o").arg(&exr));
    let info: serde_json::Value = serde_json::from_str(json.trim()).expect("render.py prints one JSON line");
    let features = extra
        .chunks(2)
        .filter(|c| c[0] == "--feature")
        .map(|c| rtdiff::cli::render::parse_feature(c[1]).unwrap())
        .collect();
    let ov = Overrides { width: Some(size), height: Some(size), features, ..Default::default() };
    let sc = Scene::load_with(&scene_path, &ov).unwrap();
    let tracer = backends::build_tracer(sc.prims.clone(), &sc.accel).unwrap();
    let ours = render(&sc, tracer.as_ref(), &RenderOptions { threads: None, quiet: true }).unwrap().image;
    let theirs = Image::read_exr(&exr).unwrap();
    // The product's own path too: `rtdiff render` to EXR, then `rtdiff compare --json`.
    let ours_exr = dir.join("rtdiff.exr");
    let mut render_cmd = Command::new(env!("CARGO_BIN_EXE_rtdiff"));
    render_cmd.arg("render").arg(&scene_path).arg("-o").arg(&ours_exr);
    render_cmd.args(["--width", &s, "--height", &s, "--quiet"]).args(extra);
    run(&mut render_cmd);
    let mut compare = Command::new(env!("CARGO_BIN_EXE_rtdiff"));
    compare.arg("compare").arg(&exr).arg(&ours_exr).arg("--json");
    let report: serde_json::Value = serde_json::from_str(&run(&mut compare)).expect("rtdiff compare --json");
    let frac = report["metrics"]["over_rel_threshold_fraction"].as_f64().unwrap();
    println!(
        "{scene}: rtdiff compare: {:.4}% over 1e-3 relative, PSNR {:.1} dB",
        100.0 * frac,
        report["metrics"]["psnr"]
    );
    assert!(frac <= 1e-3, "{scene}: rtdiff compare finds {:.4}% of pixels over 1e-3 relative", 100.0 * frac);
    let _ = std::fs::remove_dir_all(&dir);
    (theirs, ours, info)
}

/// Fraction of pixels within 1e-3 relative (absolute 1e-5 below 1e-2; the
/// tolerances of tests/mitsuba_reference.rs, justified there).
fn agreeing(a: &Image, b: &Image) -> f64 {
    assert_eq!((a.width, a.height), (b.width, b.height));
    let ok = a
        .pixels
        .iter()
        .zip(&b.pixels)
        .filter(|(p, q)| ((**p - **q).abs() / p.abs().max(q.abs()).max(Vec3::splat(1e-2))).max_element() <= 1e-3)
        .count();
    ok as f64 / a.pixels.len() as f64
}

#[test]
fn export_mitsuba_render_and_compare_round_trip() {
    let Some(py) = python() else { return };
    // Textures (bilinear), a mirror, flat and interpolated normals: the deterministic path end to end.
    for (scene, extra) in [
        ("cube_textured", &["--feature", "bilinear_filtering=on"][..]),
        ("cornell_box", &[][..]),
        ("teapot", &["--feature", "normal_interpolation=on"][..]),
    ] {
        let (theirs, ours, info) = round_trip(&py, scene, 64, extra);
        let frac = agreeing(&theirs, &ours);
        println!(
            "{scene} {extra:?}: {:.4}% of pixels agree; Mitsuba {} {} s",
            100.0 * frac,
            info["variant"],
            info["render_seconds"]
        );
        assert!(info["deterministic"].as_bool().unwrap());
        assert!(frac >= 0.999, "{scene}: only {:.4}% of pixels agree with Mitsuba", 100.0 * frac);
        // The scene must show something: a black image would agree while testing nothing.
        assert!(ours.pixels.iter().filter(|p| p.max_element() > 1e-3).count() > 200, "{scene} is nearly black");
    }
}

#[test]
fn export_names_what_mitsuba_cannot_express() {
    let dir = std::env::temp_dir().join(format!("rtdiff-live-warn-{}", std::process::id()));
    let out = Command::new(env!("CARGO_BIN_EXE_rtdiff"))
        .arg("export")
        .arg(root().join("scenes/all_features.json"))
        .args(["--to", "mitsuba", "--width", "16", "--height", "16", "-o"])
        .arg(&dir)
        .output()
        .unwrap();
    assert!(out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    // Bloom is a post-process outside Mitsuba (its oracle is OpenImageIO); glossy reflection is the
    // plugin's own (no warning).
    assert!(err.contains("bloom") && !err.contains("glossy"), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// Bloom against OpenImageIO (scripts/mitsuba/check_bloom.py): rtdiff's image before bloom goes
/// through OIIO's channel_sum, contrast_remap, make_kernel("gaussian") and convolve, and must equal
/// rtdiff's bloomed image to 1e-5.
#[test]
fn bloom_matches_openimageio() {
    let Some(py) = python() else { return };
    let dir = common::temp_dir("live-bloom");
    // A sphere lit by a point light: n.l, and so the luminance, falls smoothly from 1.2 to 0
    // across the disc, so a ring of pixels lies within 1% above the threshold and a 1% move
    // of the threshold changes which pixels bloom (checked below: `straddling_pixels`).
    let scene = serde_json::json!({
        "image": { "width": 80, "height": 64 },
        "features": { "bloom": true },
        "params": { "bloom": { "threshold": 0.6, "kernel_size": 9, "scale": 0.7 } },
        "camera": { "position": [0, 0, -3], "look_at": [0, 0, 0], "fov": 40 },
        "spheres": [ { "center": [0, 0, 0], "radius": 0.9 } ],
        "lights": [ { "type": "point", "position": [-2, 2, -3], "color": [1.2, 1.2, 1.2] } ]
    });
    let path = dir.join("bloom.json");
    std::fs::write(&path, serde_json::to_string(&scene).unwrap()).unwrap();
    let (before, after) = (dir.join("before.exr"), dir.join("after.exr"));
    for (out, on) in [(&before, "bloom=off"), (&after, "bloom=on")] {
        run(Command::new(env!("CARGO_BIN_EXE_rtdiff")).arg("render").arg(&path).arg("-o").arg(out).args([
            "--feature",
            on,
            "--quiet",
        ]));
    }
    let out = Command::new(&py)
        .arg(root().join("scripts/mitsuba/check_bloom.py"))
        .args([before.as_os_str(), after.as_os_str()])
        .args(["0.6", "9", "0.7"])
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    println!("bloom vs OpenImageIO: {text}");
    let report: serde_json::Value = serde_json::from_str(text.trim()).expect("check_bloom.py prints JSON");
    assert!(report["bright_pixels"].as_u64().unwrap() > 20, "too few pixels bloom: {text}");
    assert!(report["straddling_pixels"].as_u64().unwrap() >= 10, "too few pixels near the threshold: {text}");
    assert!(out.status.success(), "rtdiff's bloom differs from OpenImageIO's: {text}");
    // Power: the same check with the scale or the threshold 1% off must fail (the
    // threshold moved up drops the straddling pixels from the bright pass, moved down adds
    // the ones just below it).
    for (what, args) in [
        ("scale x1.01", ["0.6", "9", "0.707"]),
        ("threshold x1.01", ["0.606", "9", "0.7"]),
        ("threshold x0.99", ["0.594", "9", "0.7"]),
    ] {
        let wrong = Command::new(&py)
            .arg(root().join("scripts/mitsuba/check_bloom.py"))
            .args([before.as_os_str(), after.as_os_str()])
            .args(args)
            .output()
            .unwrap();
        println!("bloom {what}: {}", String::from_utf8_lossy(&wrong.stdout));
        assert!(!wrong.status.success(), "a bloom {what} passed");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// The exporter says per scene which oracle it wrote and why, on stdout and in the export
/// (scene.xml's comment, rtdiff.json), and `--oracle native` refuses what Mitsuba cannot express.
#[test]
fn export_says_which_oracle_it_wrote_and_why() {
    let dir = common::temp_dir("live-oracle");
    let export = |scene: &str, extra: &[&str]| {
        Command::new(env!("CARGO_BIN_EXE_rtdiff"))
            .arg("export")
            .arg(root().join("scenes").join(format!("{scene}.json")))
            .args(["--to", "mitsuba", "--width", "16", "--height", "16", "--model", "physical", "-o"])
            .arg(dir.join(scene))
            .args(extra)
            .output()
            .unwrap()
    };
    let teapot = export("teapot", &[]);
    let out = String::from_utf8_lossy(&teapot.stdout);
    assert!(teapot.status.success() && out.contains("oracle: native (Mitsuba's direct"), "{out}");
    let cfg = std::fs::read_to_string(dir.join("teapot/rtdiff.json")).unwrap();
    assert!(cfg.contains("\"oracle\": \"native\""), "{cfg}");
    let cube = export("cube", &[]);
    let out = String::from_utf8_lossy(&cube.stdout);
    assert!(out.contains("oracle: plugin rtdiff_whitted, because: light 1: segment lights"), "{out}");
    let xml = std::fs::read_to_string(dir.join("cube/scene.xml")).unwrap();
    assert!(xml.contains("<!-- Oracle: plugin rtdiff_whitted, because: light 1: segment lights"), "{xml}");
    let refused = export("cube", &["--oracle", "native"]);
    let err = String::from_utf8_lossy(&refused.stderr);
    assert!(!refused.status.success() && err.contains("segment lights have no Mitsuba emitter"), "{err}");
    let forced = export("teapot", &["--oracle", "plugin"]);
    assert!(String::from_utf8_lossy(&forced.stdout).contains("oracle: plugin rtdiff_whitted, because: asked for"));
    let _ = std::fs::remove_dir_all(&dir);
}

/// The `rtdiff_whitted` plugin against Mitsuba's own emitters, BSDFs and integrators: each
/// native reference's scene exported with `--oracle plugin` at the same settings, rendered by the
/// plugin and checked against the native reference with the checks rtdiff faces (exact check
/// with its classifier for deterministic scenes, Welch + BH for noisy ones). Mitsuba's spawn
/// offset and its `twosided` convention make some pixels differ; they are classified exactly
/// (`SpawnOffset`: rtdiff with Mitsuba's spawn rule reproduces the native pixel; `ShadingSide`)
/// and counted. `PLUGIN_VS_NATIVE` lists the scenes the test command runs;
/// `RTDIFF_PLUGIN_VS_NATIVE=all` adds depth_of_field (64 plugin passes per seed, about two
/// minutes), whose figures docs/oracles.md records.
#[test]
fn plugin_agrees_with_mitsubas_own_plugins() {
    let Some(py) = python() else { return };
    let mut names: Vec<&str> = PLUGIN_VS_NATIVE.to_vec();
    if std::env::var("RTDIFF_PLUGIN_VS_NATIVE").is_ok_and(|v| v == "all") {
        names.push("depth_of_field");
    }
    let mut failures = Vec::new();
    for name in names {
        let r = reference(&format!("{name}.physical.native"));
        let dir = common::temp_dir(&format!("live-plugin-{name}"));
        let (w, h) = (r.width.to_string(), r.height.to_string());
        let mut export = Command::new(env!("CARGO_BIN_EXE_rtdiff"));
        export.arg("export").arg(&r.scene).args(["--to", "mitsuba", "--oracle", "plugin", "--model", "physical"]);
        export.args(["--width", &w, "--height", &h, "--quiet", "-o"]).arg(dir.join("x"));
        for (f, on) in &r.features {
            export.args(["--feature", &format!("{f}={}", if *on { "on" } else { "off" })]);
        }
        if let Some(spp) = r.spp {
            export.args(["--spp", &spp.to_string()]);
        }
        if let Some(d) = r.max_depth {
            export.args(["--max-depth", &d.to_string()]);
        }
        run(&mut export);
        let mut render = Command::new(&py);
        render.arg(root().join("scripts/mitsuba/render.py")).arg(dir.join("x")).arg("-o").arg(dir.join("plugin.exr"));
        if !r.deterministic {
            render.args(["--seeds", &PLUGIN_SEEDS.to_string(), "--variance"]).arg(dir.join("plugin.var.exr"));
        }
        let t0 = std::time::Instant::now();
        run(&mut render);
        let secs = t0.elapsed().as_secs_f64();
        let native = Image::read_exr(&r.image).unwrap();
        let plugin = Image::read_exr(&dir.join("plugin.exr")).unwrap();
        if r.deterministic {
            let scene = load(&r, 0, &no_tweak);
            let offset = render_with(&load(&r, 0, &mitsuba_spawn), &plain);
            let x = exact_check_with(&scene, &native, &plugin, Some(&offset));
            println!("{name}: plugin against native, exact check {} [{secs:.1} s]", summary(&x));
            if !x.passed() {
                failures.push(format!("{name}: {}", summary(&x)));
            }
        } else {
            let var = Image::read_exr(r.variance.as_ref().unwrap()).unwrap();
            let mut a = Moments::from_mean_variance(&native, &var, r.seeds).unwrap();
            let pv = Image::read_exr(&dir.join("plugin.var.exr")).unwrap();
            let mut b = Moments::from_mean_variance(&plugin, &pv, PLUGIN_SEEDS).unwrap();
            numerically_black(&mut a, &mut b);
            let wr = welch_test(&a, &b, &WelchOptions { fdr: FDR, ..Default::default() }).unwrap();
            println!("{name}: plugin ({PLUGIN_SEEDS} seeds) against native, {} [{secs:.1} s]", welch_summary(&wr));
            if !wr.passed {
                failures.push(format!("{name}: {}", welch_summary(&wr)));
            }
        }
        let _ = std::fs::remove_dir_all(&dir);
    }
    assert!(failures.is_empty(), "the plugin disagrees with Mitsuba's own plugins:\n{}", failures.join("\n"));
}

/// Scenes whose plugin render the test command checks against the native reference.
const PLUGIN_VS_NATIVE: [&str; 9] = [
    "cornell_box",
    "dragon",
    "monkey",
    "teapot",
    "spheres",
    "cube_textured",
    "cornell_box_area_light",
    "texture_wrap",
    "texture_wrap_bilinear",
];
/// Plugin seeds of a noisy comparison (the native reference has 64).
const PLUGIN_SEEDS: u32 = 32;

/// Mitsuba 3's own spawn rule (`spawn_ray`) in place of rtdiff's.
fn mitsuba_spawn(f: &mut rtdiff::scene::SceneFile) {
    f.params.ray_offset = SpawnOffset::ScaledNormal { epsilon: MITSUBA_RAY_EPSILON };
}

/// A peer's test scene: Mitsuba 3's own Cornell box (`mi.cornell_box()`, BSD-3-Clause,
/// tests/peer/mitsuba_cornell_box/ORIGIN.md), kept as XML. scripts/mitsuba/peer_scene.py checks the
/// transcription against `mi.cornell_box()` and renders it with Mitsuba's own plugins (direct light
/// only, emitters hidden, box filter: the three changes printed); scripts/mitsuba/import_scene.py
/// converts it into an rtdiff scene; rtdiff's 32 seeds against Mitsuba's 64 by Welch + BH
/// (q = 0.01), and 8 seeds with the light 1% brighter, which must fail.
#[test]
fn peer_scene_renders_as_mitsuba_renders_it() {
    let Some(py) = python() else { return };
    let dir = common::temp_dir("live-peer");
    let xml = root().join("tests/peer/mitsuba_cornell_box/cornell_box.xml");
    let (mean, var) = (dir.join("mitsuba.exr"), dir.join("mitsuba.var.exr"));
    let info = run(Command::new(&py)
        .arg(root().join("scripts/mitsuba/peer_scene.py"))
        .arg(&xml)
        .arg("-o")
        .arg(&mean)
        .arg("--variance")
        .arg(&var)
        .args(["--builtin", "cornell_box", "--seeds", &PEER_MITSUBA_SEEDS.to_string()]));
    println!("Mitsuba: {}", info.trim());
    let imported = run(Command::new(&py)
        .arg(root().join("scripts/mitsuba/import_scene.py"))
        .arg(&xml)
        .arg("-o")
        .arg(dir.join("rtdiff")));
    println!("imported: {}", imported.trim());
    let scene_path = dir.join("rtdiff/scene.json");
    let reference = Moments::from_mean_variance(
        &Image::read_exr(&mean).unwrap(),
        &Image::read_exr(&var).unwrap(),
        PEER_MITSUBA_SEEDS,
    )
    .unwrap();
    let check = |light: f32, seeds: u32| {
        let imgs: Vec<Image> = (0..seeds)
            .map(|k| {
                let mut file = Scene::read_file(&scene_path).unwrap();
                for l in &mut file.lights {
                    if let rtdiff::scene::file::LightSpec::Parallelogram { colors, .. } = l {
                        colors.iter_mut().for_each(|c| *c *= light);
                    }
                }
                let ov = Overrides { seed: Some(1000 + k as u64), ..Default::default() };
                render_with(&Scene::from_file_with(file, &scene_path, &ov).unwrap(), &plain)
            })
            .collect();
        let (mut a, mut b) = (reference.clone(), Moments::from_images(&imgs).unwrap());
        numerically_black(&mut a, &mut b);
        welch_test(&a, &b, &WelchOptions { fdr: FDR, ..Default::default() }).unwrap()
    };
    let w = check(1.0, PLUGIN_SEEDS);
    println!("Mitsuba's Cornell box, rtdiff against Mitsuba: {}", welch_summary(&w));
    assert!(w.passed, "rtdiff disagrees with Mitsuba on its own Cornell box: {}", welch_summary(&w));
    let lit = reference.mean.iter().filter(|m| m[1] > 1e-2).count();
    assert!(lit > 30_000, "the peer scene is nearly black ({lit} lit pixels)");
    // 8 seeds are plenty to see 1% over the whole image (z ~ 70 measured).
    let wrong = check(1.01, 8);
    println!("Mitsuba's Cornell box, light x1.01: {}", welch_summary(&wrong));
    assert!(!wrong.passed && wrong.global_rejected, "a 1% brighter light passed: {}", welch_summary(&wrong));
    let _ = std::fs::remove_dir_all(&dir);
}

/// Mitsuba seeds of the peer scene's reference (16 samples each).
const PEER_MITSUBA_SEEDS: u32 = 64;

#[test]
fn export_bad_input_is_a_clear_error() {
    let missing = Command::new(env!("CARGO_BIN_EXE_rtdiff"))
        .args(["export", "no_such_scene.json", "-o", "/tmp/x"])
        .output()
        .unwrap();
    assert!(!missing.status.success());
    assert!(String::from_utf8_lossy(&missing.stderr).contains("no_such_scene.json: file not found"));
    let bad_dir = Command::new(env!("CARGO_BIN_EXE_rtdiff"))
        .arg("export")
        .arg(root().join("scenes/cube.json"))
        .args(["-o", "/proc/rtdiff-cannot-write-here"])
        .output()
        .unwrap();
    assert!(!bad_dir.status.success());
    assert!(String::from_utf8_lossy(&bad_dir.stderr).contains("cannot create folder"));
}

/// reference/ is what the current plugin and exporter make: regenerate a deterministic
/// reference (monkey: interpolated normals, Ks 0.5 mirrors, the spawn rule; and its native
/// reference, Mitsuba's own point emitters, two lights summed) and a noisy one (cube: segment
/// light, 64 seeds, mean and variance) with scripts/mitsuba/make_references.py
/// and judge them against the stored images by what may differ between CPUs (docs/oracles.md,
/// "Regenerating reference/ on another CPU"): the same seeds give the same random numbers
/// (Mitsuba's PCG32 is integer arithmetic), but LLVM picks the host's vector width and FMA and
/// Embree its kernels, so float rounding differs, and in a noisy image a rounding can flip a
/// sample (a shadow ray at an edge), which moves a 64-seed mean by far more than rounding.
///
/// - a deterministic image must pass the exact check that judges rtdiff against it (99.9% of
///   pixels within 1e-3 relative, every other pixel classified): float32 rounding of the <= ~100
///   operations behind a pixel is gamma(100) = 6e-6 relative, times at most the Phong exponent
///   where a highlight is sampled (250 on monkey: 1.5e-3 in the worst case), which is the
///   classifier's terminator class; measured as an AVX2 CPU: 5.2e-4 (monkey.phong);
/// - a noisy mean is judged by Welch's test against the stored mean with both images' own
///   variances over K = 64 seeds, Benjamini-Hochberg at q = 0.01 (the false-alarm rate for
///   independent seeds; the same seeds only make it more conservative), pixel-channels below
///   1e-5 on both sides compared absolutely to 1e-5 (`numerically_black`);
/// - a variance image by the F-test of the two variances per pixel-channel, BH at q = 0.01.
#[test]
fn references_regenerate_from_the_current_plugin() {
    let Some(py) = python() else { return };
    let dir = common::temp_dir("live-refs");
    let out = Command::new(&py)
        .arg(root().join("scripts/mitsuba/make_references.py"))
        .arg("--rtdiff")
        .arg(env!("CARGO_BIN_EXE_rtdiff"))
        .arg("--out")
        .arg(&dir)
        .args(["--only", "monkey", "cube"])
        .output()
        .unwrap();
    assert!(out.status.success(), "make_references.py failed: {}", String::from_utf8_lossy(&out.stderr));
    let read = |p: &Path| -> serde_json::Value { serde_json::from_str(&std::fs::read_to_string(p).unwrap()).unwrap() };
    let fresh = read(&dir.join("manifest.json"));
    let stored = read(&root().join("reference/manifest.json"));
    // Noisy references draw their samples in the variant's own order (one pixel at a time in
    // scalar_rgb): without libLLVM 19 only the deterministic ones can be reproduced.
    let same_variant = fresh["variant"] == stored["variant"];
    if !same_variant {
        println!(
            "Mitsuba {} here, {} in reference/: noisy references not compared",
            fresh["variant"], stored["variant"]
        );
    }
    let mut checked = 0;
    let mut failures = Vec::new();
    for e in fresh["references"].as_array().unwrap() {
        let deterministic = e["deterministic"].as_bool().unwrap();
        if !same_variant && !deterministic {
            continue;
        }
        let native = if e["oracle"] == "native" { ".native" } else { "" };
        let name = format!("{}.{}{native}", e["name"].as_str().unwrap(), e["model"].as_str().unwrap());
        let s = stored["references"]
            .as_array()
            .unwrap()
            .iter()
            .find(|s| s["name"] == e["name"] && s["model"] == e["model"] && s["oracle"] == e["oracle"])
            .expect("regenerated reference missing from reference/manifest.json");
        assert_eq!(e["traced_sha256"], s["traced_sha256"], "{name}: the exported scene changed");
        let image = |d: &Path, key: &str| Image::read_exr(&d.join(e[key].as_str().unwrap())).unwrap();
        let refdir = root().join("reference");
        if deterministic {
            let r = reference(&name);
            let scene = load(&r, 0, &no_tweak);
            let x = exact_check(&scene, &image(&refdir, "image"), &image(&dir, "image"));
            println!("{name}: regenerated, exact check {}", summary(&x));
            if !x.passed() {
                failures.push(format!("{name}: {}", summary(&x)));
            }
            checked += 1;
            continue;
        }
        let k = e["seeds"].as_array().unwrap().len() as u32;
        let moments = |d: &Path| Moments::from_mean_variance(&image(d, "image"), &image(d, "variance"), k).unwrap();
        let (mut a, mut b) = (moments(&refdir), moments(&dir));
        numerically_black(&mut a, &mut b);
        let w = welch_test(&a, &b, &WelchOptions { fdr: FDR, ..Default::default() }).unwrap();
        let v = variance_test(&a, &b, FDR).unwrap();
        println!(
            "{name}: regenerated, mean {}, min p {:.2e}; variance {} of {} rejected, min p {:.2e}, largest ratio {:.6}",
            welch_summary(&w),
            w.min_p,
            v.rejected,
            v.tests,
            v.min_p,
            v.max_ratio
        );
        if !w.passed || !v.passed {
            failures.push(format!("{name}: mean {}; variance {} rejected", welch_summary(&w), v.rejected));
        }
        checked += 1;
    }
    assert!(failures.is_empty(), "regenerated references differ from reference/:\n{}", failures.join("\n"));
    assert_eq!(checked, if same_variant { 5 } else { 3 }, "monkey and cube in both models, monkey native");
    let _ = std::fs::remove_dir_all(&dir);
}
