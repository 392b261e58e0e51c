//! `rtdiff trace` and `rtdiff parity` end to end, without Embree: CSV in and
//! out, and clear errors (naming the file and line) with a non-zero exit.

use std::path::{Path, PathBuf};
use std::process::Command;

use rtdiff::rays::file::parse_rays;

fn tmp(name: &str, text: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("rtdiff-trace-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

const QUAD: &str = "v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nf 1 2 3\nf 1 3 4\n";

#[test]
fn parse_errors_name_the_file_and_line() {
    let p = Path::new("rays.csv");
    let e =
        parse_rays(p, "ox,oy,oz,dx,dy,dz,tnear,tfar\n0,0,1,0,0,-1,0,inf\n0,0,1,0,0,-1,0\n").unwrap_err().to_string();
    assert!(e.contains("rays.csv") && e.contains("line 3") && e.contains("expected 8"), "{e}");
    let e = parse_rays(p, "0,0,1,0,0,x,0,1\n").unwrap_err().to_string();
    assert!(e.contains("line 1") && e.contains("value 6"), "{e}");
    let e = parse_rays(p, "# comment\n\n0,0,1,0,0,0,0,1\n").unwrap_err().to_string();
    assert!(e.contains("line 3") && e.contains("direction is zero"), "{e}");
    let e = parse_rays(p, "0,0,1,0,0,1,2,1\n").unwrap_err().to_string();
    assert!(e.contains("tnear"), "{e}");
    let e = parse_rays(p, "0,nan,1,0,0,1,0,1\n").unwrap_err().to_string();
    assert!(e.contains("finite"), "{e}");
    let rays = parse_rays(p, "0,0,1,0,0,-1,0,inf\n 0.5 , 0.5 , 2 , 0 , 0 , -1 , 0 , 10 \n").unwrap();
    assert_eq!(rays.len(), 2);
    assert_eq!(rays[1].t_max, 10.0);
}

#[test]
fn trace_writes_hits_and_bad_input_exits_non_zero() {
    let scene = tmp("quad.obj", QUAD);
    let rays = tmp("rays.csv", "ox,oy,oz,dx,dy,dz,tnear,tfar\n0.25,0.1,2,0,0,-1,0,inf\n3,3,2,0,0,-1,0,inf\n");
    let out = rays.with_file_name("hits.csv");
    let bin = env!("CARGO_BIN_EXE_rtdiff");
    let st =
        Command::new(bin).args(["trace"]).arg(&scene).arg("--rays").arg(&rays).arg("--out").arg(&out).output().unwrap();
    assert!(st.status.success(), "{}", String::from_utf8_lossy(&st.stderr));
    let text = std::fs::read_to_string(&out).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines[0], "hit,t,prim,u,v");
    // The quad in the file's coordinates (z = 0; normalised it would be too).
    assert!(lines[1].starts_with("1,2,"), "{text}");
    assert_eq!(lines[2], "0,,,,");

    let bad = tmp("bad.csv", "0,0,1,0,0,-1,0\n");
    let st =
        Command::new(bin).args(["trace"]).arg(&scene).arg("--rays").arg(&bad).arg("--out").arg(&out).output().unwrap();
    let err = String::from_utf8_lossy(&st.stderr);
    assert_eq!(st.status.code(), Some(1));
    assert!(err.contains("bad.csv") && err.contains("line 1"), "{err}");

    let st = Command::new(bin)
        .args(["trace", "/nonexistent/x.obj", "--rays"])
        .arg(&rays)
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&st.stderr);
    assert_eq!(st.status.code(), Some(1));
    assert!(err.contains("x.obj") && err.contains("not found"), "{err}");
}

#[test]
fn parity_with_brute_reference_runs_without_embree() {
    let scene = tmp("quad2.obj", QUAD);
    let bin = env!("CARGO_BIN_EXE_rtdiff");
    let st = Command::new(bin)
        .args(["parity"])
        .arg(&scene)
        .args(["--rays", "primary", "--count", "500", "--reference", "brute", "--json", "--default-only"])
        .output()
        .unwrap();
    assert!(st.status.success(), "{}", String::from_utf8_lossy(&st.stderr));
    let v: serde_json::Value = serde_json::from_slice(&st.stdout).unwrap();
    let set = &v["sets"][0];
    assert_eq!(set["rays"], 500);
    assert_eq!(set["variants"][0]["native_miss_ref_hit"], 0);
    let st = Command::new(bin).args(["parity", "scene.txt"]).output().unwrap();
    assert_eq!(st.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&st.stderr).contains("scene.txt"));
}
