//! `rtdiff compare` and the image files it reads, run as a user runs them:
//! the renderer's EXR output is byte-deterministic, the compare command prints
//! the metrics of `verify::image`, and every bad input is a clear error.

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;

use common::temp_dir;
use exr::prelude::{SpecificChannels, WritableImage};
use glam::Vec3;
use rtdiff::verify::image::{CompareOptions, Image, compare, read_image, write_exr};

fn rtdiff(args: &[&std::ffi::OsStr]) -> (i32, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_rtdiff")).args(args).output().expect("rtdiff runs");
    let stderr = String::from_utf8_lossy(&out.stderr).to_string();
    assert!(!stderr.contains("panicked"), "rtdiff panicked: {stderr}");
    (out.status.code().unwrap_or(-1), String::from_utf8_lossy(&out.stdout).to_string(), stderr)
}

fn render(dir: &Path, name: &str, extra: &[&str]) -> PathBuf {
    let out = dir.join(name);
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell_box_parallelogram_light.json");
    let mut args: Vec<&std::ffi::OsStr> = vec!["render".as_ref(), scene.as_os_str(), "-o".as_ref(), out.as_os_str()];
    args.extend(["--width", "96", "--height", "72", "--quiet"].iter().map(|s| std::ffi::OsStr::new(s)));
    args.extend(extra.iter().map(|s| std::ffi::OsStr::new(s)));
    let (code, _, err) = rtdiff(&args);
    assert_eq!(code, 0, "{err}");
    out
}

fn compare_cli(a: &Path, b: &Path, extra: &[&str]) -> (i32, String, String) {
    let mut args: Vec<&std::ffi::OsStr> = vec!["compare".as_ref(), a.as_os_str(), b.as_os_str()];
    args.extend(extra.iter().map(|s| std::ffi::OsStr::new(s)));
    rtdiff(&args)
}

#[test]
fn render_exr_is_byte_deterministic_across_runs_and_thread_counts() {
    let dir = temp_dir("exr-determinism");
    let a = render(&dir, "a.exr", &["--threads", "1"]);
    let b = render(&dir, "b.exr", &["--threads", "2"]);
    let c = render(&dir, "c.exr", &[]);
    let bytes = std::fs::read(&a).unwrap();
    assert_eq!(bytes, std::fs::read(&b).unwrap(), "threads 1 vs 2");
    assert_eq!(bytes, std::fs::read(&c).unwrap(), "two runs");
}

#[test]
fn compare_cli_prints_the_library_metrics_and_writes_the_pictures() {
    let dir = temp_dir("compare-cli");
    let a = render(&dir, "a.exr", &["--spp", "1", "--seed", "1"]);
    let b = render(&dir, "b.exr", &["--spp", "4", "--seed", "2"]);
    let (diff, flip) = (dir.join("d.png"), dir.join("f.png"));
    let (code, out, err) = compare_cli(
        &a,
        &b,
        &["--json", "--diff-image", diff.to_str().unwrap(), "--flip-image", flip.to_str().unwrap()],
    );
    assert_eq!(code, 0, "{err}");
    let json: serde_json::Value = serde_json::from_str(&out).unwrap();
    let lib = compare(&read_image(&a).unwrap(), &read_image(&b).unwrap(), &CompareOptions::default()).unwrap();
    assert_eq!(json["metrics"]["rmse"].as_f64().unwrap(), lib.rmse);
    assert_eq!(json["metrics"]["max_error_pixel"][0].as_u64().unwrap(), lib.max_error_pixel[0] as u64);
    assert!(lib.rmse > 0.0 && json["flip_ldr"]["mean"].as_f64().unwrap() > 0.0);
    assert!(json["flip_hdr"]["exposures"]["count"].as_u64().unwrap() >= 2);
    for png in [&diff, &flip] {
        let img = read_image(png).unwrap();
        assert_eq!((img.width, img.height), (96, 72));
    }
    // Identical images: zero error, infinite PSNR (null in JSON), exit 0 with a gate.
    let (code, out, _) = compare_cli(&a, &a, &["--json", "--fail-above", "rmse=0"]);
    assert_eq!(code, 0);
    let json: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert_eq!((json["metrics"]["rmse"].as_f64(), json["metrics"]["psnr"].is_null()), (Some(0.0), true));
    // The text output names every metric.
    let (code, out, _) = compare_cli(&a, &b, &[]);
    assert_eq!(code, 0);
    for word in ["mae", "rmse", "psnr", "relmse", "max error", "abs", "rel", "flip ldr", "flip hdr"] {
        assert!(out.contains(word), "{word} missing from:\n{out}");
    }
    // A gate the pair exceeds: non-zero exit naming the metric.
    let (code, _, err) = compare_cli(&a, &b, &["--fail-above", "flip=0.000001"]);
    assert_ne!(code, 0);
    assert!(err.contains("flip ="), "{err}");
}

#[test]
fn compare_bad_inputs_are_clear_errors() {
    let dir = temp_dir("compare-errors");
    let good = dir.join("good.exr");
    write_exr(&Image::new(4, 3), &good).unwrap();
    let fails = |a: &Path, b: &Path, extra: &[&str], needles: &[&str]| {
        let (code, _, err) = compare_cli(a, b, extra);
        assert_ne!(code, 0, "expected failure: {err}");
        for n in needles {
            assert!(err.contains(n), "stderr lacks {n:?}: {err}");
        }
    };
    // Missing file.
    fails(&good, &dir.join("nope.exr"), &[], &["nope.exr", "not found"]);
    // Unreadable EXR.
    let junk = dir.join("junk.exr");
    std::fs::write(&junk, b"not an exr").unwrap();
    fails(&good, &junk, &[], &["junk.exr", "cannot read EXR"]);
    // Unknown extension.
    let txt = dir.join("a.txt");
    std::fs::write(&txt, b"x").unwrap();
    fails(&txt, &good, &[], &["a.txt", "unknown image format"]);
    // Mismatched sizes.
    let big = dir.join("big.exr");
    write_exr(&Image::new(5, 3), &big).unwrap();
    fails(&good, &big, &[], &["sizes differ", "4x3", "5x3"]);
    // NaN and infinite pixels.
    let mut nan = Image::new(4, 3);
    nan.pixels[5] = Vec3::new(0.0, f32::NAN, 0.0);
    nan.pixels[7] = Vec3::splat(f32::INFINITY);
    let nan_path = dir.join("nan.exr");
    write_exr(&nan, &nan_path).unwrap();
    fails(&good, &nan_path, &[], &["nan.exr", "2 pixel(s) with NaN or infinite", "(1, 1)"]);
    // Missing channels: a luminance-only EXR.
    let grey = dir.join("grey.exr");
    let channels = SpecificChannels::build().with_channel("Y").with_pixel_fn(|_| (0.5f32,));
    exr::prelude::Image::from_channels((4, 3), channels).write().to_file(&grey).unwrap();
    fails(&grey, &good, &[], &["grey.exr", "no R channel", "Y"]);
    // A bad gate.
    fails(&good, &good, &["--fail-above", "speed=3"], &["METRIC=VALUE", "rmse"]);
}

#[test]
fn exr_with_alpha_and_sorted_channels_reads_rgb_by_name() {
    // Mitsuba writes channels sorted by name (A, B, G, R): the reader must pick them by name.
    let dir = temp_dir("exr-rgba");
    let p = dir.join("rgba.exr");
    let channels = SpecificChannels::rgba(|exr::prelude::Vec2(x, y)| (x as f32, y as f32, 0.25f32, 0.5f32));
    exr::prelude::Image::from_channels((3, 2), channels).write().to_file(&p).unwrap();
    let img = read_image(&p).unwrap();
    assert_eq!(img.pixels[4], Vec3::new(1.0, 1.0, 0.25));
}
