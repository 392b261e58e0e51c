//! Light sources behind one interface: each variant in its own file.

pub mod parallelogram;
pub mod point;
pub mod segment;

pub use parallelogram::ParallelogramLight;
pub use point::PointLight;
pub use segment::SegmentLight;

use glam::Vec3;

use crate::rng::Pcg32;

/// How positions on an area light are chosen.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum LightSampling {
    /// Independent uniform samples (report 000).
    Random,
    /// One uniform sample inside each cell of a regular subdivision (report 001).
    #[default]
    Jittered,
}

/// One point sampled on a light.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightSample {
    /// Position of the sample.
    pub position: Vec3,
    /// Interpolated colour: intensity for point and segment lights, radiance for parallelograms.
    pub color: Vec3,
    /// `1 / N`: the Phong model averages its N samples (the reports' convention).
    pub average_weight: f32,
    /// Monte Carlo measure: 1 for a point, `length / N` for a segment, `area / N` for a parallelogram.
    pub measure: f32,
    /// Emitting side of an area light (unit); `None` for lights that emit in all directions.
    pub normal: Option<Vec3>,
}

/// A light source.
pub trait Light: Send + Sync + std::fmt::Debug {
    /// True for a single point (no sampling needed).
    fn is_point(&self) -> bool;

    /// Call `f` with `n` samples (a point light gives exactly one, whatever `n`).
    /// A callback rather than a returned list: no allocation per shading point.
    fn sample(&self, n: u32, sampling: LightSampling, rng: &mut Pcg32, f: &mut dyn FnMut(LightSample));

    /// Position at parametric coordinates `(u, v)` in `[0, 1]^2` (ignored by point lights).
    fn position_at(&self, u: f32, v: f32) -> Vec3;

    /// Colour at parametric coordinates `(u, v)`.
    fn color_at(&self, u: f32, v: f32) -> Vec3;
}

/// `n` 1D sample positions in `[0, 1)`: jittered strata or independent.
pub(crate) fn samples_1d(n: u32, sampling: LightSampling, rng: &mut Pcg32, mut f: impl FnMut(f32)) {
    for i in 0..n {
        let x = match sampling {
            LightSampling::Random => rng.next_f32(),
            LightSampling::Jittered => (i as f32 + rng.next_f32()) / n as f32,
        };
        f(x);
    }
}
