//! The mesh corpus campaign (`scenes/campaigns/corpus.toml`: every mesh the asset script
//! brings from Debian, npm, PyPI and crates.io, and the project's own) in CI as one small
//! shard, 16/16 (about 180 of its 1,960 items, 20 s here): every item runs; a mesh that does
//! not load says why, naming its file; rtdiff's default tracer holds parity with Embree (the
//! exact arbiter finds it wrong on no ray, no leak); and the triangle counts and load results
//! agree with the full run's report in docs/corpus-report.md.

#![cfg(feature = "embree")]

mod common;

use std::process::Command;

use rtdiff::campaign::Campaign;

#[test]
fn the_corpus_ci_shard_runs_and_rtdiff_holds_parity_with_embree() {
    let root = common::root();
    for d in ["assets/assimp/glTF2", "assets/corpus/npm-stl-models"] {
        assert!(root.join(d).is_dir(), "{d} is missing: run scripts/fetch-assets.sh");
    }
    let dir = common::temp_dir("corpus-shard");
    let plan = root.join("scenes/campaigns/corpus.toml");
    let list = common::run(
        Command::new(env!("CARGO_BIN_EXE_rtdiff")).arg("campaign").arg(&plan).args(["--list", "--shard", "16/16"]),
    );
    let shard_items = list.lines().filter(|l| !l.starts_with('#')).count();
    assert!(shard_items > 100, "{shard_items} items");
    let out = dir.join("shard");
    common::run(
        Command::new(env!("CARGO_BIN_EXE_rtdiff"))
            .arg("campaign")
            .arg(&plan)
            .args(["--shard", "16/16", "--quiet", "-o"])
            .arg(&out),
    );
    let report = dir.join("report");
    common::run(
        Command::new(env!("CARGO_BIN_EXE_rtdiff")).args(["campaign", "merge"]).arg(&out).arg("-o").arg(&report),
    );
    let c: Campaign = serde_json::from_slice(&std::fs::read(report.join("campaign.json")).unwrap()).unwrap();
    assert_eq!(c.results.len(), shard_items);
    assert_eq!(c.results.len() + c.missing.len(), c.manifest.items.len());

    let docs = std::fs::read_to_string(root.join("docs/corpus-report.md")).unwrap();
    let mut loaded = 0;
    for r in &c.results {
        let input = &r.item.input;
        assert_eq!(r.error, None, "{}: failed after loading", r.item.id);
        match &r.load.error {
            Some(e) => assert!(e.starts_with(input.as_str()), "{input}: the error names the file: {e}"),
            None => loaded += 1,
        }
        // The full run's row: | input | format | triangles | load | ...
        let row = docs
            .lines()
            .find(|l| l.starts_with(&format!("| {input} |")))
            .unwrap_or_else(|| panic!("{input} is not in docs/corpus-report.md"));
        let cells: Vec<&str> = row.split('|').map(str::trim).collect();
        let triangles = if r.load.ok { r.load.triangles.to_string() } else { "-".into() };
        let load = if r.load.ok { "ok" } else { "error" };
        assert_eq!((cells[3], cells[4]), (triangles.as_str(), load), "{input}: docs/corpus-report.md is out of date");
        for s in &r.parity {
            for t in &s.tracers {
                let at = format!("{input}, set {}, {}", s.set, t.tracer);
                assert_eq!(t.leaks, 0, "{at}");
                assert_eq!(t.wrong, 0, "{at}: the arbiter finds rtdiff wrong ({:?}): {:#?}", t.wrong_by, t.disputes);
            }
        }
    }
    assert!(loaded > 50, "only {loaded} items loaded their input");
}
