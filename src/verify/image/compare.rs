//! The whole comparison of two image files, as `rtdiff compare` prints it:
//! pixel metrics, LDR-FLIP and HDR-FLIP in one typed, serialisable report.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::film::Image;
use crate::film::io::{check_same_size, read_image};
use crate::verify::image::flip::{DEFAULT_PIXELS_PER_DEGREE, Flip, FlipMode, flip};
use crate::verify::image::metrics::{CompareOptions, Metrics, compare};

/// Metrics and FLIP of one reference/test pair.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CompareReport {
    /// Reference file.
    pub reference: PathBuf,
    /// Test file.
    pub test: PathBuf,
    /// Pixel metrics.
    pub metrics: Metrics,
    /// LDR-FLIP (error map not serialised).
    pub flip_ldr: Flip,
    /// HDR-FLIP (error map not serialised).
    pub flip_hdr: Flip,
}

/// Names accepted by [`CompareReport::metric`] (and `--fail-above`).
pub const METRIC_NAMES: &[&str] = &[
    "mae",
    "rmse",
    "relmse",
    "max_error",
    "over_threshold_fraction",
    "over_rel_threshold_fraction",
    "max_rel_error",
    "flip",
    "flip_hdr",
];

impl CompareReport {
    /// A metric by name (see [`METRIC_NAMES`]); `flip` is the LDR-FLIP mean.
    pub fn metric(&self, name: &str) -> Option<f64> {
        let m = &self.metrics;
        Some(match name {
            "mae" => m.mae,
            "rmse" => m.rmse,
            "relmse" => m.rel_mse,
            "max_error" => m.max_error,
            "over_threshold_fraction" => m.over_threshold_fraction,
            "over_rel_threshold_fraction" => m.over_rel_threshold_fraction,
            "max_rel_error" => m.max_rel_error,
            "flip" => self.flip_ldr.mean,
            "flip_hdr" => self.flip_hdr.mean,
            _ => return None,
        })
    }
}

/// Read a reference and a test image (EXR or PNG), failing with the file's
/// name on unreadable files, missing channels or NaN/Inf pixels, and on
/// mismatched sizes.
pub fn load_pair(reference: &Path, test: &Path) -> Result<(Image, Image)> {
    let r = read_image(reference)?;
    let t = read_image(test)?;
    check_same_size(&r, reference, &t, test)?;
    Ok((r, t))
}

/// Metrics, LDR-FLIP and HDR-FLIP of two loaded images (paths only label the report).
pub fn compare_images(
    reference: &Image,
    test: &Image,
    paths: (&Path, &Path),
    opts: &CompareOptions,
) -> Result<CompareReport> {
    let metrics = compare(reference, test, opts)?;
    let (flip_ldr, flip_hdr) = rayon::join(
        || flip(reference, test, FlipMode::Ldr, DEFAULT_PIXELS_PER_DEGREE),
        || flip(reference, test, FlipMode::Hdr, DEFAULT_PIXELS_PER_DEGREE),
    );
    Ok(CompareReport {
        reference: paths.0.to_path_buf(),
        test: paths.1.to_path_buf(),
        metrics,
        flip_ldr: flip_ldr?,
        flip_hdr: flip_hdr?,
    })
}

/// [`load_pair`] then [`compare_images`].
pub fn compare_files(reference: &Path, test: &Path, opts: &CompareOptions) -> Result<CompareReport> {
    let (r, t) = load_pair(reference, test)?;
    compare_images(&r, &t, (reference, test), opts)
}

/// Parse a `METRIC=VALUE` gate (`--fail-above`).
pub fn parse_gate(s: &str) -> Result<(String, f64)> {
    let bad = || Error::Invalid(format!("'{s}': expected METRIC=VALUE with METRIC one of {}", METRIC_NAMES.join(", ")));
    let (name, value) = s.split_once('=').ok_or_else(bad)?;
    let value: f64 = value.trim().parse().map_err(|_| bad())?;
    if !METRIC_NAMES.contains(&name.trim()) || !value.is_finite() {
        return Err(bad());
    }
    Ok((name.trim().to_string(), value))
}

/// The gates a report exceeds, as "metric = value > limit" lines.
pub fn failed_gates(report: &CompareReport, gates: &[(String, f64)]) -> Vec<String> {
    gates
        .iter()
        .filter_map(|(name, limit)| {
            let v = report.metric(name)?;
            (v > *limit).then(|| format!("{name} = {v:.6e} > {limit:e}"))
        })
        .collect()
}
