//! Exporters: a loaded scene written for another renderer, so that both
//! renderers see the same float32 triangles, textures, lights and camera.

pub mod mitsuba;
pub mod native;
pub mod obj;

pub use mitsuba::{ExportReport, Oracle, OracleChoice, export_mitsuba};
