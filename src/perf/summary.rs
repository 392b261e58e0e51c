//! A figure measured several times: median, minimum and maximum.

use serde::{Deserialize, Serialize};

/// Median, minimum and maximum of repeated measurements of one figure.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Measure {
    /// Median (the upper median for an even count).
    pub median: f64,
    /// Smallest value.
    pub min: f64,
    /// Largest value.
    pub max: f64,
    /// Number of measurements.
    pub runs: usize,
}

impl Measure {
    /// Summary of `samples`; `None` when there are none.
    pub fn of(samples: &[f64]) -> Option<Self> {
        if samples.is_empty() {
            return None;
        }
        let mut v: Vec<f64> = samples.to_vec();
        v.sort_by(f64::total_cmp);
        Some(Self { median: v[v.len() / 2], min: v[0], max: v[v.len() - 1], runs: v.len() })
    }

    /// A figure that does not vary between runs (a count).
    pub fn exact(value: f64) -> Self {
        Self { median: value, min: value, max: value, runs: 1 }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn median_min_max() {
        let m = Measure::of(&[5.0, 1.0, 3.0, 9.0]).unwrap();
        assert_eq!((m.median, m.min, m.max, m.runs), (5.0, 1.0, 9.0, 4));
        assert_eq!(Measure::of(&[2.0, 7.0, 4.0]).unwrap().median, 4.0);
        assert!(Measure::of(&[]).is_none());
    }
}
