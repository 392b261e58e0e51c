//! Reading a convergence curve: the least-squares slope of log error against
//! log samples, and log-log interpolation along the sweep (the time at which
//! an error is reached, the error reached at a time).

use serde::Serialize;

/// A least-squares line through `(log10 x, log10 y)`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct LogLogFit {
    /// Slope (error exponent).
    pub slope: f64,
    /// Intercept: `log10 y` at `x = 1`.
    pub intercept: f64,
    /// Points used.
    pub points: usize,
}

impl LogLogFit {
    /// The fitted `y` at `x`.
    pub fn at(&self, x: f64) -> f64 {
        10f64.powf(self.intercept + self.slope * x.log10())
    }
}

/// Fit `log10 y = intercept + slope log10 x` by least squares over the points
/// with positive coordinates; `None` with fewer than two such points or a
/// single distinct x.
pub fn fit_loglog(points: &[(f64, f64)]) -> Option<LogLogFit> {
    let p: Vec<(f64, f64)> =
        points.iter().filter(|(x, y)| *x > 0.0 && *y > 0.0).map(|(x, y)| (x.log10(), y.log10())).collect();
    let n = p.len() as f64;
    if p.len() < 2 {
        return None;
    }
    let mx = p.iter().map(|q| q.0).sum::<f64>() / n;
    let my = p.iter().map(|q| q.1).sum::<f64>() / n;
    let sxx: f64 = p.iter().map(|q| (q.0 - mx).powi(2)).sum();
    let sxy: f64 = p.iter().map(|q| (q.0 - mx) * (q.1 - my)).sum();
    if sxx == 0.0 {
        return None;
    }
    let slope = sxy / sxx;
    Some(LogLogFit { slope, intercept: my - slope * mx, points: p.len() })
}

/// Along a polyline `(a, b)` in sweep order, `b` where `a` first reaches
/// `target` (the first segment whose ends bracket it, interpolated in
/// log-log); `None` when no segment does or a value is not positive.
pub fn crossing(points: &[(f64, f64)], target: f64) -> Option<f64> {
    let log = |v: f64| (v > 0.0).then(|| v.log10());
    let t = log(target)?;
    points.windows(2).find_map(|w| {
        let (a0, b0, a1, b1) = (log(w[0].0)?, log(w[0].1)?, log(w[1].0)?, log(w[1].1)?);
        if (a0 - t) * (a1 - t) > 0.0 {
            return None;
        }
        let f = if a1 == a0 { 0.0 } else { (t - a0) / (a1 - a0) };
        Some(10f64.powf(b0 + f * (b1 - b0)))
    })
}

/// The time at which the error first falls to `target`, from `(ms, error)`
/// points in sweep order: the first point's time when it is already there,
/// else interpolated in log-log between the two points around it; `None` if
/// it never does.
pub fn time_to_error(points: &[(f64, f64)], target: f64) -> Option<f64> {
    let first = points.first()?;
    if first.1 <= target {
        return Some(first.0);
    }
    let end = points.iter().position(|p| p.1 <= target)?;
    let swapped: Vec<(f64, f64)> = points[..=end].iter().map(|&(t, e)| (e, t)).collect();
    crossing(&swapped, target)
}

/// The error reached at time `ms`, from `(ms, error)` points in sweep order:
/// interpolated in log-log on the first segment whose times bracket `ms`;
/// `None` when the sweep never takes that long or every render takes longer.
pub fn error_at_time(points: &[(f64, f64)], ms: f64) -> Option<f64> {
    if let Some(p) = points.iter().find(|p| p.0 == ms) {
        return Some(p.1);
    }
    crossing(points, ms)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Pcg32;

    #[test]
    fn exact_inverse_n_has_slope_minus_one() {
        let pts: Vec<(f64, f64)> = [1.0, 4.0, 16.0, 64.0, 256.0, 1024.0].iter().map(|&n| (n, 0.3 / n)).collect();
        let f = fit_loglog(&pts).unwrap();
        // Exact data: only rounding of log10 (a few ulps).
        assert!((f.slope + 1.0).abs() < 1e-12, "{f:?}");
        assert!((f.at(1.0) - 0.3).abs() < 1e-12);
        assert!(fit_loglog(&[(1.0, 1.0)]).is_none());
        assert!(fit_loglog(&[(2.0, 1.0), (2.0, 3.0)]).is_none());
    }

    #[test]
    fn monte_carlo_mse_has_slope_minus_one() {
        // 4096 "pixels", each the mean of n uniform samples (variance 1/12);
        // the MSE against the true mean 0.5 has expectation 1/(12 n) and a
        // relative standard deviation of about sqrt(2/4096) = 2.2% per point
        // (the squared error of a near-Gaussian mean is a scaled chi^2_1), i.e.
        // 0.0096 in log10. Over log10 n = 0, 0.6, ..., 3 (sum of squared
        // deviations 6.3) the slope's standard error is 0.0096 / sqrt(6.3) =
        // 0.004: 0.03 is over seven standard errors.
        let pixels = 4096;
        let mut pts = Vec::new();
        for (k, n) in [1u32, 4, 16, 64, 256, 1024].into_iter().enumerate() {
            let mut sum = 0.0f64;
            for p in 0..pixels {
                let mut rng = Pcg32::new(p as u64, k as u64);
                let mean = (0..n).map(|_| f64::from(rng.next_f32())).sum::<f64>() / f64::from(n);
                sum += (mean - 0.5).powi(2);
            }
            pts.push((f64::from(n), sum / pixels as f64));
        }
        let f = fit_loglog(&pts).unwrap();
        assert!((f.slope + 1.0).abs() < 0.03, "slope {} from {pts:?}", f.slope);
        // The intercept is the one-sample variance 1/12: its standard error is
        // 0.0096 * sqrt(1/6 + 1.5^2/6.3) = 0.007 in log10 (1.6%); 10% is six.
        assert!((f.at(1.0) * 12.0 - 1.0).abs() < 0.1, "{f:?}");
    }

    #[test]
    fn time_to_error_interpolates_in_log_log() {
        let pts = [(10.0, 1e-1), (40.0, 1e-2), (160.0, 1e-3)];
        // 10^-1.5 lies halfway (in log10) between 1e-1 and 1e-2: halfway between 10 and 40 ms in log10 is 20.
        let t = time_to_error(&pts, 10f64.powf(-1.5)).unwrap();
        assert!((t - 20.0).abs() < 1e-9, "{t}");
        assert_eq!(time_to_error(&pts, 1e-1), Some(10.0));
        assert_eq!(time_to_error(&pts, 1e-4), None);
        // A noisy error that dips below the target and comes back: its first crossing counts.
        let noisy = [(10.0, 1e-1), (40.0, 1e-3), (160.0, 2e-2), (640.0, 1e-4)];
        let t = time_to_error(&noisy, 1e-2).unwrap();
        assert!((t - 20.0).abs() < 1e-9, "{t}");
    }

    #[test]
    fn error_at_time_interpolates_in_log_log() {
        let pts = [(10.0, 1e-1), (40.0, 1e-2), (160.0, 1e-3)];
        assert!((error_at_time(&pts, 20.0).unwrap() - 10f64.powf(-1.5)).abs() < 1e-12);
        assert_eq!(error_at_time(&pts, 160.0), Some(1e-3));
        assert_eq!(error_at_time(&pts, 5.0), None, "every render takes longer");
        assert_eq!(error_at_time(&pts, 200.0), None, "the sweep never takes that long");
    }
}
