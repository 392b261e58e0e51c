//! Bloom: `img + scale * Gauss(img * [Y >= threshold])`.
//!
//! The Gaussian is OpenImageIO's `make_kernel("gaussian", w, w)` so results
//! can be checked against `ImageBufAlgo` (shared/notes/mitsuba.md): separable,
//! `ceil(w)` rounded up to an odd tap count, `tap(x) = exp(-2 (x / r)^2)` with
//! `r = w / 2` (sigma = w / 4), zero where `|x| >= r`, normalised to sum 1;
//! borders repeat the edge pixel.

use glam::Vec3;

use crate::features::BloomParams;
use crate::film::Image;

/// Relative luminance (Rec. 709 weights, as the reports use).
#[inline]
pub fn luminance(c: Vec3) -> f32 {
    0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z
}

/// The 1D kernel of width `w` pixels.
pub fn gaussian_kernel(w: f32) -> Vec<f32> {
    let mut n = w.ceil().max(1.0) as usize;
    if n.is_multiple_of(2) {
        n += 1;
    }
    let r = w / 2.0;
    let half = (n / 2) as f32;
    let mut k: Vec<f32> = (0..n)
        .map(|i| {
            let x = i as f32 - half;
            if x.abs() >= r { 0.0 } else { (-2.0 * (x / r) * (x / r)).exp() }
        })
        .collect();
    let sum: f32 = k.iter().sum();
    if sum > 0.0 {
        k.iter_mut().for_each(|v| *v /= sum);
    } else {
        k = vec![0.0; n];
        k[n / 2] = 1.0;
    }
    k
}

/// One 1D pass along x (`along_x`) or y, repeating the edge pixels.
fn convolve_1d(img: &Image, kernel: &[f32], along_x: bool) -> Image {
    let (w, h) = (img.width as i64, img.height as i64);
    let half = (kernel.len() / 2) as i64;
    let mut out = Image::new(img.width, img.height);
    for y in 0..h {
        for x in 0..w {
            let mut s = Vec3::ZERO;
            for (i, k) in kernel.iter().enumerate() {
                let d = i as i64 - half;
                let (xx, yy) = if along_x { ((x + d).clamp(0, w - 1), y) } else { (x, (y + d).clamp(0, h - 1)) };
                s += *k * img.pixels[(yy * w + xx) as usize];
            }
            out.pixels[(y * w + x) as usize] = s;
        }
    }
    out
}

/// Separable convolution with edge clamping: rows, then columns.
pub fn blur(img: &Image, kernel: &[f32]) -> Image {
    convolve_1d(&convolve_1d(img, kernel, true), kernel, false)
}

/// Every stage of the bloom, for `--bloom-stages`.
#[derive(Clone, Debug)]
pub struct BloomStages {
    /// Pixels at or above the threshold (others black).
    pub bright: Image,
    /// The bright pass blurred.
    pub blurred: Image,
    /// The blurred pass times the scale.
    pub scaled: Image,
    /// The input plus the scaled pass.
    pub result: Image,
}

/// Apply bloom with `params`, keeping the intermediate images.
pub fn bloom_stages(img: &Image, params: &BloomParams) -> BloomStages {
    let mut bright = img.clone();
    for p in &mut bright.pixels {
        if luminance(*p) < params.threshold {
            *p = Vec3::ZERO;
        }
    }
    let blurred = blur(&bright, &gaussian_kernel(params.kernel_size));
    let mut scaled = blurred.clone();
    scaled.pixels.iter_mut().for_each(|p| *p *= params.scale);
    let mut result = img.clone();
    result.pixels.iter_mut().zip(&scaled.pixels).for_each(|(r, s)| *r += *s);
    BloomStages { bright, blurred, scaled, result }
}

/// Apply bloom with `params`.
pub fn bloom(img: &Image, params: &BloomParams) -> Image {
    bloom_stages(img, params).result
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kernel_matches_oiio_definition() {
        let k = gaussian_kernel(5.0);
        assert_eq!(k.len(), 5);
        // r = 2.5: taps at x = -2..2 are exp(-2 x^2 / 6.25), normalised.
        let raw: Vec<f32> = (-2..=2).map(|x| (-2.0 * (x * x) as f32 / 6.25).exp()).collect();
        let s: f32 = raw.iter().sum();
        for (a, b) in k.iter().zip(raw.iter().map(|r| r / s)) {
            assert!((a - b).abs() < 1e-7);
        }
        assert_eq!(gaussian_kernel(4.0).len(), 5); // even widths round up to odd
        assert!((gaussian_kernel(21.0).iter().sum::<f32>() - 1.0).abs() < 1e-6);
    }

    #[test]
    fn image_below_threshold_is_unchanged() {
        let mut img = Image::new(7, 5);
        for (i, p) in img.pixels.iter_mut().enumerate() {
            *p = Vec3::splat(0.1 + 0.01 * i as f32);
        }
        let out = bloom(&img, &BloomParams { threshold: 0.9, kernel_size: 5.0, scale: 2.0 });
        assert_eq!(out, img);
    }

    #[test]
    fn single_bright_pixel_spreads_as_the_kernel_and_conserves_energy() {
        let mut img = Image::new(21, 21);
        img.pixels[10 * 21 + 10] = Vec3::ONE;
        let p = BloomParams { threshold: 0.5, kernel_size: 5.0, scale: 1.0 };
        let st = bloom_stages(&img, &p);
        let k = gaussian_kernel(5.0);
        // Separable: the blurred value at offset (dx, dy) is k[dx] k[dy].
        for dy in 0..5 {
            for dx in 0..5 {
                let v = st.blurred.get(8 + dx, 8 + dy).x;
                assert!((v - k[dx as usize] * k[dy as usize]).abs() < 1e-7);
            }
        }
        let total: f32 = st.blurred.pixels.iter().map(|p| p.x).sum();
        assert!((total - 1.0).abs() < 1e-5);
        assert!((st.result.get(10, 10).x - (1.0 + k[2] * k[2])).abs() < 1e-6);
    }
}
