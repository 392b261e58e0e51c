//! The Embree backend's configuration: build quality and scene flags (robust,
//! the default of rtdiff's Embree backend, or Embree's own default flags).
//! Compiled without the `embree` feature too, so scene files and command lines
//! naming it parse everywhere.

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

/// Embree's scene flags (`rtcSetSceneFlags`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum EmbreeMode {
    /// `RTC_SCENE_FLAG_ROBUST`: Embree's robust (watertight-leaning) traversal
    /// and triangle test, the like-for-like opponent of rtdiff's watertight test.
    #[default]
    Robust,
    /// Embree's default flags (`RTC_SCENE_FLAG_NONE`): its faster traversal,
    /// which lets rays slip through shared edges (docs/embree.md, finding 1).
    Default,
}

impl EmbreeQuality {
    /// The one label of the Embree backend at this quality with the robust
    /// flag (`embree-high`, ...); see [`embree_label`] for the other mode.
    pub fn label(self) -> String {
        embree_label(self, EmbreeMode::Robust)
    }
}

/// The one label of the Embree backend at `quality` in `mode`: `embree-medium`
/// (robust, the backend's default) or `embree-medium-default` (Embree's
/// default scene flags).
pub fn embree_label(quality: EmbreeQuality, mode: EmbreeMode) -> String {
    let q = match quality {
        EmbreeQuality::Low => "low",
        EmbreeQuality::Medium => "medium",
        EmbreeQuality::High => "high",
    };
    match mode {
        EmbreeMode::Robust => format!("embree-{q}"),
        EmbreeMode::Default => format!("embree-{q}-default"),
    }
}
