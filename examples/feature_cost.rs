//! What does switching on every feature cost on a scene that uses none of them?
//!
//! Renders each scene twice per round, alternating: once with only the switches
//! the scene needs (shading, hard shadows, BVH), once with all thirteen on, and
//! prints the median render times and their ratio (the render plan should make
//! the ratio ~1). Post-processing (bloom) is excluded: it always applies.
//!
//! `cargo run --release --example feature_cost [-- ROUNDS]`

use std::path::Path;

use rtdiff::backends;
use rtdiff::features::FEATURE_NAMES;
use rtdiff::render::{RenderOptions, render};
use rtdiff::scene::{Overrides, Scene};

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() -> rtdiff::Result<()> {
    let rounds: usize = std::env::args().nth(1).and_then(|a| a.parse().ok()).unwrap_or(9);
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    println!("| scene | minimal ms | all features ms | ratio |\n|---|---:|---:|---:|");
    for name in ["single_triangle", "spheres"] {
        let path = root.join("scenes").join(format!("{name}.json"));
        let needed = ["shading", "hard_shadows", "bvh", "sah"];
        let minimal = FEATURE_NAMES.iter().map(|n| (n.to_string(), needed.contains(n))).collect();
        let all = FEATURE_NAMES.iter().map(|n| (n.to_string(), true)).collect();
        let scenes = [
            Scene::load_with(&path, &Overrides { features: minimal, ..Default::default() })?,
            Scene::load_with(&path, &Overrides { features: all, ..Default::default() })?,
        ];
        let tracers = scenes
            .iter()
            .map(|s| backends::build_tracer(s.prims.clone(), &s.accel))
            .collect::<rtdiff::Result<Vec<_>>>()?;
        let mut times = [Vec::new(), Vec::new()];
        for _ in 0..rounds {
            for i in 0..2 {
                let r = render(&scenes[i], tracers[i].as_ref(), &RenderOptions { threads: Some(1), quiet: true })?;
                times[i].push(r.seconds * 1e3);
            }
        }
        let [a, b] = times.map(median);
        println!("| {name} | {a:.1} | {b:.1} | {:.3} |", b / a);
    }
    Ok(())
}
