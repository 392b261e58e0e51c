//! The profiling scripts docs cite as the way to reproduce their figures:
//! `scripts/callgrind-per-ray.py` (instructions per call, instruction by
//! instruction, docs/bvh.md "Embree's walk, counted") parses a callgrind
//! profile as callgrind writes it (compressed object names, relative and
//! repeated positions, call lines whose cost is not the instruction's own).

mod common;

use std::process::Command;

#[test]
fn callgrind_per_ray_reads_its_sample_profile() {
    let Some(py) = common::venv_python("callgrind_per_ray_reads_its_sample_profile") else {
        return;
    };
    let script = common::root().join("scripts/callgrind-per-ray.py");
    let out = Command::new(py).arg(&script).arg("--self-test").output().unwrap();
    let (stdout, stderr) = (String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
    assert!(out.status.success(), "{stdout}{stderr}");
    assert!(stdout.contains("self-test passed"), "{stdout}");
}

#[test]
fn callgrind_per_ray_names_a_missing_profile() {
    let Some(py) = common::venv_python("callgrind_per_ray_names_a_missing_profile") else {
        return;
    };
    let script = common::root().join("scripts/callgrind-per-ray.py");
    let missing = common::temp_dir("callgrind-per-ray").join("no-such.out");
    let out = Command::new(py).arg(&script).arg(&missing).args(["--object", "x"]).output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(stderr.contains("no-such.out") && stderr.contains("No such file"), "{stderr}");
}
