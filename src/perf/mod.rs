//! Measurements for the reports: each returns a typed, serde-serialisable
//! result that [`crate::report`] turns into tables, plots and pages.

#[cfg(rtdiff_tmp)]
pub mod convergence;
pub mod machine;
pub mod progress;
pub mod stability;
pub mod summary;
pub mod table;
