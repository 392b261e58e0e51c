//! The statistical test for noisy features (area lights, glossy, depth of
//! field, stochastic masks, anti-aliasing), where both renderers are noisy.
//!
//! Each side renders K independent seeds; [`Moments`] holds, per pixel and
//! channel, the mean of the K images and the unbiased sample variance of one
//! image. [`welch_test`] then tests H0: "same expected value" with
//!
//! - one **Welch t-test per pixel and channel**: t = (m_t - m_r) / sqrt(v_r/K_r + v_t/K_t),
//!   Welch-Satterthwaite degrees of freedom, two-sided p from the Student-t
//!   distribution (`statrs`);
//! - three **image-wide tests** (one per channel) that catch a small bias spread
//!   over many pixels, which no single pixel can show at realistic noise:
//!   z = sum(m_t - m_r) / sqrt(sum(v_r/K_r + v_t/K_t)), normal two-sided p
//!   (pixels are independent, and the sum of many of them is normal);
//! - **Benjamini-Hochberg** over that whole family at false-discovery rate q.
//!   Under the complete null (the renderers agree) BH's FDR equals its
//!   family-wise error rate, so q is also the false-alarm rate of the whole check.
//!
//! Pixels with zero variance on both sides (background, pixels no noisy
//! feature reaches) are deterministic: they count as rejected when
//! |m_t - m_r| > `exact_tolerance` and take no part in BH.
//!
//! It also splits the error: with d = m_t - m_r and se^2 = v_r/K_r + v_t/K_t,
//! bias^2 = mean(d^2 - se^2) (unbiased for the squared difference of the
//! expected values, so it can be slightly negative when there is none),
//! variance = mean(v_t), and mse = bias^2 + variance is the expected squared
//! error of one test image against the reference's expected value.

use glam::Vec3;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use statrs::distribution::{ContinuousCDF, FisherSnedecor, Normal, StudentsT};

use crate::error::{Error, Result};
use crate::film::Image;

/// Per-pixel, per-channel mean and one-image variance over K independent renders.
#[derive(Clone, Debug, PartialEq)]
pub struct Moments {
    /// Width.
    pub width: u32,
    /// Height.
    pub height: u32,
    /// K, the number of independent images.
    pub count: u32,
    /// Mean of the K images, row-major.
    pub mean: Vec<[f64; 3]>,
    /// Unbiased sample variance of one image (divisor K - 1), row-major.
    pub variance: Vec<[f64; 3]>,
}

impl Moments {
    /// Moments of K >= 2 images of one size (Welford's update in f64).
    pub fn from_images(images: &[Image]) -> Result<Self> {
        let first = images.first().ok_or_else(|| Error::Invalid("no images to take moments of".into()))?;
        if images.len() < 2 {
            return Err(Error::Invalid("a variance needs at least 2 independent images".into()));
        }
        let n = first.pixels.len();
        let (mut mean, mut m2) = (vec![[0f64; 3]; n], vec![[0f64; 3]; n]);
        for (k, img) in images.iter().enumerate() {
            if (img.width, img.height) != (first.width, first.height) {
                return Err(Error::Invalid(format!(
                    "image {k} is {}x{}, image 0 is {}x{}",
                    img.width, img.height, first.width, first.height
                )));
            }
            let kf = (k + 1) as f64;
            for ((m, s), p) in mean.iter_mut().zip(&mut m2).zip(&img.pixels) {
                for c in 0..3 {
                    let x = p[c] as f64;
                    let d = x - m[c];
                    m[c] += d / kf;
                    s[c] += d * (x - m[c]);
                }
            }
        }
        let k1 = (images.len() - 1) as f64;
        let variance = m2.into_iter().map(|s| [s[0] / k1, s[1] / k1, s[2] / k1]).collect();
        Ok(Self { width: first.width, height: first.height, count: images.len() as u32, mean, variance })
    }

    /// Moments stored as two images: the mean of `count` renders and the
    /// unbiased sample variance of one render (as [`Moments::variance_image`] writes).
    pub fn from_mean_variance(mean: &Image, variance: &Image, count: u32) -> Result<Self> {
        if (mean.width, mean.height) != (variance.width, variance.height) {
            return Err(Error::Invalid("mean and variance images differ in size".into()));
        }
        if count < 2 {
            return Err(Error::Invalid("a variance needs at least 2 independent images".into()));
        }
        if variance.pixels.iter().any(|v| v.min_element() < 0.0) {
            return Err(Error::Invalid("variance image has negative values".into()));
        }
        let f = |p: &Vec3| [p.x as f64, p.y as f64, p.z as f64];
        Ok(Self {
            width: mean.width,
            height: mean.height,
            count,
            mean: mean.pixels.iter().map(f).collect(),
            variance: variance.pixels.iter().map(f).collect(),
        })
    }

    /// The mean as an image.
    pub fn mean_image(&self) -> Image {
        self.to_image(&self.mean)
    }

    /// The one-image variance as an image.
    pub fn variance_image(&self) -> Image {
        self.to_image(&self.variance)
    }

    fn to_image(&self, v: &[[f64; 3]]) -> Image {
        Image {
            width: self.width,
            height: self.height,
            pixels: v.iter().map(|p| Vec3::new(p[0] as f32, p[1] as f32, p[2] as f32)).collect(),
        }
    }
}

/// Settings of [`welch_test`].
#[derive(Clone, Copy, Debug, Serialize, Deserialize)]
pub struct WelchOptions {
    /// Benjamini-Hochberg false-discovery rate q (also the false-alarm rate of the check).
    pub fdr: f64,
    /// Largest |m_t - m_r| accepted on pixels with zero variance on both sides.
    pub exact_tolerance: f64,
}

impl Default for WelchOptions {
    /// q = 0.01: one false alarm in a hundred agreeing comparisons. Exact
    /// tolerance 1e-5: about 100 f32 ulps at 1.0, far below any 1% bias yet
    /// above the rounding differences of two renderers summing the same terms.
    fn default() -> Self {
        Self { fdr: 0.01, exact_tolerance: 1e-5 }
    }
}

/// What [`welch_test`] found.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct WelchReport {
    /// K of the reference.
    pub reference_count: u32,
    /// K of the test.
    pub test_count: u32,
    /// The false-discovery rate q.
    pub fdr: f64,
    /// Hypotheses in the BH family (noisy pixel-channels + 3 image-wide).
    pub tests: u64,
    /// Hypotheses BH rejected.
    pub rejected: u64,
    /// Pixels with a rejected channel (noisy or deterministic).
    pub rejected_pixels: u64,
    /// BH's p-value cut-off (0 when nothing is rejected).
    pub p_cutoff: f64,
    /// Smallest per-pixel p-value and its pixel.
    pub min_p: f64,
    /// Pixel (x, y) of `min_p`.
    pub min_p_pixel: [u32; 2],
    /// Image-wide z per channel.
    pub global_z: [f64; 3],
    /// Image-wide two-sided p per channel.
    pub global_p: [f64; 3],
    /// Whether BH rejected an image-wide test.
    pub global_rejected: bool,
    /// Pixels with zero variance on both sides.
    pub exact_pixels: u64,
    /// Of those, pixels differing by more than `exact_tolerance`.
    pub exact_mismatches: u64,
    /// Mean of m_t - m_r over pixels and channels.
    pub mean_difference: f64,
    /// Unbiased squared bias, mean(d^2 - se^2).
    pub bias2: f64,
    /// Mean one-image variance of the test.
    pub variance: f64,
    /// Mean one-image variance of the reference.
    pub reference_variance: f64,
    /// bias2 + variance: expected MSE of one test image against the reference's expectation.
    pub mse: f64,
    /// True when nothing was rejected.
    pub passed: bool,
    /// Row-major per-pixel rejection flags (not serialised).
    #[serde(skip)]
    pub rejected_map: Vec<bool>,
}

/// Two-sided p-value of Welch's t-test for means `m1`, `m2` with one-sample
/// variances `v1`, `v2` and counts `n1`, `n2` (both variances > 0 or one of them).
pub fn welch_p(m1: f64, v1: f64, n1: u32, m2: f64, v2: f64, n2: u32) -> f64 {
    let (a, b) = (v1 / n1 as f64, v2 / n2 as f64);
    let se2 = a + b;
    let t = (m2 - m1) / se2.sqrt();
    let df = se2 * se2 / (a * a / (n1 as f64 - 1.0) + b * b / (n2 as f64 - 1.0));
    match StudentsT::new(0.0, 1.0, df) {
        Ok(dist) => (2.0 * dist.sf(t.abs())).min(1.0),
        Err(_) => f64::NAN,
    }
}

/// Benjamini-Hochberg at rate `q`: the p-value cut-off (every p <= it is
/// rejected), or `None` when nothing is rejected.
pub fn benjamini_hochberg(p: &[f64], q: f64) -> Option<f64> {
    let mut sorted: Vec<f64> = p.to_vec();
    sorted.sort_by(f64::total_cmp);
    let m = sorted.len() as f64;
    sorted.iter().enumerate().rev().find(|(i, pv)| **pv <= (*i as f64 + 1.0) * q / m).map(|(_, pv)| *pv)
}

/// Test whether `test` and `reference` have the same per-pixel expectation
/// (see the module doc).
pub fn welch_test(reference: &Moments, test: &Moments, opts: &WelchOptions) -> Result<WelchReport> {
    if (reference.width, reference.height) != (test.width, test.height) {
        return Err(Error::Invalid(format!(
            "image sizes differ: reference {}x{}, test {}x{}",
            reference.width, reference.height, test.width, test.height
        )));
    }
    let (kr, kt) = (reference.count, test.count);
    let n = reference.mean.len();
    // Per pixel-channel p (NaN where both variances are zero).
    let p: Vec<[f64; 3]> = (0..n)
        .into_par_iter()
        .map(|i| {
            let (mr, vr, mt, vt) = (reference.mean[i], reference.variance[i], test.mean[i], test.variance[i]);
            std::array::from_fn(|c| {
                if vr[c] + vt[c] > 0.0 { welch_p(mr[c], vr[c], kr, mt[c], vt[c], kt) } else { f64::NAN }
            })
        })
        .collect();
    let (mut sum_d, mut sum_se2, mut sum_d2_minus, mut sum_vt, mut sum_vr) = ([0f64; 3], [0f64; 3], 0f64, 0f64, 0f64);
    let mut exact_pixels = 0u64;
    let mut exact_bad = vec![false; n];
    for (i, bad) in exact_bad.iter_mut().enumerate() {
        let (mr, vr, mt, vt) = (reference.mean[i], reference.variance[i], test.mean[i], test.variance[i]);
        let mut exact = true;
        for c in 0..3 {
            let d = mt[c] - mr[c];
            let se2 = vr[c] / kr as f64 + vt[c] / kt as f64;
            sum_d[c] += d;
            sum_se2[c] += se2;
            sum_d2_minus += d * d - se2;
            sum_vt += vt[c];
            sum_vr += vr[c];
            if se2 > 0.0 {
                exact = false;
            } else if d.abs() > opts.exact_tolerance {
                *bad = true;
            }
        }
        exact_pixels += exact as u64;
    }
    let normal = Normal::new(0.0, 1.0).map_err(|e| Error::Invalid(format!("normal distribution: {e}")))?;
    let global_z: [f64; 3] = std::array::from_fn(|c| if sum_se2[c] > 0.0 { sum_d[c] / sum_se2[c].sqrt() } else { 0.0 });
    let global_p: [f64; 3] =
        std::array::from_fn(|c| if sum_se2[c] > 0.0 { (2.0 * normal.sf(global_z[c].abs())).min(1.0) } else { 1.0 });
    let mut family: Vec<f64> = p.iter().flatten().copied().filter(|v| !v.is_nan()).collect();
    family.extend_from_slice(&global_p);
    let cutoff = benjamini_hochberg(&family, opts.fdr);
    let rejects = |v: f64| cutoff.is_some_and(|cut| v <= cut);
    let rejected = family.iter().filter(|v| rejects(**v)).count() as u64;
    let rejected_map: Vec<bool> =
        (0..n).map(|i| exact_bad[i] || p[i].iter().any(|v| !v.is_nan() && rejects(*v))).collect();
    let (mut min_p, mut min_i) = (1f64, 0usize);
    for (i, pp) in p.iter().enumerate() {
        for v in pp.iter().filter(|v| !v.is_nan()) {
            if *v < min_p {
                (min_p, min_i) = (*v, i);
            }
        }
    }
    let samples = (3 * n) as f64;
    let bias2 = sum_d2_minus / samples;
    let variance = sum_vt / samples;
    let exact_mismatches = exact_bad.iter().filter(|b| **b).count() as u64;
    let rejected_pixels = rejected_map.iter().filter(|b| **b).count() as u64;
    let global_rejected = global_p.iter().any(|v| rejects(*v));
    Ok(WelchReport {
        reference_count: kr,
        test_count: kt,
        fdr: opts.fdr,
        tests: family.len() as u64,
        rejected,
        rejected_pixels,
        p_cutoff: cutoff.unwrap_or(0.0),
        min_p,
        min_p_pixel: [min_i as u32 % reference.width, min_i as u32 / reference.width],
        global_z,
        global_p,
        global_rejected,
        exact_pixels,
        exact_mismatches,
        mean_difference: sum_d.iter().sum::<f64>() / samples,
        bias2,
        variance,
        reference_variance: sum_vr / samples,
        mse: bias2 + variance,
        passed: rejected == 0 && exact_mismatches == 0,
        rejected_map,
    })
}

/// What [`variance_test`] found.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct VarianceReport {
    /// Pixel-channels tested (those with a non-zero variance on either side).
    pub tests: u64,
    /// Hypotheses rejected by Benjamini-Hochberg.
    pub rejected: u64,
    /// Smallest p-value.
    pub min_p: f64,
    /// Largest ratio of the two variances (the larger over the smaller) among the tested.
    pub max_ratio: f64,
    /// No hypothesis rejected.
    pub passed: bool,
}

/// Two-sided p-value of the F-test of H0 "same variance" for one-sample variances `v1`, `v2`
/// estimated from `n1`, `n2` values: `v1 / v2 ~ F(n1 - 1, n2 - 1)` for normal values.
pub fn variance_ratio_p(v1: f64, n1: u32, v2: f64, n2: u32) -> f64 {
    if v1 == v2 {
        return 1.0;
    }
    if v1 <= 0.0 || v2 <= 0.0 {
        return 0.0;
    }
    match FisherSnedecor::new(n1 as f64 - 1.0, n2 as f64 - 1.0) {
        Ok(f) => {
            let x = v1 / v2;
            (2.0 * f.cdf(x).min(f.sf(x))).min(1.0)
        }
        Err(_) => f64::NAN,
    }
}

/// Test whether `a` and `b` have the same per-pixel one-image variance: one F-test per
/// pixel-channel ([`variance_ratio_p`]; pixel-channels with zero variance on both sides are
/// deterministic and skipped), Benjamini-Hochberg over the family at rate `fdr`. The F-test
/// assumes normally distributed per-image values (each image's pixel is a mean over many
/// samples); it checks a reference's noise estimate, not its expected value (that is
/// [`welch_test`]'s job).
pub fn variance_test(a: &Moments, b: &Moments, fdr: f64) -> Result<VarianceReport> {
    if (a.width, a.height) != (b.width, b.height) {
        return Err(Error::Invalid(format!(
            "image sizes differ: {}x{} and {}x{}",
            a.width, a.height, b.width, b.height
        )));
    }
    let mut p = Vec::new();
    let mut max_ratio = 1f64;
    for (va, vb) in a.variance.iter().zip(&b.variance) {
        for c in 0..3 {
            if va[c] > 0.0 || vb[c] > 0.0 {
                p.push(variance_ratio_p(va[c], a.count, vb[c], b.count));
                max_ratio = max_ratio.max(va[c].max(vb[c]) / va[c].min(vb[c]));
            }
        }
    }
    let cutoff = benjamini_hochberg(&p, fdr);
    let rejected = p.iter().filter(|v| cutoff.is_some_and(|cut| **v <= cut)).count() as u64;
    Ok(VarianceReport {
        tests: p.len() as u64,
        rejected,
        min_p: p.iter().copied().fold(1.0, f64::min),
        max_ratio,
        passed: rejected == 0,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Pcg32;

    /// A standard normal sample (Box-Muller).
    fn gauss(rng: &mut Pcg32) -> f64 {
        let u1 = (rng.next_f32() as f64).max(1e-12);
        let u2 = rng.next_f32() as f64;
        (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
    }

    /// K noisy images of `w` x `h` around `mean(x, y)` with per-sample standard deviation `sd`.
    fn noisy(rng: &mut Pcg32, k: usize, w: u32, h: u32, bias: f64, sd: f64) -> Vec<Image> {
        (0..k)
            .map(|_| {
                let mut im = Image::new(w, h);
                for (i, p) in im.pixels.iter_mut().enumerate() {
                    let mu = 0.2 + 0.6 * (i as f64 / (w * h) as f64);
                    *p = Vec3::from_array(std::array::from_fn(|_| (mu * (1.0 + bias) + sd * gauss(rng)) as f32));
                }
                im
            })
            .collect()
    }

    #[test]
    fn moments_match_closed_form() {
        let a = Image { width: 1, height: 1, pixels: vec![Vec3::splat(1.0)] };
        let b = Image { width: 1, height: 1, pixels: vec![Vec3::splat(3.0)] };
        let m = Moments::from_images(&[a.clone(), b, a]).unwrap();
        // values 1, 3, 1: mean 5/3, sample variance ((2/3)^2 * 2 + (4/3)^2) / 2 = 4/3.
        assert!((m.mean[0][0] - 5.0 / 3.0).abs() < 1e-12 && (m.variance[0][0] - 4.0 / 3.0).abs() < 1e-12);
    }

    #[test]
    fn welch_p_matches_a_textbook_value() {
        // Equal variances and counts: t = 2 / sqrt(2/10 + 2/10) = 3.1623, df = 18: p = 0.005394 (t tables).
        let p = welch_p(0.0, 2.0, 10, 2.0, 2.0, 10);
        assert!((p - 0.005394).abs() < 2e-5, "{p}");
    }

    #[test]
    fn benjamini_hochberg_cutoff() {
        // m = 5, q = 0.05: thresholds 0.01 0.02 0.03 0.04 0.05; sorted p 0.001 0.015 0.04 0.5 0.9:
        // the largest k with p_(k) <= k q / m is k = 2 (0.04 > 0.03 at k = 3).
        assert_eq!(benjamini_hochberg(&[0.04, 0.001, 0.5, 0.015, 0.9], 0.05), Some(0.015));
        // Step-up: p_(2) = 0.035 > 0.02 but p_(4) = 0.04 <= 0.04 rejects all four.
        assert_eq!(benjamini_hochberg(&[0.04, 0.035, 0.039, 0.001, 0.9], 0.05), Some(0.04));
        assert_eq!(benjamini_hochberg(&[0.2, 0.3], 0.05), None);
    }

    /// Under H0 the check raises a false alarm at most at rate q: measured over
    /// 300 independent comparisons of 24x24 images, K = 8 per side.
    #[test]
    fn equal_means_pass_at_the_stated_false_alarm_rate() {
        let q = 0.05;
        let trials = 300;
        let mut rng = Pcg32::new(7, 1);
        let (mut alarms, mut raw_below, mut raw_total) = (0, 0u64, 0u64);
        for _ in 0..trials {
            let r = Moments::from_images(&noisy(&mut rng, 8, 24, 24, 0.0, 0.1)).unwrap();
            let t = Moments::from_images(&noisy(&mut rng, 8, 24, 24, 0.0, 0.1)).unwrap();
            let rep = welch_test(&r, &t, &WelchOptions { fdr: q, ..Default::default() }).unwrap();
            alarms += !rep.passed as u32;
            for i in 0..r.mean.len() {
                for c in 0..3 {
                    let p = welch_p(r.mean[i][c], r.variance[i][c], 8, t.mean[i][c], t.variance[i][c], 8);
                    raw_below += (p < 0.05) as u64;
                    raw_total += 1;
                }
            }
        }
        let rate = alarms as f64 / trials as f64;
        // Binomial(300, 0.05): mean 15, sd 3.8; allow 3 sd above q.
        let bound = q + 3.0 * (q * (1.0 - q) / trials as f64).sqrt();
        assert!(rate <= bound, "false-alarm rate {rate} above {bound}");
        // Each Welch p is uniform under H0: 5% below 0.05 (518,400 tests: sd 0.0003; Welch's df is
        // an approximation, so allow 0.003).
        let frac = raw_below as f64 / raw_total as f64;
        assert!((frac - 0.05).abs() < 0.003, "P(p < 0.05) = {frac}");
    }

    /// A 1% bias at 6-25% per-image noise (sd 0.05 on values 0.2-0.8, K = 8,
    /// 64x64) fails every time, while unbiased pairs stay far from the cut-off.
    #[test]
    fn one_percent_bias_fails() {
        let mut rng = Pcg32::new(11, 3);
        let opts = WelchOptions::default();
        let mut worst_pass_z: f64 = 0.0;
        for _ in 0..5 {
            let r = Moments::from_images(&noisy(&mut rng, 8, 64, 64, 0.0, 0.05)).unwrap();
            let same = Moments::from_images(&noisy(&mut rng, 8, 64, 64, 0.0, 0.05)).unwrap();
            let biased = Moments::from_images(&noisy(&mut rng, 8, 64, 64, 0.01, 0.05)).unwrap();
            let ok = welch_test(&r, &same, &opts).unwrap();
            let bad = welch_test(&r, &biased, &opts).unwrap();
            assert!(!bad.passed && bad.global_rejected, "1% bias passed: {bad:?}");
            worst_pass_z = worst_pass_z.max(ok.global_z.iter().fold(0.0, |a: f64, z| a.max(z.abs())));
        }
        // |z| of an agreeing pair is |N(0,1)|: 15 draws stay below 4 with probability 0.999.
        assert!(worst_pass_z < 4.0, "{worst_pass_z}");
    }

    /// The bias^2 / variance split recovers the known values.
    #[test]
    fn bias_variance_split() {
        let mut rng = Pcg32::new(5, 9);
        let (k, sd) = (8, 0.02);
        let r = Moments::from_images(&noisy(&mut rng, k, 64, 64, 0.0, sd)).unwrap();
        let biased = Moments::from_images(&noisy(&mut rng, k, 64, 64, 0.01, sd)).unwrap();
        let same = Moments::from_images(&noisy(&mut rng, k, 64, 64, 0.0, sd)).unwrap();
        let bad = welch_test(&r, &biased, &WelchOptions::default()).unwrap();
        let ok = welch_test(&r, &same, &WelchOptions::default()).unwrap();
        // Expected bias^2: mean of (0.01 mu)^2 with mu uniform on [0.2, 0.8] = 1e-4 E[mu^2].
        let expect = 1e-4 * (0.2f64.powi(2) + 0.2 * 0.6 + 0.6f64.powi(2) / 3.0);
        // Standard error of the estimate: each d^2 - se^2 has sd ~ sqrt(2) se^2 (+ the bias cross
        // term 2 |bias| se), over 3 * 4096 samples; allow 4 standard errors.
        let se2 = 2.0 * sd * sd / k as f64;
        let sem = (2.0 * se2 * se2 + 4.0 * expect * se2).sqrt() / (3.0f64 * 4096.0).sqrt();
        assert!((bad.bias2 - expect).abs() < 4.0 * sem, "bias2 {} vs {expect} (sem {sem})", bad.bias2);
        assert!(ok.bias2.abs() < 4.0 * sem, "unbiased bias2 {}", ok.bias2);
        // Mean one-image variance: sd^2, with relative standard error sqrt(2 / (K - 1) / 12288).
        let rel = (2.0 / (k as f64 - 1.0) / 12288.0).sqrt();
        assert!((bad.variance / (sd * sd) - 1.0).abs() < 4.0 * rel, "variance {}", bad.variance);
        assert!((bad.mse - bad.bias2 - bad.variance).abs() < 1e-15);
    }

    #[test]
    fn deterministic_pixels_use_the_exact_tolerance() {
        let img = |v: f32| Image { width: 2, height: 1, pixels: vec![Vec3::splat(0.5), Vec3::splat(v)] };
        let r = Moments::from_images(&[img(0.5), img(0.5)]).unwrap();
        let t_ok = Moments::from_images(&[img(0.500001), img(0.500001)]).unwrap();
        let t_bad = Moments::from_images(&[img(0.51), img(0.51)]).unwrap();
        let ok = welch_test(&r, &t_ok, &WelchOptions::default()).unwrap();
        let bad = welch_test(&r, &t_bad, &WelchOptions::default()).unwrap();
        assert!(ok.passed && ok.exact_pixels == 2);
        assert!(!bad.passed && bad.exact_mismatches == 1 && bad.rejected_map == vec![false, true]);
    }

    #[test]
    fn variance_test_accepts_equal_noise_and_rejects_doubled_noise() {
        let mut rng = Pcg32::new(11, 5);
        let (a, b) = (noisy(&mut rng, 64, 24, 24, 0.0, 0.05), noisy(&mut rng, 64, 24, 24, 0.0, 0.05));
        let (ma, mb) = (Moments::from_images(&a).unwrap(), Moments::from_images(&b).unwrap());
        let same = variance_test(&ma, &mb, 0.01).unwrap();
        assert!(same.passed && same.tests == 24 * 24 * 3, "{same:?}");
        let c = noisy(&mut rng, 64, 24, 24, 0.0, 0.1);
        let wider = variance_test(&ma, &Moments::from_images(&c).unwrap(), 0.01).unwrap();
        assert!(!wider.passed && wider.rejected > 1000, "{wider:?}");
        // Closed form: equal variances give p = 1, a zero against a non-zero variance p = 0.
        assert_eq!(variance_ratio_p(0.3, 10, 0.3, 20), 1.0);
        assert_eq!(variance_ratio_p(0.0, 10, 0.3, 20), 0.0);
        let p = variance_ratio_p(2.0, 64, 1.0, 64);
        assert!(p > 0.0 && p < 0.01, "{p}");
    }
}
