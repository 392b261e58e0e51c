//! `rtdiff report all --quick` as CI runs it: every file of the page exists,
//! every link of index.html resolves, and the performance table has the
//! reports' structure and units. Needs the meshes of scripts/fetch-assets.sh.

mod common;

use std::path::Path;
use std::process::Command;

use rtdiff::perf::table::{RowKind, Unit, rows};
use rtdiff::report::html::links;

#[test]
fn perf_rows_follow_the_reports_table() {
    let rows = rows();
    let mut keys: Vec<&str> = rows.iter().map(|r| r.key.as_str()).collect();
    keys.sort();
    keys.dedup();
    assert_eq!(keys.len(), rows.len(), "row keys are unique");
    // The reports' 12 rows, in their order, with their published figures.
    let published: Vec<&str> = rows.iter().filter(|r| r.published.is_some()).map(|r| r.key.as_str()).collect();
    assert_eq!(
        published,
        [
            "triangles",
            "build-median",
            "build-sah-volume",
            "render-median-basic",
            "render-median-priority-queue",
            "render-median-nth-element",
            "render-median-sorted-vector",
            "render-sah-volume-basic",
            "levels-median",
            "levels-sah-volume",
            "max-leaf-median",
            "max-leaf-sah-volume"
        ]
    );
    assert_eq!(rows.iter().position(|r| r.published.is_none()), Some(12), "the reports' rows come first");
    for r in &rows {
        let timed = matches!(r.kind, RowKind::Build { .. } | RowKind::Render { .. });
        assert_eq!(r.unit == Unit::Ms, timed, "{}: unit {:?}", r.key, r.unit);
    }
    // The new rows the issue asks for.
    for k in ["build-sah", "render-sah-fast", "render-sah-fast-1t", "render-embree", "render-brute", "levels-sah"] {
        assert!(keys.contains(&k), "missing row {k}");
    }
}

#[test]
fn report_all_quick_writes_a_page_whose_links_resolve() {
    let dir = common::temp_dir("report-all");
    let out = Command::new(env!("CARGO_BIN_EXE_rtdiff"))
        .args(["report", "all", "--quick", "--quiet", "-o"])
        .arg(&dir)
        .output()
        .unwrap();
    assert!(out.status.success(), "report failed: {}", String::from_utf8_lossy(&out.stderr));
    let html = std::fs::read_to_string(dir.join("index.html")).unwrap();
    let targets: Vec<String> = links(&html).into_iter().filter(|l| !l.starts_with('#')).collect();
    assert!(targets.len() >= 15, "too few links: {targets:?}");
    for t in &targets {
        assert!(!t.contains("://") && !Path::new(t).is_absolute(), "{t}: links stay inside the folder");
        let p = dir.join(t);
        let len = std::fs::metadata(&p).unwrap_or_else(|e| panic!("{t}: {e}")).len();
        assert!(len > 0, "{t} is empty");
        if t.ends_with(".svg") {
            assert!(std::fs::read_to_string(&p).unwrap().contains("<svg"), "{t} is not an SVG");
        }
    }
    for expected in ["perf.svg", "convergence-samples.svg", "stability-leaks-scale.svg", "perf.json", "stability.json"]
    {
        assert!(targets.iter().any(|t| t == expected), "index.html does not show {expected}");
    }
    assert!(targets.iter().filter(|t| t.starts_with("images/")).count() >= 4 * 5, "side-by-side rows missing");
    // Each figure and table has the command that regenerates it.
    let tables = html.matches("</table>").count() - 1; // all but the machine facts
    let plots = targets.iter().filter(|t| t.ends_with(".svg")).count();
    assert!(html.matches("Regenerate: <code>rtdiff report ").count() >= tables + plots);

    // The performance table: three columns, one cell per column, units as declared.
    let perf: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("perf.json")).unwrap()).unwrap();
    let cols = perf["columns"].as_array().unwrap();
    let tris: Vec<u64> = cols.iter().map(|c| c["triangles"].as_u64().unwrap()).collect();
    assert_eq!(&tris[..2], [32, 968]);
    assert!((80_000..95_000).contains(&tris[2]), "the dragon has about 87K triangles: {}", tris[2]);
    for k in ["cpu", "cores", "rustc", "commit", "embree"] {
        assert!(perf["machine"][k].is_string() || perf["machine"][k].is_u64(), "machine fact {k}");
    }
    for row in perf["rows"].as_array().unwrap() {
        let key = row["spec"]["key"].as_str().unwrap();
        let unit = row["spec"]["unit"].as_str().unwrap();
        let cells = row["cells"].as_array().unwrap();
        assert_eq!(cells.len(), 3, "{key}");
        for c in cells {
            let Some(m) = c["measured"].as_object() else {
                assert!(c["note"].is_string(), "{key}: a missing figure says why");
                continue;
            };
            let (med, min, max) =
                (m["median"].as_f64().unwrap(), m["min"].as_f64().unwrap(), m["max"].as_f64().unwrap());
            assert!(min <= med && med <= max, "{key}: {min} {med} {max}");
            match unit {
                "ms" => {
                    assert!(med > 0.0 && m["runs"].as_u64() == Some(3), "{key}: {m:?}");
                    if let (Some(p), Some(s)) = (c["published"].as_f64(), c["speedup"].as_f64()) {
                        assert!((s - p / med).abs() <= 1e-9 * s.abs(), "{key}: speed-up = published / median");
                    }
                }
                "count" => assert!(med >= 1.0 && med.fract() == 0.0 && min == max, "{key}: {m:?}"),
                u => panic!("{key}: unknown unit {u}"),
            }
        }
    }
    let md = std::fs::read_to_string(dir.join("perf.md")).unwrap();
    assert!(md.contains("| Time to render for basic |") && md.contains(" ms ["), "{md}");
}
