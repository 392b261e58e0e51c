//! `rtdiff bench --race` runs rtdiff's walks on the instruction set asked for
//! (`--rtdiff-isa`) and reports the set it ran, in the text and in the JSON.
#![cfg(feature = "embree")]

use std::process::Command;

use rtdiff::bvh::WalkIsa;

/// A fresh folder for one test's files (removed by the test when it passes).
fn scratch(name: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("{name}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Race one round on a cube of twelve triangles (on one thread unless
/// `extra` says otherwise); returns stdout and the JSON report.
fn race(dir: &std::path::Path, extra: &[&str]) -> (String, serde_json::Value) {
    let mesh = dir.join("cube.obj");
    let mut obj = String::new();
    for v in 0..8 {
        let c = |bit: usize| if v >> bit & 1 == 1 { 1.0 } else { -1.0 };
        obj += &format!("v {} {} {}\n", c(0), c(1), c(2));
    }
    for f in
        ["1 2 4", "1 4 3", "5 7 8", "5 8 6", "1 5 6", "1 6 2", "3 4 8", "3 8 7", "1 3 7", "1 7 5", "2 6 8", "2 8 4"]
    {
        obj += &format!("f {f}\n");
    }
    std::fs::write(&mesh, obj).unwrap();
    let json = dir.join("race.json");
    let mut args = vec!["bench", "--race", "1", "--json", json.to_str().unwrap()];
    if !extra.contains(&"--threads") {
        args.extend_from_slice(&["--threads", "1"]);
    }
    args.extend_from_slice(extra);
    args.push(mesh.to_str().unwrap());
    let out = Command::new(env!("CARGO_BIN_EXE_rtdiff")).args(&args).output().expect("runs");
    let (stdout, stderr) = (String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
    assert!(out.status.success(), "{args:?}: {stderr}");
    let report = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    (stdout.into_owned(), report)
}

#[test]
fn the_race_runs_and_reports_the_walks_instruction_set() {
    let dir = scratch("rtdiff-race-cli");
    let widest = WalkIsa::supported()[0];
    for (extra, isa, note) in
        [(vec![], widest, ""), (vec!["--rtdiff-isa", "portable"], WalkIsa::Portable, " (set by --rtdiff-isa)")]
    {
        let (text, report) = race(&dir, &extra);
        let line = format!("instruction sets: rtdiff {}{note}, Embree", isa.summary());
        assert!(text.contains(&line), "{extra:?}: no `{line}` in\n{text}");
        let mesh = &report["meshes"][0];
        assert_eq!(mesh["rtdiff_isa"], isa.summary(), "{extra:?}");
        assert_eq!(mesh["rtdiff_isa_set"], !extra.is_empty(), "{extra:?}");
        // Every ray contest ran once (one round), every build contest
        // three times (the default builds per round).
        let contests = mesh["contests"].as_array().unwrap();
        for set in ["camera", "incoherent", "shadow", "batch camera", "batch shadow"] {
            assert!(contests.iter().any(|c| c["name"] == set), "{extra:?}: no {set} contest");
        }
        // Each side counts its own hits (Embree through its C API): the same
        // count on every ray set, and the camera rays mostly miss the cube
        // (framed by its bounding sphere) without all missing it.
        for c in contests.iter().filter(|c| c["name"] != "build") {
            assert_eq!(c["hits"], c["opponent_hits"], "{extra:?}: {} against {}", c["name"], c["opponent"]);
        }
        let camera = contests.iter().find(|c| c["name"] == "camera").unwrap();
        let rate = camera["hits"].as_f64().unwrap() / camera["rays"].as_f64().unwrap();
        assert!(rate > 0.1 && rate < 0.6, "{extra:?}: camera hit rate {rate}");
        assert!(text.contains("ns/ray"), "{extra:?}: no ns per ray in\n{text}");
        assert_eq!(mesh["build_repeats"], 3, "{extra:?}");
        for c in contests {
            let samples = if c["name"] == "build" { 3 } else { 1 };
            assert_eq!(c["times"].as_array().unwrap().len(), samples, "{extra:?}: {}", c["name"]);
        }
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// `--build-repeats N` times each contestant's build N times per round, each
/// a sample of the build contests, and says so in the mesh's heading.
#[test]
fn builds_repeat_within_a_round() {
    let dir = scratch("rtdiff-race-repeats");
    let (text, report) = race(&dir, &["--build-repeats", "2"]);
    assert!(text.contains("1 interleaved rounds (2 builds of each per round)"), "{text}");
    let mesh = &report["meshes"][0];
    assert_eq!(mesh["build_repeats"], 2);
    let builds: Vec<_> = mesh["contests"].as_array().unwrap().iter().filter(|c| c["name"] == "build").collect();
    assert_eq!(builds.len(), 4, "one build contest per Embree mode");
    for c in builds {
        assert_eq!(c["times"].as_array().unwrap().len(), 2, "{}", c["opponent"]);
        assert_eq!(c["walls"].as_array().unwrap().len(), 2, "{}", c["opponent"]);
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// With a two-thread pool raced, the race first measures how long the
/// host takes to start an idle pool thread (`perf::wake`) and prints it, in
/// the text and in the JSON, beside the build scaling; with one thread only
/// it measures nothing.
#[test]
fn two_threads_report_the_hosts_idle_wake() {
    let dir = scratch("rtdiff-race-wake");
    let (text, report) = race(&dir, &["--threads", "1,2"]);
    assert!(text.contains("host: an idle thread of a 2-thread pool started work"), "{text}");
    assert!(text.contains("an idle thread of the host's 2-thread pool started work after"), "{text}");
    let wakes = report["idle_wake"].as_array().unwrap();
    assert_eq!(wakes.len(), 1);
    assert_eq!(wakes[0]["threads"], 2);
    assert_eq!(wakes[0]["delays_ms"].as_array().unwrap().len(), 5);
    let (text, report) = race(&dir, &[]);
    assert!(!text.contains("host: an idle thread"), "{text}");
    assert!(report["idle_wake"].as_array().unwrap().is_empty());
    std::fs::remove_dir_all(&dir).ok();
}
