//! The shipped scheduler examples (`scripts/campaign/`) run a small plan and merge into the
//! report of one unsharded run: GNU parallel for real (Debian's `parallel`; `scripts/test.sh`
//! installs it and sets `RTDIFF_REQUIRE_PARALLEL=1`, elsewhere the check is skipped with a
//! note when it is missing), the Slurm array script as each array task would run it (the
//! `SLURM_ARRAY_*` variables set by hand: there is no Slurm here), and the GitHub Actions
//! workflow's `rtdiff campaign` commands with the matrix values filled in.

#![cfg(unix)]

mod common;

use std::path::Path;
use std::process::Command;

const PLAN: &str = r#"
name = "schedulers"
meshes = ["meshes"]
tracers = ["rtdiff"]
reference = "REFERENCE"
reports = ["parity"]

[rays]
sets = ["primary", "edges"]
count = 400
seed = 9
"#;

/// The plan with the reference this build has: Embree when built with it, else brute force.
fn plan() -> String {
    PLAN.replace("REFERENCE", if cfg!(feature = "embree") { "embree" } else { "brute" })
}

fn setup(name: &str) -> std::path::PathBuf {
    let d = common::temp_dir(name);
    let meshes = d.join("meshes");
    std::fs::create_dir_all(&meshes).unwrap();
    for m in ["cube.obj", "cube.stl", "cube_textured.glb", "icosphere.obj", "single_triangle.obj"] {
        std::fs::copy(common::root().join("scenes/meshes").join(m), meshes.join(m)).unwrap();
    }
    common::write(&d, "plan.toml", &plan());
    d
}

fn bin() -> &'static str {
    env!("CARGO_BIN_EXE_rtdiff")
}

/// The timing-free report of `folders` (paths relative to `d`), as (json, md, html).
fn report(d: &Path, folders: &[String], out: &str) -> [Vec<u8>; 3] {
    common::run(Command::new(bin()).current_dir(d).args(["campaign", "merge"]).args(folders).args([
        "-o",
        out,
        "--no-timings",
        "--require-complete",
    ]));
    ["campaign.json", "campaign.md", "index.html"].map(|f| std::fs::read(d.join(out).join(f)).unwrap())
}

fn unsharded(d: &Path) -> [Vec<u8>; 3] {
    common::run(Command::new(bin()).current_dir(d).args(["campaign", "plan.toml", "-o", "whole", "--quiet"]));
    report(d, &["whole".into()], "report-whole")
}

fn script(name: &str) -> std::path::PathBuf {
    common::root().join("scripts/campaign").join(name)
}

#[test]
fn gnu_parallel_runs_the_shards_and_merges_them() {
    let have = Command::new("parallel").arg("--version").output().is_ok_and(|o| o.status.success());
    if !have {
        let required = std::env::var("RTDIFF_REQUIRE_PARALLEL").is_ok_and(|v| v == "1");
        assert!(!required, "RTDIFF_REQUIRE_PARALLEL=1 but GNU parallel is not installed (apt-get install parallel)");
        eprintln!("gnu_parallel_runs_the_shards_and_merges_them: skipped, GNU parallel is not installed");
        return;
    }
    let d = setup("sched-parallel");
    let whole = unsharded(&d);
    common::run(Command::new(script("parallel.sh")).current_dir(&d).env("RTDIFF", bin()).args([
        "plan.toml",
        "par",
        "3",
        "2",
    ]));
    let merged =
        ["campaign.json", "campaign.md", "index.html"].map(|f| std::fs::read(d.join("par/report").join(f)).unwrap());
    // The script's own report has timings; the same folders without them equal the unsharded run.
    assert!(!merged[0].is_empty());
    let shards: Vec<String> = (1..=3).map(|k| format!("par/shard-{k}")).collect();
    assert!(report(&d, &shards, "report-par") == whole, "parallel.sh's shards merge differently");
    // Run again: every item is skipped (resume), the report is the same.
    common::run(Command::new(script("parallel.sh")).current_dir(&d).env("RTDIFF", bin()).args([
        "plan.toml",
        "par",
        "3",
        "2",
    ]));
    assert!(report(&d, &shards, "report-par2") == whole);
}

#[test]
fn the_slurm_array_script_runs_each_task_as_slurm_would() {
    let d = setup("sched-slurm");
    let whole = unsharded(&d);
    // An array --array=0-3 (first index 0): tasks 0..3 are shards 1..4.
    for task in [2, 0, 3, 1] {
        common::run(
            Command::new("bash")
                .current_dir(&d)
                .arg(script("slurm-array.sh"))
                .args(["plan.toml", "slurm"])
                .env("RTDIFF", bin())
                .env("SLURM_ARRAY_TASK_ID", task.to_string())
                .env("SLURM_ARRAY_TASK_COUNT", "4")
                .env("SLURM_ARRAY_TASK_MIN", "0")
                .env("SLURM_CPUS_PER_TASK", "1"),
        );
    }
    let shards: Vec<String> = (1..=4).map(|k| format!("slurm/shard-{k}")).collect();
    assert!(report(&d, &shards, "report-slurm") == whole, "the array's shards merge differently");
    // Outside an array it says how to submit it.
    let out =
        Command::new("bash").current_dir(&d).arg(script("slurm-array.sh")).args(["plan.toml", "x"]).output().unwrap();
    assert!(!out.status.success() && String::from_utf8_lossy(&out.stderr).contains("sbatch --array"));
}

/// The workflow's `run:` lines that call rtdiff, with `${{ matrix.shard }}` filled in.
#[test]
fn the_github_actions_matrix_commands_merge_like_one_run() {
    let d = setup("sched-gha");
    let whole = unsharded(&d);
    let yml = std::fs::read_to_string(script("github-actions.yml")).unwrap();
    let commands: Vec<&str> = yml
        .lines()
        .filter_map(|l| l.trim().strip_prefix("- run: "))
        .filter(|l| l.starts_with("$RTDIFF campaign"))
        .collect();
    assert_eq!(commands.len(), 2, "one shard command and one merge command: {commands:?}");
    let matrix = yml.lines().find_map(|l| l.trim().strip_prefix("shard: [")).unwrap();
    let shards = matrix.trim_end_matches(']').split(',').count();
    for k in 1..=shards {
        let c = commands[0].replace("${{ matrix.shard }}", &k.to_string());
        common::run(
            Command::new("bash")
                .current_dir(&d)
                .args(["-euc", &c])
                .env("RTDIFF", bin())
                .env("PLAN", "plan.toml")
                .env("SHARDS", shards.to_string()),
        );
    }
    // The merge job downloads every shard's artifact into out/shard-K.
    common::run(Command::new("bash").current_dir(&d).args(["-euc", commands[1]]).env("RTDIFF", bin()));
    let folders: Vec<String> = (1..=shards).map(|k| format!("out/shard-{k}")).collect();
    assert!(report(&d, &folders, "report-gha") == whole, "the matrix's shards merge differently");
    assert!(d.join("report/index.html").is_file());
}
