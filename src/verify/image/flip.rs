//! NVIDIA FLIP (LDR and HDR) through the `nv-flip` crate (NVIDIA's C++ FLIP,
//! compiled by `nv-flip-sys`).
//!
//! - **LDR-FLIP**: the linear images are clamped to [0, 1], sRGB-encoded and
//!   quantised to 8 bits (the only input `nv-flip` takes), then compared.
//! - **HDR-FLIP** (Andersson et al., EG 2021), built here on the crate's LDR
//!   kernel: exposures from c_start = log2(x_max / Y_max) to
//!   c_stop = log2(x_max / Y_median) (Y = 0.2126 R + 0.7152 G + 0.0722 B of
//!   the reference, Y_median the mean of the two middle values, x_max the input
//!   that the ACES tone curve maps to 0.85), `max(2, ceil(c_stop - c_start))`
//!   evenly spaced exposures; at each, both images are scaled by 2^c,
//!   ACES-tone-mapped (FLIP's fitted rational curve, pre-exposure 0.6),
//!   clamped, sRGB-encoded and LDR-FLIPped; the error is the per-pixel maximum.
//!
//! The 8-bit quantisation (half an LSB, 0.002 in sRGB) is the only difference
//! from flip-evaluator's float pipeline; `tests/image_crosscheck.rs` measures it.

use glam::Vec3;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::film::Image;
use crate::texture::linear_to_srgb;
use crate::verify::image::metrics::same_size;

/// FLIP's default viewing condition: 0.7 m from a 0.7 m wide 3840-pixel monitor.
pub const DEFAULT_PIXELS_PER_DEGREE: f32 = nv_flip::DEFAULT_PIXELS_PER_DEGREE;

/// FLIP's ACES fit `(x^2 a + x b + c) / (x^2 d + x e + f)` (0.6 = pre-exposure cancellation).
const ACES: [f32; 6] = [0.6 * 0.6 * 2.51, 0.6 * 0.03, 0.0, 0.6 * 0.6 * 2.43, 0.6 * 0.59, 0.14];

/// Which FLIP.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum FlipMode {
    /// Low dynamic range: linear values clamped to [0, 1] and sRGB-encoded.
    Ldr,
    /// High dynamic range: LDR-FLIP over a range of tone-mapped exposures.
    Hdr,
}

/// The exposure range HDR-FLIP used.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Exposures {
    /// First exposure (stops).
    pub start: f32,
    /// Last exposure (stops).
    pub stop: f32,
    /// Number of exposures.
    pub count: u32,
}

/// A FLIP result: the mean and the per-pixel error map in [0, 1].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Flip {
    /// LDR or HDR.
    pub mode: FlipMode,
    /// Mean of the error map.
    pub mean: f64,
    /// Largest per-pixel error.
    pub max: f32,
    /// Viewing condition used.
    pub pixels_per_degree: f32,
    /// HDR only: the exposures.
    pub exposures: Option<Exposures>,
    /// Map width.
    pub width: u32,
    /// Map height.
    pub height: u32,
    /// Row-major per-pixel error (not serialised).
    #[serde(skip)]
    pub error_map: Vec<f32>,
}

/// FLIP of `test` against `reference` (linear RGB), at `pixels_per_degree`.
/// Errors on mismatched sizes; the images must be finite.
pub fn flip(reference: &Image, test: &Image, mode: FlipMode, pixels_per_degree: f32) -> Result<Flip> {
    same_size(reference, test)?;
    if reference.pixels.iter().chain(&test.pixels).any(|p| !p.is_finite()) {
        return Err(Error::Invalid("FLIP: the images contain NaN or infinite values".into()));
    }
    let (w, h) = (reference.width, reference.height);
    let (error_map, exposures) = match mode {
        FlipMode::Ldr => (ldr(reference, test, |c| c, pixels_per_degree), None),
        FlipMode::Hdr => {
            let e = hdr_exposures(reference);
            let step = if e.count > 1 { (e.stop - e.start) / (e.count - 1) as f32 } else { 0.0 };
            let maps: Vec<Vec<f32>> = (0..e.count)
                .into_par_iter()
                .map(|i| {
                    let scale = (e.start + i as f32 * step).exp2();
                    ldr(reference, test, |c| aces(c * scale), pixels_per_degree)
                })
                .collect();
            let mut map = vec![0f32; (w * h) as usize];
            for m in &maps {
                for (a, b) in map.iter_mut().zip(m) {
                    *a = a.max(*b);
                }
            }
            (map, Some(e))
        }
    };
    let mean = error_map.iter().map(|&v| v as f64).sum::<f64>() / error_map.len() as f64;
    let max = error_map.iter().copied().fold(0f32, f32::max);
    Ok(Flip { mode, mean, max, pixels_per_degree, exposures, width: w, height: h, error_map })
}

/// HDR-FLIP's automatic exposure range for `reference` (see the module doc).
/// When the median luminance is 0 (mostly black images) the stop exposure
/// would be infinite: it is then taken from the smallest non-zero luminance.
pub fn hdr_exposures(reference: &Image) -> Exposures {
    // Solve (a - t d) x^2 + (b - t e) x + (c - t f) = 0 for the larger root x_max, t = 0.85.
    let t = 0.85f32;
    let (a, b, c) = (ACES[0] - t * ACES[3], ACES[1] - t * ACES[4], ACES[2] - t * ACES[5]);
    let d1 = -b / (2.0 * a);
    let x_max = d1 + (d1 * d1 - c / a).sqrt();
    let mut y: Vec<f32> = reference.pixels.iter().map(|p| luminance(*p)).collect();
    y.sort_by(f32::total_cmp);
    let y_max = *y.last().unwrap_or(&0.0);
    let mid = (y.len() / 2).max(1) - 1;
    let mut y_median = 0.5 * (y[mid] + y[(mid + 1).min(y.len() - 1)]);
    if y_median <= 0.0 {
        y_median = y.iter().copied().find(|&v| v > 0.0).unwrap_or(1.0);
    }
    let y_max = if y_max > 0.0 { y_max } else { 1.0 };
    let start = (x_max / y_max).log2();
    let stop = (x_max / y_median).log2();
    let count = ((stop - start).ceil() as u32).max(2);
    Exposures { start, stop, count }
}

fn luminance(p: Vec3) -> f32 {
    0.2126 * p.x + 0.7152 * p.y + 0.0722 * p.z
}

fn aces(x: f32) -> f32 {
    (x * x * ACES[0] + x * ACES[1] + ACES[2]) / (x * x * ACES[3] + x * ACES[4] + ACES[5])
}

/// 8-bit sRGB bytes of `tone(linear)` clamped to [0, 1].
fn to_srgb8(img: &Image, tone: impl Fn(f32) -> f32) -> Vec<u8> {
    let enc = |c: f32| (linear_to_srgb(tone(c).clamp(0.0, 1.0)) * 255.0 + 0.5) as u8;
    img.pixels.iter().flat_map(|p| [enc(p.x), enc(p.y), enc(p.z)]).collect()
}

fn ldr(reference: &Image, test: &Image, tone: impl Fn(f32) -> f32 + Copy, ppd: f32) -> Vec<f32> {
    let (w, h) = (reference.width, reference.height);
    let r = nv_flip::FlipImageRgb8::with_data(w, h, &to_srgb8(reference, tone));
    let t = nv_flip::FlipImageRgb8::with_data(w, h, &to_srgb8(test, tone));
    nv_flip::flip(r, t, ppd).to_vec()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn checker(w: u32, h: u32, a: f32, b: f32) -> Image {
        let mut im = Image::new(w, h);
        for (i, p) in im.pixels.iter_mut().enumerate() {
            let (x, y) = (i as u32 % w, i as u32 / w);
            *p = Vec3::splat(if (x / 4 + y / 4) % 2 == 0 { a } else { b });
        }
        im
    }

    #[test]
    fn identical_images_have_zero_flip_and_differences_do_not() {
        let r = checker(32, 32, 0.2, 0.8);
        for mode in [FlipMode::Ldr, FlipMode::Hdr] {
            let same = flip(&r, &r, mode, DEFAULT_PIXELS_PER_DEGREE).unwrap();
            assert_eq!((same.mean, same.max), (0.0, 0.0), "{mode:?}");
            let other = flip(&r, &checker(32, 32, 0.8, 0.2), mode, DEFAULT_PIXELS_PER_DEGREE).unwrap();
            assert!(other.mean > 0.1 && other.max <= 1.0, "{mode:?}: mean {} max {}", other.mean, other.max);
            assert_eq!(other.error_map.len(), 32 * 32);
        }
    }

    #[test]
    fn hdr_exposure_range_follows_the_reference() {
        // Half the pixels at luminance 1, half at 4: median (1 + 4) / 2, max 4.
        let r = checker(8, 8, 1.0, 4.0);
        let e = hdr_exposures(&r);
        // x_max: ACES maps it to 0.85.
        let x_max = 4.0 * e.start.exp2();
        assert!((aces(x_max) - 0.85).abs() < 1e-5, "{}", aces(x_max));
        assert!((e.stop - (x_max / 2.5).log2()).abs() < 1e-5);
        assert_eq!(e.count, 2);
    }
}
