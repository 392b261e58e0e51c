//! Links Intel Embree 4 when the `embree` feature is on, and records the
//! compiler's version for the reports.
//!
//! The library comes from `scripts/setup-embree.sh` (into `third_party/embree/lib`).
//! An absolute rpath lets binaries, tests and doctests run without
//! `LD_LIBRARY_PATH`. Without the feature it links nothing.

use std::path::PathBuf;

fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    println!("cargo:rerun-if-env-changed=CARGO_FEATURE_EMBREE");
    // The compiler's version, for the machine facts of `rtdiff report`.
    let rustc = std::env::var("RUSTC").unwrap_or_else(|_| "rustc".into());
    let version = std::process::Command::new(rustc)
        .arg("--version")
        .output()
        .ok()
        .and_then(|o| String::from_utf8(o.stdout).ok())
        .map_or_else(|| "unknown".to_string(), |v| v.trim().to_string());
    println!("cargo:rustc-env=RTDIFF_RUSTC_VERSION={version}");
    if std::env::var_os("CARGO_FEATURE_EMBREE").is_none() {
        return;
    }
    let root = PathBuf::from(std::env::var("CARGO_MANIFEST_DIR").expect("cargo sets CARGO_MANIFEST_DIR"));
    let lib = root.join("third_party").join("embree").join("lib");
    let so = lib.join("libembree4.so");
    println!("cargo:rerun-if-changed={}", so.display());
    if !so.exists() {
        eprintln!(
            "error: the `embree` feature needs Intel Embree 4.4 in {}: run scripts/setup-embree.sh first",
            lib.display()
        );
        panic!("Embree 4 library not found in {}: run scripts/setup-embree.sh first", lib.display());
    }
    println!("cargo:rustc-link-search=native={}", lib.display());
    println!("cargo:rustc-link-lib=dylib=embree4");
    println!("cargo:rustc-link-arg=-Wl,-rpath,{}", lib.display());
}
