//! The Embree backend's configuration: build quality (the scene is always
//! built with the robust flag). Compiled without the `embree` feature too, so
//! scene files and command lines naming it parse everywhere.

use serde::{Deserialize, Serialize};

/// Embree's build quality (`rtcSetSceneBuildQuality`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum EmbreeQuality {
    /// RTC_BUILD_QUALITY_LOW.
    Low,
    /// RTC_BUILD_QUALITY_MEDIUM.
    Medium,
    /// RTC_BUILD_QUALITY_HIGH.
    #[default]
    High,
}

impl EmbreeQuality {
    /// The one label of the Embree backend at this quality (`embree-high`, ...).
    pub fn label(self) -> String {
        let q = match self {
            EmbreeQuality::Low => "low",
            EmbreeQuality::Medium => "medium",
            EmbreeQuality::High => "high",
        };
        format!("embree-{q}")
    }
}
