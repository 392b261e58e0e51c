//! Campaigns (`rtdiff campaign`): a plan killed with SIGKILL at random moments (20 times)
//! and resumed, and the same plan run as 4 shards in any order (one killed and restarted
//! twice), merge into the same report, byte for byte, as the plan run once without
//! interruption (timings left out); listing is stable when the files move; merging refuses
//! mixed plans and versions and lists missing items.

#![cfg(unix)]

mod common;

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

const PLAN: &str = r#"
name = "kill-test"
meshes = ["meshes"]
tracers = ["rtdiff", "rtdiff:median/basic"]
reference = "REFERENCE"
reports = ["parity", "speed"]

[rays]
sets = ["primary", "shadow", "edges", "vertices"]
count = 3000
seed = 5

[speed]
size = 16
incoherent = 512
runs = 1
"#;

/// The plan with the reference this build has: Embree when built with it, else brute force.
fn plan() -> String {
    PLAN.replace("REFERENCE", if cfg!(feature = "embree") { "embree" } else { "brute" })
}

/// A folder with the plan and a copy of the authored meshes, plus one file that does not load.
fn campaign_dir(name: &str) -> PathBuf {
    let d = common::temp_dir(name);
    let meshes = d.join("meshes");
    std::fs::create_dir_all(&meshes).unwrap();
    for e in std::fs::read_dir(common::root().join("scenes/meshes")).unwrap().flatten() {
        std::fs::copy(e.path(), meshes.join(e.file_name())).unwrap();
    }
    common::write(&meshes, "broken.stl", "solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 q\nendsolid x\n");
    common::write(&d, "plan.toml", &plan());
    d
}

fn rtdiff(dir: &Path) -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_rtdiff"));
    c.current_dir(dir);
    c
}

fn run_ok(dir: &Path, args: &[&str]) -> String {
    common::run(rtdiff(dir).args(args))
}

/// The merged report of `folders` without timings: (campaign.json, campaign.md, index.html).
fn merged(dir: &Path, folders: &[&str], report: &str) -> [Vec<u8>; 3] {
    let mut args = vec!["campaign", "merge"];
    args.extend(folders);
    args.extend(["-o", report, "--no-timings", "--require-complete"]);
    run_ok(dir, &args);
    ["campaign.json", "campaign.md", "index.html"].map(|f| std::fs::read(dir.join(report).join(f)).unwrap())
}

fn results_in(out: &Path) -> usize {
    std::fs::read_dir(out.join("items")).map_or(0, |d| {
        d.flatten()
            .filter(|e| e.file_name().to_str().is_some_and(|n| n.ends_with(".json") && !n.starts_with('.')))
            .count()
    })
}

/// Start a run of `args` and kill it (SIGKILL) after `after`; every result file left must parse.
fn kill_after(dir: &Path, args: &[&str], out: &Path, after: Duration) {
    let mut child = rtdiff(dir).args(args).stdout(Stdio::null()).stderr(Stdio::null()).spawn().unwrap();
    std::thread::sleep(after);
    let _ = child.kill();
    let _ = child.wait();
    for e in std::fs::read_dir(out.join("items")).into_iter().flatten().flatten() {
        let name = e.file_name().to_string_lossy().into_owned();
        if name.ends_with(".json") && !name.starts_with('.') {
            let text = std::fs::read_to_string(e.path()).unwrap();
            serde_json::from_str::<rtdiff::campaign::ItemResult>(&text)
                .unwrap_or_else(|err| panic!("{name} is not a whole result after a kill: {err}"));
        }
    }
}

fn assert_same(a: &[Vec<u8>; 3], b: &[Vec<u8>; 3], what: &str) {
    for (k, name) in ["campaign.json", "campaign.md", "index.html"].iter().enumerate() {
        assert!(a[k] == b[k], "{what}: {name} differs from the uninterrupted run's");
    }
}

#[test]
fn killed_twenty_times_and_sharded_four_ways_it_merges_like_one_uninterrupted_run() {
    let d = campaign_dir("campaign-kill");
    let items: usize = run_ok(&d, &["campaign", "plan.toml", "--list"]).lines().filter(|l| !l.starts_with('#')).count();
    // Every mesh file of scenes/meshes and the broken one, each with 4 parity sets and speed.
    let inputs = std::fs::read_dir(d.join("meshes"))
        .unwrap()
        .flatten()
        .filter(|e| rtdiff::mesh::is_mesh_file(&e.path()))
        .count();
    assert!(inputs >= 10, "the authored meshes and broken.stl ({inputs})");
    assert_eq!(items, inputs * 5, "{inputs} inputs x (4 parity sets + speed)");

    // One uninterrupted run.
    let t0 = Instant::now();
    run_ok(&d, &["campaign", "plan.toml", "-o", "whole", "--quiet"]);
    let whole_time = t0.elapsed();
    let reference = merged(&d, &["whole"], "report-whole");
    let md = String::from_utf8_lossy(&reference[1]).into_owned();
    assert!(md.contains("| meshes/broken.stl | stl | - | error |"), "{md}");
    assert!(md.contains("broken.stl:4: facet 1: 'q' is not a number"), "{md}");
    assert!(md.contains("| meshes/icosphere.obj | obj | 1280 | ok |"), "{md}");

    // Killed at random moments 20 times, then finished.
    let out = d.join("killed");
    let mut rng = rtdiff::rng::Pcg32::new(2026, 50);
    // The start-up (plan, tracer check, every item skipped): kills land after it, within a
    // sixth of the work, so that most stop the run midway, many after finished items.
    let t0 = Instant::now();
    run_ok(&d, &["campaign", "plan.toml", "-o", "whole", "--quiet"]);
    let startup = t0.elapsed().as_secs_f64();
    let window = ((whole_time.as_secs_f64() - startup) / 6.0).max(0.01);
    let mut interrupted = 0;
    let mut progressed = 0;
    for _ in 0..20 {
        let before = results_in(&out);
        kill_after(
            &d,
            &["campaign", "plan.toml", "-o", "killed", "--quiet"],
            &out,
            Duration::from_secs_f64(startup + window * rng.next_f32() as f64),
        );
        let after = results_in(&out);
        assert!(after >= before, "a kill lost results ({before} -> {after})");
        progressed += usize::from(after > before);
        interrupted += usize::from(after < items);
    }
    eprintln!(
        "uninterrupted run {:.2} s (start-up {startup:.2} s); {interrupted} of 20 kills stopped the campaign before its end, {progressed} after \
         it had finished items",
        whole_time.as_secs_f64()
    );
    assert!(interrupted >= 10, "only {interrupted} of the 20 kills stopped the campaign before its end");
    assert!(progressed >= 3, "only {progressed} of the 20 kills came after the run had finished items");
    run_ok(&d, &["campaign", "plan.toml", "-o", "killed", "--quiet"]);
    assert_same(&merged(&d, &["killed"], "report-killed"), &reference, "killed and resumed");
    let leftovers: Vec<String> = std::fs::read_dir(out.join("items"))
        .unwrap()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with('.'))
        .collect();
    assert!(leftovers.is_empty(), "temporary files of killed runs left after the resume: {leftovers:?}");

    // Four shards, run in the order 3, 1, 4, 2; shard 2 killed twice and restarted.
    for k in [3, 1, 4] {
        run_ok(&d, &["campaign", "plan.toml", "--shard", &format!("{k}/4"), "-o", &format!("shard{k}"), "--quiet"]);
    }
    let s2 = ["campaign", "plan.toml", "--shard", "2/4", "-o", "shard2", "--quiet"];
    for _ in 0..2 {
        // A quarter of the items: a quarter of the window.
        let at = startup + window / 4.0 * rng.next_f32() as f64;
        kill_after(&d, &s2, &d.join("shard2"), Duration::from_secs_f64(at));
    }
    let partial = merged_partial(&d);
    let done: usize = (1..=4).map(|k| results_in(&d.join(format!("shard{k}")))).sum();
    assert_eq!(partial.contains("Missing items"), done < items, "the report lists missing items when there are");
    run_ok(&d, &s2);
    let sharded = merged(&d, &["shard4", "shard2", "shard1", "shard3"], "report-sharded");
    assert_same(&sharded, &reference, "four shards");
}

/// Merge the four shard folders while shard 2 is unfinished: the Markdown.
fn merged_partial(d: &Path) -> String {
    let out = rtdiff(d)
        .args(["campaign", "merge", "shard1", "shard2", "shard3", "shard4", "-o", "report-partial", "--no-timings"])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let failing = rtdiff(d)
        .args(["campaign", "merge", "shard1", "-o", "report-partial2", "--require-complete"])
        .output()
        .unwrap();
    assert_eq!(failing.status.code(), Some(1), "--require-complete fails with items missing");
    assert!(String::from_utf8_lossy(&failing.stderr).contains("missing "));
    std::fs::read_to_string(d.join("report-partial/campaign.md")).unwrap()
}

#[test]
fn the_item_list_does_not_depend_on_where_the_files_are() {
    let a = campaign_dir("campaign-list-a");
    let b = campaign_dir("campaign-list-b");
    let list = |d: &Path, shard: &str| {
        let out = run_ok(d, &["campaign", "plan.toml", "--list", "--shard", shard]);
        out.lines().filter(|l| !l.starts_with("# plan")).map(str::to_string).collect::<Vec<_>>()
    };
    assert_eq!(list(&a, "1/1"), list(&b, "1/1"));
    // The shards partition the items.
    let mut all: Vec<String> =
        (1..=3).flat_map(|k| list(&a, &format!("{k}/3"))).filter(|l| !l.starts_with('#')).collect();
    all.iter_mut().for_each(|l| *l = l.split('\t').next().unwrap().to_string());
    all.sort();
    let mut whole: Vec<String> = list(&a, "1/1")
        .into_iter()
        .filter(|l| !l.starts_with('#'))
        .map(|l| l.split('\t').next().unwrap().into())
        .collect();
    whole.sort();
    assert_eq!(all, whole);
}

#[test]
fn mixed_plans_and_versions_are_refused_and_bad_plans_named() {
    let d = campaign_dir("campaign-mixed");
    let small = plan()
        .replace("count = 3000", "count = 50")
        .replace("reports = [\"parity\", \"speed\"]", "reports = [\"parity\"]");
    common::write(&d, "small.toml", &small);
    common::write(&d, "other.toml", &small.replace("seed = 5", "seed = 6"));
    run_ok(&d, &["campaign", "small.toml", "-o", "a", "--quiet"]);
    run_ok(&d, &["campaign", "other.toml", "-o", "b", "--quiet"]);
    let fail = |args: &[&str]| {
        let out = rtdiff(&d).args(args).output().unwrap();
        assert_eq!(out.status.code(), Some(1), "{args:?}");
        String::from_utf8_lossy(&out.stderr).into_owned()
    };
    let e = fail(&["campaign", "merge", "a", "b", "-o", "r"]);
    assert!(e.contains("shards of different plans") && e.contains("a holds") && e.contains("and b"), "{e}");
    // A folder of one plan refuses another plan's run.
    let e = fail(&["campaign", "other.toml", "-o", "a", "--quiet"]);
    assert!(e.contains("holds results of another plan"), "{e}");
    // Another rtdiff version's shard.
    std::fs::create_dir_all(d.join("c/items")).unwrap();
    let m = std::fs::read_to_string(d.join("a/campaign.json")).unwrap();
    let v = format!("\"rtdiff\": \"{}\"", env!("CARGO_PKG_VERSION"));
    assert!(m.contains(&v));
    std::fs::write(d.join("c/campaign.json"), m.replace(&v, "\"rtdiff\": \"0.0.1\"")).unwrap();
    let e = fail(&["campaign", "merge", "a", "c", "-o", "r"]);
    assert!(e.contains("rtdiff 0.0.1") && e.contains("different versions"), "{e}");
    // Plans: unknown fields with their line, bad tracers, nothing to run.
    common::write(&d, "typo.toml", "meshes = [\"meshes\"]\n\n[rays]\ncuont = 5\n");
    let e = fail(&["campaign", "typo.toml", "--list"]);
    assert!(e.contains("typo.toml:4:") && e.contains("cuont"), "{e}");
    common::write(&d, "tracer.toml", "meshes = [\"meshes\"]\ntracers = [\"optix\"]\n");
    assert!(fail(&["campaign", "tracer.toml", "--list"]).contains("tracer 'optix'"));
    common::write(&d, "empty.toml", "meshes = [\"meshes/*.fbx\"]\n");
    assert!(fail(&["campaign", "empty.toml", "--list"]).contains("no inputs"));
    assert!(fail(&["campaign", "small.toml"]).contains("-o OUT"));
}
