//! Tracers rtdiff did not write, end to end: the third-party plugins of `plugins/` (tinybvh,
//! obvhs) through `--tracer plugin:PATH`; the C plugin of `plugins/c/brute.c` built correct and
//! with one deliberate bug each, caught by `parity` and by `judge` with the right classes; clear
//! errors for a missing file, missing symbols and a wrong ABI version; the program path (`rays`,
//! a tracer as a program, `judge`) with Embree's default mode through the embreex wheel; and
//! primitive ids that are triangle positions in the mesh file.

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;

fn bin() -> &'static str {
    env!("CARGO_BIN_EXE_rtdiff")
}

/// `plugins/target/release/librtdiff_NAME.so`, the workspace built once per test binary.
fn third_party(name: &str) -> PathBuf {
    static BUILT: OnceLock<()> = OnceLock::new();
    BUILT.get_or_init(|| {
        let manifest = common::root().join("plugins/Cargo.toml");
        common::run(
            Command::new(env!("CARGO")).args(["build", "--release", "--locked", "--manifest-path"]).arg(&manifest),
        );
    });
    common::root().join(format!("plugins/target/release/librtdiff_{name}.so"))
}

/// `plugins/c/brute.c` compiled with `-DBREAK_<flag>` (or correct for `None`) into a shared library.
fn c_plugin(flag: Option<&str>) -> PathBuf {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    let dir = DIR.get_or_init(|| common::temp_dir("c-plugins"));
    let out = dir.join(format!("brute_{}.so", flag.unwrap_or("ok")));
    // Tests run in parallel: one compiles at a time, so none loads a library another is writing.
    static COMPILING: std::sync::Mutex<()> = std::sync::Mutex::new(());
    let _guard = COMPILING.lock().unwrap_or_else(|e| e.into_inner());
    if !out.exists() {
        let mut cmd = Command::new("cc");
        cmd.args(["-O2", "-std=c99", "-Wall", "-Werror", "-shared", "-fPIC", "-I"])
            .arg(common::root().join("include"))
            .arg(common::root().join("plugins/c/brute.c"))
            .arg("-o")
            .arg(&out)
            .arg("-lm");
        if let Some(f) = flag {
            cmd.arg(format!("-DBREAK_{f}"));
        }
        common::run(&mut cmd);
    }
    out
}

fn suzanne() -> PathBuf {
    common::root().join("assets/suzanne.obj")
}

/// `rtdiff ARGS`: (exit code, stdout, stderr).
fn rtdiff(args: &[&str]) -> (i32, String, String) {
    let out = Command::new(bin()).args(args).output().unwrap();
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// `rtdiff parity suzanne --tracer plugin:LIB` on every set (brute-force reference), as JSON.
fn parity_json(lib: &Path, count: &str) -> (i32, serde_json::Value) {
    let tracer = format!("plugin:{}", s(lib));
    let (code, out, err) =
        rtdiff(&["parity", s(&suzanne()), "--tracer", &tracer, "--reference", "brute", "--count", count, "--json"]);
    assert!(code == 0 || code == 2, "{err}");
    (code, serde_json::from_str(&out).unwrap_or_else(|e| panic!("{e}: {out}")))
}

/// Sum of `wrong_by[class]` over the verdict's rows.
fn wrong_by(v: &serde_json::Value, class: &str) -> u64 {
    v["verdict"]["rows"].as_array().unwrap().iter().map(|r| r["wrong_by"][class].as_u64().unwrap_or(0)).sum()
}

fn total(v: &serde_json::Value, field: &str) -> u64 {
    v["verdict"]["rows"].as_array().unwrap().iter().map(|r| r[field].as_u64().unwrap()).sum()
}

#[test]
fn third_party_plugins_trace_through_parity() {
    for name in ["tinybvh", "obvhs"] {
        let (_, v) = parity_json(&third_party(name), "2000");
        let rows = v["verdict"]["rows"].as_array().unwrap();
        assert_eq!(rows.len(), 11, "{name}: every set, the scaled set's three parts included");
        assert!(rows.iter().all(|r| r["tracer"].as_str().unwrap().starts_with(&format!("plugin:{name} "))));
        // The libraries agree with the brute force on ordinary camera rays...
        let primary = rows.iter().find(|r| r["set"] == "primary").unwrap();
        assert_eq!(primary["wrong"], 0, "{name}: {primary}");
        assert!(primary["agree"].as_u64().unwrap() >= 1990, "{name}: {primary}");
        // ... never return a hit that is no hit ...
        for fault in ["no-such-primitive", "t-outside-interval", "t-not-finite", "uv-not-finite"] {
            assert_eq!(wrong_by(&v, fault), 0, "{name}: {fault}");
        }
        // ... and leak through shared edges and vertices (Moller-Trumbore is not watertight):
        // the findings of docs/plugins.md.
        assert!(total(&v, "leaks") > 0, "{name}: no leak found");
    }
    // tinybvh's absolute determinant epsilon (1e-6) loses every small triangle: on the mesh
    // scaled by 1e-4 most hits are wrong (docs/plugins.md).
    let (code, v) = parity_json(&third_party("tinybvh"), "2000");
    assert_eq!(code, 2, "a failing tracer exits with 2");
    let rows = v["verdict"]["rows"].as_array().unwrap();
    let small = rows.iter().find(|r| r["set"] == "scaled-1e-4").unwrap();
    assert!(small["wrong"].as_u64().unwrap() > 300, "{small}");
}

#[test]
fn render_and_trace_take_a_plugin() {
    let d = common::temp_dir("plugin-render");
    let lib = format!("plugin:{}", s(&third_party("tinybvh")));
    let png = d.join("cb.png");
    let scene = common::root().join("scenes/cornell_box.json");
    let (code, _, err) =
        rtdiff(&["render", s(&scene), "-o", s(&png), "--width", "32", "--height", "32", "--tracer", &lib]);
    assert_eq!(code, 0, "{err}");
    assert!(png.is_file());
    // The same picture as rtdiff's own tracer, pixel for pixel but for rounding at edges.
    let own = d.join("own.png");
    let (code, _, err) = rtdiff(&["render", s(&scene), "-o", s(&own), "--width", "32", "--height", "32", "--quiet"]);
    assert_eq!(code, 0, "{err}");
    let (a, b) = (image::open(&png).unwrap().to_rgb8(), image::open(&own).unwrap().to_rgb8());
    let same = a.pixels().zip(b.pixels()).filter(|(x, y)| x == y).count();
    assert!(same >= 32 * 32 * 95 / 100, "{same} of 1024 pixels equal");
    // A plugin's garbage never reaches the shading: an invalid hit renders as a miss, named once on stderr.
    let garbage = format!("plugin:{}", s(&c_plugin(Some("GARBAGE"))));
    let (code, _, err) =
        rtdiff(&["render", s(&scene), "-o", s(&png), "--width", "16", "--height", "16", "--tracer", &garbage]);
    assert_eq!(code, 0, "{err}");
    assert_eq!(err.matches("returned an invalid hit (uv-not-finite").count(), 1, "{err}");
    // A scene with spheres is refused by a triangles-only plugin, with its name.
    let spheres = common::root().join("scenes/spheres.json");
    let (code, _, err) =
        rtdiff(&["render", s(&spheres), "-o", s(&png), "--width", "8", "--height", "8", "--tracer", &lib]);
    assert_eq!(code, 1);
    assert!(err.contains("tinybvh") && err.contains("spheres"), "{err}");
}

#[test]
fn deliberately_broken_plugins_are_caught_with_the_right_classes() {
    // The correct C plugin passes.
    let (code, v) = parity_json(&c_plugin(None), "1000");
    assert_eq!(code, 0, "{}", v["verdict"]);
    assert!(v["verdict"]["passed"].as_bool().unwrap());
    // Off-by-one ids: wrong primitives, and ids past the last triangle.
    let (code, v) = parity_json(&c_plugin(Some("IDS")), "1000");
    assert_eq!(code, 2);
    assert!(wrong_by(&v, "primitive") > 1000, "{}", v["verdict"]);
    assert!(wrong_by(&v, "no-such-primitive") > 0, "{}", v["verdict"]);
    // A skipped edge test: hits outside triangles, judged wrong by the arbiter.
    let (code, v) = parity_json(&c_plugin(Some("EDGE")), "1000");
    assert_eq!(code, 2);
    assert!(wrong_by(&v, "primitive") > 1000, "{}", v["verdict"]);
    // t scaled by 1 + 1e-4, far outside the float bound: wrong distances, and leaks at the
    // crossings (the hit lies beyond the shared edge).
    let (code, v) = parity_json(&c_plugin(Some("T")), "1000");
    assert_eq!(code, 2);
    assert!(wrong_by(&v, "distance") > 1000 && wrong_by(&v, "primitive") == 0, "{}", v["verdict"]);
    assert!(total(&v, "leaks") > 0);
    // NaN barycentrics: a verdict naming the fault, no panic.
    let (code, v) = parity_json(&c_plugin(Some("GARBAGE")), "1000");
    assert_eq!(code, 2);
    assert!(wrong_by(&v, "uv-not-finite") > 1000, "{}", v["verdict"]);
    // The text verdict opens with FAIL and names the class; each wrong ray is printed replayable.
    let tracer = format!("plugin:{}", s(&c_plugin(Some("IDS"))));
    let (code, out, _) = rtdiff(&[
        "parity",
        s(&suzanne()),
        "--tracer",
        &tracer,
        "--reference",
        "brute",
        "--rays",
        "primary",
        "--count",
        "500",
    ]);
    assert_eq!(code, 2);
    assert!(out.starts_with("FAIL"), "{out}");
    assert!(out.contains("wrong hits (primitive") && out.contains("replay: "), "{out}");
    assert!(out.lines().count() < 25, "one screen: {out}");
}

#[test]
fn plugin_errors_are_clear() {
    let d = common::temp_dir("plugin-errors");
    let cases: Vec<(String, Vec<&str>)> = vec![
        (format!("plugin:{}", s(&d.join("missing.so"))), vec!["missing.so", "not found"]),
        (format!("plugin:{}", s(&c_plugin(Some("SYMBOLS")))), vec!["symbol rtdiff_tracer_occluded_n is missing"]),
        (format!("plugin:{}", s(&c_plugin(Some("VERSION")))), vec!["ABI version 2", "this rtdiff version 1"]),
        (format!("plugin:{}", s(&suzanne())), vec!["suzanne.obj", "cannot load the plugin"]),
        ("plugin:".to_string(), vec!["unknown tracer"]),
    ];
    for (tracer, want) in cases {
        for args in [
            vec!["parity", s(&suzanne()), "--count", "10", "--reference", "brute", "--tracer", &tracer],
            vec!["trace", s(&suzanne()), "--rays", "r.csv", "--out", "h.csv", "--tracer", &tracer],
        ] {
            let (code, _, err) = rtdiff(&args);
            assert!(code == 1 || code == 2, "{args:?}: {code}");
            assert!(want.iter().all(|w| err.contains(w)), "{args:?}: {err}");
            assert!(!err.contains("panicked"), "{err}");
        }
    }
}

#[test]
fn the_program_path_judges_a_tracer_it_cannot_link() {
    let d = common::temp_dir("program-path");
    let rays = d.join("rays.csv");
    let (code, _, err) =
        rtdiff(&["rays", s(&suzanne()), "--set", "all", "--count", "1000", "--reference", "brute", "-o", s(&rays)]);
    assert_eq!(code, 0, "{err}");
    assert!(d.join("rays.tags.csv").is_file());
    let judge =
        |hits: &Path| rtdiff(&["judge", s(&suzanne()), "--rays", s(&rays), "--hits", s(hits), "--reference", "brute"]);
    // A correct tracer as a program (here the C plugin through `rtdiff trace`) passes...
    for (flag, expect) in [(None, 0), (Some("T"), 2), (Some("IDS"), 2)] {
        let hits = d.join(format!("hits_{}.csv", flag.unwrap_or("ok")));
        let tracer = format!("plugin:{}", s(&c_plugin(flag)));
        let (code, _, err) =
            rtdiff(&["trace", s(&suzanne()), "--rays", s(&rays), "--out", s(&hits), "--tracer", &tracer]);
        assert_eq!(code, 0, "{err}");
        let (code, out, err) = judge(&hits);
        assert_eq!(code, expect, "{flag:?}: {out}{err}");
        match flag {
            None => assert!(out.starts_with("PASS"), "{out}"),
            Some("T") => assert!(out.starts_with("FAIL") && out.contains("distance"), "{out}"),
            _ => assert!(out.contains("primitive") && out.contains("no-such-primitive"), "{out}"),
        }
        if let Some(f) = flag {
            // The disputes are a ray file `trace` reads back.
            let disputes = d.join(format!("hits_{f}.disputes.csv"));
            let back = rtdiff::rays::file::read_rays(&disputes).unwrap();
            assert!(!back.is_empty());
            let text = std::fs::read_to_string(&disputes).unwrap();
            assert!(text.contains("# ") && text.contains("wrong"), "{text}");
        }
    }
    // A hit file of the wrong length, or with a line that is not a hit, is an error naming it.
    let short = common::write(&d, "short.csv", "hit,t,prim,u,v\n0,,,,\n");
    let (code, _, err) = judge(&short);
    assert_eq!(code, 1);
    assert!(err.contains("short.csv") && err.contains("one hit line per ray"), "{err}");
    let bad = common::write(&d, "bad.csv", "hit,t,prim,u,v\n1,0.5,-3,0,0\n");
    let (code, _, err) = judge(&bad);
    assert_eq!(code, 1);
    assert!(err.contains("bad.csv") && err.contains("line 2"), "{err}");
    // Embree's default mode as a program: scripts/program/embree_hits.py on the embreex wheel.
    let Some(py) = program_python() else { return };
    let hits = d.join("embree_default.csv");
    common::run(Command::new(py).arg(common::root().join("scripts/program/embree_hits.py")).args([
        s(&suzanne()),
        s(&rays),
        s(&hits),
    ]));
    let (code, out, err) = judge(&hits);
    assert!(code == 0 || code == 2, "{err}");
    assert!(out.contains("primary") || out.contains("every tracer agrees"), "{out}");
    // Embree's hits are never wrong on ordinary rays.
    let v = {
        let out = Command::new(bin())
            .args(["judge", s(&suzanne()), "--rays", s(&rays), "--hits", s(&hits), "--reference", "brute", "--json"])
            .output()
            .unwrap();
        serde_json::from_slice::<serde_json::Value>(&out.stdout).unwrap()
    };
    assert_eq!(wrong_by(&v, "primitive") + wrong_by(&v, "distance"), 0, "{}", v["verdict"]);
}

/// A Python with embreex: `RTDIFF_PROGRAM_PYTHON`, else `.venv/bin/python` when it imports embreex
/// (scripts/test.sh installs it); `None` with a note, or a failure under `RTDIFF_REQUIRE_PYTHON=1`.
fn program_python() -> Option<PathBuf> {
    let candidates: Vec<PathBuf> = std::env::var_os("RTDIFF_PROGRAM_PYTHON")
        .map(PathBuf::from)
        .into_iter()
        .chain(common::venv_python("the_program_path_judges_a_tracer_it_cannot_link"))
        .collect();
    for py in candidates {
        let ok = Command::new(&py).args(["-c", "import embreex"]).output().is_ok_and(|o| o.status.success());
        if ok {
            return Some(py);
        }
    }
    if common::python_required() {
        panic!(
            "RTDIFF_REQUIRE_PYTHON=1 but no Python with embreex (scripts/test.sh installs scripts/program/requirements.txt)"
        );
    }
    eprintln!("the_program_path_judges_a_tracer_it_cannot_link: embreex part skipped, no Python with embreex");
    None
}

#[test]
fn primitive_ids_are_triangle_positions_in_the_file() {
    let d = common::temp_dir("file-ids");
    // A zero-area triangle first, then a quad (two triangles fanned from its first vertex).
    let obj = common::write(&d, "m.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 2 0 0\nf 1 2 5\nf 1 2 3 4\n");
    let rays = common::write(&d, "r.csv", "0.75,0.25,1,0,0,-1,0,inf\n0.25,0.75,1,0,0,-1,0,inf\n");
    let hits = d.join("h.csv");
    let (code, _, err) = rtdiff(&["trace", s(&obj), "--rays", s(&rays), "--out", s(&hits)]);
    assert_eq!(code, 0, "{err}");
    assert!(err.contains("1 zero-area triangles (kept"), "{err}");
    let text = std::fs::read_to_string(&hits).unwrap();
    let prims: Vec<&str> = text.lines().skip(1).map(|l| l.split(',').nth(2).unwrap()).collect();
    assert_eq!(prims, ["1", "2"], "{text}");
    // `judge` reads the same ids back and agrees; the ray through the zero-area triangle's id is wrong.
    let (code, out, err) = rtdiff(&["judge", s(&obj), "--rays", s(&rays), "--hits", s(&hits), "--reference", "brute"]);
    assert_eq!(code, 0, "{out}{err}");
    // In a scene, the meshes' triangles follow each other in meshes[] order, then the spheres.
    let scene = common::write(
        &d,
        "s.json",
        r#"{ "meshes": [ { "file": "m.obj" }, { "file": "m.obj" } ], "spheres": [ { "center": [0, 0, -5], "radius": 1 } ] }"#,
    );
    let sc = rtdiff::scene::Scene::load(&scene).unwrap();
    assert_eq!(sc.prims.len(), 7);
    let origins: Vec<String> = [0, 2, 3, 5, 6].iter().map(|&p| sc.primitive_origin(p)).collect();
    assert_eq!(
        origins,
        ["meshes[0] triangle 0", "meshes[0] triangle 2", "meshes[1] triangle 0", "meshes[1] triangle 2", "sphere 0"]
    );
    let wrong = common::write(&d, "w.csv", "hit,t,prim,u,v\n1,1,0,0.5,0.25\n1,1,2,0.25,0.5\n");
    let (code, out, _) = rtdiff(&["judge", s(&obj), "--rays", s(&rays), "--hits", s(&wrong), "--reference", "brute"]);
    assert_eq!(code, 2, "{out}");
}

/// `bench --race --tracer plugin:PATH` races a third-party plugin against Embree and rtdiff in one
/// run: the plugin's contests on every workload in the JSON, its table against Embree's MEDIUM
/// modes and rtdiff in the text; `--tracer` takes plugins only and applies to the race only.
#[cfg(feature = "embree")]
#[test]
fn the_race_runs_a_plugin_against_embree_and_rtdiff() {
    let d = common::temp_dir("race-plugin");
    let json = d.join("race.json");
    let tracer = format!("plugin:{}", s(&third_party("tinybvh")));
    let (code, out, err) = rtdiff(&[
        "bench",
        "--race",
        "1",
        "--threads",
        "1",
        "--size",
        "64",
        "--incoherent",
        "4096",
        "--tracer",
        &tracer,
        "--json",
        s(&json),
        s(&suzanne()),
    ]);
    assert_eq!(code, 0, "{err}");
    let report: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let contests = report["meshes"][0]["contests"].as_array().unwrap();
    let label = "plugin:tinybvh 1.6.8";
    for set in ["build", "camera", "incoherent", "shadow", "batch camera", "batch shadow"] {
        let c = contests.iter().find(|c| c["name"] == set && c["opponent"] == label);
        let c = c.unwrap_or_else(|| panic!("no {set} contest against {label}"));
        let times = c["times"].as_array().unwrap();
        assert!(!times.is_empty() && times.iter().all(|t| t[1].as_f64().unwrap() > 0.0), "{set}: {times:?}");
        if set != "build" {
            assert!(c["opponent_hits"].as_u64().unwrap() > 0, "{set}: the plugin found no hit");
        }
    }
    assert!(out.contains(&format!("{label} against Embree and rtdiff")), "{out}");
    let row = out.lines().find(|l| l.trim_start().starts_with("1 camera") && l.contains("ns/ray") && l.contains('['));
    assert!(row.is_some(), "no camera row in the plugin's table:\n{out}");
    // Embree's goals stay Embree's: no goal line names the plugin.
    let goals = out.split("## Goals").nth(1).unwrap();
    assert!(!goals.contains(label), "{goals}");
    for args in [
        vec!["bench", "--race", "1", "--tracer", "embree", s(&suzanne())],
        vec!["bench", "--tracer", &tracer, s(&suzanne())],
    ] {
        let (code, _, err) = rtdiff(&args);
        assert_eq!(code, 1, "{args:?}: {err}");
        assert!(err.contains("--tracer") && !err.contains("panicked"), "{args:?}: {err}");
    }
}

/// A campaign plan names plugins as tracers (`plugin:PATH`, relative to the plan's folder): the
/// merged report has each plugin's verdicts, and the C plugin whose distances are scaled by
/// 1 + 1e-4 is wrong by distance (the arbiter's exact hit decides), the correct one is not.
#[test]
fn a_campaign_runs_plugins_named_in_its_plan() {
    let d = common::temp_dir("campaign-plugins");
    std::fs::create_dir_all(d.join("meshes")).unwrap();
    std::fs::copy(suzanne(), d.join("meshes/suzanne.obj")).unwrap();
    std::fs::copy(c_plugin(Some("T")), d.join("brute_t.so")).unwrap();
    std::fs::copy(c_plugin(None), d.join("brute_ok.so")).unwrap();
    let plan = r#"
name = "plugins"
meshes = ["meshes"]
tracers = ["rtdiff", "plugin:brute_ok.so", "plugin:brute_t.so"]
reference = "brute"
reports = ["parity"]

[rays]
sets = ["primary", "edges"]
count = 400
seed = 3
"#;
    common::write(&d, "plan.toml", plan);
    let (code, _, err) = rtdiff(&["campaign", s(&d.join("plan.toml")), "-o", s(&d.join("out")), "--quiet"]);
    assert_eq!(code, 0, "{err}");
    let (code, _, err) = rtdiff(&["campaign", "merge", s(&d.join("out")), "-o", s(&d.join("report"))]);
    assert_eq!(code, 0, "{err}");
    let c: rtdiff::campaign::Campaign =
        serde_json::from_slice(&std::fs::read(d.join("report/campaign.json")).unwrap()).unwrap();
    let mut seen = std::collections::BTreeMap::new();
    for r in &c.results {
        for set in &r.parity {
            for t in &set.tracers {
                let e = seen.entry(t.tracer.clone()).or_insert((0u64, 0u64));
                e.0 += t.wrong;
                e.1 += t.wrong_by.get("distance").copied().unwrap_or(0);
            }
        }
    }
    let broken: Vec<_> = seen.iter().filter(|&(_, &(w, _))| w > 0).collect();
    assert_eq!(broken.len(), 1, "exactly the broken plugin is wrong: {seen:?}");
    let (name, &(wrong, distance)) = broken[0];
    assert!(name.starts_with("plugin:") && wrong > 100 && distance == wrong, "{seen:?}");
    assert_eq!(seen.len(), 3, "{seen:?}");
    let md = std::fs::read_to_string(d.join("report/campaign.md")).unwrap();
    assert!(md.contains(&format!("{name}: ")) && md.contains("wrong (distance"), "{md}");
}
