//! Image oracle: linear images read and written by [`crate::film::io`], pixel metrics
//! ([`metrics`]), NVIDIA FLIP ([`flip`](mod@flip)), false-colour difference pictures
//! ([`diff_image`]), the statistical test for noisy renders ([`stats`]) and
//! the whole comparison of two image files ([`compare`](mod@compare)), and whether two
//! tracers render a scene alike ([`agreement`]), and another renderer's images checked against
//! `reference/` ([`check`]).
//! Definitions and formulas: `docs/image-metrics.md`.

pub mod agreement;
pub mod check;
pub mod compare;
pub mod diff_image;
pub mod flip;
pub mod metrics;
pub mod stats;

pub use crate::film::Image;
pub use crate::film::io::{read_image, write_exr, write_png};
pub use compare::{CompareReport, compare_files, compare_images, load_pair};
pub use flip::{Flip, FlipMode, flip};
pub use metrics::{CompareOptions, Metrics, compare};
pub use stats::{Moments, WelchOptions, WelchReport, welch_test};
