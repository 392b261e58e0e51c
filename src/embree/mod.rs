//! Intel Embree 4 as a ground-truth tracer backend (cargo feature `embree`;
//! its configuration, [`EmbreeQuality`], is always compiled).
//!
//! With the feature, `ffi` holds hand-written bindings laid out as the Embree
//! 4.4 headers; `Device` and `Scene` wrap them safely (errors become
//! [`crate::Error`]); `EmbreeTracer` implements [`crate::accel::Tracer`] with
//! `rtcIntersect1` and `rtcOccluded1`. (Plain names: links to items that
//! exist only with the feature would break the documentation without it.)

#[cfg(feature = "embree")]
pub mod device;
#[cfg(feature = "embree")]
pub mod ffi;
pub mod quality;
#[cfg(feature = "embree")]
pub mod scene;
#[cfg(feature = "embree")]
pub mod tracer;

#[cfg(feature = "embree")]
pub use device::Device;
pub use quality::{EmbreeMode, EmbreeQuality, embree_label};
#[cfg(feature = "embree")]
pub use scene::{Scene, SceneMemory};
#[cfg(feature = "embree")]
pub use tracer::EmbreeTracer;
