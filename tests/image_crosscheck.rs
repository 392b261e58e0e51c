//! Cross-check of `rtdiff compare` against independent implementations:
//! OpenImageIO's `ImageBufAlgo.compare` and NVIDIA's flip-evaluator (Python,
//! `scripts/mitsuba/crosscheck_metrics.py` in the `.venv/` that
//! `scripts/mitsuba/setup.sh` makes), on rtdiff renders of two scenes at 1
//! and 16 spp and on two Mitsuba 3 renders (PIZ EXRs) at 4 and 16 spp; and
//! OpenImageIO's compare on every reference pair (each Mitsuba reference of
//! `reference/` against rtdiff's render of its scene).
//!
//! Skipped (with a message) when `.venv/bin/python` is missing, unless
//! `RTDIFF_REQUIRE_PYTHON=1`, as `scripts/test.sh` sets, makes that a failure.

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;

use common::{root, run};

use serde_json::Value;

fn python() -> Option<PathBuf> {
    common::venv_python("image_crosscheck")
}

fn render(dir: &Path, scene: &str, spp: u32, seed: u32) -> PathBuf {
    let out = dir.join(format!("{scene}_{spp}.exr"));
    run(Command::new(env!("CARGO_BIN_EXE_rtdiff"))
        .arg("render")
        .arg(root().join("scenes").join(format!("{scene}.json")))
        .arg("-o")
        .arg(&out)
        .args(["--width", "128", "--height", "96", "--quiet"])
        .args(["--spp", &spp.to_string(), "--seed", &seed.to_string()]));
    out
}

/// `rtdiff compare A B --json --threshold T`, parsed.
fn rtdiff_compare(a: &Path, b: &Path, threshold: &str) -> Value {
    serde_json::from_str(&run(Command::new(env!("CARGO_BIN_EXE_rtdiff")).arg("compare").arg(a).arg(b).args([
        "--json",
        "--threshold",
        threshold,
    ])))
    .unwrap()
}

#[track_caller]
fn close(what: &str, rust: f64, other: f64, rel: f64) {
    let err = (rust - other).abs() / other.abs().max(1e-300);
    assert!(err <= rel, "{what}: rtdiff {rust:e} vs {other:e}, relative difference {err:e} > {rel:e}");
}

#[test]
fn metrics_and_flip_match_openimageio_and_flip_evaluator() {
    let Some(py) = python() else { return };
    let dir = common::temp_dir("crosscheck");
    let script = root().join("scripts/mitsuba/crosscheck_metrics.py");
    let mi: Value =
        serde_json::from_str(&run(Command::new(&py).arg(&script).arg("--mitsuba-pair").arg(dir.join("mitsuba"))))
            .unwrap();
    let mi_images: Vec<PathBuf> = mi["images"].as_array().unwrap().iter().map(|p| p.as_str().unwrap().into()).collect();
    let pairs = [
        (render(&dir, "cornell_box_parallelogram_light", 1, 1), render(&dir, "cornell_box_parallelogram_light", 16, 2)),
        (render(&dir, "spheres", 1, 1), render(&dir, "spheres", 16, 2)),
        (mi_images[0].clone(), mi_images[1].clone()),
    ];
    let threshold = "0.001";
    let mut cmd = Command::new(&py);
    cmd.arg(&script).args(["--threshold", threshold]);
    for (a, b) in &pairs {
        cmd.arg(a).arg(b);
    }
    let oracle: Vec<Value> = serde_json::from_str(&run(&mut cmd)).unwrap();
    for ((a, b), o) in pairs.iter().zip(&oracle) {
        let r = rtdiff_compare(a, b, threshold);
        let name = a.file_name().unwrap().to_string_lossy().to_string();
        let (m, oi) = (&r["metrics"], &o["oiio"]);
        let f = |v: &Value| v.as_f64().unwrap();
        eprintln!(
            "{name}: rmse {:e} (oiio {:e}), psnr {} ({}), flip ldr {} (flip-evaluator {}, on 8-bit inputs {}), flip hdr {} ({}, {})",
            f(&m["rmse"]),
            f(&oi["rms_error"]),
            f(&m["psnr"]),
            f(&oi["PSNR"]),
            f(&r["flip_ldr"]["mean"]),
            f(&o["flip"]["ldr"]),
            f(&o["flip_q"]["ldr"]),
            f(&r["flip_hdr"]["mean"]),
            f(&o["flip"]["hdr"]),
            f(&o["flip_q"]["hdr"])
        );
        // Pixel metrics: both sides sum the same f32 samples in f64; only the summation order
        // differs (relative error ~1e-15 x pixels), far below the 1e-6 the issue asks for.
        close(&format!("{name} MAE"), f(&m["mae"]), f(&oi["meanerror"]), 1e-6);
        close(&format!("{name} RMSE"), f(&m["rmse"]), f(&oi["rms_error"]), 1e-6);
        close(&format!("{name} PSNR"), f(&m["psnr"]), f(&oi["PSNR"]), 1e-6);
        close(&format!("{name} max error"), f(&m["max_error"]), f(&oi["maxerror"]), 1e-6);
        assert_eq!(
            (&m["max_error_pixel"][0], &m["max_error_pixel"][1], &m["max_error_channel"]),
            (&oi["maxx"], &oi["maxy"], &oi["maxc"]),
            "{name}: max error location"
        );
        assert_eq!(m["over_threshold"], oi["nfail"], "{name}: pixels over the threshold");
        // FLIP kernel: on identical 8-bit sRGB inputs both run NVIDIA's C++ FLIP; LDR agrees to
        // float rounding. HDR computes each exposure's scale 2^c in f32 here and in f64 there,
        // which moves a few 8-bit inputs by one step: 1e-4 relative covers it (measured <= 8e-6).
        let exp = &r["flip_hdr"]["exposures"];
        let op = &o["flip"]["hdr_params"];
        close(&format!("{name} HDR start exposure"), f(&exp["start"]), f(&op["startExposure"]), 1e-5);
        close(&format!("{name} HDR stop exposure"), f(&exp["stop"]), f(&op["stopExposure"]), 1e-5);
        assert_eq!(exp["count"].as_u64().unwrap() as f64, f(&op["numExposures"]), "{name}: exposure count");
        close(&format!("{name} FLIP LDR (8-bit inputs)"), f(&r["flip_ldr"]["mean"]), f(&o["flip_q"]["ldr"]), 1e-5);
        close(&format!("{name} FLIP HDR (8-bit inputs)"), f(&r["flip_hdr"]["mean"]), f(&o["flip_q"]["hdr"]), 1e-4);
        // Against flip-evaluator's float pipeline the only difference is nv-flip's 8-bit input:
        // each sRGB value moves by at most half a step (1/510 = 0.00196). On every pair measured
        // the mean FLIP moved by less than that step size (largest: 7.9e-4, HDR on `spheres`),
        // so the bound is 1/510 absolute.
        for (mode, rust, other) in [
            ("LDR", f(&r["flip_ldr"]["mean"]), f(&o["flip"]["ldr"])),
            ("HDR", f(&r["flip_hdr"]["mean"]), f(&o["flip"]["hdr"])),
        ] {
            assert!(
                (rust - other).abs() <= 1.0 / 510.0,
                "{name} FLIP {mode}: rtdiff {rust} vs flip-evaluator {other}: differ by more than 1/510"
            );
        }
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// `rtdiff compare` against OpenImageIO's compare on every pair the image oracle
/// compares: each reference of `reference/` and rtdiff's render of its scene (in
/// its model, at its size, with its features). Same tolerances as above: 1e-6
/// relative, the max-error pixel and the count over the threshold exactly.
#[test]
fn compare_matches_openimageio_on_every_reference_pair() {
    let Some(py) = python() else { return };
    let dir = common::temp_dir("crosscheck-refs");
    let refs = common::references::manifest();
    let mut pairs = Vec::new();
    for r in &refs {
        let scene = common::references::load(r, 0, &common::references::no_tweak);
        let ours = dir.join(format!("{}.exr", r.name()));
        common::references::render_with(&scene, &common::references::plain).write(&ours).unwrap();
        pairs.push((r.image.clone(), ours));
    }
    let threshold = "0.001";
    let mut cmd = Command::new(&py);
    cmd.arg(root().join("scripts/mitsuba/crosscheck_metrics.py")).args(["--threshold", threshold, "--no-flip"]);
    for (a, b) in &pairs {
        cmd.arg(a).arg(b);
    }
    let oracle: Vec<Value> = serde_json::from_str(&run(&mut cmd)).unwrap();
    let f = |v: &Value| v.as_f64().unwrap();
    let mut worst = 0f64;
    for ((a, b), o) in pairs.iter().zip(&oracle) {
        let r = rtdiff_compare(a, b, threshold);
        let name = b.file_stem().unwrap().to_string_lossy().to_string();
        let (m, oi) = (&r["metrics"], &o["oiio"]);
        for (what, ours, theirs) in [
            ("MAE", f(&m["mae"]), f(&oi["meanerror"])),
            ("RMSE", f(&m["rmse"]), f(&oi["rms_error"])),
            ("PSNR", f(&m["psnr"]), f(&oi["PSNR"])),
            ("max error", f(&m["max_error"]), f(&oi["maxerror"])),
        ] {
            close(&format!("{name} {what}"), ours, theirs, 1e-6);
            worst = worst.max((ours - theirs).abs() / theirs.abs().max(1e-300));
        }
        assert_eq!(
            (&m["max_error_pixel"][0], &m["max_error_pixel"][1], &m["max_error_channel"]),
            (&oi["maxx"], &oi["maxy"], &oi["maxc"]),
            "{name}: max error location"
        );
        assert_eq!(m["over_threshold"], oi["nfail"], "{name}: pixels over the threshold");
    }
    println!("{} reference pairs: rtdiff compare and OpenImageIO agree within {worst:.1e} relative", pairs.len());
    std::fs::remove_dir_all(&dir).ok();
}
