//! Reports a user can open: the typed results of [`crate::perf`] written as
//! JSON, Markdown, SVG plots (plotters) and one `index.html`.

pub mod campaign;
pub mod convergence;
pub mod generate;
pub mod html;
pub mod perf;
pub mod plot;
pub mod stability;
pub mod table;

pub use generate::{Generated, ReportKind, ReportOptions, generate};
