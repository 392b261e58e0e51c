//! Post-processing applied to the film.

pub mod bloom;
