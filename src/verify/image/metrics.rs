//! Pixel metrics between a reference and a test image: MAE, RMSE, relMSE,
//! PSNR, the largest error and its pixel, and how many pixels exceed an
//! absolute or a relative threshold.
//!
//! Definitions (n = width x height pixels, c = 3 channels, d = test - reference,
//! sums over every pixel and channel, accumulated in f64):
//! - MAE = sum |d| / (n c) and RMSE = sqrt(sum d^2 / (n c)): OpenImageIO's
//!   `ImageBufAlgo.compare` `meanerror` and `rms_error`.
//! - PSNR = 20 log10(peak / RMSE) with peak = max(1, largest |sample| of
//!   either image): OpenImageIO's `PSNR` exactly (measured with OIIO 3.2:
//!   20 log10(1 / RMSE) for images within [0, 1], the brightest sample's
//!   magnitude as peak for HDR images); infinite when the images are equal.
//! - relMSE = sum d^2 / (ref^2 + eps) / (n c) with eps = [`REL_MSE_EPSILON`]
//!   (1e-2, the usual choice in the denoising literature, so near-black
//!   pixels do not dominate).
//! - max error = max |d| with its pixel and channel (OIIO's `maxerror`,
//!   `maxx`, `maxy`, `maxc`; the first in row-major order on ties).
//! - over threshold: pixels where any channel has |d| > threshold (OIIO's
//!   `nfail` with `failthresh`).
//! - relative difference of a pixel: max over channels of |d| / max(|ref|, floor);
//!   `floor` keeps it finite on black pixels (where it becomes |d| / floor).

use glam::Vec3;
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::film::Image;

/// The epsilon of relMSE's denominator `ref^2 + eps`.
pub const REL_MSE_EPSILON: f64 = 1e-2;

/// Thresholds for the counted metrics.
#[derive(Clone, Copy, Debug, Serialize, Deserialize)]
pub struct CompareOptions {
    /// Absolute threshold: a pixel is over it when any channel's |test - ref| exceeds it.
    pub threshold: f32,
    /// Relative threshold on [`relative_difference`].
    pub rel_threshold: f32,
    /// Floor of the relative difference's denominator.
    pub rel_floor: f32,
}

impl Default for CompareOptions {
    /// threshold 1e-3, relative threshold 1e-3 (issue 9's agreement criterion),
    /// floor 1e-2 (pixels darker than 1% of white are compared to 1e-5 absolute).
    fn default() -> Self {
        Self { threshold: 1e-3, rel_threshold: 1e-3, rel_floor: 1e-2 }
    }
}

/// Every pixel metric of one image pair (see the module doc for definitions).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Metrics {
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Mean absolute error over pixels and channels.
    pub mae: f64,
    /// Root mean squared error over pixels and channels.
    pub rmse: f64,
    /// 20 log10(peak / RMSE) in dB (infinite, `null` in JSON, when RMSE is 0).
    pub psnr: f64,
    /// PSNR's peak: max(1, largest |sample| of either image).
    pub psnr_peak: f64,
    /// Mean of d^2 / (ref^2 + eps).
    pub rel_mse: f64,
    /// The eps of `rel_mse`.
    pub rel_mse_epsilon: f64,
    /// Largest |test - ref| over pixels and channels.
    pub max_error: f64,
    /// Its pixel (x, y), (0, 0) at the top left.
    pub max_error_pixel: [u32; 2],
    /// Its channel (0 R, 1 G, 2 B).
    pub max_error_channel: u32,
    /// The absolute threshold.
    pub threshold: f64,
    /// Pixels with some channel's |d| above `threshold`.
    pub over_threshold: u64,
    /// `over_threshold` / pixels.
    pub over_threshold_fraction: f64,
    /// The relative threshold.
    pub rel_threshold: f64,
    /// The floor of the relative difference's denominator.
    pub rel_floor: f64,
    /// Pixels whose relative difference exceeds `rel_threshold`.
    pub over_rel_threshold: u64,
    /// `over_rel_threshold` / pixels.
    pub over_rel_threshold_fraction: f64,
    /// Largest per-pixel relative difference.
    pub max_rel_error: f64,
    /// Its pixel (x, y).
    pub max_rel_error_pixel: [u32; 2],
    /// Mean of the reference over pixels and channels.
    pub mean_reference: f64,
    /// Mean of the test image over pixels and channels.
    pub mean_test: f64,
}

/// Fail unless the two images have the same size.
pub fn same_size(reference: &Image, test: &Image) -> Result<()> {
    if (reference.width, reference.height) != (test.width, test.height) {
        return Err(Error::Invalid(format!(
            "image sizes differ: reference {}x{}, test {}x{}",
            reference.width, reference.height, test.width, test.height
        )));
    }
    Ok(())
}

/// Per-pixel relative difference: max over channels of |t - r| / max(|r|, floor).
pub fn relative_difference(reference: &Image, test: &Image, floor: f32) -> Result<Vec<f32>> {
    same_size(reference, test)?;
    Ok(reference.pixels.iter().zip(&test.pixels).map(|(r, t)| pixel_rel(*r, *t, floor)).collect())
}

/// Per-pixel absolute difference: max over channels of |t - r|.
pub fn absolute_difference(reference: &Image, test: &Image) -> Result<Vec<f32>> {
    same_size(reference, test)?;
    Ok(reference.pixels.iter().zip(&test.pixels).map(|(r, t)| (*t - *r).abs().max_element()).collect())
}

fn pixel_rel(r: Vec3, t: Vec3, floor: f32) -> f32 {
    let d = (t - r).abs();
    let den = r.abs().max(Vec3::splat(floor));
    (d / den).max_element()
}

/// Compute every metric of [`Metrics`]. Errors on mismatched sizes.
pub fn compare(reference: &Image, test: &Image, opts: &CompareOptions) -> Result<Metrics> {
    same_size(reference, test)?;
    let w = reference.width;
    let n = reference.pixels.len();
    let (mut sum_abs, mut sum_sq, mut sum_rel, mut sum_r, mut sum_t) = (0f64, 0f64, 0f64, 0f64, 0f64);
    let (mut max_err, mut max_i, mut max_c) = (0f64, 0usize, 0u32);
    let (mut max_rel, mut max_rel_i) = (0f64, 0usize);
    let (mut over, mut over_rel) = (0u64, 0u64);
    let mut peak = 1f64;
    for (i, (r, t)) in reference.pixels.iter().zip(&test.pixels).enumerate() {
        let mut pixel_over = false;
        for c in 0..3 {
            let (rv, tv) = (r[c] as f64, t[c] as f64);
            let d = tv - rv;
            let ad = d.abs();
            sum_abs += ad;
            sum_sq += d * d;
            sum_rel += d * d / (rv * rv + REL_MSE_EPSILON);
            sum_r += rv;
            sum_t += tv;
            peak = peak.max(rv.abs()).max(tv.abs());
            if ad > max_err {
                (max_err, max_i, max_c) = (ad, i, c as u32);
            }
            pixel_over |= ad > opts.threshold as f64;
        }
        over += pixel_over as u64;
        let rel = pixel_rel(*r, *t, opts.rel_floor) as f64;
        if rel > max_rel {
            (max_rel, max_rel_i) = (rel, i);
        }
        over_rel += (rel > opts.rel_threshold as f64) as u64;
    }
    let samples = (n * 3) as f64;
    let rmse = (sum_sq / samples).sqrt();
    let at = |i: usize| [i as u32 % w, i as u32 / w];
    Ok(Metrics {
        width: reference.width,
        height: reference.height,
        mae: sum_abs / samples,
        rmse,
        psnr: if rmse > 0.0 { 20.0 * (peak / rmse).log10() } else { f64::INFINITY },
        psnr_peak: peak,
        rel_mse: sum_rel / samples,
        rel_mse_epsilon: REL_MSE_EPSILON,
        max_error: max_err,
        max_error_pixel: at(max_i),
        max_error_channel: max_c,
        threshold: opts.threshold as f64,
        over_threshold: over,
        over_threshold_fraction: over as f64 / n as f64,
        rel_threshold: opts.rel_threshold as f64,
        rel_floor: opts.rel_floor as f64,
        over_rel_threshold: over_rel,
        over_rel_threshold_fraction: over_rel as f64 / n as f64,
        max_rel_error: max_rel,
        max_rel_error_pixel: at(max_rel_i),
        mean_reference: sum_r / samples,
        mean_test: sum_t / samples,
    })
}

/// The part of a test image's expected relMSE that a noisy reference adds by
/// itself: sum var / (ref^2 + eps) / (n c), with `variance` the reference's
/// per-pixel variance (of the mean, when the reference is a mean of renders).
/// For a test image independent of the reference, E[(t - r)^2] is
/// E[(t - mu)^2] plus var(r) at each pixel, so subtracting this from the
/// measured relMSE leaves the test's own error (to first order: the
/// denominator uses the noisy `ref`).
pub fn rel_mse_noise_floor(reference: &Image, variance: &Image) -> Result<f64> {
    same_size(reference, variance)?;
    let sum: f64 = reference
        .pixels
        .iter()
        .zip(&variance.pixels)
        .flat_map(|(r, v)| (0..3).map(move |c| f64::from(v[c]) / (f64::from(r[c]).powi(2) + REL_MSE_EPSILON)))
        .sum();
    Ok(sum / (reference.pixels.len() * 3) as f64)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn img(w: u32, h: u32, f: impl Fn(u32, u32) -> Vec3) -> Image {
        let mut im = Image::new(w, h);
        for y in 0..h {
            for x in 0..w {
                im.pixels[(y * w + x) as usize] = f(x, y);
            }
        }
        im
    }

    #[test]
    fn closed_form_values() {
        // Reference 0.5 everywhere; test adds 0.1 to the red channel of one pixel of 4x2.
        let r = img(4, 2, |_, _| Vec3::splat(0.5));
        let t = img(4, 2, |x, y| if (x, y) == (3, 1) { Vec3::new(0.6, 0.5, 0.5) } else { Vec3::splat(0.5) });
        let m = compare(&r, &t, &CompareOptions::default()).unwrap();
        let d = (0.6f32 as f64) - 0.5; // the f32 value actually stored
        assert!((m.mae - d / 24.0).abs() < 1e-15);
        assert!((m.rmse - (d * d / 24.0).sqrt()).abs() < 1e-15);
        assert!((m.psnr - 20.0 * (1.0 / m.rmse).log10()).abs() < 1e-12);
        assert!((m.rel_mse - d * d / (0.25 + REL_MSE_EPSILON) / 24.0).abs() < 1e-15);
        assert_eq!((m.max_error, m.max_error_pixel, m.max_error_channel), (d, [3, 1], 0));
        assert_eq!((m.over_threshold, m.over_rel_threshold), (1, 1));
        assert!((m.over_threshold_fraction - 0.125).abs() < 1e-15);
        assert!((m.max_rel_error - d / 0.5).abs() < 1e-6);
        // HDR: the peak is the largest magnitude of either image.
        let hdr = img(4, 2, |x, _| if x == 0 { Vec3::new(-3.0, 0.5, 0.5) } else { Vec3::splat(0.5) });
        let mh = compare(&r, &hdr, &CompareOptions::default()).unwrap();
        assert_eq!(mh.psnr_peak, 3.0);
        assert!((mh.psnr - 20.0 * (3.0 / mh.rmse).log10()).abs() < 1e-12);
        let same = compare(&r, &r, &CompareOptions::default()).unwrap();
        assert_eq!((same.rmse, same.psnr, same.over_threshold), (0.0, f64::INFINITY, 0));
    }

    #[test]
    fn relative_difference_uses_the_floor_on_black() {
        let r = img(2, 1, |x, _| if x == 0 { Vec3::ZERO } else { Vec3::splat(2.0) });
        let t = img(2, 1, |x, _| if x == 0 { Vec3::splat(1e-3) } else { Vec3::splat(2.002) });
        let rel = relative_difference(&r, &t, 1e-2).unwrap();
        assert!((rel[0] - 0.1).abs() < 1e-6 && (rel[1] - 1e-3).abs() < 1e-5, "{rel:?}");
    }

    #[test]
    fn mismatched_sizes_are_an_error() {
        let e = compare(&Image::new(2, 2), &Image::new(3, 2), &CompareOptions::default()).unwrap_err();
        assert!(e.to_string().contains("2x2") && e.to_string().contains("3x2"), "{e}");
    }

    #[test]
    fn subtracting_the_reference_noise_leaves_the_test_error() {
        // Every pixel's true value is 0.5. The reference is the mean of 256 uniform draws in
        // [0, 1) (variance of the mean 1/3072), the test the truth plus an independent
        // (U - 1/2) / 4 (variance 1/192, 16 times the reference's). The test's own relMSE is
        // 1/192 / (0.25 + eps); the measured one adds the reference's 1/3072 / (0.25 + eps)
        // (6.25%), which the floor removes. Left over: the noisy denominator's second-order
        // effect, f''(0.5) var / 2 f(0.5) = 0.4%, and sampling noise: 49152 squared
        // differences of near-Gaussian noise scatter their mean by sqrt(2 / 49152) = 0.64%.
        // 3% is over four of those, and half the correction.
        let (w, h) = (128u32, 128u32);
        let mut rng = crate::rng::Pcg32::new(7, 0);
        let mut reference = Image::new(w, h);
        let mut test = Image::new(w, h);
        for (r, t) in reference.pixels.iter_mut().zip(&mut test.pixels) {
            for _ in 0..256 {
                *r += Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) / 256.0;
            }
            *t = Vec3::splat(0.5) + (Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) - 0.5) / 4.0;
        }
        let variance = Image { width: w, height: h, pixels: vec![Vec3::splat(1.0 / 3072.0); (w * h) as usize] };
        let floor = rel_mse_noise_floor(&reference, &variance).unwrap();
        let measured = compare(&reference, &test, &CompareOptions::default()).unwrap().rel_mse;
        let own = (1.0 / 192.0) / (0.25 + REL_MSE_EPSILON);
        assert!((floor * 16.0 / own - 1.0).abs() < 0.03, "floor {floor} against {}", own / 16.0);
        assert!(measured / own - 1.0 > 0.04, "the reference's noise is in the measured {measured}");
        assert!(((measured - floor) / own - 1.0).abs() < 0.03, "{measured} - {floor} against {own}");
        assert!(rel_mse_noise_floor(&reference, &Image::new(2, 2)).is_err());
    }
}
