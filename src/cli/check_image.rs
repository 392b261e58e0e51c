//! `rtdiff check-image SCENE --image THEIR.exr`: another renderer's image of a reference scene
//! checked against `reference/` (deterministic scenes: 99.9% of pixels within 1e-3 and the rest
//! explained by rtdiff's ray tree; noisy scenes: Welch + Benjamini-Hochberg over several
//! renders); exit status 2 when it fails.

use std::path::PathBuf;

use crate::error::Result;
use crate::verify::image::check::{check, manifest, plan};

/// Arguments of `rtdiff check-image`.
#[derive(clap::Args, Debug)]
pub struct CheckImageArgs {
    /// The scene the image is of (a scene of reference/manifest.json); optional with a folder.
    pub scene: Option<PathBuf>,
    /// The renderer's image (EXR, linear; PNG read as sRGB), repeated for the seeds of a noisy
    /// scene; or one folder of images named like reference/ (NAME.MODEL.exr, NAME.MODEL.sK.exr).
    #[arg(long, required = true)]
    pub image: Vec<PathBuf>,
    /// The reference's shading model: phong or physical (default: the manifest's first for the scene).
    #[arg(long)]
    pub model: Option<String>,
    /// The reference folder (with manifest.json).
    #[arg(long, default_value = "reference")]
    pub reference: PathBuf,
    /// Print the verdicts as JSON.
    #[arg(long)]
    pub json: bool,
}

/// Run `rtdiff check-image`.
pub fn run(args: &CheckImageArgs) -> Result<()> {
    let root = std::env::current_dir().map_err(|e| crate::error::Error::Invalid(format!("no current folder: {e}")))?;
    let entries = manifest(&root, &args.reference)?;
    let jobs = plan(&entries, args.scene.as_deref(), &args.image, args.model.as_deref())?;
    let mut results = Vec::new();
    for (entry, images) in &jobs {
        results.push(check(entry, images)?);
    }
    let passed = results.iter().all(|r| r.passed);
    if args.json {
        println!("{}", serde_json::to_string_pretty(&results).unwrap_or_default());
    } else {
        let failed: Vec<&str> = results.iter().filter(|r| !r.passed).map(|r| r.reference.as_str()).collect();
        if passed {
            println!("PASS: {} images agree with reference/", results.len());
        } else {
            println!("FAIL: {} of {} differ from reference/: {}", failed.len(), results.len(), failed.join(", "));
        }
        for r in &results {
            let verdict = if r.passed { "pass" } else { "FAIL" };
            if let Some(e) = &r.exact {
                let classes: Vec<String> = e.classes.iter().map(|(k, n)| format!("{k} {n}")).collect();
                println!(
                    "  {verdict} {}: {:.3}% of pixels within 1e-3 (max rel {:.2e}){}{}",
                    r.reference,
                    100.0 * e.agreeing,
                    e.max_rel,
                    if classes.is_empty() {
                        String::new()
                    } else {
                        format!("; differing pixels: {}", classes.join(", "))
                    },
                    match e.unexplained.first() {
                        Some((x, y, d)) => format!("; first unexplained pixel ({x}, {y}), rel {d:.2e}"),
                        None => String::new(),
                    }
                );
            }
            if let Some(w) = &r.welch {
                println!(
                    "  {verdict} {}: {} of {} pixel tests rejected at q = 0.01 ({} renders vs {} reference seeds), global z {:.2?}",
                    r.reference, w.rejected, w.tests, w.test_count, w.reference_count, w.global_z
                );
            }
        }
    }
    super::exit_on_fail(passed)
}
