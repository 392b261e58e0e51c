//! Output files are written whole or not at all (`rtdiff::output`): a render
//! killed with SIGKILL while it writes its image leaves the previous image
//! readable (issue 50: a 1600x1600 `render -o out.exr` over an existing
//! `out.exr`, killed at random moments, left an unreadable file in 2 of 20
//! tries); and no subcommand panics when its standard output is closed.

#![cfg(unix)]

mod common;

use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// The kills land while the file is being written: the folder is watched and the
/// process killed as soon as anything in it changes (a temporary file appears, or
/// the image itself changes length or time), after a further 0 to 8 ms.
#[test]
fn a_render_killed_while_writing_its_image_leaves_the_old_one_readable() {
    let d = common::temp_dir("atomic-render");
    let scene = common::root().join("scenes/cornell_box.json");
    let out = d.join("out.exr");
    let args = |out: &Path| {
        let mut c = Command::new(env!("CARGO_BIN_EXE_rtdiff"));
        c.args(["render", scene.to_str().unwrap(), "-o", out.to_str().unwrap()])
            .args(["--width", "800", "--height", "800", "--quiet"]);
        c
    };
    common::run(&mut args(&out));
    let before = std::fs::read(&out).unwrap();
    let snapshot = |dir: &Path| -> Vec<(String, u64, std::time::SystemTime)> {
        let mut v: Vec<_> = std::fs::read_dir(dir)
            .unwrap()
            .flatten()
            .filter_map(|e| {
                let m = e.metadata().ok()?;
                Some((e.file_name().to_string_lossy().into_owned(), m.len(), m.modified().ok()?))
            })
            .collect();
        v.sort();
        v
    };
    let mut caught_writing = 0;
    for k in 0..10u64 {
        let start = snapshot(&d);
        let mut child = args(&out).stdout(Stdio::null()).stderr(Stdio::null()).spawn().unwrap();
        let deadline = Instant::now() + Duration::from_secs(120);
        loop {
            if snapshot(&d) != start {
                std::thread::sleep(Duration::from_micros(k * 800));
                caught_writing += 1;
                break;
            }
            if child.try_wait().unwrap().is_some() || Instant::now() > deadline {
                break;
            }
            std::thread::sleep(Duration::from_micros(200));
        }
        let _ = child.kill();
        let _ = child.wait();
        let now = std::fs::read(&out).unwrap_or_default();
        // The same scene renders the same bytes: old or new, the file is whole.
        assert!(now == before, "try {k}: out.exr is {} bytes, not the whole image's {}", now.len(), before.len());
        rtdiff::film::io::read_image(&out).unwrap_or_else(|e| panic!("try {k}: {e}"));
    }
    assert!(caught_writing >= 5, "only {caught_writing} of 10 kills landed while the image was written");
    // What the kills left behind is only hidden temporary files, which a later cleanup removes.
    let removed = rtdiff::output::remove_stale_temps(&d).unwrap();
    let names: Vec<String> = snapshot(&d).into_iter().map(|(n, _, _)| n).collect();
    assert_eq!(names, ["out.exr"], "after removing {removed} stale temporary files");
}

/// `rtdiff SUBCOMMAND ... | head`: every subcommand with its standard output gone before
/// it prints (it used to panic: `failed printing to stdout: Broken pipe`): no panic; the
/// process ends quietly (SIGPIPE, as any Unix filter) or exits 0.
#[test]
fn no_subcommand_panics_on_a_closed_stdout() {
    use std::os::unix::process::ExitStatusExt;
    let d = common::temp_dir("atomic-pipe");
    let scene = common::root().join("scenes/cornell_box.json");
    let scene = scene.to_str().unwrap();
    let png = d.join("c.png");
    let png_s = png.to_str().unwrap();
    common::run(
        Command::new(env!("CARGO_BIN_EXE_rtdiff"))
            .args(["render", scene, "-o", png_s, "--width", "16", "--height", "16", "--quiet"]),
    );
    let rays = common::write(&d, "rays.csv", "0,0,-5,0,0,1,0,100\n");
    let meshes = common::root().join("scenes/meshes");
    let plan = common::write(
        &d,
        "plan.toml",
        &format!("meshes = [{:?}]\nreports = [\"parity\"]\n", meshes.display().to_string()),
    );
    let plan = plan.to_str().unwrap();
    let hits = d.join("hits.csv");
    let export = d.join("export");
    let cases: Vec<Vec<&str>> = vec![
        vec!["render", scene, "-o", png_s, "--width", "16", "--height", "16"],
        vec!["trace", scene, "--rays", rays.to_str().unwrap(), "--out", hits.to_str().unwrap()],
        vec!["compare", png_s, png_s],
        vec!["compare", png_s, png_s, "--json"],
        vec!["bvh-stats", scene],
        vec!["bvh-stats", scene, "--json"],
        vec!["parity", scene, "--count", "100", "--default-only", "--reference", "brute"],
        vec!["parity", scene, "--count", "100", "--default-only", "--reference", "brute", "--json"],
        vec!["bench", scene, "--size", "8", "--runs", "1", "--incoherent", "64"],
        vec!["debug", scene, "--pixel", "8", "8"],
        vec!["debug", scene, "--pixel", "8", "8", "--json"],
        vec!["export", scene, "-o", export.to_str().unwrap()],
        vec!["render", "--help"],
        vec!["--version"],
        vec!["report", "--help"],
        vec!["campaign", plan, "--list"],
    ];
    for args in cases {
        // Both outputs closed: what a command prints to stderr (a summary, a
        // warning) must not panic either.
        for close_stderr in [false, true] {
            let mut child = Command::new(env!("CARGO_BIN_EXE_rtdiff"))
                .args(&args)
                .stdout(Stdio::piped())
                .stderr(Stdio::piped())
                .spawn()
                .expect("spawn");
            drop(child.stdout.take());
            let mut stderr = child.stderr.take();
            if close_stderr {
                stderr = None;
            }
            let err = stderr.map(|mut s| {
                let mut t = String::new();
                std::io::Read::read_to_string(&mut s, &mut t).unwrap();
                t
            });
            let status = child.wait().unwrap();
            let err = err.unwrap_or_default();
            assert!(!err.contains("panicked"), "{args:?}: {err}");
            let quiet = status.signal() == Some(libc::SIGPIPE) || status.code() == Some(0);
            assert!(quiet, "{args:?} (stderr closed: {close_stderr}): {status:?} {err}");
        }
    }
}
