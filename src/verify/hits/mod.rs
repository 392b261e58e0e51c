//! Hit parity against an independent oracle (Embree or brute force): the
//! error bounds two correct tracers may differ by ([`bounds`]), the
//! classification of every disagreement ([`classify`]), the exact arbiter that
//! decides who is right ([`arbiter`], on [`exact`] arithmetic, applied to every
//! disagreement by [`arbitrate`]), the run over
//! the ray sets of [`crate::rays`] ([`run`](mod@run)), its typed report ([`report`]) and the
//! verdict a person reads first ([`verdict`]).

pub mod arbiter;
pub mod arbitrate;
pub mod bounds;
pub mod classify;
pub mod condition;
pub mod exact;
pub mod judge;
pub mod line_index;
pub mod report;
pub mod run;
pub mod verdict;

pub use crate::backends::native_variants;
pub use bounds::K_ROUNDING;
pub use report::{Example, ParityReport, SetReport, StressRow, VariantStats, format_report};
pub use run::{ParityOptions, Reference, run};
pub use verdict::{VariantVerdict, Verdict, format_verdict};
