//! `rtdiff compare`: two images in, every metric and FLIP out.

use std::path::PathBuf;

use crate::error::{Error, Result};
use crate::verify::image::compare::{compare_images, failed_gates, load_pair, parse_gate};
use crate::verify::image::diff_image::{write_error_png, write_flip_png};
use crate::verify::image::metrics::{CompareOptions, absolute_difference};

/// Arguments of `rtdiff compare`.
#[derive(Clone, Debug, clap::Args)]
pub struct CompareArgs {
    /// Reference image (.exr linear, or .png sRGB).
    pub reference: PathBuf,
    /// Test image (.exr or .png).
    pub test: PathBuf,
    /// Print the report as JSON.
    #[arg(long)]
    pub json: bool,
    /// Write the per-pixel absolute error (max over channels) as a magma PNG.
    #[arg(long, value_name = "D.png")]
    pub diff_image: Option<PathBuf>,
    /// Full scale of the difference image (default: the largest error).
    #[arg(long)]
    pub diff_scale: Option<f32>,
    /// Write the LDR-FLIP error map as a magma PNG.
    #[arg(long, value_name = "F.png")]
    pub flip_image: Option<PathBuf>,
    /// Write the HDR-FLIP error map as a magma PNG.
    #[arg(long, value_name = "F.png")]
    pub flip_hdr_image: Option<PathBuf>,
    /// Absolute threshold for the count of pixels over it.
    #[arg(long, default_value_t = 1e-3)]
    pub threshold: f32,
    /// Relative threshold for the count of pixels over it.
    #[arg(long, default_value_t = 1e-3)]
    pub rel_threshold: f32,
    /// Floor of the relative difference's denominator.
    #[arg(long, default_value_t = 1e-2)]
    pub rel_floor: f32,
    /// Exit non-zero when METRIC exceeds VALUE (repeatable), e.g. `--fail-above rmse=1e-3`.
    #[arg(long, value_name = "METRIC=VALUE")]
    pub fail_above: Vec<String>,
}

/// Run `rtdiff compare`.
pub fn run(args: &CompareArgs) -> Result<()> {
    let gates = args.fail_above.iter().map(|g| parse_gate(g)).collect::<Result<Vec<_>>>()?;
    let opts =
        CompareOptions { threshold: args.threshold, rel_threshold: args.rel_threshold, rel_floor: args.rel_floor };
    let (r, t) = load_pair(&args.reference, &args.test)?;
    let report = compare_images(&r, &t, (&args.reference, &args.test), &opts)?;
    if let Some(p) = &args.diff_image {
        write_error_png(&absolute_difference(&r, &t)?, r.width, r.height, args.diff_scale, p)?;
    }
    if let Some(p) = &args.flip_image {
        write_flip_png(&report.flip_ldr, p)?;
    }
    if let Some(p) = &args.flip_hdr_image {
        write_flip_png(&report.flip_hdr, p)?;
    }
    if args.json {
        println!("{}", serde_json::to_string_pretty(&report).map_err(|e| Error::Invalid(e.to_string()))?);
    } else {
        let m = &report.metrics;
        println!("reference {}  test {}  ({}x{})", args.reference.display(), args.test.display(), m.width, m.height);
        println!("mae        {:.9e}", m.mae);
        println!("rmse       {:.9e}", m.rmse);
        println!("psnr       {:.6} dB", m.psnr);
        println!("relmse     {:.9e}  (eps {})", m.rel_mse, m.rel_mse_epsilon);
        println!(
            "max error  {:.9e} at ({}, {}) channel {}",
            m.max_error, m.max_error_pixel[0], m.max_error_pixel[1], m.max_error_channel
        );
        println!("over {:e} abs  {} pixels ({:.6}%)", m.threshold, m.over_threshold, 100.0 * m.over_threshold_fraction);
        println!(
            "over {:e} rel  {} pixels ({:.6}%), max relative {:.6e} at ({}, {}) (floor {})",
            m.rel_threshold,
            m.over_rel_threshold,
            100.0 * m.over_rel_threshold_fraction,
            m.max_rel_error,
            m.max_rel_error_pixel[0],
            m.max_rel_error_pixel[1],
            m.rel_floor
        );
        println!(
            "flip ldr   {:.6} (max {:.6}, {} ppd)",
            report.flip_ldr.mean, report.flip_ldr.max, report.flip_ldr.pixels_per_degree
        );
        if let Some(e) = report.flip_hdr.exposures {
            println!(
                "flip hdr   {:.6} (max {:.6}, exposures {:.3} to {:.3} in {})",
                report.flip_hdr.mean, report.flip_hdr.max, e.start, e.stop, e.count
            );
        }
    }
    let failed = failed_gates(&report, &gates);
    if !failed.is_empty() {
        return Err(Error::Invalid(format!("compare: above the limit: {}", failed.join("; "))));
    }
    Ok(())
}
